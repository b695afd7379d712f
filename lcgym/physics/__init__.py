"""What is machine-independent in the physics: the effect library (``effects.py``) and the
diagnosis's candidates from it (``candidates.py``), the least-squares physical model of any machine
(``model.py``), kinematics and filters (``kinematics.py``), and the settings of compiled kernels
(``compiled.py``). The machines' own equations live in ``systems/<machine>/``."""

from .effects import EFFECTS, Effect, make_effect
from .model import PhysicalModel

__all__ = ["EFFECTS", "Effect", "PhysicalModel", "make_effect"]
