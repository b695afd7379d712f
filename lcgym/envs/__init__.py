"""Plants, reference generators and the Gymnasium environments (registered on import of lcgym)."""

import gymnasium as gym


def register_envs() -> None:
    """Register ``lcgym/IX-v0`` (single and vector entry points) and ``lcgym/FlexArm-v0`` with
    Gymnasium, once."""
    if "lcgym/IX-v0" not in gym.registry:
        gym.register(
            id="lcgym/IX-v0",
            entry_point="lcgym.envs.ix_env:IXEnv",
            vector_entry_point="lcgym.envs.ix_env:IXVectorEnv",
        )
    if "lcgym/FlexArm-v0" not in gym.registry:
        gym.register(id="lcgym/FlexArm-v0", entry_point="lcgym.envs.flexarm_env:FlexArmEnv")


def plant_from_record(record: dict):
    """The plant a ``record()`` describes (stored in simulated measurement files' sidecars)."""
    from .ix import IXPlant

    plants = {"ix": IXPlant}
    system = record.get("system") if isinstance(record, dict) else None
    if system not in plants:
        raise ValueError(f"plant record of unknown system {system!r}; known: {sorted(plants)}")
    return plants[system].from_record(record)
