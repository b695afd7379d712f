"""Which effect is missing: every candidate on every axis, scored on held-out data.

The residual is worked with after the model's own reduction (``Preprocessing.reduce``: zero-phase
low-pass of u and of every regressor column, then decimation), so that the encoder-quantization
noise the feedback puts into u does not count as something to explain.

Held-out scoring (blocked two-fold cross-validation). Each trial is cut into blocks of
``block_seconds``; blocks alternate between fold 0 and fold 1 (shifted by one from trial to trial,
the repeats of one trajectory in step). For fold f, the model (its linear parameters) plus the
candidate (its coefficients, and its nonlinear parameters chosen among the grid values by the
training fit) is fitted on the other fold and evaluated on f. A candidate's ``explained`` share is

    1 - sum_f SSE_f(model + candidate) / sum_f SSE_f(model)

on its axis, both SSE held-out. Where the data hold runs of different motions, the folds are whole
runs instead (``layout.run_folds``): a candidate is then judged on motions it was not fitted on, as
the next run will judge it. A flexible candidate that fits noise gains nothing held-out.

Periods of periodic candidates come from the spectrum of the training fold's residual over the
axis position, |sum_k r_k w_k exp(-2 pi i q_k / P)|^2 (w = 1, or the model torque for torque
ripple), at the frequency resolution the position range allows; the strongest peaks are tried
(periods from 1 % of the axis's position scale up: 1 deg on the IX).

Greedy forward selection: at every step *every* candidate on every axis is scored again against
what the model with the picks so far leaves (a candidate that failed before can pass once the
effect that hid it is in). The passing candidate that removes the most held-out residual energy
(in the input's unit, so that axes compare by what matters, not by the share of a residual that
may be tiny) is added to the model, its continuous nonlinear parameters refined (``refine``), and
the model refitted. Stopping rule: the selection ends when no candidate passes, when a pick, once
the model is refitted with it, no longer lowers its axis's held-out error (the pick is then
undone), or after ``max_steps`` picks. Each step is recorded (``Step``: what each axis had left,
what every candidate removed of it, and why it passed or not); the report prints and writes
them. A candidate passes when, at its step,

1. it removes at least ``min_explained`` of its axis's held-out residual energy *at that step*;
2. it removes at least ``LATE_FACTOR`` x ``min_explained`` of the axis's *original* error (a late
   pick must still matter against the original error, not only chase the structure that is left),
   or at least ``REVEALED`` of what is left (a real effect a larger one hid: once the larger one
   is in, it explains most of the rest, where chasing explains a little of it). An axis's
   original error is its baseline (the model alone) less what picks on *other* axes removed from
   it: a large effect on one axis leaks into the others through the shared rigid-body fit, and
   once it is in, that leak is no error of theirs;
3. the removed part has an RMS of at least ``min_rms`` of its axis (the noise floor: a nearly
   perfect model otherwise makes a few millivolts of quantization structure look like a large
   share);
4. both folds fit the coefficients that are positive physically (``Effect.positive``: a friction
   level, a stiffness, an inertia) with that sign: a negative friction level or rotor inertia is
   some other structure, not the effect;
5. its torque as fitted lies mostly at frequencies the input holds (``spectra.unheld_share``): a
   gear's ripple at 12-18 Hz cannot be in torques a logger low-passed at 2 Hz.

A candidate that ``extends`` a simpler one (asymmetric friction contains Coulomb friction) passes
only if what it removes beyond the simpler one passes rules 1-3 against what the simpler one
leaves. Among candidates on the same axis within ``tie`` of the best, the one with the fewest parameters
is taken (the simpler of two friction curves that fit equally well). Once a pick is in, every form
that extends it is tried in its place (``_other_form``), and each try is recorded with the rule's
numbers (``figures``) and its verdict. The cases that set ``REVEALED`` and ``LATE_FACTOR``:
docs/diagnosis.md, "What set the rules for hidden effects".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..physics.candidates import period_peaks, refined_setting, refinement
from ..physics.effects import SMOOTHING, Loads
from ..physics.model import PhysicalModel
from .candidates import Candidate
from .layout import Layout, fold_assignment
from .spectra import UNHELD_SHARE, unheld_share

DEG = math.pi / 180.0
OVER_POSITION = ("spring", "position", "gravity", "periodic")
"""Families of effects that are curves over their axis's position (a spring, a position map, a drape,
a gear's ripple): on an axis that moves in proportion with another, data cannot tell whose position."""
LATE_FACTOR = 0.5  # a pick must also remove this fraction of min_explained of its axis's original error ...
REVEALED = 1 / 4  # ... unless it removes at least this share of what is left: an effect a larger one hid
FOLD_SHARE = 1 / 3  # and in each fold at least this fraction of min_explained of that fold's held-out error


