"""What a machine's loop needs in its feedforward path beyond the force: the one rule every base
follows (``bases``), and the diagnosis's replay and the Gymnasium envs with them.

A loop that differentiates the measured position (a cascade drive's velocity loop, the EMPS's
nu = kp kv (q_r - q) - kv qd_m) reacts to the motion itself: with a perfect force feedforward it
still leaves e = (kd / kp) qd_r. A drive's velocity feedforward cancels that reaction. In general
the feedforward that makes a loop track exactly is the force minus what the feedback outputs when
the measurement follows the reference (``plant.reference_feedback``): kd times the reference's
velocity, as the loop differentiates it, on such a loop; nothing where the loop acts on the tracking
error alone (the IX, the FlexArm, the two-link arm).
"""

from __future__ import annotations

import numpy as np

from .. import systems
from ..physics.kinematics import reference_positions


def machine_loop(system: systems.System):
    """The closed loop a base's feedforward goes into: the plant of ``system``'s newest bench (its
    ``reference_feedback``), or None for a machine without a plant (a URDF for the diagnosis)."""
    return None if system.bench is None else system.make_bench().plant


def loop_feedforward(loop, reference) -> np.ndarray | float:
    """What ``loop`` (a plant, ``machine_loop``; None: none) needs in its feedforward path, beyond the
    force, to track ``reference`` exactly: minus its feedback's output when its encoders follow the
    reference (``plant.reference_feedback``), (T, n_axes) in the input's unit; 0.0 without a loop."""
    if loop is None:
        return 0.0
    return -loop.reference_feedback(reference_positions(reference))
