"""A user's own code named as ``module:attr`` (a machine, ``lcgym bench --systems my_mod:arm``; a
method, ``--methods my_ff:GravityOnly``): imported as ``python -m`` would find it, from the current
folder first. The one place lcgym changes ``sys.path``."""

from __future__ import annotations

import importlib
import os
import sys
from types import ModuleType


def import_user_module(name: str) -> ModuleType:
    """``importlib.import_module(name)`` with the current folder on ``sys.path`` (put first once, as
    ``python -m`` does), so that a module saved beside the user's command is found. Errors are the
    import's own: the caller says what it was looking for."""
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    return importlib.import_module(name)