@dataclass
class Prepared:
    """Trials reduced once: full-rate kinematics ``kin``, model torque ``torque`` and the model's
    own torques ``loads`` (``physics.effects.Loads``: its rigid-body torque, and its gravity torque
    where a candidate reads it) (T, A);
    reduced input ``u`` and reduced design ``design`` (R, A, p) of the fitted model (the columns
    of its free parameters, ``PhysicalModel.design``: the IX's rigid regressor at its fitted
    centres of mass; + its effects' columns), zero where ``used`` (R, A) is False (a sample the
    layout leaves out of that axis's fit and score). The torque of parameters the model holds fixed
    is subtracted from both ``u`` and ``torque``; ``fold`` (R,) in {0, 1}; ``guard`` (R,) rows
    within the filters' reach of a block boundary (left out of the training folds);
    ``rows`` (R,) the full-rate sample of each reduced row; ``trial`` (R,) its trial index."""

    model: PhysicalModel
    kin: tuple[np.ndarray, np.ndarray, np.ndarray]
    lengths: list[int]
    torque: np.ndarray
    loads: Loads
    u: np.ndarray
    design: np.ndarray
    mask: np.ndarray
    used: np.ndarray
    fold: np.ndarray
    guard: np.ndarray
    rows: np.ndarray
    trial: np.ndarray
    penalties: list = field(default_factory=list)  # the design's roughness penalties (``PhysicalModel.penalties``)

    def reduce(self, columns: np.ndarray, axis: int) -> np.ndarray:
        """Columns (T, k) of ``axis`` reduced as the design is (``Preprocessing.masked_reduce``)."""
        return self.model.preprocessing.masked_reduce(columns, self.lengths, self.mask[:, axis])

    @property
    def residual(self) -> np.ndarray:
        """Reduced residual (R, A) of the fitted model: u minus the reduced model torque (zero where not used)."""
        return self.u - self.model.preprocessing.masked_reduce(self.torque, self.lengths, self.mask)

    @property
    def n_used(self) -> np.ndarray:
        """Rows used per axis (A,)."""
        return self.used.sum(axis=0)

    def with_gravity(self) -> Prepared:
        """This, with the model's gravity torque in ``loads`` (a candidate that reads it)."""
        if self.loads.gravity is None:
            q, qd, qdd = self.kin
            p = self.model.fitted_params.to_vector()
            gravity = self.model.system.inverse_dynamics(p, q, np.zeros_like(qd), np.zeros_like(qdd))
            self.loads = Loads(torque=self.loads.torque, gravity=gravity)
        return self


def prepare(trials: Sequence, model: PhysicalModel, layout: Layout, kinematics: tuple | None = None) -> Prepared:
    """Fit ``model`` (unfitted) on the samples of ``trials`` that ``layout`` uses and reduce
    everything the search needs. ``kinematics``: ``model.preprocessing.kinematics(trials)`` where
    the caller has it (every model of one diagnosis has the same kinematics: computed once)."""
    pre = model.preprocessing
    kinematics = pre.kinematics(trials) if kinematics is None else kinematics
    model.fit(trials, mask=layout.used, kinematics=kinematics)
    design = model.design(trials, kinematics, layout.used)
    kin, lengths = kinematics
    rows = pre.reduced_rows(lengths)
    trial, guard = [], []
    for k, n in enumerate(lengths):
        t = np.arange(0, n, max(1, model.decimate)) / model.fs
        length = layout.blocks[k]
        n_blocks = max(1, int(round(n / model.fs / length)))
        nearest = np.clip(np.round(t / length), 1, max(1, n_blocks - 1))  # the closest boundary between two blocks
        trial.append(np.full(t.size, k))
        guard.append((np.abs(t - nearest * length) < layout.settle) & (n_blocks > 1))
    return Prepared(model=model, kin=kin, lengths=lengths, torque=design.torque, loads=Loads(torque=design.rigid_torque),
                    u=design.u, design=design.design, mask=layout.used, used=layout.used[rows],
                    fold=fold_assignment(lengths, model.fs, layout.blocks, layout.first or None)[rows],
                    guard=np.concatenate(guard), rows=rows, trial=np.concatenate(trial), penalties=design.penalties)


def verdict(removed, left, own: float, min_explained: float, min_rms: float, n_rows: int,
            physical: bool = True) -> str:
    """Why a candidate that removes ``removed`` of an axis's held-out SSE ``left`` (each per fold,
    (2,); the axis's original error ``own``) does or does not pass the significance rule of the
    module docstring: "passes", or the first rule it fails."""
    removed_f, left_f = np.asarray(removed, dtype=float), np.asarray(left, dtype=float)
    removed, left = float(removed_f.sum()), float(left_f.sum())
    share = removed / left if left > 0 else 0.0
    of_original = removed / own if own > 0 else 0.0
    if not physical:
        return "unphysical sign"
    if share < min_explained:
        return "removes too little of what is left"
    if np.any(removed_f < FOLD_SHARE * min_explained * left_f):
        return "not in both folds"
    if of_original < LATE_FACTOR * min_explained and share < REVEALED:
        return "too little of the original error"
    if math.sqrt(max(removed, 0.0) / n_rows) < min_rms:
        return "below the noise floor"
    return "passes"


