"""The IX plant: true rigid body + hidden effects + feedback + actuator and sensor, at 500 Hz.

What one run does, per sample k (Ts = 1/fs = 2 ms):

1. The encoders read the axis angles, quantized to 0.0669 deg (propeller) and 0.0119 deg (roll);
   with drivetrain flexibility they sit on the motor side.
2. The fixed diagonal feedback (PD + first-order low-pass on its output, ``FeedbackGains``) computes
   ``fb[k]`` from e[k] = ref[k] - measured[k]; the input is u[k] = sat(fb[k] + ff[k], +-5 V).
3. u[k] is applied over [t_{k+1}, t_{k+2}) (one-sample computation delay, zero-order hold).
4. The true dynamics are integrated over each interval in ``substeps`` steps (default 1: 2 ms).
   Each step is a Strang split: the LuGre bristle states relax exactly (exponential solution for
   frozen position and speed) over half a step, the mechanics take one classical RK4 step, and
   the bristles relax over the other half. The bristle relaxation (rate sigma0 |v| ~ 3500/s at
   20 deg/s) is the only stiff part; solved exactly, it no longer limits the step, and RK4 at
   2 ms resolves the drivetrain modes (15-34 Hz, omega h < 0.45). Second order overall:
   tests/test_plant_ix.py shows the trajectory converging as the step shrinks. Without encoder
   quantization, the default differs from 64 substeps by at most 1.2e-5 deg on a normal run and
   2.2e-4 deg under +-5 V white-noise feedforward (a roll encoder count is 0.0119 deg). Raise
   ``substeps`` for stiffer effects than the defaults (e.g. a much stiffer drive).

Before recording, the plant holds the first reference sample for ``preroll`` seconds so that
gravity sag and friction states settle. If the state leaves the safe range (tracking error over
``max_error`` or speed over ``max_velocity``, or a non-finite value), the run stops with
``SimulationDiverged`` naming the reference, time and state.

Effects: any tuple of effects from `physics.effects` and the IX's own guidance friction
(``systems/ix/effects.py``): model-side ones (all but ``rotor_inertia``: the IX's rigid body
holds its drives' inertia) and the plant-only ``stiction``, ``drivetrain_flexibility`` and
``tabulated_force``, each on one axis, each with its parameters.
``default_hidden_effects()`` reproduces the situation of paper 000 (see its docstring).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numba
import numpy as np

from ...data import Trial
from ...physics import effects as fx
from ...physics import plant_effects
from ...physics.lti import rigid_axis
from ...references import Reference
from ..feedback import FeedbackGains
from ..plant import EncoderLoop
from ..runs import remembered
from ..system import SimulationDiverged
from . import dynamics as ix
from . import kernel as K
from .effects import PositionDependentFriction

DEG = math.pi / 180.0
ENCODER_RESOLUTION = (0.0669 * DEG, 0.0119 * DEG)  # rad per count: propeller, roll


IX_GAINS = FeedbackGains(kp=(170.0, 120.0), kd=(14.0, 12.0), f_lp=(20.0, 20.0), u_max=5.0, filtered="output")
"""IX-v0's diagonal PD + low-pass feedback per axis (propeller, roll); fixed, as on the real IX: kp
[V/rad], kd [V s/rad], the first-order low-pass on the PD output at f_lp [Hz], the amplifier's
saturation u_max [V]. Crossover about 2.7 Hz, phase margin 47-53 deg on the rigid plant."""


def gain_matrix(gains: FeedbackGains, fs: float) -> np.ndarray:
    """The kernel's controller rows (2, 3): kp, kd and the low-pass's pole exp(-2 pi f_lp / fs) per axis."""
    alpha = [math.exp(-2 * math.pi * f / fs) for f in gains.f_lp]
    return np.array([[gains.kp[i], gains.kd[i], alpha[i]] for i in range(2)], dtype=float)


@dataclass(frozen=True)
class HiddenEffectSizes:
    """The sizes of the IX plant's hidden effects [V, rad, s] (``effects()`` builds them).

    The defaults are IX-v0's (``default_hidden_effects``); ``V1_SIZES`` are IX-v1's, calibrated
    by ``studies/calibrate_ix.py`` so that the machine-describing rows of the benchmark match
    paper 000's Tables II-V. Only sizes differ between versions, not the effects' forms.
    """

    roll_coulomb: float = 0.045
    roll_normal_cos: float = 0.075  # PositionDependentFriction c_cos, c_cos_roll, c_sin
    roll_normal_cos_roll: float = 0.03
    roll_normal_sin: float = 0.06
    roll_stribeck: float = 0.09
    roll_stribeck_speed: float = 0.4 * DEG
    roll_bristle: float = 1e4  # LuGre sigma0 [1/rad]
    roll_spring: float = 0.22  # V/rad beyond 20 deg
    roll_cable_inertia: float = 0.06
    propeller_coulomb: float = 0.10
    propeller_normal_cos: float = 0.06
    propeller_stribeck: float = 0.075
    propeller_stribeck_speed: float = 0.3 * DEG
    propeller_bristle: float = 1e4
    propeller_harmonic: float = 0.14  # first harmonic of the 5-degree gear period
    propeller_harmonic_2: float = 0.06
    propeller_drape: float = 0.18

    def effects(self) -> tuple[fx.Effect, ...]:
        """The hidden effects of these sizes (the forms of ``default_hidden_effects``)."""
        return (
            fx.CoulombFriction("roll", Fc=self.roll_coulomb),
            PositionDependentFriction("roll", c_cos=self.roll_normal_cos, c_cos_roll=self.roll_normal_cos_roll,
                                      c_sin=self.roll_normal_sin),
            fx.StribeckFriction("roll", dF=self.roll_stribeck, vs=self.roll_stribeck_speed),
            fx.Stiction("roll", sigma0=self.roll_bristle, sigma1=60.0),
            fx.CableSpring("roll", k=self.roll_spring, q0=20 * DEG, width=3 * DEG),
            fx.CableInertia("roll", dJ=self.roll_cable_inertia, q0=20 * DEG, width=10 * DEG),
            fx.CoulombFriction("propeller", Fc=self.propeller_coulomb),
            PositionDependentFriction("propeller", c_cos=self.propeller_normal_cos),
            fx.StribeckFriction("propeller", dF=self.propeller_stribeck, vs=self.propeller_stribeck_speed),
            fx.Stiction("propeller", sigma0=self.propeller_bristle, sigma1=60.0),
            fx.GearHarmonic.from_amplitudes("propeller", self.propeller_harmonic, 0.7, self.propeller_harmonic_2, 2.0,
                                            velocity_gain=0.5),
            fx.CableDrape.from_amplitude("propeller", self.propeller_drape, 20 * DEG),
            fx.DrivetrainFlexibility("propeller", k=7500.0, c=7.0, Jm=0.20),
            fx.DrivetrainFlexibility("roll", k=7000.0, c=6.5, Jm=0.20),
            fx.TorqueRipple.from_amplitude("propeller", 0.03, 3.0 * DEG, 0.4),
            fx.TorqueRipple.from_amplitude("roll", 0.03, 2.4 * DEG, 1.3),
        )


V1_SIZES = HiddenEffectSizes(
    roll_normal_cos=0.39, roll_normal_cos_roll=0.156, roll_normal_sin=0.312, roll_spring=0.55,
    propeller_coulomb=0.18, propeller_normal_cos=0.15, propeller_stribeck=1.15, propeller_stribeck_speed=0.1 * DEG,
    propeller_bristle=1e6, propeller_harmonic=0.042, propeller_harmonic_2=0.018,
)
"""IX-v1's hidden-effect sizes (``studies/calibrate_ix.py``). Against v0: the roll's guidance
friction 5.2x and cable spring 2.5x (the roll's residual, and the offset and slope of its tracking
error); the propeller's sliding friction 0.18 + 0.15 |cos th2| V (v0: 0.10 + 0.06), a breakaway
1.15 V above it below 0.1 deg/s on bristles 100x stiffer, so that the axis really sticks (the
stiction transients after standstill that make Table II's Inf of 1.88 V), and its gear harmonic
0.3x (with the softer feedback it would otherwise dominate the residual's RMS). The stiff bristles
make the default 2 ms step differ from 8 substeps by up to 2e-3 deg of the propeller's angle (3 %
of an encoder count) on a validation reference without quantization."""

V1_GAINS = FeedbackGains(kp=(140.0, 170.0), kd=(16.0, 14.0), f_lp=(5.0, 20.0), u_max=5.0, filtered="output")
"""IX-v1's feedback (``studies/calibrate_ix.py``): the propeller's loop softer (kp 140 against v0's
170: Table IV's feedback-only error) and low-passed at 5 Hz (the encoder's 0.0669 deg counts
otherwise make 0.5 V of chatter in u: Table II's residual); the roll's stiffer (kp 170)."""


def default_hidden_effects() -> tuple[fx.Effect, ...]:
    """The IX's hidden effects at IX-v0's sizes (``HiddenEffectSizes``), sized so that the fitted
    rigid model leaves a structured error. Roll: guidance friction whose level follows the normal
    force, a Stribeck rise (an additive level) and LuGre stiction, a one-sided cable spring beyond
    20 deg and a cable inertia around it. Propeller: friction with a Stribeck rise and stiction, a
    gear harmonic of period 5 deg and a cable drape. Both: two-mass drives (modes near 15-17 and
    34 Hz) and 3 % torque ripple."""
    return HiddenEffectSizes().effects()


VERSIONS = {
    "v0": lambda: {},
    "v1": lambda: {"effects": V1_SIZES.effects(), "gains": V1_GAINS},
}
"""IX versions: the ``IXPlant`` arguments that make each (``IXPlant.of_version``)."""


def pack_effects(effects: Sequence[fx.Effect], rigid: ix.IXParameters) -> tuple[np.ndarray, np.ndarray]:
    """Effect parameters as the kernel's (2, STATIC + width) array, and the load's rigid parameters
    (motor inertia of a flexible drive moved out of J2yy / J3xx). The IX's friction law, stiction
    and the effects that change its equation go to the kernel's slots; the effects that add a torque
    of q and qd to the records of ``physics.plant_effects``."""
    fx.check_unique(effects)
    p = rigid.to_vector()
    for e in effects:
        if e.axis not in ix.AXES:
            raise ValueError(f"{e.key} is not an effect of the IX (axes {', '.join(ix.AXES)})")
        if isinstance(e, fx.LoadFriction):
            raise ValueError(f"{e.key}: the IX plant does not simulate a load-dependent friction (its kernel does "
                             "not compute the gravity torque apart)")
    bound = [e.bound(ix.AXES) for e in effects]
    kernel_own = [not plant_effects.has_plant_kind(e) or isinstance(e, OWN_FRICTION_LAW) for e in bound]
    own = [e for e, k in zip(bound, kernel_own, strict=True) if k]
    records = plant_effects.pack([e for e, k in zip(bound, kernel_own, strict=True) if not k], 2)
    E = np.zeros((2, K.STATIC + records.shape[1]))
    E[:, K.EPS] = 1e-3
    E[:, K.STATIC :] = records
    for e in own:
        row = E[e.index]
        if isinstance(e, fx.CoulombFriction):
            row[K.FC], row[K.EPS] = e.Fc, e.eps
        elif isinstance(e, PositionDependentFriction):
            row[K.PD_COS], row[K.PD_COS_ROLL], row[K.PD_SIN] = e.c_cos, e.c_cos_roll, e.c_sin
        elif isinstance(e, fx.StribeckFriction):
            row[K.ST_DF], row[K.ST_VS] = e.dF, e.vs
        elif isinstance(e, fx.Stiction):
            row[K.LG_S0], row[K.LG_S1] = e.sigma0, e.sigma1
        elif isinstance(e, fx.CableInertia):
            row[K.CI_DJ], row[K.CI_Q0], row[K.CI_W] = e.dJ, e.q0, e.width
        elif isinstance(e, fx.TorqueRipple):
            row[K.RP_AS], row[K.RP_AC], row[K.RP_PER] = e.a_sin, e.a_cos, e.period
        elif isinstance(e, fx.DrivetrainFlexibility):
            row[K.FX_K], row[K.FX_C], row[K.FX_JM] = e.k, e.c, e.Jm
            j = ix.J2YY if e.index == 0 else ix.J3XX
            if p[j] - e.Jm <= 0:
                raise ValueError(f"{e.key}: motor inertia {e.Jm} exceeds the axis inertia {p[j]}")
            p[j] -= e.Jm
        else:
            raise TypeError(f"the IX plant has no model of effect {e.key} ({type(e).__name__}): "
                            f"{plant_effects.refusal(type(e))}")
    return E, p


OWN_FRICTION_LAW = (fx.CoulombFriction, fx.StribeckFriction)
"""Effects of ``physics.plant_effects``' kinds that the IX simulates in its own friction law instead:
their level, with the guidance friction's, is what its LuGre stiction scales (``kernel.friction_level``;
the Stribeck rise takes the Coulomb friction's smoothing)."""


@dataclass
class IXPlant(EncoderLoop):
    """Closed-loop IX (propeller, roll) simulator with switchable hidden effects.

    rigid: true rigid-body parameters (total axis inertias); effects: true effects;
    gains: feedback; fs [Hz]; substeps: RK4 steps per sample; encoder_resolution [rad];
    preroll [s]; max_error [rad] and max_velocity [rad/s]: the safe range.
    """

    rigid: ix.IXParameters = field(default_factory=ix.IXParameters)
    effects: tuple[fx.Effect, ...] = field(default_factory=default_hidden_effects)
    gains: FeedbackGains = IX_GAINS
    fs: float = 500.0
    substeps: int = 1
    encoder_resolution: tuple[float, float] = ENCODER_RESOLUTION
    preroll: float = 1.0
    max_error: float = 30 * DEG
    max_velocity: float = 1.0  # rad/s: 57 deg/s, about 3x the IX's top speed

    axes = ix.AXES

    @classmethod
    def of_version(cls, version: str, **overrides) -> IXPlant:
        """The plant of IX-``version`` ("v0": the defaults of this class; "v1": the effect sizes
        ``V1_SIZES`` and feedback ``V1_GAINS``, calibrated to paper 000), with ``overrides``."""
        if version not in VERSIONS:
            raise ValueError(f"unknown IX version {version!r}; available: {', '.join(VERSIONS)}")
        return cls(**{**VERSIONS[version](), **overrides})

    def __post_init__(self):
        self.effects = tuple(self.effects)
        if self.substeps < 1:
            raise ValueError(f"substeps must be >= 1, got {self.substeps}")
        if self.fs <= 0:
            raise ValueError(f"fs must be positive, got {self.fs}")
        self._E, self._p = pack_effects(self.effects, self.rigid)
        self.gains.require("output", "the IX plant")
        if self.gains.n_axes != 2 or self.gains.u_max is None or any(k != 0 for k in self.gains.ki):
            raise ValueError(f"the IX plant's feedback is a PD per axis (propeller, roll) with an amplifier limit u_max; "
                             f"got {self.gains}")
        self._C = gain_matrix(self.gains, self.fs)
        self._cfg = np.zeros(K.N_CFG)
        self._cfg[[K.CFG_UMAX, K.CFG_TS, K.CFG_ERR, K.CFG_VEL, K.CFG_SUB]] = (
            self.gains.u_max, 1.0 / self.fs, self.max_error, self.max_velocity, self.substeps)
        self._cfg[[K.CFG_RES0, K.CFG_RES1]] = self.encoder_resolution

    def record(self) -> dict:
        """A JSON-ready description from which ``from_record`` rebuilds this plant (stored in the
        sidecar of simulated measurement files, so that ``lcgym diagnose --replay`` can re-run it)."""
        return {"system": "ix", "rigid": self.rigid.to_vector().tolist(), "effects": [fx.effect_record(e) for e in self.effects],
                "gains": {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(self.gains).items()},
                "fs": self.fs, "substeps": self.substeps, "encoder_resolution": list(self.encoder_resolution),
                "preroll": self.preroll, "max_error": self.max_error, "max_velocity": self.max_velocity}

    @classmethod
    def from_record(cls, record: dict) -> IXPlant:
        """The plant that ``record`` describes."""
        # a record written before the gains named where they filter: the IX's place, its output
        gains = FeedbackGains(**{"filtered": "output", **{k: tuple(v) if isinstance(v, list) else v
                                                        for k, v in record["gains"].items()}})
        effects = tuple(fx.effect_from_record(r, own=(PositionDependentFriction,)) for r in record["effects"])
        return cls(rigid=ix.IXParameters.from_vector(np.asarray(record["rigid"], dtype=float)), effects=effects,
                   gains=gains, fs=record["fs"],
                   substeps=record["substeps"], encoder_resolution=tuple(record["encoder_resolution"]),
                   preroll=record["preroll"], max_error=record["max_error"], max_velocity=record["max_velocity"])

    @property
    def preroll_samples(self) -> int:
        return int(round(self.preroll * self.fs))

    def static_model(self, system):
        """The plant's own static feedforward on ``system`` (the IX's ``System``, ``systems.ix.IX``),
        a ``PhysicalModel`` with the true rigid body and the
        true sizes of every hidden effect that is a function of (theta, theta', theta'') (friction
        levels and Stribeck rise, spring, cable, gear harmonic, ripple), without the internal
        dynamics (LuGre bristles, drive flexibility). The best a static function of the PGNN's
        inputs can do (paper 000 eq. 11, the relay aside): the oracle the PGNN is reported against."""
        from ...physics.model import PhysicalModel

        return PhysicalModel(system, params=self.rigid, effects=tuple(e for e in self.effects if not e.plant_only),
                             fs=self.fs)

    def process_sensitivity(self, n: int, positions: np.ndarray, params: ix.IXParameters | None = None) -> np.ndarray:
        """P S (e^{i w Ts}) (n_freq, 2) [rad/V] of the nominal closed loop per axis on the rfft grid of
        n samples (what plant-inversion ILC inverts, ``methods.ilc.method``): the rigid axis P(s) = 1 / (J s^2
        + D s) with J the diagonal of the nominal mass matrix at the mean pose of ``positions`` (T, 2)
        [rad] and D the nominal viscous coefficient, discretized with a zero-order hold and the plant's
        one-sample computation delay, and this plant's PD + low-pass feedback C(z)."""
        return process_sensitivity(n, self.fs, positions, self.gains, params)

    def reference_feedback(self, positions) -> np.ndarray:
        """What the feedback outputs (T, 2) [V] when the encoders follow ``positions`` exactly: zero,
        since its PD acts on the tracking error alone (``urdf_plant.URDFPlant.reference_feedback``
        for a loop that differentiates the measurement)."""
        return np.zeros_like(np.asarray(positions, dtype=float))

    @property
    def u_max(self) -> float:
        """The amplifier's limit [V], both axes."""
        return self.gains.u_max

    @property
    def deterministic(self) -> bool:
        """A run is a function of its inputs (no noise: the encoders quantize)."""
        return True

    @remembered  # inside the benchmark's cells: a run made before is not made again (``systems.runs``)
    def run(self, references, feedforward=None) -> Trial | list[Trial]:
        """Run the closed loop on one reference or a list of them (in parallel).

        references: a Reference, an array (T, 2) of positions [rad], or a list of these.
        feedforward: None (zero), an array (T, 2) [V], or a list matching ``references``.
        Returns a Trial (or a list of Trials) with the reference, encoder position, input u,
        feedforward, and the true load angle in ``extra["load_<axis>"]``.
        """
        single = not isinstance(references, (list, tuple))
        refs = [references] if single else list(references)
        ffs = [feedforward] if single else (list(feedforward) if feedforward is not None else [None] * len(refs))
        if len(ffs) != len(refs):
            raise ValueError(f"{len(refs)} references but {len(ffs)} feedforward signals")
        names, pos = [], []
        for i, r in enumerate(refs):
            x = np.asarray(r.positions if isinstance(r, Reference) else r, dtype=float)
            name = r.name if isinstance(r, Reference) else f"reference-{i}"
            if x.ndim != 2 or x.shape[1] != 2 or x.shape[0] < 2:
                raise ValueError(f"{name}: reference must have shape (T >= 2, 2), got {x.shape}")
            if not np.all(np.isfinite(x)):
                raise ValueError(f"{name}: reference contains NaN or inf")
            names.append(name)
            pos.append(x)
        lengths = np.array([x.shape[0] for x in pos], dtype=np.int64)
        T, B = int(lengths.max()), len(pos)
        ref = np.zeros((B, T, 2))
        ff = np.zeros((B, T, 2))
        for b, (x, f) in enumerate(zip(pos, ffs, strict=True)):
            ref[b, : len(x)] = x
            ref[b, len(x) :] = x[-1]
            if f is not None:
                f = np.asarray(f, dtype=float)
                if f.shape != x.shape:
                    raise ValueError(f"{names[b]}: feedforward shape {f.shape} differs from reference {x.shape}")
                if not np.all(np.isfinite(f)):
                    row = int(np.argwhere(~np.isfinite(f))[0, 0])
                    raise ValueError(f"{names[b]}: feedforward is NaN or inf at sample {row}")
                ff[b, : len(x)] = f
        sig = np.zeros((B, T, K.N_SIG))
        status = np.zeros(B, dtype=np.int64)
        fail_k = np.zeros(B, dtype=np.int64)
        final = np.zeros((B, K.N_STATE))
        with numba.parallel_chunksize(1):  # references of unequal length: hand them out one by one
            K.simulate_batch(ref, ff, lengths, self._p, self._E, self._C, self._cfg, self.preroll_samples,
                             sig, status, fail_k, final)
        for b in np.flatnonzero(status != K.OK):
            k, s = int(fail_k[b]), final[b]
            when = "during the settling pre-roll or the first sample" if k == 0 else f"at t = {k / self.fs:.3f} s (sample {k})"
            raise SimulationDiverged(
                f"{names[b]}: the IX plant left its safe range {when}: "
                f"angles {np.degrees(s[:2]).round(2).tolist()} deg, reference {np.degrees(ref[b, k]).round(2).tolist()} deg, "
                f"velocities {s[2:4].round(3).tolist()} rad/s (limits: error {np.degrees(self.max_error):.0f} deg, "
                f"speed {self.max_velocity} rad/s)"
            )
        trials = []
        for b in range(B):
            n = int(lengths[b])
            trials.append(
                Trial(
                    t=np.arange(n) / self.fs, ref=ref[b, :n], pos=sig[b, :n, K.SIG_Y : K.SIG_Y + 2],
                    u=sig[b, :n, K.SIG_U : K.SIG_U + 2], ff=ff[b, :n], axes=self.axes,
                    extra={f"load_{ax}": sig[b, :n, K.SIG_LOAD + i] for i, ax in enumerate(self.axes)},
                    meta={"system": "ix", "reference": names[b], "effects": [e.key for e in self.effects],
                          "plant": self.record()},
                )
            )
        return trials[0] if single else trials


def process_sensitivity(n: int, fs: float, positions: np.ndarray, gains: FeedbackGains | None = None,
                        params: ix.IXParameters | None = None) -> np.ndarray:
    """P S (e^{i w Ts}) (n_freq, 2) [rad/V] of the nominal IX closed loop (``IXPlant.process_sensitivity``)."""
    gains = gains or IX_GAINS
    p = (params or ix.IXParameters()).to_vector()
    q_mean = np.asarray(positions, dtype=float).mean(axis=0)
    J = np.diag(ix.mass_matrix(p, q_mean[None, :])[0])
    D = p[[ix.D2, ix.D3]]
    ts = 1.0 / fs
    z = np.exp(1j * 2 * math.pi * np.fft.rfftfreq(n, ts) * ts)
    out = np.empty((z.size, 2), dtype=complex)
    for a in range(2):
        pn, pd = rigid_axis(J[a], D[a], fs, z, delay=1)  # the ZOH plant and the one-sample computation delay
        alpha = math.exp(-2 * math.pi * gains.f_lp[a] / fs)
        c = (1 - alpha) * (gains.kp[a] + gains.kd[a] * (1 - 1 / z) / ts) / (1 - alpha / z)
        out[:, a] = pn / (pd + pn * c)  # P / (1 + P C), finite at z = 1 (P has a pole there)
    return out
