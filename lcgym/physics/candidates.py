"""Candidate effects: what the diagnosis may add to a model, each an ``Effect`` class with the grids
of its nonlinear parameters (``diagnose.search`` tries every combination).

Every effect of the library declares how it is searched (its ``search``, a ``physics.grids.Search``);
``library()`` gives those effects as candidates, in the order of ``physics.effects.EFFECTS``, which
is the order the diagnosis tries them. A machine adds its own (``System.diagnosis.candidates``: the IX's
guidance friction, the FlexArm's payload; a user's, ``diagnose.register_effect``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from . import effects as fx
from .grids import Scaled, Search

DEG = math.pi / 180.0

__all__ = ["Candidate", "Scaled", "Search", "axis_scale", "candidates_of", "library", "period_peaks",
           "refined_setting", "refinement"]


@dataclass(frozen=True)
class Candidate(Search):
    """An effect the diagnosis can add: ``effect`` (an Effect subclass) searched as ``Search`` says.
    ``Candidate.of(cls)`` takes the effect's own ``search``."""

    effect: type[fx.Effect] | None = field(default=None, kw_only=True)

    def __post_init__(self):
        super().__post_init__()
        if not (isinstance(self.effect, type) and issubclass(self.effect, fx.Effect)):
            raise TypeError(f"Candidate: effect must be an Effect subclass, got {self.effect!r}")

    @classmethod
    def of(cls, effect: type[fx.Effect], search: Search | None = None) -> Candidate:
        """The candidate of ``effect``, searched as ``search`` says (default: the effect's own)."""
        search = search or effect.search
        if search is None:
            raise ValueError(f"{effect.name}: the effect declares no search (Effect.search)")
        return cls(**{f.name: getattr(search, f.name) for f in fields(Search)}, effect=effect)

    @property
    def name(self) -> str:
        return self.effect.name

    @property
    def n_params(self) -> int:
        """Linear plus searched nonlinear parameters: the tie-break prefers fewer."""
        return len(self.effect.linear) + len(self.grid) + (self.period is not None)

    def build(self, axis: str, **nonlinear) -> fx.Effect:
        return self.effect(axis=axis, **nonlinear)


def library() -> list[Candidate]:
    """The library's candidates: every effect of ``physics.effects.EFFECTS`` that declares a
    ``search``, in that order (the order the diagnosis tries them)."""
    return [Candidate.of(cls) for cls in fx.EFFECTS.values() if cls.search is not None]


def candidates_of(system) -> list[Candidate]:
    """The candidates of a machine (a ``systems.System``): the library's and its own
    (``System.diagnosis.candidates``, with those ``diagnose.register_effect`` added), limited to
    ``System.diagnosis.candidate_names`` where the machine sets them and to those whose formula applies to one
    of its axes at least (``Effect.applies_to``). What the diagnosis tries, ``--add`` accepts and a
    machine's model may carry (``System.model_effects``, a machine file's ``[[model]]`` tables)."""
    settings = system.diagnosis
    pool = {c.name: c for c in (*library(), *settings.candidates)}
    if settings.candidate_names is not None:
        pool = {n: c for n, c in pool.items() if n in settings.candidate_names}
    return [c for c in pool.values() if any(c.effect.applies_to(a) for a in system.axes)]


def axis_scale(axis, q: np.ndarray, qd: np.ndarray) -> dict:
    """The {"speed" [rad/s or m/s], "position" [rad or m]} scales of the candidates' grids on one
    axis (a ``systems.Axis``, with its positions q and velocities qd (T,)): the axis's declared ones,
    else the data's (the 99th percentile of |qd|, the range of q), else 1."""
    speed = axis.speed_scale or float(np.quantile(np.abs(qd), 0.99)) or 1.0
    position = axis.position_scale or float(np.ptp(q)) or 1.0
    return {"speed": speed, "position": position}