def figures(removed, left, own: float, n_rows: int) -> str:
    """The numbers ``verdict`` judges, for a refusal or a replacement to name: the share of what was
    left that a candidate removes, the share of the axis's original error, and the RMS of what it
    removes [input unit] (``removed``, ``left``: held-out SSE per fold, as ``verdict`` takes them)."""
    removed, left = float(np.sum(removed)), float(np.sum(left))
    if removed <= 0:
        return f"nothing (held-out it leaves {(left - removed) / left:.2f}x as much)" if left > 0 else "nothing"
    share = removed / left if left > 0 else 0.0
    of_original = removed / own if own > 0 else 0.0
    return (f"{100 * share:.0f}% of what that leaves, {100 * of_original:.1f}% of the original error, "
            f"RMS {math.sqrt(max(removed, 0.0) / n_rows):.3g}")


def _named(rule: str, floor: float) -> str:
    """A ``verdict`` with its number where it has one of its own: the noise floor [input unit]."""
    return f"{rule} ({floor:.3g})" if rule == "below the noise floor" else rule


def _pinv(G, rtol=1e-10):
    """Pseudo-inverse of G (symmetric PSD) taken with its columns scaled to unit diagonal: G+ b is
    the minimum-norm solution of G theta = b in scaled units (eigenvalues below ``rtol`` of the
    largest count as zero: directions the data lack)."""
    s = np.sqrt(np.clip(np.diag(G), 0.0, None))  # a Schur complement's diagonal can round below zero
    s[s == 0] = 1.0
    w, V = np.linalg.eigh(G / np.outer(s, s))
    keep = w > rtol * max(w.max(), 1e-300)
    Vs = V[:, keep] / s[:, None]
    return (Vs / w[keep]) @ Vs.T


def _solve(G, b, rtol=1e-10):
    """Minimum-norm solution of G theta = b (G symmetric PSD), columns scaled to unit diagonal."""
    return _pinv(G, rtol) @ b


class Scorer:
    """Two-fold least squares of the reduced design plus one candidate's columns on one axis."""

    def __init__(self, design: np.ndarray, u: np.ndarray, fold: np.ndarray, guard: np.ndarray | None = None,
                 penalties=()):
        self.design, self.u, self.fold, self.penalties = design, u, fold, list(penalties)
        self.guard = np.zeros(fold.shape, dtype=bool) if guard is None else guard
        self.memo: dict = {}  # what candidates of this scorer share (spectral peaks)
        # every fold's fit is a minimum-norm correction to the fit on all data (as PhysicalModel.fit
        # corrects the nominal values): directions one fold cannot identify keep the full-data values
        self.theta0 = _solve(_penalized(np.einsum("rap,raq->pq", design, design), self.penalties),
                             np.einsum("rap,ra->p", design, u))
        self.parts = []
        for f in (0, 1):
            tr, te = np.flatnonzero((fold != f) & ~self.guard), np.flatnonzero(fold == f)
            D, y = design[tr], u[tr]
            G = _penalized(np.einsum("rap,raq->pq", D, D), self.penalties)
            b = np.einsum("rap,ra->p", D, y)
            pinv = _pinv(G)
            r = b - G @ self.theta0  # the normal equations' residual at the full-data fit
            theta = self.theta0 + pinv @ r
            self.parts.append({"tr": tr, "te": te, "G": G, "b": b, "uu": float((y * y).sum()), "pinv": pinv, "r": r,
                               "theta": theta,
                               "D_axis": [np.ascontiguousarray(D[:, a, :]) for a in range(D.shape[1])],
                               "test_axis": [np.ascontiguousarray(design[te, a, :]) for a in range(D.shape[1])],
                               "u_tr": [np.ascontiguousarray(y[:, a]) for a in range(D.shape[1])],
                               "u_te": [np.ascontiguousarray(u[te, a]) for a in range(D.shape[1])],
                               "resid_tr": y - D @ theta, "test_sse": ((u[te] - design[te] @ theta) ** 2).sum(axis=0)})

    @property
    def test_sse(self) -> np.ndarray:
        """Held-out SSE per axis of the design alone, summed over the folds."""
        return self.parts[0]["test_sse"] + self.parts[1]["test_sse"]

    def fold_sse(self, axis: int) -> np.ndarray:
        """Held-out SSE of ``axis`` per fold (2,) of the design alone."""
        return np.array([self.parts[0]["test_sse"][axis], self.parts[1]["test_sse"][axis]])

    def evaluate(self, cols: np.ndarray, axis: int, f: int, roughness: np.ndarray | None = None
                 ) -> tuple[float, float, np.ndarray]:
        """(training SSE of all axes, held-out SSE of ``axis``, the columns' fitted coefficients (k,)) of
        fold f with ``cols`` (R, k) added on ``axis`` (``roughness``: their penalty, ``Effect.roughness``;
        the training SSE then includes it).

        The fold's fit of the design plus the columns, by block elimination: the columns' part
        orthogonal to the design's span (Gram ``F - C' G+ C``) takes their coefficients, the design's
        own minimum-norm correction (``pinv``, kept per fold) the rest; the same solution as the
        minimum-norm solve of the augmented normal equations, at a fraction of its cost."""
        P = self.parts[f]
        E = cols[P["tr"]]
        C = P["D_axis"][axis].T @ E
        b_e = E.T @ P["u_tr"][axis]
        F = E.T @ E
        if roughness is not None:
            F = _penalized(F, [(np.arange(F.shape[0]), roughness)])
        pinv_C = P["pinv"] @ C
        coef = _solve(F - C.T @ pinv_C, b_e - C.T @ self.theta0 - pinv_C.T @ P["r"])
        theta = P["theta"] - pinv_C @ coef
        train = (P["uu"] - 2 * (theta @ P["b"] + coef @ b_e) + theta @ P["G"] @ theta + 2 * theta @ C @ coef
                 + coef @ F @ coef)
        te = P["te"]
        pred = P["test_axis"][axis] @ theta + cols[te] @ coef
        return float(train), float(((P["u_te"][axis] - pred) ** 2).sum()), coef

    @classmethod
    def of(cls, prep: Prepared) -> Scorer:
        return cls(prep.design, prep.u, prep.fold, prep.guard, prep.penalties)


