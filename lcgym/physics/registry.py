"""The physical model class of each system (what ``diagnose``, the PGNN and the CLI start from)."""

from __future__ import annotations

from .arm_model import ArmModel
from .model import PhysicalModel

MODELS: dict[str, type[PhysicalModel]] = {"ix": PhysicalModel, "flexarm": ArmModel}


def system_of(trials) -> str:
    """The system that recorded ``trials`` (their ``meta["system"]``; "ix" when unset)."""
    systems = {t.meta.get("system", "ix") for t in trials}
    if len(systems) != 1:
        raise ValueError(f"trials of several systems mixed: {sorted(systems)}")
    system = systems.pop()
    if system not in MODELS:
        raise ValueError(f"no physical model for system {system!r}; available: {', '.join(MODELS)}")
    return system
