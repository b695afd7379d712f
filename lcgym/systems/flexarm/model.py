"""``ArmModel``: the FlexArm's physical model, fitted by least squares, as a feedforward.

The model is the motor-side rigid-joint dynamics of ``systems.flexarm.motor`` (eqs. 1-2 of paper 002
with stiff joints: the load-side rigid body reflected through the gears, plus motor inertia and
viscous and Coulomb friction), linear in its 78 parameters theta. It gives two feedforward
signals for a load-side reference q_lr:

- ``predict``: the motor torque u(q_lr, qd_lr, qdd_lr) [N m] (T, 6), evaluated ``advance``
  samples ahead (half a sample: the plant holds u over the sample);
- ``reference_offset``: the joint torsion tau_l / K_J [rad, load side] (T, 6) that the gear springs
  take when they carry the load torque tau_l = M_l qdd + C qd + G + D_l qd + F_lc sgn(qd). Added
  to the reference of the motor loop, it makes the load arrive where the reference says instead
  of sagging by the torsion: the quasi-static form of F1 and r_q (eqs. 9, 11), with the fitted
  rigid body in place of the nominal one and without F1's D_J lag (a time constant
  D_J / K_J of 1 ms).

``fit(trials)`` is ``PhysicalModel.fit`` for a machine linear in all its parameters: kinematics of
the reference (or, ``positions="measured"``, of the motion the encoders saw), the measured torque u
and every regressor column low-passed at ``filter_hz`` (zero phase) and decimated, then the
minimum-norm correction of the nominal theta that fits them in least squares. Only joints 2, 3 and
5 move on the TCP lines, so only the combinations of inertial parameters those motions excite are
identified; the rest keep their nominal (CAD) values. An unmodelled payload at the flange is such a
combination: the fit takes it up into link 6's parameters (tested). K_J, D_l and F_lc are not
identifiable from the motor torque and stay nominal.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ...physics.kinematics import reference_kinematics, reference_positions
from ...physics.model import PhysicalModel, diagnosis_decimation
from . import dynamics as arm
from . import motor as arm_motor


@dataclass
class ArmModel(PhysicalModel):
    """FlexArm motor-side model (+ effects); ``fit`` then ``predict`` / ``reference_offset``.
    Constructor arguments are stored as given; ``fit`` sets ``params_`` (``ArmMotorParameters``),
    ``effects_`` and ``fit_info_``; before ``fit`` the given (default nominal) parameters are used.

    fit_inertia: fit the inertial parameters (False: keep the given ones, e.g. CAD values);
    fit_coulomb: fit the Coulomb friction c (False: keep the given c; the diagnosis starts from c = 0
    and offers Coulomb friction as a candidate effect).
    """

    fit_inertia: bool = True
    fit_coulomb: bool = True
    built_in: ClassVar[tuple[str, ...]] = ("rigid_body", "motor_inertia", "viscous_friction", "coulomb_friction")
    # the motor encoders' motion carries the gear torsion, which the load-side model takes for the load's
    # motion: fitted on it, the benchmark's joint errors rose (docs/machines/flexarm.md)
    fitted_on: ClassVar[str] = "reference"
    # besides the exactly unexcited directions, the stationary joints' columns carry round-off of the
    # inverse kinematics (1e-7 relative) that must not be fitted
    rcond: ClassVar[float] = 1e-6

    @classmethod
    def for_diagnosis(cls, system, fs: float) -> ArmModel:
        """The engineer's model: CAD inertial parameters, fitted motor inertia and viscous friction,
        no Coulomb friction; fitted to the motion the motor encoders measured."""
        nominal = arm_motor.ArmMotorParameters()
        return cls(system=system, params=dataclasses.replace(nominal, c=(0.0,) * arm_motor.N), fs=fs,
                   positions="measured", decimate=diagnosis_decimation(fs, cls.filter_hz), fit_inertia=False,
                   fit_coulomb=False)

    def parts(self) -> tuple[str, ...]:
        return (("rigid_body" if self.fit_inertia else "rigid_body (inertial parameters as given)"),
                "motor_inertia", "viscous_friction", *(("coulomb_friction",) if self.fit_coulomb else ()))

    def reference_offset(self, reference) -> np.ndarray:
        """Joint torsion tau_l / K_J [rad, load side] (T, 6) along a reference (module docstring)."""
        q, qd, qdd = reference_kinematics(reference_positions(reference), self.fs, self.advance)
        d = arm.DriveParameters()
        return arm.load_torque(self.fitted_params.arm(), d, q, qd, qdd, arm_motor.EPS) / np.asarray(d.KJ)

    def free_mask(self) -> np.ndarray:
        """Boolean mask (78,) of the parameters the fit adjusts."""
        free = np.ones(arm_motor.N_THETA, dtype=bool)
        free[: arm_motor.N_PI] = self.fit_inertia
        free[arm_motor.N_PI + 2 * arm_motor.N :] = self.fit_coulomb
        return free