def _penalized(G: np.ndarray, penalties) -> np.ndarray:
    """The Gram matrix G with the roughness penalties [(column indices, D)] of some of its columns
    added (``physics.model.penalty_rows``: weighted by SMOOTHING times their mean square)."""
    if not penalties:
        return G
    G = G.copy()
    for idx, D in penalties:
        lam = SMOOTHING * float(np.trace(G[np.ix_(idx, idx)])) / len(idx)
        G[np.ix_(idx, idx)] += lam * (D.T @ D)
    return G


@dataclass
class Score:
    """A candidate on one axis: held-out SSE with it, its nonlinear parameters (fitted on all
    data), the reduced columns at those parameters, and whether both folds' fits gave its signed
    coefficients the physical sign (``Effect.positive``: a friction level, a stiffness, an inertia)."""

    candidate: Candidate
    axis: int
    held_out_sse: float
    params: dict
    cols: np.ndarray = field(repr=False)
    physical: bool = True
    folds: np.ndarray = field(default_factory=lambda: np.zeros(2), repr=False)  # held-out SSE per fold


class ColumnCache:
    """Reduced columns of (candidate, axis, parameters), computed once per diagnosis."""

    def __init__(self, prep: Prepared, axes: Sequence[str], shared: ColumnCache | None = None,
                 scales: Sequence[dict] | None = None):
        self.prep, self.axes, self.store = prep, tuple(axes), {}
        self.scales = scales if scales is not None else (shared.scales if shared is not None else None)
        if shared is not None and shared.prep.mask is prep.mask:  # the same samples: what reads no torque is the same
            self.store = {k: v for k, v in shared.store.items() if not k[3]}

    def scale(self, axis: int) -> dict:
        """The axis's grid scales (``score_candidate``)."""
        return self.scales[axis]

    def use(self, prep: Prepared) -> None:
        """Switch to a refitted model's data: columns that read its torques are recomputed."""
        self.prep = prep
        self.store = {k: v for k, v in self.store.items() if not k[3]}

    def __call__(self, cand: Candidate, axis: int, params: dict, keep: bool = True) -> np.ndarray:
        """The reduced columns (zero where the axis's rows are not used); ``keep=False``: not stored
        (a refinement's trial parameters)."""
        key = (cand.name, axis, tuple(sorted(params.items())), bool(cand.effect.reads))
        if key in self.store:
            return self.store[key]
        eff = cand.build(self.axes[axis], **params).bound(self.axes)
        q, qd, qdd = self.prep.kin
        loads = self.prep.with_gravity().loads if "gravity" in eff.reads else self.prep.loads
        cols = self.prep.reduce(eff.columns(q, qd, qdd, loads), axis)
        if keep:
            self.store[key] = cols
        return cols