def refinement(cand: Candidate, grid: list[dict], start: dict, span: float = 0.05
               ) -> tuple[list[str], list[bool], np.ndarray, list[tuple[float, float]]]:
    """What a refinement of the setting ``start`` of candidate ``cand`` (one of ``grid``, its
    ``settings``) moves, for the diagnosis's (``diagnose.search.refine``) and a model's
    (``physics.shapes``) Nelder-Mead alike: (names, logged, x0, bounds). The continuous nonlinear
    parameters (those its grid spans as a range or takes from the data, and a period that ``start``
    has; not a grid of fixed values such as a spring's side, nor those the candidate keeps
    ``fixed``); positive ones (widths, smoothing speeds, periods) in log space (``logged``), an onset
    position as is; bounded within the grid's span widened by 2x (log) or by half the span on
    either side, a period (or a parameter the grid lacks) within ``span`` (5 %) of its start."""
    names = [n for n, g in cand.grid.items() if not isinstance(g, tuple) and n not in cand.fixed]
    names += [cand.period] if cand.period and cand.period in start else []
    logged = [n != "q0" for n in names]  # every continuous parameter but an onset position is > 0
    x0 = np.array([math.log(start[n]) if lg else start[n] for n, lg in zip(names, logged, strict=True)])
    bounds = []
    for n, lg, x in zip(names, logged, x0, strict=True):
        values = [g[n] for g in grid if n in g]
        if n == cand.period or not values:
            bounds.append((x - span, x + span) if lg else (x - span * abs(x), x + span * abs(x)))
        elif lg:
            bounds.append((math.log(min(values) / 2), math.log(max(values) * 2)))
        else:
            half = 0.5 * (max(values) - min(values))
            bounds.append((min(values) - half, max(values) + half))
    return names, logged, x0, bounds


def refined_setting(start: dict, names: list[str], logged: list[bool], x) -> dict:
    """``start`` with the parameters ``names`` at the point ``x`` of ``refinement``'s space."""
    return {**start, **{n: float(math.exp(v) if lg else v) for n, v, lg in zip(names, x, logged, strict=True)}}


def period_peaks(r: np.ndarray, q: np.ndarray, weight: np.ndarray | None, n_peaks: int = 3,
                 shortest: float = 1 * DEG) -> list[float]:
    """Periods [rad or m] of the strongest peaks of |sum_k r_k w_k exp(-2 pi i q_k / P)|^2.

    Frequencies (cycles per rad or m) on a grid of 1/(4 x position range), from the longest period
    that repeats three times within the range (at least 3 x ``shortest``) to ``shortest``; each
    peak refined by parabolic interpolation.
    """
    travel = float(np.ptp(q))
    if travel < 3 * shortest:
        return []
    df = 1.0 / (4.0 * travel)
    freqs = np.arange(1.0 / max(3 * shortest, travel / 3), 1.0 / shortest, df)
    x = r * (weight if weight is not None else 1.0)
    x = x - x.mean()
    # the transform block by block of 32 frequencies: the exponentials of one block are those of the
    # block before times exp(-2 pi i q 32 df) (a product costs a fraction of an exponential)
    block = 32
    phase = np.exp(-2j * np.pi * np.outer(q, freqs[0] + df * np.arange(block)))
    step = np.exp(-2j * np.pi * q * df * block)[:, None]
    acc = np.empty(freqs.size, dtype=complex)
    for start in range(0, freqs.size, block):
        n = min(block, freqs.size - start)
        acc[start : start + n] = x @ phase[:, :n]
        phase *= step
    power = np.abs(acc) ** 2
    peaks = [k for k in range(1, freqs.size - 1) if power[k] >= power[k - 1] and power[k] > power[k + 1]]
    peaks = sorted(peaks, key=lambda k: -power[k])[:n_peaks]
    out = []
    for k in peaks:
        a, b, c = power[k - 1], power[k], power[k + 1]
        shift = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) != 0 else 0.0
        out.append(1.0 / (freqs[k] + shift * df))
    return out
