"""lcgym: a benchmark suite for learning feedforward control of precision motion systems.

Subpackages: ``systems`` (the machines: one ``System`` object each, the built-in IX and FlexArm with
their plants and Gymnasium envs, registered here: ``gym.make("lcgym/IX-v1")``, and a user's
machine from a URDF or Python), ``physics`` (the effect library, the least-squares model, filters),
``envs`` (Gymnasium glue), ``methods`` (one module or folder per method), ``leaderboard``
(runner, store, report), ``diagnose`` (which effect a model misses), ``data`` (trials and files).
"""

from .provenance import __version__ as __version__
from .systems import register_envs

register_envs()