def score_candidate(scorer: Scorer, cand: Candidate, axis: int, prep: Prepared, cache: ColumnCache,
                    scale: dict) -> Score | None:
    """Nested choice of the nonlinear parameters: per fold, the grid value with the smallest
    training SSE among those whose fit has the effect's physical signs (``Effect.physical``; any
    value where none has), scored on the held-out fold: a one-sided spring is tried on both sides of
    its onset before its sign is judged. The reported parameters minimize the SSE on all data
    (summed training SSE of both folds), among the physical ones where there are. ``scale``: the
    axis's {"speed", "position"} scales of the grids (``physics.grids.Scaled``; the shortest
    period searched is 1 % of "position")."""
    q_full = prep.kin[0]
    grid = cand.settings(q_full, prep.kin[1], axis, scale)
    shortest = 0.01 * scale["position"]
    q_red = q_full[prep.rows, axis]
    weight = prep.loads.torque[prep.rows, axis] if "torque" in cand.effect.reads else None

    def peaks(f: int) -> list[float]:
        """Spectral peaks of fold f's training residual (kept on the scorer: every periodic candidate
        of the axis with the same weight reads the same ones)."""
        key = ("peaks", axis, f, weight is not None, shortest)
        if key not in scorer.memo:
            P = scorer.parts[f]
            scorer.memo[key] = period_peaks(P["resid_tr"][:, axis], q_red[P["tr"]],
                                            None if weight is None else weight[P["tr"]], shortest=shortest)
        return scorer.memo[key]

    def settings(f: int | None) -> list[dict]:
        if cand.period is None:
            return grid
        periods = list(dict.fromkeys(peaks(0) + peaks(1))) if f is None else peaks(f)
        return [{**g, cand.period: float(p)} for g in grid for p in periods]

    memo: dict = {}

    rough = cand.effect.roughness()

    def evaluate(setting: dict, f: int):
        key = (tuple(sorted(setting.items())), f)
        if key not in memo:
            memo[key] = scorer.evaluate(cache(cand, axis, setting), axis, f, rough)
        return memo[key]

    folds, physical = np.zeros(2), True
    for f in (0, 1):
        options = settings(f)
        if not options:
            return None
        results = [evaluate(s, f) for s in options]
        signed = [r for r in results if cand.effect.physical(r[2])]
        chosen = min(signed or results, key=lambda r: r[0])  # chosen by the training fit alone
        folds[f] = chosen[1]
        physical &= bool(signed)
    options = settings(None)
    fits = [[evaluate(s, f) for f in (0, 1)] for s in options]
    signed = [k for k, r in enumerate(fits) if all(cand.effect.physical(x[2]) for x in r)] or range(len(options))
    best = options[min(signed, key=lambda k: fits[k][0][0] + fits[k][1][0])]
    return Score(cand, axis, float(folds.sum()), best, cache(cand, axis, best), physical, folds)


@dataclass
class Step:
    """One step of the greedy selection: ``left`` (n_axes,) each axis's held-out SSE before it,
    ``original`` each axis's original error then (rule 2), ``scores`` every candidate scored at
    this step as (Score, held-out SSE it removes from its axis, verdict: "passes" or the rule it
    fails), ``picked`` the Score selected (None: the selection stopped here); ``revised``: picks
    put in another form of theirs once this one was in (``rank``); ``replacements``: each other form
    tried in place of a pick then, with the numbers of the rule and its verdict (``_other_form``)."""

    left: np.ndarray
    original: np.ndarray
    scores: list[tuple[Score, float, str]]
    picked: Score | None = None
    revised: list[str] = field(default_factory=list)
    replacements: list[str] = field(default_factory=list)  # every other form tried in place of a pick, and why (not)


@dataclass
class Ranking:
    """Outcome of the search: ``baseline`` held-out SSE per axis of the model alone; ``n_rows``
    (n_axes,) the rows each axis is scored on; ``alone`` every candidate's Score against the model
    alone; ``selected`` the greedy picks as (Score at its step, or of the form it was revised to;
    share of what was left removed at that step, held-out SSE of its axis before that step);
    ``named`` per selected entry, the candidate its step picked (a form of no set shape revised from
    it keeps its name: ``cable_spring`` -> ``position_map`` is a spring); ``model`` the model refitted
    with the selected effects; ``min_rms`` (n_axes,) the noise floor per axis; ``steps`` every
    step's record (``Step``); ``stop`` why the selection ended."""

    baseline: np.ndarray
    n_rows: np.ndarray
    alone: list[Score]
    selected: list[tuple[Score, float, float]]
    model: PhysicalModel
    min_explained: float
    min_rms: np.ndarray
    steps: list[Step] = field(default_factory=list)
    stop: str = ""
    named: list[Candidate] = field(default_factory=list)

    def explained(self, s: Score) -> float:
        return max(0.0, 1.0 - s.held_out_sse / self.baseline[s.axis]) if self.baseline[s.axis] > 0 else 0.0

    def passes_alone(self, s: Score) -> bool:
        """Whether ``s`` passed the significance rule against the model alone (the first step; a
        richer form that added too little to a simpler one passed alone too)."""
        why = {(x.candidate.name, x.axis): v for x, _, v in self.steps[0].scores}.get((s.candidate.name, s.axis), "")
        return why == "passes" or why.startswith("adds too little")


