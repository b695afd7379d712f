"""lcgym: a benchmark suite for learning feedforward control of precision motion systems.

Subpackages: ``physics`` (equations of motion and effects), ``envs`` (plants, references and the
Gymnasium environments, registered here: ``gym.make("lcgym/IX-v0")``), ``baselines``
(feedforward controllers), ``leaderboard`` (metrics), ``data`` (trials and files).
"""

from .envs import register_envs

__version__ = "0.1.0"

register_envs()
