"""The IX: the interventional X-ray C-arm of paper 000 (propeller theta2, roll theta3), input in V.

``IX`` is the machine: its rigid body of eqs. (2)-(9) (``dynamics.py``, the compiled regressor of
Lemma 1 in ``compiled.py``), its guidance friction (``effects.py``), and for the benchmark its
plant with the hidden effects (``plant.py``, ``kernel.py``), reference sets (``references.py``),
Gymnasium envs (``env.py``: ``lcgym/IX-v0`` and its vector env) and scoring (``bench.py``).
"""

from __future__ import annotations

import math

import numpy as np

from .. import ENVS
from ..bench import BenchFactory
from ..system import Axis, DiagnosisSettings, NonlinearStructure, System
from . import dynamics
from .bench import IXBench
from .compiled import regressor
from .effects import CANDIDATES, PositionDependentFriction

DEG = math.pi / 180.0


def joint_axes() -> np.ndarray:
    """Propeller about the base's y (R02 = Ry(theta2)), roll about x of the propeller frame (R03 =
    Ry Rx), at theta = 0: perpendicular."""
    return np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])


IX = System(
    name="ix",
    axes=tuple(Axis(a, "revolute", "V", speed_scale=20 * DEG, position_scale=100 * DEG) for a in dynamics.AXES),
    param_names=dynamics.PARAM_NAMES,
    n_linear=dynamics.N_LINEAR,
    regressor=regressor,
    inverse_dynamics=dynamics.inverse_dynamics,
    mass_matrix=dynamics.mass_matrix,
    positive=(dynamics.M2, dynamics.M3, dynamics.J2YY, dynamics.J3XX, dynamics.J3YY, dynamics.J3ZZ, dynamics.D2,
              dynamics.D3),
    parameters=dynamics.IXParameters,
    fs=500.0,
    advance=1.5,  # samples: one computation delay + half a hold interval
    effects=(PositionDependentFriction,),
    diagnosis=DiagnosisSettings(noise_rms=0.004, candidates=CANDIDATES),  # V: the low-passed input's quantization noise
    # m2 x2, m3 y3 z3, ...: the masses carry zeta_n
    nonlinear=NonlinearStructure(quadratic=True, columns=(dynamics.M2, dynamics.M3)),
    # the RL agent gets 3 passes over the training samples in 8 envs, acting at 50 Hz
    settings={"pgnn": {"constraint_configs": None},  # R2 over every configuration: the IX's 2 x 2 M is cheap
              "rl": {"passes": 3.0, "num_envs": 8, "agent_rate": 50.0}},
    description="interventional X-ray C-arm of paper 000: propeller and roll, input in V",
    joint_axes=joint_axes,
    bench=BenchFactory(IXBench, envs={k: v for k, v in ENVS.items() if k.startswith("lcgym/IX-")},
                       observation_error=slice(34, 36)),
)

__all__ = ["IX"]