def rank(prep: Prepared, trials: Sequence, candidates: Sequence[Candidate], axes: Sequence[str], layout: Layout,
         min_explained: float = 0.1, min_rms: float | Sequence[float] = 0.004, tie: float = 0.01, max_steps: int = 4,
         progress=None, search_axes: Sequence[int] | None = None, scales: Sequence[dict] | None = None,
         kinds: Sequence | None = None, position_blind: Sequence[int] = ()) -> Ranking:
    """Score every candidate on every axis, then select greedily (module docstring). After each
    pick the model is refitted with it (centres of mass included) before the rest are rescored.

    The pass rule at every step (module docstring, ``verdict``): the candidate removes at least
    ``min_explained`` of its axis's current held-out residual energy, ``LATE_FACTOR`` times that
    share of the original one (or ``REVEALED`` of what is left), with a removed RMS of at least
    ``min_rms`` (one value, or one per axis). ``layout``: the samples used and the held-out blocks
    (``diagnose.layout``); ``search_axes``: the axis indices candidates are tried on (default all);
    ``scales``: each axis's grid scales (``score_candidate``; default the IX's 20 deg/s and 100
    deg); ``kinds``: the ``systems.Axis`` of each axis, where a candidate whose formula does not
    apply to the axis (``Effect.applies_to``) is skipped; ``position_blind``: axes that move in
    proportion with another (``workflow.proportional_groups``), where no candidate over the position
    (``OVER_POSITION``) is tried: the data cannot tell which axis's position it would follow.
    """
    min_rms = np.broadcast_to(np.asarray(min_rms, dtype=float), (len(axes),))
    if scales is None:
        scales = [{"speed": 20 * DEG, "position": 100 * DEG}] * len(axes)
    cache = ColumnCache(prep, axes, scales=scales)
    scorer = Scorer.of(prep)
    baseline = scorer.test_sse.copy()
    own = baseline.copy()  # each axis's original error without what picks on other axes removed from it
    n_rows = np.maximum(prep.n_used, 1)
    have = {e.key for e in prep.model.effects}  # a start model's own effects are not offered again
    pairs = [(c, a) for a in (range(len(axes)) if search_axes is None else search_axes) for c in candidates
             if (kinds is None or c.effect.applies_to(kinds[a])) and f"{c.name}@{axes[a]}" not in have
             and not (a in position_blind and c.family in OVER_POSITION)]
    alone, selected, named, steps, model = [], [], [], [], prep.model
    inputs = np.concatenate([np.asarray(tr.u, dtype=float) for tr in trials])
    stop = f"{max_steps} effects selected (the most allowed)"
    context = _Context(trials, candidates, axes, own, min_explained, min_rms, n_rows, layout, scales, position_blind,
                       (prep.kin, prep.lengths))
    for step in range(max_steps):
        current = scorer.test_sse
        if progress is not None:
            progress.total = progress.n + len(pairs) - len(selected)
            progress.refresh()
        scores = []
        in_model = {(s.candidate.name, s.axis) for s, _, _ in selected}
        for cand, a in pairs:
            if (cand.name, a) in in_model or any((c, a) in in_model for c in _forms(cand, candidates)):
                continue  # in the model already, or another form of it is (revisited below)
            s = score_candidate(scorer, cand, a, prep, cache, scales[a])
            if progress is not None:
                progress.update()
            if s is not None:
                scores.append(s)
        if step == 0:
            alone = scores
        rows = []  # (score, removed, verdict) of every candidate at this step
        by_key = {(s.candidate.name, s.axis): s for s in scores}
        for s in scores:
            a = s.axis
            left = scorer.fold_sse(a)
            why = verdict(left - s.folds, left, own[a], min_explained, min_rms[a], n_rows[a], s.physical)
            inner = [by_key[(e, a)] for e in s.candidate.extends if (e, a) in by_key and by_key[(e, a)].physical]
            if why == "passes" and inner:  # in place of the best simpler form, its extra parameters must pass
                best = min(inner, key=lambda x: x.held_out_sse)
                rule = verdict(best.folds - s.folds, best.folds, own[a], min_explained, min_rms[a], n_rows[a])
                if rule != "passes":
                    why = (f"adds too little to {best.candidate.name} (in its place it removes "
                           f"{figures(best.folds - s.folds, best.folds, own[a], n_rows[a])}: "
                           f"{_named(rule, min_rms[a])})")
            if why == "passes":
                why = _spectral_verdict(scorer, s, prep, inputs, axes)
            rows.append((s, float(current[a] - s.held_out_sse), why))
        record = Step(left=current.copy(), original=own.copy(), scores=rows)
        steps.append(record)
        passing = [(s, removed / current[s.axis], removed) for s, removed, why in rows if why == "passes"]
        if not passing:
            stop = "no candidate passes the significance rule"
            break
        top = max(passing, key=lambda x: x[2])
        plain = [x for x in passing if x[0].axis == top[0].axis and not x[0].candidate.shape_free]
        if plain and top[0].candidate.shape_free:
            # a curve of no set shape goes in as the best library effect of its axis, the form it refines
            # revised to it below: flexible, it also takes up part of another effect there (on the IX's
            # roll a friction curve removed 78 % of a Coulomb friction and a spring, Coulomb 43 %, the spring 63 %)
            top = max(plain, key=lambda x: x[2])
        near = [x for x in passing if x[0].axis == top[0].axis and x[1] >= top[1] - tie and not x[0].candidate.shape_free]
        pick = min(near or [top], key=lambda x: (x[0].candidate.n_params, -x[1]))[:2]
        params = refine(scorer, pick[0], cache)
        new_model = model.with_effect(pick[0].candidate.build(axes[pick[0].axis], **params))
        new_prep = prepare(trials, new_model, layout, (prep.kin, prep.lengths))
        new_scorer = Scorer.of(new_prep)
        if new_scorer.test_sse[pick[0].axis] >= current[pick[0].axis]:
            stop = (f"{pick[0].candidate.name}@{axes[pick[0].axis]} passed, but refitted with it the model does no "
                    "better held-out (not kept)")
            break
        record.picked = pick[0]
        selected.append((*pick, float(current[pick[0].axis])))
        named.append(pick[0].candidate)
        others = np.arange(len(axes)) != pick[0].axis
        own[others] -= np.clip(current - new_scorer.test_sse, 0.0, None)[others]
        model, prep, scorer = new_model, new_prep, new_scorer
        cache.use(prep)
        # with the new pick in, is another form of an earlier pick on its axis better now? The new pick
        # itself is tried against the forms that refine it (a friction curve, a load-dependent level,
        # a position map in place of a spring: its shape refined, now that its nonlinear parameters are too)
        richer = {c.name for c in candidates if pick[0].candidate.name in c.extends}
        for k, (s, share, before) in enumerate(selected):
            latest = k == len(selected) - 1
            if (latest and not richer) or s.axis != pick[0].axis:  # a pick on another axis changes little here
                continue
            other = _other_form(s, model, scorer, context, cache, only=richer if latest else None,
                                tried=record.replacements)
            if other is not None:
                record.revised.append(f"{s.candidate.name}@{axes[s.axis]} -> {other[0].candidate.name}@{axes[s.axis]}")
                selected[k] = (other[0], share, before)
                model, prep, scorer = other[1], other[2], Scorer.of(other[2])
                cache.use(prep)
    return Ranking(baseline, n_rows, alone, selected, model, min_explained, min_rms, steps, stop, named)


