"""Bad actions, on purpose, in every environment: NaN, inf, wrong shape, wrong dtype.

Each bad action raises ``ValueError`` naming the env and the step, and is refused before the
plant moves: the next good action continues the episode exactly as if the bad one had never been
sent (nothing lost, nothing half-stepped). Out-of-bound actions are not an error: they are
clipped and counted, as the env docstrings say.

Envs: ``lcgym/IX-v0`` (single), its vector entry point (2 sub-envs, one action row each), and
``lcgym/FlexArm-v0``.
"""

import gymnasium as gym
import numpy as np
import pytest

import lcgym  # noqa: F401  (registers the ids)
from lcgym.systems.flexarm.env import FlexArmEnv
from lcgym.systems.flexarm.references import arm_reference_set

SHORT = {"n_references": 2, "duration": 4.0}
GOOD_STEPS = 3  # good steps before the bad action: the error must name step 3


def make_ix():
    return gym.make("lcgym/IX-v0", **SHORT), (2,), "IX env"


def make_ix_vector():
    venv = gym.make_vec("lcgym/IX-v0", num_envs=2, vectorization_mode="vector_entry_point", **SHORT)
    return venv, (2, 2), "IX vector env"


def make_flexarm():
    return FlexArmEnv(references=arm_reference_set("validation", seed=0, n_references=1)), (6,), "FlexArmEnv"


ENVS = {"ix": make_ix, "ix-vector": make_ix_vector, "flexarm": make_flexarm}


def bad_actions(shape: tuple[int, ...]) -> dict[str, object]:
    """Each bad action of an env whose actions have ``shape``, with the words its error must hold."""
    with_one = lambda value: np.where(np.arange(np.prod(shape)).reshape(shape) == 1, value, 0.0)  # noqa: E731
    return {
        "nan": (with_one(np.nan), "NaN or inf"),
        "inf": (with_one(np.inf), "NaN or inf"),
        "-inf": (with_one(-np.inf), "NaN or inf"),
        "one too many": (np.zeros(shape[:-1] + (shape[-1] + 1,)), "must have shape"),
        "flat or batched": (np.zeros(int(np.prod(shape))) if len(shape) == 2 else np.zeros((1, *shape)),
                            "must have shape"),
        "scalar": (0.5, "must have shape"),
        "empty": (np.array([]), "must have shape"),
        "strings": (np.full(shape, "1.0"), "must be real numbers"),
        "complex": (np.zeros(shape, dtype=complex), "must be real numbers"),
        "bool": (np.zeros(shape, dtype=bool), "must be real numbers"),
        "None": (None, "must be real numbers"),
        "list with None": ([None] * shape[-1] if len(shape) == 1 else [[None] * shape[-1]] * shape[0],
                           "must be real numbers"),
    }


CASES = [(env, case) for env in ENVS for case in bad_actions((2,))]


def _episode(make, actions):
    """Observations and rewards of a fresh env (seed 0) stepped with ``actions``."""
    env, shape, _ = make()
    env.reset(seed=0)
    out = []
    for a in actions:
        obs, reward, *_ = env.step(a)
        out.append((np.asarray(obs).copy(), np.asarray(reward).copy()))
    return out


@pytest.mark.bad_input
@pytest.mark.parametrize(("env_name", "case"), CASES)
def test_bad_action_is_refused_naming_env_and_step_and_loses_nothing(env_name, case):
    env, shape, label = ENVS[env_name]()
    action, words = bad_actions(shape)[case]
    rng = np.random.default_rng(1)
    good = [rng.uniform(-0.5, 0.5, size=shape).astype(np.float32) for _ in range(GOOD_STEPS + 2)]
    env.reset(seed=0)
    before = [env.step(a)[:2] for a in good[:GOOD_STEPS]]
    with pytest.raises(ValueError) as exc:
        env.step(action)
    message = str(exc.value)
    assert message.startswith(f"{label}: action") and f"at step {GOOD_STEPS}" in message, message
    assert words in message, message
    after = [env.step(a)[:2] for a in good[GOOD_STEPS:]]
    expected = _episode(ENVS[env_name], good)
    for (obs, reward), (obs_e, reward_e) in zip(before + after, expected, strict=True):
        np.testing.assert_array_equal(obs, obs_e)
        np.testing.assert_array_equal(reward, reward_e)


@pytest.mark.parametrize("env_name", list(ENVS))
def test_integer_and_float32_actions_are_numbers(env_name):
    env, shape, _ = ENVS[env_name]()
    env.reset(seed=0)
    env.step(np.zeros(shape, dtype=np.int64))
    env.step(np.zeros(shape, dtype=np.float32))
    env.step(np.zeros(shape).tolist())


def test_out_of_bound_actions_are_clipped_and_counted():
    env, _, _ = make_ix()
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([9.0, -0.5], dtype=np.float32))
    assert info["clipped_actions"] == 1 and info["ff"][0] == 5.0
    _, _, _, _, info = env.step(np.array([-7.0, 8.0], dtype=np.float32))
    assert info["clipped_actions"] == 3
    arm, _, _ = make_flexarm()
    arm.reset(seed=1)
    _, _, _, _, info = arm.step(np.full(6, 100.0))
    assert info["clipped_actions"] == 1


def test_vector_env_ignores_the_action_of_a_sub_env_that_autoresets():
    """Gymnasium's next-step autoreset: the step after an episode ends resets that sub-env and
    ignores its action, so a NaN there (a policy's output on a final observation) is no error."""
    venv, _, _ = make_ix_vector()
    venv.reset(seed=0)
    inner = venv.unwrapped
    inner._autoreset[1] = True  # as after sub-env 1's last sample
    venv.step(np.array([[0.0, 0.0], [np.nan, np.nan]]))
    with pytest.raises(ValueError, match="sub-env 1"):
        venv.step(np.array([[0.0, 0.0], [np.nan, 0.0]]))
