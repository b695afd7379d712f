"""``PhysicalModel``: a machine's rigid-body model plus a list of effects, fitted by least squares.

    f(k) = M(theta_d) thetadd_d + H(theta_d, thetad_d) + D thetad_d + sum_e tau_e(theta_d, ...)

evaluated on the reference at t_k + advance / fs (paper 000, Definition 2, eq. 9), for any
``systems.System`` (the IX, the FlexArm through ``systems.flexarm.model.ArmModel``, a URDF or a
user's machine). It is linear in the rigid parameters zeta_l (Lemma 1) and in every effect's
coefficients, and may be nonlinear in zeta_n (the IX's centres of mass) and in the effects' shapes.

Fit (``fit(trials)``):

1. Kinematics, ``advance`` samples ahead (``positions``):
   - ``"reference"`` (default): central differences of the reference;
   - ``"measured"`` (the diagnosis): the motion the machine made, q = ref - e with the tracking
     error e low-passed at ``error_filter_hz`` before it is differentiated. With feedback only the
     axis lags the reference and u pays for the actual motion; a reference-only fit would leave
     that lag in the residual, where it looks like low-speed friction;
   - ``"position"`` (and a log without a reference): the measured position low-passed at
     ``position_filter_hz`` (default twice ``filter_hz``), then differentiated. u passes the same
     low-pass first (``Preprocessing.inputs``), so that u and the columns linear in the kinematics
     see one filter.
2. u and every regressor column pass one zero-phase Butterworth low-pass (``filter_hz``, order 2)
   per trial and are decimated (``decimate``). One linear filter on both sides keeps the least
   squares consistent and removes the quantization noise that the feedback's derivative puts in u.
3. zeta_n, if the machine has any, by variable projection: the linear parameters eliminated by
   least squares, the residual minimized over zeta_n (``scipy.optimize.least_squares``).
4. The linear parameters, as the minimum-norm correction to the given (nominal) values in
   column-scaled units: combinations the data cannot identify keep their nominal values
   (``fit_info_``: ``rank`` of ``n_free``).

Effects' nonlinear parameters stay as built (``diagnose`` searches them), except those named in
``search_shapes`` (a machine file's ``[[model]]`` tables without values): ``fit`` finds those
shapes first, on the diagnosis' grids (``physics.shapes``). Ripple columns need the model's own
torque: they are built from the rigid-body torque of the given parameters, then of the first
pass's fit. What the filters' corners do to a fit, measured on the EMPS: docs/emps.md.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from scipy.optimize import least_squares

from ..fitted import is_fitted
from .compiled import Kernels
from .effects import Effect, Loads
from .kinematics import reference_kinematics, reference_positions
from .linalg import penalty_rows, solve_min_norm  # noqa: F401 (the fit's solve; tests import it from here)
from .preprocessing import POSITIONS, Preprocessing, reduction_memo, reductions


@dataclass(frozen=True)
class FittedDesign:
    """A fitted model's design on the trials and mask it was fitted on (``PhysicalModel.design``),
    with the torque of the parameters it holds fixed moved to the input side: ``torque`` (T, A) the
    model's torque less that part; ``rigid_torque`` (T, A) its rigid-body torque (the effects that
    read it see this); ``u`` (R, A) and ``design`` (R, A, p), the reduced input and the reduced
    columns of the free linear parameters, then the first-order columns of zeta_n (a machine with
    nonlinear parameters: a candidate is scored with the freedom the refit has), then the effects';
    ``penalties``: the effects' roughness penalties on those columns (``PhysicalModel.penalties``)."""

    torque: np.ndarray
    rigid_torque: np.ndarray
    u: np.ndarray
    design: np.ndarray
    penalties: list