def _spectral_verdict(scorer: Scorer, s: Score, prep: Prepared, inputs: np.ndarray, axes: Sequence[str]) -> str:
    """"passes", or the refusal of a candidate whose torque as fitted (both folds' coefficients
    averaged, its columns at the full rate) lies mostly where the input ``inputs`` (T, A) holds less
    power than it would add (``spectra.unheld_share``)."""
    a = s.axis
    rough = s.candidate.effect.roughness()
    coef = np.mean([scorer.evaluate(s.cols, a, f, rough)[2] for f in (0, 1)], axis=0)
    eff = s.candidate.build(axes[a], **s.params).bound(axes)
    loads = prep.with_gravity().loads if "gravity" in eff.reads else prep.loads
    y = eff.columns(*prep.kin, loads) @ coef
    share, above = unheld_share(y, inputs[:, a], prep.lengths, prep.model.fs)
    if share <= UNHELD_SHARE:
        return "passes"
    return (f"not in the input's spectrum ({100 * share:.0f}% of its torque lies where the input holds less, mostly "
            f"above {above:.3g} Hz)")


@dataclass
class _Context:
    """What revisiting a pick needs of the selection (``_other_form``)."""

    trials: Sequence
    candidates: Sequence[Candidate]
    axes: Sequence[str]
    own: np.ndarray
    min_explained: float
    min_rms: np.ndarray
    n_rows: np.ndarray
    layout: Layout
    scales: Sequence[dict]
    position_blind: Sequence[int] = ()
    kinematics: tuple | None = None  # ((q, qd, qdd), lengths) of the trials: every model's


def _without(model: PhysicalModel, key: str) -> PhysicalModel:
    """A new, unfitted model without effect ``key`` (``name@axis``), from ``model``'s fitted values."""
    return dataclasses.replace(model, params=model.fitted_params,
                               effects=tuple(e for e in model.fitted_effects if e.key != key))


def _forms(cand: Candidate, candidates: Sequence[Candidate]) -> list[str]:
    """Names of the other forms of ``cand``: the simpler ones it extends and those that extend it."""
    return [c.name for c in candidates if c.name != cand.name and (c.name in cand.extends or cand.name in c.extends)]


