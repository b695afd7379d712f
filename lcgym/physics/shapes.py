"""The shapes of a model's effects: what the fit finds of an effect declared without values.

A machine may declare effects its physical model knows without giving their values (a machine
file's ``[[model]]`` tables, ``System.model_effects``; ``PhysicalModel.search_shapes``). An effect
is linear in its coefficients (a friction level, a stiffness), which the model's least-squares fit
takes together with the rigid-body parameters, and may have nonlinear parameters: its *shape* (a
friction's smoothing speed eps [rad/s or m/s], a spring's onset q0 and width [rad or m], a ripple's
period). ``fit_shapes`` finds them as the diagnosis does for an effect it adds (``diagnose.search``),
from the same pieces:

* the grid of the effect's candidate (``physics.candidates``: the same values, scaled by the
  axis's speed and position, ``axis_scale``); a periodic effect's period at the strongest peaks of
  the residual's spectrum over the axis position (``period_peaks``);
* each value judged by the least-squares fit of the whole model (the rigid body, the other effects,
  this one's columns: ``Effect.columns``, the one implementation of its formula, low-passed and
  decimated as in ``PhysicalModel.fit``): the least SSE among the fits whose coefficients have the
  effect's physical signs (``Effect.physical``; any where none has);
* the continuous ones then refined from the grid's best (bounded Nelder-Mead, log scale for
  positive ones; a period within 5 %), kept where the SSE falls and the signs stay physical.

The effects are searched in the order given, each with the ones before it in the model (as the
diagnosis's greedy selection adds them), then, where there are several, once more each with all the
others in. The rigid-body columns are those of the model's given parameters (a machine nonlinear in
some, the IX, at their given values); the fit that follows refits everything with the shapes found.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from scipy.optimize import minimize

from .candidates import Candidate, axis_scale, candidates_of, period_peaks, refined_setting, refinement
from .effects import Effect, parse_key
from .linalg import solve_min_norm

PERIOD_SPAN = 0.05  # a period is refined within +-5 % of its spectral peak (``diagnose.search.refine``)


def model_candidate(system, key: str, built_in: Sequence[str]) -> Candidate:
    """The candidate (``physics.candidates``) of effect ``key`` (``name@axis``) that a machine's
    physical model can carry with its parameters fitted (``System.model_effects``); a ValueError
    saying why not: an unknown name or axis, an effect the model has built in, one with internal
    state or a tabulated curve (plant only: no static regressor), one whose formula does not apply to
    the axis. ``built_in``: the effects the model carries on every axis (``PhysicalModel.built_in``)."""
    name, axis = parse_key(key)
    if name in built_in:
        raise ValueError(f"{key}: the physical model has {name} on every axis already (it is fitted with the "
                         f"rigid body: {', '.join(built_in)})")
    candidates = {c.name: c for c in candidates_of(system)}
    known = system.effect_classes()
    if name in known and known[name].plant_only:
        raise ValueError(f"{key}: {name} exists in plants only (internal state, or a curve of no set shape): a "
                         f"static model has no regressor to fit it; a model can carry {', '.join(candidates)}")
    if name not in candidates:
        raise ValueError(f"{key}: unknown effect {name!r} for {system.name}'s model; it can carry "
                         f"{', '.join(candidates)} (lcgym effects)")
    kind = system.axis(axis)  # a ValueError names the machine's axes
    if not candidates[name].effect.applies_to(kind):
        raise ValueError(f"{key}: {name} does not apply to a {kind.kind} axis")
    return candidates[name]


def fit_shapes(model, kin, lengths: Sequence[int], u: np.ndarray, mask: np.ndarray | None = None
               ) -> tuple[Effect, ...]:
    """``model.effects`` (a ``PhysicalModel``) with the nonlinear parameters of those named in
    ``model.search_shapes`` found (module docstring), the others and every coefficient as given; on
    the fit's kinematics ``kin`` (q, qd, qdd), trial ``lengths`` and input ``u`` (``PhysicalModel.
    kinematics``, ``inputs``); ``mask``: the samples of each axis that count (``PhysicalModel.fit``)."""
    problem = _Problem(model, kin, lengths, u, mask)
    effects = list(model.effects)
    order = [k for k, e in enumerate(effects) if e.key in model.search_shapes]
    present = [k for k in range(len(effects)) if k not in order]
    for k in order:  # in the order given, each with the ones before it
        effects[k] = problem.best_shape(effects, present, k)
        present.append(k)
    if len(order) > 1:  # then each once more with all the others in
        for k in order:
            effects[k] = problem.best_shape(effects, [j for j in present if j != k], k)
    return tuple(effects)


class _Problem:
    """The reduced least-squares problem of a model on its trials (``PhysicalModel.fit``'s): the
    rigid-body columns and the input, low-passed and decimated once; an effect's columns reduced
    per shape tried."""

    def __init__(self, model, kin, lengths: Sequence[int], u: np.ndarray, mask: np.ndarray | None):
        self.model, self.kin, self.lengths, self.mask = model, kin, list(lengths), mask
        free, fixed, self.theta = model.free_design(kin, model.params)
        self.loads = model.load_torques(kin, model.params.to_vector(), rigid=free @ self.theta + fixed)
        pre = model.preprocessing
        self.base = pre.kept_reduce(free, self.lengths, mask)  # (R, A, k)
        self.y = pre.kept_reduce(u - fixed, self.lengths, mask)  # (R, A)
        self.rows = pre.reduced_rows(self.lengths)

    def columns(self, effect: Effect) -> np.ndarray:
        """The effect's reduced columns (R, len(linear)) on its own axis."""
        i = effect.index
        cols = effect.columns(*self.kin, self.loads)
        return self.model.preprocessing.masked_reduce(cols, self.lengths, None if self.mask is None else self.mask[:, i])

    def design(self, effects: Sequence[Effect], columns: Sequence[np.ndarray], rigid: bool = True) -> np.ndarray:
        """The reduced design (R, A, p): the rigid body's columns (``rigid``), then those of
        ``effects`` (their reduced ``columns`` on their own axes)."""
        R, A, _ = self.base.shape
        parts = [self.base] if rigid else []
        for e, c in zip(effects, columns, strict=True):
            block = np.zeros((R, A, c.shape[1]))
            block[:, e.index, :] = c
            parts.append(block)
        return np.concatenate(parts, axis=2) if parts else np.zeros((R, A, 0))

    def solve(self, effects: Sequence[Effect], columns: Sequence[np.ndarray]) -> tuple[float, np.ndarray, np.ndarray]:
        """(SSE, the effects' coefficients, the residual (R, A)) of the model with ``effects`` whose
        reduced ``columns`` are given (``solve_min_norm``: the fit's own solve, penalties included)."""
        theta0, penalties, start = [self.theta], [], self.base.shape[2]
        for e, c in zip(effects, columns, strict=True):
            theta0.append(e.coefficients())
            rough = e.roughness()
            if rough is not None:
                penalties.append((np.arange(start, start + c.shape[1]), rough))
            start += c.shape[1]
        theta, resid = solve_min_norm(self.design(effects, columns), self.y.reshape(-1), np.concatenate(theta0),
                                      rcond=self.model.rcond, penalties=penalties)
        return float(resid @ resid), theta[self.base.shape[2]:], resid.reshape(self.y.shape)

    def best_shape(self, effects: list[Effect], present: Sequence[int], k: int) -> Effect:
        """Effect ``k`` of ``effects`` with the shape that fits best with the effects ``present``
        in the model (module docstring)."""
        effect = effects[k]
        cand = model_candidate(self.model.system, effect.key, type(self.model).built_in)
        others = [effects[j] for j in present]
        other_cols = [self.columns(e) for e in others]
        n_other = sum(len(e.linear) for e in others)
        i = effect.index
        scale = axis_scale(self.model.system.axes[i], self.kin[0][:, i], self.kin[1][:, i])
        grid = cand.settings(self.kin[0], self.kin[1], i, scale)
        # without roughness penalties, the model without the effect is projected off once (_Projection)
        smooth = all(e.roughness() is None for e in (*others, effect))
        fixed = _Projection(self.design(others, other_cols), self.y.reshape(-1), self.model.rcond) if smooth else None
        if cand.period is not None:
            resid = fixed.residual.reshape(self.y.shape) if smooth else self.solve(others, other_cols)[2]
            weight = self.loads.torque[self.rows, i] if "torque" in cand.effect.reads else None
            periods = period_peaks(resid[:, i], self.kin[0][self.rows, i], weight, shortest=0.01 * scale["position"])
            grid = [{**g, cand.period: p} for g in grid for p in periods] or grid  # too little travel: as given

        def fit(shape: dict) -> tuple[float, bool]:
            """(SSE, physical signs) with the effect at ``shape``."""
            trial = dataclasses.replace(effect, **shape)
            cols = self.columns(trial)
            if smooth:
                sse, coef = fixed.solve(self.design([trial], [cols], rigid=False).reshape(-1, cols.shape[1]))
            else:
                sse, coef, _ = self.solve([*others, trial], [*other_cols, cols])
                coef = coef[n_other:]
            return sse, cand.effect.physical(coef)

        results = [(fit(g), g) for g in grid]
        signed = [r for r in results if r[0][1]]
        (best_sse, physical), best = min(signed or results, key=lambda r: r[0][0])
        return dataclasses.replace(effect, **self._refined(cand, grid, best, best_sse, physical, fit))

    @staticmethod
    def _refined(cand: Candidate, grid: list[dict], best: dict, best_sse: float, physical: bool, fit) -> dict:
        """``best`` with its continuous parameters refined (module docstring; the diagnosis's space and
        bounds, ``physics.candidates.refinement``)."""
        names, logged, x0, bounds = refinement(cand, grid, best, PERIOD_SPAN)
        if not names:
            return best
        result = minimize(lambda x: fit(refined_setting(best, names, logged, x))[0], x0, method="Nelder-Mead",
                          bounds=bounds, options={"maxiter": 60 * len(names), "xatol": 1e-3,
                                                  "fatol": 1e-9 * max(best_sse, 1e-300)})
        if result.fun >= best_sse:
            return best
        refined = refined_setting(best, names, logged, result.x)
        return refined if fit(refined)[1] or not physical else best


class _Projection:
    """Least squares of y on a fixed design B (R, A, p) plus a few columns E that change (an effect's
    at each shape tried): B's span is projected off once (an orthonormal basis of its columns scaled
    to unit norm, singular values below ``rcond`` of the largest left out, as ``solve_min_norm``
    does), so each E costs a projection and a solve of its own size. The same SSE and coefficients
    of E as the whole solve where E is identified."""

    def __init__(self, B: np.ndarray, y: np.ndarray, rcond: float):
        B = B.reshape(y.size, -1)
        scale = np.linalg.norm(B, axis=0)
        used = scale > 1e-12 * scale.max(initial=0.0)
        U, s, _ = np.linalg.svd(B[:, used] / scale[used], full_matrices=False)
        self.U = U[:, s > rcond * s[0]] if s.size else U
        self.residual = y - self.U @ (self.U.T @ y)  # of the fixed design alone

    def solve(self, E: np.ndarray) -> tuple[float, np.ndarray]:
        """(SSE, coefficients of E (k,)) with the columns E (rows of y, k) added."""
        E = E - self.U @ (self.U.T @ E)
        scale = np.linalg.norm(E, axis=0)
        scale[scale == 0] = 1.0
        coef = np.linalg.lstsq(E / scale, self.residual, rcond=None)[0] / scale
        r = self.residual - E @ coef
        return float(r @ r), coef


__all__ = ["fit_shapes", "model_candidate"]
