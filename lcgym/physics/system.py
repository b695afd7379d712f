"""What a learner needs to know about a system's rigid-body physics, in one object.

``RigidBodySystem`` bundles the functions of a system's physics module that the learners share
(the PGNN's physical part and its projection, the diagnosis): inverse dynamics (numpy and
torch), the regressor of the parameters the model is linear in (Lemma 1 of paper 000), the mass
matrix, and which parameters must stay positive. A learner written against it runs on any
system that provides one: ``IX`` and the FlexArm's motor-side model ``ARM`` (``physics.arm_motor``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from . import arm_motor, compiled, ix


@dataclass(frozen=True)
class RigidBodySystem:
    """The physics of one system, parameter vector p = [zeta_l (n_linear), zeta_n].

    inverse_dynamics(p, q, qd, qdd) -> (..., n_axes) [actuator units]; numpy or torch (autograd in p).
    regressor(zeta_n, q, qd, qdd) -> (T, n_axes, n_linear), numpy: tau = regressor @ zeta_l.
    mass_matrix(p, q) -> (..., n_axes, n_axes); numpy or torch.
    positive: indices of parameters that are positive physically (masses, inertias, damping).
    parameters: a dataclass type with ``from_vector(p)`` and ``to_vector()``.
    input_unit: unit of the actuator input; noise_rms: the RMS [input_unit] below which a
    diagnosis does not count an improvement as real (the low-passed input's noise scale).
    constraint_configs: at most this many configurations of a batch enter the PGNN's mass-matrix
    constraint (None: all; the arm's 6 x 6 matrices cost 6 regressor evaluations each).
    """

    name: str
    axes: tuple[str, ...]
    param_names: tuple[str, ...]
    n_linear: int
    inverse_dynamics: Callable
    regressor: Callable
    mass_matrix: Callable
    positive: tuple[int, ...]
    parameters: type
    input_unit: str = "V"
    noise_rms: float = 0.004
    constraint_configs: int | None = None

    @property
    def fully_linear(self) -> bool:
        """True when every parameter is linear (no zeta_n): then u = regressor @ p exactly."""
        return self.n_linear == len(self.param_names)


IX = RigidBodySystem(
    name="ix",
    axes=ix.AXES,
    param_names=ix.PARAM_NAMES,
    n_linear=ix.N_LINEAR,
    inverse_dynamics=ix.inverse_dynamics,
    regressor=compiled.regressor,
    mass_matrix=ix.mass_matrix,
    positive=(ix.M2, ix.M3, ix.J2YY, ix.J3XX, ix.J3YY, ix.J3ZZ, ix.D2, ix.D3),
    parameters=ix.IXParameters,
)

ARM = RigidBodySystem(
    name="flexarm",
    axes=arm_motor.arm.AXES,
    param_names=arm_motor.PARAM_NAMES,
    n_linear=arm_motor.N_THETA,
    inverse_dynamics=arm_motor.inverse_dynamics,
    regressor=arm_motor.regressor,
    mass_matrix=arm_motor.mass_matrix,
    positive=(*arm_motor.MASS_INDICES, *range(arm_motor.N_PI, arm_motor.N_THETA)),
    parameters=arm_motor.ArmMotorParameters,
    input_unit="N m",
    noise_rms=0.01,
    constraint_configs=16,
)

SYSTEMS = {IX.name: IX, ARM.name: ARM}
