"""The one check of an agent's action, shared by the IX and FlexArm environments.

An action must be real numbers (a float or integer array) of the env's action shape. Strings,
booleans, complex numbers or Python objects are refused before numpy would convert them
silently (a complex action would lose its imaginary part, ``True`` would become 1 V) or fail
with a message that names neither the env nor the step. NaN and inf are checked by each env
next to the physics (the IX kernel refuses them in its loop).
"""

from __future__ import annotations

import numpy as np

NUMERIC_KINDS = "fiu"  # float, signed and unsigned integer


def checked_action(action, shape: tuple[int, ...], env: str, step: int, what: str) -> np.ndarray:
    """``action`` as an array of ``shape``; ValueError naming ``env``, ``step`` and the fault if not.

    ``what`` describes one action in words and units, e.g. "(propeller, roll) feedforward in V".
    """
    a = np.asarray(action)
    if a.dtype.kind not in NUMERIC_KINDS:
        raise ValueError(
            f"{env}: action at step {step} must be real numbers, {what}; got dtype {a.dtype}: {short_repr(action)}"
        )
    if a.shape != shape:
        raise ValueError(f"{env}: action at step {step} must have shape {shape}, {what}; got shape {a.shape}")
    return a


def short_repr(value, width: int = 80) -> str:
    """``repr(value)`` on one line (numpy's line breaks folded) and at most ``width`` characters."""
    text = " ".join(repr(value).split())
    return text if len(text) <= width else text[: width - 3] + "..."
