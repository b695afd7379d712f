"""The FlexArm: the flexible-joint 6-DOF industrial arm of paper 002, input in N m (motor side).

``FLEXARM`` is the machine seen from its motors (the rigid-joint model learners fit:
``motor.py``, on the load-side rigid body of ``dynamics.py``; the physical model with its
joint-torsion reference offset in ``model.py``), its payload effect (``effects.py``), and for the
benchmark the flexible plant with the accelerometer (``plant.py``, ``sensors.py``), paper 002's
nominal feedforward "Basic" (``nominal.py``), the TCP-line references (``references.py``), the
Gymnasium env ``lcgym/FlexArm-v0`` (``env.py``) and scoring (``bench.py``).
"""

from __future__ import annotations

import math

from .. import ENVS
from ..bench import BenchFactory
from ..system import Axis, DiagnosisSettings, System
from . import dynamics, motor
from .bench import FlexArmBench
from .effects import CANDIDATES, Payload
from .model import ArmModel
from .nominal import BasicFeedforward

DEG = math.pi / 180.0

FLEXARM = System(
    name="flexarm",
    axes=tuple(Axis(a, "revolute", "N m", speed_scale=20 * DEG, position_scale=100 * DEG) for a in dynamics.AXES),
    param_names=motor.PARAM_NAMES,
    regressor=motor.regressor,
    inverse_dynamics=motor.inverse_dynamics,
    mass_matrix=motor.mass_matrix,
    positive=(*motor.MASS_INDICES, *range(motor.N_PI, motor.N_THETA)),
    parameters=motor.ArmMotorParameters,
    model=ArmModel,
    fs=1000.0,
    advance=0.5,  # samples: the plant holds u over the sample
    effects=(Payload,),
    diagnosis=DiagnosisSettings(noise_rms=0.01, candidates=CANDIDATES,  # N m
                                candidate_names=("coulomb_friction", "stribeck_friction", "payload")),
    # the PGNN on 1 kHz data of moves of 1-2 s: every 10th sample, R2 on 16 configurations per batch (the 6 x 6
    # mass matrices cost 6 regressor evaluations each), u at 10 Hz: the base's measured torque, run as the
    # feedforward of its own reference, tracks as well low-passed at 10 Hz as unfiltered, worse at 5 Hz, and at
    # 2 Hz worse than the base (docs/methods/pgnn.md); the RL agent: 1 pass in 4 envs
    settings={"pgnn": {"filter_hz": 10.0, "decimate": 10, "constraint_configs": 16},
              "rl": {"passes": 1.0, "num_envs": 4}},
    description="flexible-joint 6-DOF industrial arm of paper 002: joints j1-j6, motor torques in N m",
    joint_axes=lambda: dynamics.joint_axes(dynamics.HOME),
    caching=motor.cached_regressors,
    bench=BenchFactory(FlexArmBench, envs={k: v for k, v in ENVS.items() if k.startswith("lcgym/FlexArm-")},
                       observation_error=slice(30, 36)),
    nominal=BasicFeedforward(),
)

__all__ = ["FLEXARM"]