@dataclass
class PhysicalModel:
    """A machine's rigid body (the IX: eqs. 2-9) + effects; ``fit`` then ``predict`` (scikit-learn style).

    system: the machine (``systems.System``); params: its parameters (default its nominal ones);
    effects: bound to its axes on construction; fs [Hz] and advance [samples]: default the
    machine's. Constructor arguments are stored as given; ``fit`` sets ``params_``, ``effects_``
    (effects with fitted coefficients) and ``fit_info_``. Before ``fit``, ``predict`` uses the
    given parameters (a nominal model is a working feedforward). search_shapes: the ``name@axis``
    keys of effects whose nonlinear parameters ``fit`` finds (``physics.shapes``; the machine's
    ``model_effects``); it sets them in ``effects`` too (their shapes, coefficients as given), and
    ``fit_info_["shapes"]`` records them.
    """

    system: Any
    params: Any = None
    effects: tuple[Effect, ...] = ()
    fs: float | None = None
    advance: float | None = None  # samples; default the machine's (IX: one computation delay + half a hold)
    filter_hz: float | None = 5.0
    decimate: int = 10
    fit_nonlinear: bool = True
    positions: str = "reference"  # kinematics of the fit: "reference", "measured" or "position" (see above)
    error_filter_hz: float = 5.0
    position_filter_hz: float | None = None  # kinematics from the measured position (see above); None: 2 filter_hz
    search_shapes: tuple[str, ...] = ()  # effects (name@axis) whose nonlinear parameters fit finds (physics.shapes)
    built_in: ClassVar[tuple[str, ...]] = ("rigid_body", "viscous_friction")  # what the model has without effects
    fitted_on: ClassVar[str] = "measured"
    """The kinematics a machine's model is fitted on (``System.physical_model``): the motion the machine
    made, as the diagnosis fits it. On the reference instead, a feedback-only run's lag is taken for
    the motion: a position-dependent effect lands where the reference was, not where the axis was (a
    one-sided elbow spring fitted at k 16 for 25, tests/test_model_tables.py)."""
    rcond: ClassVar[float] = 1e-9  # relative singular-value cut of the linear solve (directions the data lacks)

    def __post_init__(self):
        if self.params is None:
            self.params = self.system.nominal_params()
        if self.fs is None:
            if self.system.fs is None:
                raise ValueError(f"{self.system.name} has no sample rate of its own: give the model's fs [Hz]")
            self.fs = self.system.fs
        if self.advance is None:
            self.advance = self.system.advance
        if self.positions not in POSITIONS:
            raise ValueError(f"positions must be one of {', '.join(POSITIONS)}, got {self.positions!r}")
        for e in self.effects:
            if e.plant_only:
                raise ValueError(f"{e.key} has internal dynamics: it exists in plants only, not in a static model")
        self.effects = tuple(self.system.effect(e) for e in self.effects)
        self.search_shapes = tuple(self.search_shapes)
        if self.search_shapes:
            from .shapes import model_candidate

            keys = [e.key for e in self.effects]
            for key in self.search_shapes:
                if key not in keys:
                    raise ValueError(f"search_shapes names {key}, which is not among the model's effects "
                                     f"({', '.join(keys)})")
                model_candidate(self.system, key, type(self).built_in)  # a ValueError says why the fit could not find its shape

    @classmethod
    def for_diagnosis(cls, system, fs: float) -> PhysicalModel:
        """The nominal model ``diagnose`` starts from: this one, fitted to the measured motion, the
        reduced rows at least 4 per period of the low-pass's corner (every 10th sample from 200 Hz up)."""
        return cls(system=system, fs=fs, positions="measured", decimate=diagnosis_decimation(fs, cls.filter_hz))

    def parts(self) -> tuple[str, ...]:
        """What this model has without its effects (the diagnosis does not offer these again)."""
        return self.built_in

    @property
    def preprocessing(self) -> Preprocessing:
        """How this model sees data (``physics.preprocessing``): the kinematics of its fit, the
        input as it uses it, and the low-pass and decimation of both."""
        return Preprocessing(self.fs, self.advance, self.filter_hz, self.decimate, self.positions,
                             self.error_filter_hz, self.position_filter_hz)

    # ------------------------------------------------------------------ evaluation
    @property
    def fitted_params(self):
        return getattr(self, "params_", self.params)

    @property
    def fitted_effects(self) -> tuple[Effect, ...]:
        return getattr(self, "effects_", self.effects)

    def torque(self, q, qd, qdd) -> np.ndarray:
        """Model input (T, n_axes) [input unit] for given kinematics (rad or m, per s, per s^2)."""
        p = self.fitted_params.to_vector()
        base = self.system.inverse_dynamics(p, q, qd, qdd)
        return base + self.effects_torque(q, qd, qdd, rigid=base)

    def effects_torque(self, q, qd, qdd, rigid=None) -> np.ndarray:
        """The fitted effects' part of ``torque`` (T, n_axes) [input unit] (zero without effects);
        ``rigid``: the rigid-body torque there, where the caller has it."""
        tau = np.zeros(np.shape(q), dtype=float)
        loads = self.load_torques((q, qd, qdd), rigid=rigid)
        for e in self.fitted_effects:
            tau += e.torque(q, qd, qdd, loads)
        return tau

    def load_torques(self, kin, p=None, rigid=None) -> Loads | None:
        """The model torques its effects read (``Effect.reads``) for kinematics ``kin`` at the
        parameter vector ``p`` (default the fitted one); ``rigid``: the rigid-body torque there,
        where the caller has it. None when no effect reads any."""
        reads = {r for e in self.effects for r in e.reads}
        if not reads:
            return None
        p = self.fitted_params.to_vector() if p is None else p
        q, qd, qdd = kin
        if "torque" in reads and rigid is None:
            rigid = self.system.inverse_dynamics(p, q, qd, qdd)
        gravity = self.system.inverse_dynamics(p, q, np.zeros_like(qd), np.zeros_like(qdd)) if "gravity" in reads else None
        return Loads(torque=rigid if "torque" in reads else None, gravity=gravity)

    def predict(self, reference) -> np.ndarray:
        """Feedforward (T, n_axes) [input unit] for a reference: an array of positions (T, n_axes)
        sampled at ``fs``, a Trial or a Reference."""
        q, qd, qdd = reference_kinematics(reference_positions(reference), self.fs, self.advance)
        return self.torque(q, qd, qdd)

    def with_effect(self, effect: Effect | str, **params) -> PhysicalModel:
        """A new, unfitted model with one more effect (an Effect or a ``name@axis`` label);
        it starts from this model's fitted rigid parameters."""
        effect = self.system.effect(effect, **params)
        if any(e.key == effect.key for e in self.effects):
            raise ValueError(f"model already has {effect.key}")
        fitted = is_fitted(self, "effects_")  # then its effects' shapes are found: they start from them
        return dataclasses.replace(self, params=self.fitted_params, effects=(*self.fitted_effects, effect),
                                   search_shapes=() if fitted else self.search_shapes)

    # ------------------------------------------------------------------ fitting
    def free_mask(self) -> np.ndarray:
        """Boolean mask (n_linear,) of the linear parameters a fit adjusts (here: all)."""
        return np.ones(self.system.n_linear, dtype=bool)

    def free_design(self, kin, params=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What a linear fit of the model adjusts, at ``params`` (default the fitted parameters): the
        columns of the free linear parameters (T, A, k), the torque of the parameters held fixed
        (T, A), and the free parameters' values (k,). The IX: its whole rigid regressor at zeta_n."""
        p = (params or self.fitted_params).to_vector()
        n = self.system.n_linear
        X = self.system.regressor(p[n:], *kin)
        free = self.free_mask()
        if free.all():
            return X, np.zeros(X.shape[:2]), p[:n]
        return X[:, :, free], X[:, :, ~free] @ p[:n][~free], p[:n][free]

    def nonlinear_design(self, kin, step: float = 1e-6) -> np.ndarray | None:
        """First-order columns (T, A, n_nonlinear) of the rigid-body torque in the nonlinear
        parameters zeta_n at the fitted values (central differences, ``step`` relative, at least
        ``step`` absolute), or None for a machine linear in its parameters or without
        ``fit_nonlinear``. The diagnosis adds them to the linear design so that a candidate is
        scored with the freedom the refit has: on the IX, a constant roll input is partly taken
        up by the fitted centres of mass, and with zeta_n frozen an offset scored 34 % of what
        its refit removes, 84 %."""
        if self.system.fully_linear or not self.fit_nonlinear:
            return None
        p = self.fitted_params.to_vector()
        n = self.system.n_linear
        cols = []
        for j in range(n, p.size):
            h = step * max(1.0, abs(p[j]))
            hi, lo = p.copy(), p.copy()
            hi[j] += h
            lo[j] -= h
            cols.append((self.system.inverse_dynamics(hi, *kin) - self.system.inverse_dynamics(lo, *kin)) / (2 * h))
        return np.stack(cols, axis=-1)

    def penalties(self, offset: int) -> list:
        """The roughness penalties (``penalty_rows``) of the effects whose columns follow ``offset``
        columns of the design."""
        out, start = [], offset
        for e in self.effects:
            D = e.roughness()
            if D is not None:
                out.append((np.arange(start, start + len(e.linear)), D))
            start += len(e.linear)
        return out

    def effect_design(self, kin, loads: Loads | None) -> np.ndarray:
        """Regressor columns (T, A, n_effect_coefficients) of the effects (independent of zeta_n);
        ``loads``: the model torques they read (``loads``)."""
        q, qd, qdd = kin
        cols = [np.zeros((q.shape[0], q.shape[1], 0))]
        for e in self.effects:
            c = np.zeros((q.shape[0], q.shape[1], len(e.linear)))
            c[:, e.index, :] = e.columns(q, qd, qdd, loads)
            cols.append(c)
        return np.concatenate(cols, axis=2)

    def design(self, trials: Sequence, kinematics: tuple, mask: np.ndarray | None = None) -> FittedDesign:
        """The fitted model's design on the ``trials`` and ``mask`` it was fitted on (``FittedDesign``);
        ``kinematics``: ``self.preprocessing.kinematics(trials)``."""
        pre = self.preprocessing
        kin, lengths = kinematics
        free, fixed, theta = self.free_design(kin)
        torque = self.torque(*kin) - fixed
        nonlinear = None
        if self.reduced_ is not None:  # a linear fit's own reduced design: the same columns
            design, u = self.reduced_
        else:
            nonlinear = self.nonlinear_design(kin)  # zeta_n refitted to first order with each candidate
            parts = [free] + ([] if nonlinear is None else [nonlinear]) + [self.effect_design(kin, self.load_torques(kin))]
            design = pre.masked_reduce(np.concatenate(parts, axis=2), lengths, mask)
            u = pre.masked_reduce(pre.inputs(trials) - fixed, lengths, mask)
        offset = free.shape[2] + (0 if nonlinear is None else nonlinear.shape[2])
        return FittedDesign(torque, free @ theta + fixed, u, design, self.penalties(offset))

    def residual(self, trials: Sequence, mask: np.ndarray | None = None) -> np.ndarray:
        """Reduced residual (R, n_axes) [input unit] of this fitted model on ``trials`` (any, e.g.
        data it was not fitted on): the input as the fit uses it minus the model's torque, both
        through ``reduce`` (low-pass and decimation), the kinematics taken as in the fit; ``mask``
        as in ``fit`` (the rows it leaves out are zero)."""
        pre = self.preprocessing
        kin, lengths = pre.kinematics(trials)
        return pre.masked_reduce(pre.inputs(trials) - self.torque(*kin), lengths, mask)

    def fit(self, trials: Sequence, mask: np.ndarray | None = None, kinematics: tuple | None = None) -> PhysicalModel:
        """Least-squares fit on measured trials (each with ``ref`` (or None), ``pos``, ``u`` and sample
        rate ``fs``): the free linear parameters, the effects' coefficients and, where the machine
        has them and ``fit_nonlinear``, its nonlinear parameters zeta_n (module docstring).
        ``mask`` (samples of all trials, n_axes), bool: the samples of each axis the fit uses (default
        all), e.g. the diagnosis's without standstill: the others are set to zero in u and in every
        regressor column of that axis before the low-pass (the equation u = X theta holds there as
        0 = 0, so nothing of them spreads into the samples used), and their rows are left out after it.
        ``kinematics``: ``self.preprocessing.kinematics(trials)`` where the caller has it (a diagnosis refits models
        of the same kinematic settings on the same trials many times)."""
        pre = self.preprocessing
        kin, lengths = pre.kinematics(trials) if kinematics is None else _same_trials(kinematics, trials)
        self.reduced_ = None
        u = pre.inputs(trials)
        if mask is not None:
            mask = np.asarray(mask, dtype=bool)
            if mask.shape != u.shape:
                raise ValueError(f"mask must have shape {u.shape} (samples, axes), got {mask.shape}")
        if self.search_shapes:  # the shapes of the effects declared without values, first (physics.shapes)
            with ExitStack() as shared:
                if self.system.caching is not None:  # the search and the fit share the regressor and its reduction
                    shared.enter_context(self.system.caching())
                shared.enter_context(reduction_memo())
                shaped = self._shapes(kin, lengths, u, mask)
                # then the model with those shapes is fitted; this one keeps its arguments as given
                fitted = dataclasses.replace(self, effects=shaped, search_shapes=()).fit(trials, mask, (kin, lengths))
            self.__dict__.update({k: v for k, v in vars(fitted).items() if k.endswith("_")})
            self.fit_info_ = {**fitted.fit_info_, "shapes": {e.key: {n: float(getattr(e, n)) for n in e.nonlinear}
                                                            for e in shaped if e.key in self.search_shapes}}
            return self
        if self.system.fully_linear:
            theta, resid = self._fit_linear(kin, lengths, u, mask)
        else:
            theta, resid = self._fit_variable_projection(kin, lengths, u, mask)
        n_free = theta.size - sum(len(e.linear) for e in self.effects)
        effects, i = [], n_free
        for e in self.effects:
            effects.append(e.with_coefficients(theta[i : i + len(e.linear)]))
            i += len(e.linear)
        self.effects_ = tuple(effects)
        self.fit_info_ = {**self.fit_info_, "residual_rms": float(np.sqrt(np.mean(resid**2))),
                          "n_samples": int(sum(lengths)), "n_used": int(resid.size // len(self.system.axes))}
        return self

    def _shapes(self, kin, lengths, u, mask) -> tuple[Effect, ...]:
        """``self.effects`` with the shapes of those in ``search_shapes`` found (``physics.shapes``)."""
        from .shapes import fit_shapes

        shaped = fit_shapes(self, kin, lengths, u, mask)
        if not self.system.fully_linear:
            # the search's rigid-body columns are at the given nonlinear parameters (the IX's centres of
            # mass), which a fit without the effects may have left far from the data's: search once
            # more at those the fit finds with the shapes in (the diagnosis's refits chain so)
            first = dataclasses.replace(self, effects=shaped, search_shapes=())
            first._fit_variable_projection(kin, lengths, u, mask)
            shaped = fit_shapes(dataclasses.replace(self, params=first.params_, effects=shaped), kin, lengths, u, mask)
        return shaped

    def _fit_linear(self, kin, lengths, u, mask=None):
        """A machine linear in all its parameters: one minimum-norm least-squares solve of the free
        parameters and the effects' coefficients, the fixed parameters' torque moved to u's side;
        ``mask``: the samples of each axis that count (``fit``)."""
        free, fixed, theta_free = self.free_design(kin, self.params)  # a fit starts from the given values
        loads = self.load_torques(kin, self.params.to_vector(), rigid=free @ theta_free + fixed)
        pre = self.preprocessing
        X = np.concatenate([pre.kept_reduce(free, lengths, mask),  # a diagnosis's refits share this one
                            pre.masked_reduce(self.effect_design(kin, loads), lengths, mask)], axis=2)
        y = pre.kept_reduce(u - fixed, lengths, mask).reshape(-1)
        theta0 = np.concatenate([theta_free, *[e.coefficients() for e in self.effects]])
        theta, resid = solve_min_norm(X, y, theta0, rcond=self.rcond, penalties=self.penalties(free.shape[2]))
        vector = self.params.to_vector()
        mask = self.free_mask()
        vector[: self.system.n_linear][mask] = theta[: int(mask.sum())]
        self.params_ = self.system.params_from_vector(vector)
        free_columns = X[:, :, : int(mask.sum())]
        self.fit_info_ = {"n_free": int(mask.sum()),
                          "rank": reductions().get(lambda: np.array(column_rank(free_columns, self.rcond)), free_columns, None,
                                            extra=("rank", self.rcond)).item()}
        # the reduced design and input as fitted: unchanged by the fit where no effect reads the model's
        # torques, so the diagnosis reuses them (``diagnose.search.prepare``) instead of filtering them again
        self.reduced_ = None if loads is not None else (X, y.reshape(X.shape[:2]))
        return theta, resid

    def _fit_variable_projection(self, kin, lengths, u, mask=None):
        """A machine with nonlinear parameters zeta_n (the IX): variable projection over zeta_n, the
        linear parameters and the effects' coefficients eliminated by least squares at each step;
        ``mask`` as in ``_fit_linear``."""
        pre = self.preprocessing
        u_red = pre.kept_reduce(u, lengths, mask).reshape(-1)
        # masked before the low-pass (linear: the design stays quadratic in zeta_n) and after it
        before = after = lambda A: A  # noqa: E731
        if mask is not None:
            m_before, m_after = mask[..., None], mask[pre.reduced_rows(lengths)][..., None]
            before, after = (lambda A: A * m_before), (lambda A: A * m_after)
        n = self.system.n_linear
        p0 = self.params.to_vector()
        theta0 = np.concatenate([p0[:n], *[e.coefficients() for e in self.effects]])
        zeta_n = p0[n:].copy()
        loads = self.load_torques(kin, p0)  # the model torques effects read (ripple), refined per pass
        n_pass = 2 if loads is not None else 1
        penalties = self.penalties(n)
        evaluate = (QuadraticDesign if self.system.nonlinear.quadratic else _Design)
        for _ in range(n_pass):
            rigid = evaluate(lambda zn, columns=None: before(self.system.regressor(zn, *kin, **(
                {} if columns is None else {"columns": columns}))), zeta_n.size, lambda A: pre.reduce(A, lengths),
                columns=self.system.nonlinear.columns)
            fixed = pre.masked_reduce(self.effect_design(kin, loads), lengths, mask)
            design = lambda zn, r=rigid, f=fixed: np.concatenate([after(r(zn)), f], axis=2)  # noqa: E731
            if self.fit_nonlinear:
                sol = least_squares(
                    lambda zn, d=design: solve_min_norm(d(zn), u_red, theta0, rcond=self.rcond, penalties=penalties)[1],
                    zeta_n, x_scale=0.01, diff_step=1e-3, max_nfev=100,
                )
                zeta_n = sol.x
            theta, resid = solve_min_norm(design(zeta_n), u_red, theta0, rcond=self.rcond, penalties=penalties)
            p = np.concatenate([theta[:n], zeta_n])
            loads = self.load_torques(kin, p)
        self.params_ = self.system.params_from_vector(p)
        self.fit_info_ = {"n_free": n, "rank": column_rank(rigid(zeta_n), self.rcond)}
        return theta, resid


def _same_trials(kinematics: tuple, trials: Sequence) -> tuple:
    """``kinematics`` ((q, qd, qdd), lengths) after checking that it is of ``trials``."""
    kin, lengths = kinematics
    if list(lengths) != [tr.n_samples for tr in trials] or kin[0].shape[0] != sum(lengths):
        raise ValueError("PhysicalModel.fit: the kinematics given are not of these trials (their lengths differ)")
    return kin, list(lengths)


def diagnosis_decimation(fs: float, filter_hz: float) -> int:
    """Every how many samples the diagnosis keeps after its ``filter_hz`` low-pass: 10, or fewer
    where that would leave fewer than 4 rows per period of the corner frequency."""
    if not fs > 4 * filter_hz:
        raise ValueError(f"the diagnosis low-passes at {filter_hz:g} Hz: it needs data sampled above "
                         f"{4 * filter_hz:g} Hz, got {fs:g} Hz")
    return int(min(10, fs // (4 * filter_hz)))


def column_rank(A: np.ndarray, rcond: float = 1e-9, zero: float = 1e-10) -> int:
    """Numerical rank of a design A (R, ..., k) stacked to (R ..., k): the parameter combinations a
    fit identifies. A column at most ``zero`` times the largest column's norm is round-off (a
    parameter nothing depends on); the others are scaled to unit norm (their units differ), and
    singular values above ``rcond`` times the largest count."""
    A = np.asarray(A, dtype=float).reshape(-1, np.shape(A)[-1])
    scale = np.linalg.norm(A, axis=0)
    used = scale > zero * scale.max(initial=0.0)
    if not used.any():
        return 0
    s = np.linalg.svd(A[:, used] / scale[used], compute_uv=False)
    return int((s > rcond * s[0]).sum())


class _Design:
    """Reduced design matrix at any zeta_n, by evaluating the regressor there (any machine; every
    column, so ``columns`` is not used)."""

    def __init__(self, evaluate, n, reduce=lambda A: A, columns=None):
        self._evaluate, self._reduce = evaluate, reduce

    def __call__(self, z):
        return self._reduce(self._evaluate(np.asarray(z, dtype=float)))


class QuadraticDesign:
    """Reduced design matrix as an exact quadratic polynomial in zeta_n.

    The IX regressor's entries are polynomials of total degree <= 2 in the centre-of-mass
    coordinates (terms like m3 y3 z3, m2 (x2^2 + z2^2) in eqs. 5-7), and filtering and decimation
    (``reduce``) are linear. So the design at any zeta_n is c + sum_i z_i b_i + sum_{i<=j} z_i z_j
    a_ij, with the coefficient arrays taken from 1 + 2n + n(n-1)/2 evaluations (n = 5: 21) at the
    nodes 0, +-h e_i, h (e_i + e_j); the variable projection then costs no filtering per step.

    Most coefficient columns are zero (a column depends on one or two of the coordinates, if
    any): only the non-zero ones are reduced, 34 filtered columns instead of 21 x 22 for the IX.
    ``columns`` (the machine's ``nonlinear.columns``): the linear parameters whose columns depend on
    zeta_n at all; the 20 nodes other than 0 evaluate only those (``evaluate(z, columns)``), the
    IX's two masses of eleven parameters. The non-zero columns are found on blocks of rows
    (``_sparse_term``). Both give the same numbers as the dense evaluation, bit for bit (tested);
    at the paper's N = 1e6 the IX's fit took 8-9 s instead of 19 s (docs/speed.md).
    """

    def __init__(self, evaluate, n, reduce=lambda A: A, h=0.05, columns=None):
        self.n = n
        self._reduce = reduce
        c = evaluate(np.zeros(n))
        self.shape = c.shape[1:]
        self.rows = reduce(np.zeros((c.shape[0], 1))).shape[0]
        scale = float(np.abs(c).max(initial=0.0))
        # the nodes other than 0 evaluate only the columns that depend on zeta_n (``columns``: of the
        # last axis); ``full`` maps their flattened index to that of all columns
        if columns is None:
            full, at = np.arange(int(np.prod(self.shape))), evaluate
        else:
            full = np.ravel_multi_index(np.ix_(*(np.arange(k) for k in self.shape[:-1]), columns), self.shape).ravel()
            at = lambda z: evaluate(z, columns)  # noqa: E731
        c_all = c.reshape(c.shape[0], -1)
        c = c_all[:, full]
        e = np.eye(n) * h
        b, a_diag = [], []
        for i in range(n):
            plus, minus = (at(x).reshape(c.shape) for x in (e[i], -e[i]))
            b.append(_sparse_term(lambda r, k, p=plus, m=minus: (p[r, k] - m[r, k]) / (2 * h), c.shape, scale))
            a_diag.append(_sparse_term(lambda r, k, p=plus, m=minus: (p[r, k] + m[r, k] - 2 * c[r, k]) / (2 * h * h),
                                       c.shape, scale))
        self.c = self._reduced(_sparse_term(lambda r, k: c_all[r, k], c_all.shape, scale))
        self.b = [self._reduced(x, full) for x in b]
        self.a = {(i, i): self._reduced(a_diag[i], full) for i in range(n)}
        for i in range(n):
            for j in range(i + 1, n):
                both = at(e[i] + e[j]).reshape(c.shape)
                known = ((b[i], h), (b[j], h), (a_diag[i], h * h), (a_diag[j], h * h))

                def rest(r, k, both=both, known=known):
                    """The pair's column values less the terms already known, divided by h^2."""
                    out = both[r, k] - c[r, k]
                    for (idx, values), w in known:
                        into, of = _shared_columns(k, idx)
                        out[:, into] -= w * values[r][:, of]
                    return out / (h * h)

                self.a[i, j] = self._reduced(_sparse_term(rest, c.shape, scale), full)
        # all terms' columns side by side, in the order they are summed (``__call__``)
        self._present = np.array([t is not None for t in self._terms()])
        present = [t for t in self._terms() if t is not None]
        self._counts = np.array([t[0].size for t in present])
        self._columns = np.concatenate([t[0] for t in present]) if present else np.zeros(0, dtype=int)
        self._values = (np.ascontiguousarray(np.concatenate([t[1] for t in present], axis=1)) if present
                        else np.zeros((self.rows, 0)))

    def _terms(self) -> list:
        """The coefficient arrays in the order of ``_weights``."""
        return [self.c, *self.b, *self.a.values()]

    def _weights(self, z) -> list[float]:
        """The polynomial's monomials at z: 1, z_i, z_i z_j (i <= j, in the order of ``a``)."""
        return [1.0, *(z[i] for i in range(self.n)), *(z[i] * z[j] for i, j in self.a)]

    def _reduced(self, sparse, full=None):
        """Reduce the non-zero columns (indices, values (T, k)); zero columns stay zero. ``full``: the
        flattened index among all columns of each column the indices count."""
        idx, values = sparse
        if idx.size == 0:
            return None
        return (idx if full is None else full[idx]), self._reduce(values)

    def __call__(self, z):
        weights = np.repeat(np.array(self._weights(z), dtype=float)[self._present], self._counts)
        out = np.zeros((self.rows, int(np.prod(self.shape))))
        _add_columns(out, self._columns, weights, self._values)
        return out.reshape(-1, *self.shape)


njit = Kernels(__file__)


@njit  # no fast-math: numpy's products and sums, bit for bit
def _add_columns(out, idx, w, values):
    """out[:, idx[j]] += w[j] * values[:, j] for j in order (out (rows, m), values (rows, len(idx))):
    ``out[:, idx] += w * values`` term after term, in one pass over the rows."""
    for t in range(out.shape[0]):
        for j in range(idx.size):
            out[t, idx[j]] += w[j] * values[t, j]


def _sparse_term(term, shape: tuple[int, int], scale: float, rtol: float = 1e-9, block: int = 1 << 16):
    """(indices, values (rows, k)) of the columns of an array of ``shape`` given by ``term(rows,
    columns)`` (rows a slice, columns a slice or an index array) that are not zero up to rounding:
    larger than ``rtol`` times ``scale`` (the size of the evaluated design). The columns are chosen
    on blocks of about ``block`` entries, so that the whole array is never formed (the IX at 1e6
    samples: 176 MB per evaluation), and only the chosen ones are computed in full: the same numbers
    as forming it, in a fraction of the time."""
    n_rows, chunk = shape[0], max(1, block // max(1, shape[1]))
    peak = None
    for s in range(0, n_rows, chunk):
        part = _column_peak(term(slice(s, s + chunk), slice(None)))
        peak = part if peak is None else np.maximum(peak, part)
    if peak is None:
        return np.zeros(0, dtype=int), np.zeros((0, 0))
    idx = np.flatnonzero(peak > rtol * scale)
    return idx, term(slice(None), idx)


def _column_peak(a: np.ndarray) -> np.ndarray:
    """max |a| over the rows of a (rows, k), per column. The rows are first laid side by side in rows
    of about 256 entries: numpy reduces a narrow array (the IX's 4 columns) 10x slower."""
    n, k = a.shape
    fold = max(1, 256 // max(1, k))
    head = n - n % fold
    peak = np.abs(a[:head].reshape(-1, fold * k)).max(axis=0, initial=0.0).reshape(fold, k).max(axis=0)
    return peak if head == n else np.maximum(peak, np.abs(a[head:]).max(axis=0))


def _shared_columns(k, idx: np.ndarray) -> tuple:
    """Where the columns ``idx`` lie among the columns ``k`` (a slice of all of them, or indices),
    and which of ``idx`` they are: (positions in k, positions in idx)."""
    if isinstance(k, slice):
        return idx, slice(None)
    _, at, of = np.intersect1d(k, idx, assume_unique=True, return_indices=True)
    return at, of
