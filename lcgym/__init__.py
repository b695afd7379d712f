"""lcgym: a benchmark suite for learning feedforward control of precision motion systems.

Subpackages: ``systems`` (the machines: one ``System`` object each, the built-in IX and FlexArm with
their plants and Gymnasium envs, registered here: ``gym.make("lcgym/IX-v0")``, and a user's
machine from a URDF or Python), ``physics`` (the effect library, the least-squares model, filters),
``envs`` (Gymnasium glue), ``baselines``, ``pgnn``, ``rbf_expert`` (the methods), ``leaderboard``
(runner, store, report), ``diagnose`` (which effect a model misses), ``data`` (trials and files).
"""

__version__ = "0.1.0"

from .systems import register_envs  # noqa: E402  (the version first: modules below read it)

register_envs()
