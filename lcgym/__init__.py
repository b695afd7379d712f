"""lcgym: a benchmark suite for learning feedforward control of precision motion systems.

Subpackages: ``physics`` (equations of motion and effects), ``envs`` (plants and references),
``baselines`` (feedforward controllers), ``leaderboard`` (metrics), ``data`` (trials and files).
"""

__version__ = "0.1.0"
