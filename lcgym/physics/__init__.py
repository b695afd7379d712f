"""Equations of motion and the effect library, written once for numpy, torch and the compiled plant."""

from .effects import EFFECTS, Effect, make_effect
from .ix import IXParameters
from .model import PhysicalModel

__all__ = ["EFFECTS", "Effect", "IXParameters", "PhysicalModel", "make_effect"]
