"""``PhysicalModel``: the IX rigid-body model plus a list of effects, fitted by least squares.

    f(k) = M(theta_d) thetadd_d + H(theta_d, thetad_d) + D thetad_d + sum_e tau_e(theta_d, ...)

evaluated on the reference at t_k + advance / fs (paper 000, Definition 2, eq. 9). The model is
linear in the rigid parameters zeta_l (Lemma 1) and in every effect's coefficients, and
nonlinear in the centres of mass zeta_n and in the effects' shape parameters.

Fit (``fit(trials)``):

1. Kinematics of the reference (central differences, ``advance`` samples ahead).
2. The measured input u and every regressor column go through the same zero-phase Butterworth
   low-pass (``filter_hz``, order 2) per trial and are then decimated (``decimate``). Filtering
   both sides with one linear filter keeps the least-squares problem consistent while it removes
   the encoder-quantization noise that the feedback's derivative action puts into u.
3. zeta_n (the 5 centre-of-mass coordinates) by variable projection: for each candidate zeta_n
   the linear parameters are eliminated by least squares and the remaining residual is
   minimized over zeta_n with ``scipy.optimize.least_squares``, starting at the given values.
4. The linear parameters are solved as a correction to the given (nominal) values of minimum
   norm in column-scaled units: combinations the data cannot identify keep their nominal values
   (e.g. the split between J2yy and J3yy + J3zz: their columns obey X_J2yy = X_J3yy + X_J3zz).

``positions="measured"`` (what the diagnosis uses) fits the motion the machine made rather than
the one it was asked for: the reference's kinematics corrected by the measured tracking error
e = ref - pos, low-passed at ``error_filter_hz`` (zero phase) before it is differentiated:
q = ref - e, qd = qd_ref - de/dt, qdd = qdd_ref - d2e/dt2 (all ``advance`` samples ahead; q is
the encoder reading smoothed). With
feedback only, the reference leads the axis by tenths of a degree and the input u pays for the
actual motion: a reference-only fit leaves that lag in the residual, where it looks like
low-speed friction. Differentiating the quantized encoder reading itself would bias the inertia
fit; the low-passed error carries far less quantization noise (tested).

Effects' nonlinear parameters stay at the values the effect was built with (``diagnose``
searches them). Ripple columns need the model's own torque: they are built from the rigid-body
torque of the given parameters, then of the first pass's fit (two passes).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from scipy.optimize import least_squares

from . import ix
from .effects import Effect, make_effect
from .kinematics import lowpass_zero_phase, reference_kinematics, reference_positions
from .system import IX, RigidBodySystem


@dataclass
class PhysicalModel:
    """IX rigid body (eqs. 2-9) + effects; ``fit`` then ``predict`` (scikit-learn style).

    Constructor arguments are stored as given; ``fit`` sets ``params_`` (IXParameters),
    ``effects_`` (effects with fitted coefficients) and ``fit_info_``. Before ``fit``,
    ``predict`` uses the given parameters (a nominal model is a working feedforward).
    """

    params: ix.IXParameters = field(default_factory=ix.IXParameters)
    effects: tuple[Effect, ...] = ()
    fs: float = 500.0
    advance: float = 1.5  # samples: one computation delay + half a hold interval
    filter_hz: float | None = 5.0
    decimate: int = 10
    fit_nonlinear: bool = True
    positions: str = "reference"  # kinematics of the fit: "reference" or "measured" (see above)
    error_filter_hz: float = 5.0
    system: ClassVar[RigidBodySystem] = IX  # the physics the learners (PGNN, diagnosis) share with it
    built_in: ClassVar[tuple[str, ...]] = ("rigid_body", "viscous_friction")  # what the model has without effects

    def __post_init__(self):
        self.effects = tuple(self.effects)
        if self.positions not in ("reference", "measured"):
            raise ValueError(f"positions must be 'reference' or 'measured', got {self.positions!r}")
        for e in self.effects:
            if e.plant_only:
                raise ValueError(f"{e.key} has internal dynamics: it exists in plants only, not in a static model")
            if e.axis not in self.system.axes:
                raise ValueError(f"{e.key} is not an effect of the {self.system.name} model (axes {', '.join(self.system.axes)})")

    @classmethod
    def for_diagnosis(cls, fs: float) -> PhysicalModel:
        """The nominal model ``diagnose`` starts from: this one, fitted to the measured motion."""
        return cls(fs=fs, positions="measured")

    def parts(self) -> tuple[str, ...]:
        """What this model has without its effects (the diagnosis does not offer these again)."""
        return self.built_in

    # ------------------------------------------------------------------ evaluation
    @property
    def fitted_params(self) -> ix.IXParameters:
        return getattr(self, "params_", self.params)

    @property
    def fitted_effects(self) -> tuple[Effect, ...]:
        return getattr(self, "effects_", self.effects)

    def torque(self, q, qd, qdd) -> np.ndarray:
        """Model input [V], shape (T, 2), for given kinematics (rad, rad/s, rad/s^2)."""
        p = self.fitted_params.to_vector()
        base = ix.inverse_dynamics(p, q, qd, qdd)
        tau = base.copy()
        for e in self.fitted_effects:
            tau += e.torque(q, qd, qdd, base=base[:, e.index] if e.needs_base_torque else None)
        return tau

    def predict(self, reference) -> np.ndarray:
        """Feedforward (T, 2) [V] for a reference: an array of positions (T, 2) [rad] sampled at
        ``fs``, a Trial or a Reference."""
        q, qd, qdd = reference_kinematics(reference_positions(reference), self.fs, self.advance)
        return self.torque(q, qd, qdd)

    def with_effect(self, effect: Effect | str, **params) -> PhysicalModel:
        """A new, unfitted model with one more effect (an Effect or a ``name@axis`` label);
        it starts from this model's fitted rigid parameters."""
        if isinstance(effect, str):
            effect = make_effect(effect, **params)
        if any(e.key == effect.key for e in self.effects):
            raise ValueError(f"model already has {effect.key}")
        return dataclasses.replace(self, params=self.fitted_params, effects=(*self.fitted_effects, effect))

    # ------------------------------------------------------------------ fitting
    def free_design(self, kin, params=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What a linear fit of the model adjusts, at ``params`` (default the fitted parameters): the
        columns of the free linear parameters (T, A, k), the torque of the parameters held fixed
        (T, A), and the free parameters' values (k,). The IX: its whole rigid regressor at zeta_n."""
        p = (params or self.fitted_params).to_vector()
        n = self.system.n_linear
        X = self.system.regressor(p[n:], *kin)
        return X, np.zeros(X.shape[:2]), p[:n]

    def _effect_columns(self, kin, base):
        """Regressor columns (T, A, n_effect_coefficients) of the effects (independent of zeta_n)."""
        q, qd, qdd = kin
        cols = [np.zeros((q.shape[0], q.shape[1], 0))]
        for e in self.effects:
            c = np.zeros((q.shape[0], q.shape[1], len(e.linear)))
            c[:, e.index, :] = e.columns(q, qd, qdd, base=base[:, e.index])
            cols.append(c)
        return np.concatenate(cols, axis=2)

    def reduce(self, A, lengths):
        """Per-trial zero-phase low-pass along time, then decimation; A is (T, ...)."""
        out, start = [], 0
        for n in lengths:
            seg = A[start : start + n]
            start += n
            if self.filter_hz:
                seg = lowpass_zero_phase(seg, self.fs, self.filter_hz, axis=0)
            out.append(seg[:: max(1, self.decimate)])
        return np.concatenate(out, axis=0)

    def kinematics(self, trials: Sequence) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], list[int]]:
        """(q, qd, qdd) of the fit, each (sum of T, 2), and the trial lengths (see ``positions``)."""
        if not trials:
            raise ValueError("PhysicalModel.fit: no trials given")
        kins, lengths = [], []
        for tr in trials:
            if abs(tr.fs - self.fs) > 1e-6 * self.fs:
                raise ValueError(f"trial sampled at {tr.fs} Hz, model expects {self.fs} Hz")
            q, qd, qdd = reference_kinematics(tr.ref, self.fs, self.advance)
            if self.positions == "measured":
                e = lowpass_zero_phase(tr.ref - tr.pos, self.fs, self.error_filter_hz)
                e, ed, edd = reference_kinematics(e, self.fs, self.advance)
                q, qd, qdd = q - e, qd - ed, qdd - edd
            kins.append((q, qd, qdd))
            lengths.append(tr.n_samples)
        return tuple(np.concatenate([k[i] for k in kins]) for i in range(3)), lengths

    def fit(self, trials: Sequence) -> PhysicalModel:
        """Least-squares fit on measured trials (each with ``ref``, ``pos``, ``u`` and sample rate ``fs``)."""
        kin, lengths = self.kinematics(trials)
        u_red = self.reduce(np.concatenate([tr.u for tr in trials]), lengths).reshape(-1)

        p0 = self.params.to_vector()
        theta0 = np.concatenate([p0[: ix.N_LINEAR], *[e.coefficients() for e in self.effects]])
        zeta_n = p0[ix.N_LINEAR :].copy()
        base = ix.inverse_dynamics(p0, *kin)  # rigid torque for ripple columns, refined per pass
        n_pass = 2 if any(e.needs_base_torque for e in self.effects) else 1
        for _ in range(n_pass):
            rigid = _QuadraticDesign(lambda zn: self.system.regressor(zn, *kin), zeta_n.size, lambda A: self.reduce(A, lengths))
            fixed = self.reduce(self._effect_columns(kin, base), lengths)
            design = lambda zn, r=rigid, f=fixed: np.concatenate([r(zn), f], axis=2)  # noqa: E731
            if self.fit_nonlinear:
                sol = least_squares(
                    lambda zn, d=design: solve_min_norm(d(zn), u_red, theta0)[1],
                    zeta_n, x_scale=0.01, diff_step=1e-3, max_nfev=100,
                )
                zeta_n = sol.x
            theta, resid = solve_min_norm(design(zeta_n), u_red, theta0)
            p = np.concatenate([theta[: ix.N_LINEAR], zeta_n])
            base = ix.inverse_dynamics(p, *kin)
        self.params_ = ix.IXParameters.from_vector(p)
        effects, i = [], ix.N_LINEAR
        for e in self.effects:
            effects.append(e.with_coefficients(theta[i : i + len(e.linear)]))
            i += len(e.linear)
        self.effects_ = tuple(effects)
        self.fit_info_ = {
            "residual_rms": float(np.sqrt(np.mean(resid**2))),
            "n_samples": int(sum(lengths)),
            "n_used": int(u_red.size // 2),
        }
        return self


def solve_min_norm(A, u, theta0, rcond: float = 1e-9):
    """Minimum-norm correction to theta0 (column-scaled) of the least-squares problem A theta = u;
    singular values below ``rcond`` times the largest count as zero (directions the data lacks)."""
    A = A.reshape(-1, theta0.size)
    y = u - A @ theta0
    scale = np.linalg.norm(A, axis=0)
    used = scale > 1e-12 * scale.max(initial=0.0)  # a column of round-off only is no direction
    scale[~used] = 1.0
    delta, *_ = np.linalg.lstsq(np.where(used, A / scale, 0.0), y, rcond=rcond)
    theta = theta0 + delta / scale
    return theta, u - A @ theta


class _QuadraticDesign:
    """Reduced design matrix as an exact quadratic polynomial in zeta_n.

    The IX regressor's entries are polynomials of total degree <= 2 in the centre-of-mass
    coordinates (terms like m3 y3 z3, m2 (x2^2 + z2^2) in eqs. 5-7), and filtering and decimation
    (``reduce``) are linear. So the design at any zeta_n is c + sum_i z_i b_i + sum_{i<=j} z_i z_j
    a_ij, with the coefficient arrays taken from 1 + 2n + n(n-1)/2 evaluations (n = 5: 21) at the
    nodes 0, +-h e_i, h (e_i + e_j); the variable projection then costs no filtering per step.

    Most coefficient columns are zero (a column depends on one or two of the coordinates, if
    any): only the non-zero ones are reduced, 34 filtered columns instead of 21 x 22 for the IX.
    """

    def __init__(self, evaluate, n, reduce=lambda A: A, h=0.05):
        self.n = n
        self._reduce = reduce
        c = evaluate(np.zeros(n))
        self.shape = c.shape[1:]
        self.rows = reduce(np.zeros((c.shape[0], 1))).shape[0]
        scale = float(np.abs(c).max(initial=0.0))
        e = np.eye(n) * h
        b, a_diag = [], []
        for i in range(n):
            plus, minus = evaluate(e[i]), evaluate(-e[i])
            b.append(_sparse_columns((plus - minus) / (2 * h), scale))
            a_diag.append(_sparse_columns((plus + minus - 2 * c) / (2 * h * h), scale))
        self.c = self._reduced(_sparse_columns(c, scale))
        self.b = [self._reduced(x) for x in b]
        self.a = {(i, i): self._reduced(a_diag[i]) for i in range(n)}
        for i in range(n):
            for j in range(i + 1, n):
                rest = evaluate(e[i] + e[j]).reshape(c.shape[0], -1) - c.reshape(c.shape[0], -1)
                for x in (b[i], b[j]):
                    rest[:, x[0]] -= h * x[1]
                for x in (a_diag[i], a_diag[j]):
                    rest[:, x[0]] -= h * h * x[1]
                self.a[i, j] = self._reduced(_sparse_columns(rest / (h * h), scale))

    def _reduced(self, sparse):
        """Reduce the non-zero columns (indices, values (T, k)); zero columns stay zero."""
        idx, values = sparse
        if idx.size == 0:
            return None
        return idx, self._reduce(values)

    def __call__(self, z):
        terms = [(1.0, self.c)] + [(z[i], b) for i, b in enumerate(self.b)]
        terms += [(z[i] * z[j], a) for (i, j), a in self.a.items()]
        out = np.zeros((self.rows, int(np.prod(self.shape))))
        for w, term in terms:
            if term is not None:
                out[:, term[0]] += w * term[1]
        return out.reshape(-1, *self.shape)


def _sparse_columns(A, scale, rtol=1e-9):
    """(indices, values) of the columns of A (T, ...) flattened to (T, m) that are not zero up to
    rounding: larger than ``rtol`` times ``scale`` (the size of the evaluated design)."""
    flat = A.reshape(A.shape[0], -1)
    peak = np.abs(flat).max(axis=0) if flat.shape[0] else np.zeros(flat.shape[1])
    idx = np.flatnonzero(peak > rtol * scale)
    return idx, flat[:, idx]
