"""What is machine-independent in the physics: the effect library (``effects.py``: each effect's
formula, how the diagnosis searches it, ``grids.py``, and its kind in every plant's compiled
torque, ``plant_effects.py``), the diagnosis's candidates from it (``candidates.py``), the
least-squares physical model of any machine (``model.py``) and how it sees data
(``preprocessing.py``), kinematics and filters (``kinematics.py``), the caches a process keeps
(``workspace.py``), and the settings of compiled kernels (``compiled.py``). The machines' own
equations live in ``systems/<machine>/``."""

from .effects import EFFECTS, Effect, make_effect
from .model import PhysicalModel

__all__ = ["EFFECTS", "Effect", "PhysicalModel", "make_effect"]