def _other_form(s: Score, model: PhysicalModel, scorer: Scorer, ctx: _Context, shared: ColumnCache,
                only: set[str] | None = None, tried: list[str] | None = None
                ) -> tuple[Score, PhysicalModel, Prepared] | None:
    """Revisit a pick that has another form (asymmetric friction and the Coulomb friction it extends)
    once later picks are in: each form is scored against the model without the pick, and a richer
    one is kept only where its extra parameters pass the significance rule against what the
    simpler one leaves (a direction-dependent level can stand in for part of a one-sided spring
    until the spring is in; a spring picked first can hide a friction's asymmetry). ``only``: the
    forms to try (default all); ``shared``: the selection's column cache (columns that read no
    model torque are the same here); ``tried``: a list that gets one line per form tried, with the
    rule's numbers (``figures``) and its verdict. Returns (the other form's Score, the model with it
    instead, prepared), or None to keep ``s``."""
    a, axes = s.axis, ctx.axes
    others = [c for c in ctx.candidates if c.name in _forms(s.candidate, ctx.candidates) and (only is None or c.name in only)
              and not (a in ctx.position_blind and c.family in OVER_POSITION)]
    if not others:
        return None
    without = prepare(ctx.trials, _without(model, f"{s.candidate.name}@{axes[a]}"), ctx.layout, ctx.kinematics)
    base, cache = Scorer.of(without), ColumnCache(without, axes, shared)
    best = None
    for other in others:
        alt = score_candidate(base, other, a, without, cache, ctx.scales[a])
        if alt is None or not alt.physical:
            if alt is not None and tried is not None:
                tried.append(f"{other.name}@{axes[a]} in place of {s.candidate.name}@{axes[a]}: unphysical sign")
            continue
        richer, simpler = (alt, None) if s.candidate.name in other.extends else (None, alt)
        richer_sse = scorer.fold_sse(a) if richer is None else alt.folds
        simpler_sse = scorer.fold_sse(a) if simpler is None else alt.folds
        rule = verdict(simpler_sse - richer_sse, simpler_sse, ctx.own[a], ctx.min_explained, ctx.min_rms[a],
                       ctx.n_rows[a])
        richer_needed = rule == "passes"
        if tried is not None:
            key, pick = f"{other.name}@{axes[a]}", f"{s.candidate.name}@{axes[a]}"
            numbers = figures(simpler_sse - richer_sse, simpler_sse, ctx.own[a], ctx.n_rows[a])
            if richer is not None:
                tried.append(f"{key} in place of {pick}: removes {numbers}: "
                             + ("better by the significance rule" if richer_needed else _named(rule, ctx.min_rms[a])))
            else:
                tried.append(f"{key} in place of {pick}: {pick} removes {numbers}: "
                             + ("needed, kept" if richer_needed else f"{_named(rule, ctx.min_rms[a])}, the simpler "
                                                                     "form taken"))
        if (richer is not None and richer_needed) or (simpler is not None and not richer_needed):
            if best is None or alt.held_out_sse < best.held_out_sse:
                best = alt
    if best is None:
        return None
    params = refine(base, best, cache)
    swapped = without.model.with_effect(best.candidate.build(axes[a], **params))
    return best, swapped, prepare(ctx.trials, swapped, ctx.layout, ctx.kinematics)


def refine(scorer: Scorer, score: Score, cache: ColumnCache, iterations: int = 60) -> dict:
    """The picked candidate's continuous nonlinear parameters (those its grid spans as a range or
    from the data, and a period; not a grid of fixed values such as a spring's side, nor those the
    candidate keeps ``fixed``) refined from the grid's best by Nelder-Mead on the training SSE of
    both folds: a spring found on a 9-point grid of onsets at 25.7 deg, 1 deg wide, where the truth
    is 20 deg, 3 deg, leaves its own shape's mismatch in the residual, and that can hide a
    five-times-smaller effect on its axis. Positive parameters (widths, smoothing speeds, periods)
    are searched in log space; the refined values are kept only where the held-out error falls
    too and both folds' fits keep the effect's physical signs."""
    cand, axis = score.candidate, score.axis
    grid = cand.settings(cache.prep.kin[0], cache.prep.kin[1], axis, cache.scale(axis))
    names, logged, x0, bounds = refinement(cand, grid, score.params)
    if not names:
        return dict(score.params)

    def params(x) -> dict:
        return refined_setting(score.params, names, logged, x)

    rough = cand.effect.roughness()

    def cost(x) -> float:
        cols = cache(cand, axis, params(x), keep=False)
        return sum(scorer.evaluate(cols, axis, f, rough)[0] for f in (0, 1))

    from scipy.optimize import minimize

    start = cost(x0)
    result = minimize(cost, x0, method="Nelder-Mead", bounds=bounds,
                      options={"maxiter": iterations * len(names), "xatol": 1e-3, "fatol": 1e-9 * max(start, 1e-300)})
    if result.fun >= start:
        return dict(score.params)
    refined = params(result.x)
    cols = cache(cand, axis, refined, keep=False)
    fits = [scorer.evaluate(cols, axis, f, rough) for f in (0, 1)]
    if score.physical and not all(cand.effect.physical(r[2]) for r in fits):
        return dict(score.params)
    held_out = sum(r[1] for r in fits)
    return refined if held_out < score.held_out_sse else dict(score.params)  # a better training fit that holds
