"""The training-reference safeguard: keep what a method learned only on the axes where it lowers the
tracking error on each of its own training references, against its base alone.

A method that cannot measure the reference it is scored on before it acts (RL, the RBF expert, ILC
transfer) picks what it returns on its training references: the learned feedforward and the base's
are both run there, and compared per scored axis and per reference (RMS of the tracking error over
the reference: the leaderboard's ranking signal; the input residual u - f is not guarded, since a
better tracking may take more feedback effort, as the RBF expert's correction on the IX's
propeller does, tests/test_rbf_expert.py). Where the learned one is worse on an axis on any
reference, that axis falls back to the base; the mixed
feedforward is run again to check it, and if it is still worse on any axis and reference, the base
acts alone on every axis. (Per reference, not over all of them: a learner better on 7 training
references and worse on the 8th did not generalize, measured on the IX with RL: docs/methods/rl.md.)
A choice made on training references cannot promise the validation result; the rows' note says so
where it dropped something.

``keep_axes`` is the rule; RL applies it to its policy's rollouts, ``Safeguard`` to feedforward
signals.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..systems import SimulationDiverged
from .bases import closed_loop

Signals = Callable[[object], tuple[np.ndarray, np.ndarray | None]]
"""A reference -> (feedforward (T, n), load-side reference offset (T, n) [rad] or None)."""


def scored_axes(system, n_axes: int) -> list[int]:
    """The axes (indices) the machine's benchmark scores (``System.bench.scored``; None: all)."""
    scored = system.bench.scored if system.bench is not None else None
    return list(range(n_axes)) if scored is None else list(scored)


def action_axes(better: np.ndarray, scored: Sequence[int], n_axes: int) -> np.ndarray:
    """Per axis, whether to keep the learned signal: on scored axes where it was ``better`` (per
    scored axis), and on unscored ones where it was better on every scored one."""
    kept = np.full(n_axes, bool(np.all(better)))
    kept[list(scored)] = better
    return kept


def keep_axes(base: np.ndarray, learned: np.ndarray, masked_rms: Callable[[np.ndarray], np.ndarray],
              scored: Sequence[int], n_axes: int, learned_key: str = "learned") -> tuple[np.ndarray, dict]:
    """The rule (module docstring). ``base``, ``learned``: RMS tracking error (references, scored
    axes) of the base alone and of the learned signal; ``masked_rms(kept)``: the same with the learned
    signal on the axes ``kept`` only. Returns (kept per axis, {"base", learned_key, maybe "masked"}:
    the RMS arrays compared)."""
    kept = np.ones(n_axes, dtype=bool)
    figures = {"base": base, learned_key: learned}
    worse = (learned > base).any(axis=0)  # per scored axis: worse on some training reference
    if worse.any():
        kept = action_axes(~worse, scored, n_axes)
        figures["masked"] = masked = masked_rms(kept) if kept.any() and not worse.all() else learned
        kept = kept if kept.any() and not (masked > base).any() else np.zeros(n_axes, dtype=bool)
    return kept, figures


def dropped_note(method: str, kept: np.ndarray, axes: Sequence[str], references_worse: int, n_references: int,
                 what: str = "correction", diverged: int = 0) -> str:
    """The results row's note of a safeguard that dropped ``what`` on some axes ("" if none);
    ``diverged``: its runs that left the plant's safe range."""
    dropped = [a for a, k in zip(axes, kept, strict=True) if not k]
    if not dropped:
        return ""
    kept_names = [a for a, k in zip(axes, kept, strict=True) if k]
    failed = f"; {diverged} of its runs left the plant's safe range" if diverged else ""
    return (f"{method}: {what} dropped on {', '.join(dropped)} (it raised the tracking error on {references_worse} "
            f"of {n_references} training references{failed}); the base acts alone there"
            + (f", the {what} on {', '.join(kept_names)}" if kept_names else ""))


@dataclass
class Safeguard:
    """The rule on feedforward signals: ``choose(plant, references, base, learned)`` runs both on the
    training ``references`` and sets ``kept_`` (per axis), ``figures_`` (RMS [rad or m] per
    reference and scored axis), ``references_worse_``, ``trials_`` (plant trials it ran) and
    ``diverged_`` (runs with learned signals that left the plant's safe range)."""

    system: object
    kept_: np.ndarray = field(init=False)
    figures_: dict = field(init=False, default_factory=dict)
    references_worse_: int = field(init=False, default=0)
    trials_: int = field(init=False, default=0)
    diverged_: int = field(init=False, default=0)

    def choose(self, plant, references: Sequence, base: Signals, learned: Signals) -> np.ndarray:
        n = references[0].positions.shape[1]
        scored = scored_axes(self.system, n)
        base, learned = _once_per_reference(base, references), _once_per_reference(learned, references)
        base_rms = self._rms(plant, references, base, learned, np.zeros(n, dtype=bool), scored)
        learned_rms = self._rms(plant, references, base, learned, np.ones(n, dtype=bool), scored)
        self.kept_, self.figures_ = keep_axes(
            base_rms, learned_rms, lambda kept: self._rms(plant, references, base, learned, kept, scored), scored, n)
        self.references_worse_ = int((learned_rms > base_rms).any(axis=1).sum())
        return self.kept_

    def _rms(self, plant, references, base: Signals, learned: Signals, kept: np.ndarray, scored) -> np.ndarray:
        """RMS tracking error (references, scored axes) with the learned signal on the axes ``kept``. A
        run with learned signals that leaves the plant's safe range counts as infinitely worse (the
        method's failed trial: ``diverged_``); the base's own run failing is raised as it is."""
        rms = []
        for r in references:
            f, o = mixed(base(r), learned(r), kept)
            self.trials_ += 1
            try:
                trial = closed_loop(plant, r, f, o)
            except SimulationDiverged:
                if not kept.any():
                    raise
                self.diverged_ += 1
                rms.append(np.full(len(scored), np.inf))
                continue
            error = self.system.bench.tracking_error(trial)
            rms.append(np.sqrt(np.mean(np.square(error[:, scored]), axis=0)))
        return np.array(rms)


def _once_per_reference(signals: Signals, references: Sequence) -> Signals:
    """``signals`` computed once per reference of ``references`` (a method's prediction may cost more
    than the plant run it feeds; the rule asks for each up to three times)."""
    done: dict[int, tuple] = {}

    def once(reference):
        k = next(i for i, r in enumerate(references) if r is reference)
        if k not in done:
            done[k] = signals(reference)
        return done[k]

    return once


def mixed(base: tuple, learned: tuple, kept: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """(feedforward, offset) with the learned columns on the axes ``kept`` and the base's elsewhere."""
    (fb, ob), (fl, ol) = base, learned
    f = np.where(kept, fl, fb)
    if ob is None and ol is None:
        return f, None
    ob = np.zeros_like(f) if ob is None else ob
    ol = np.zeros_like(f) if ol is None else ol
    return f, np.where(kept, ol, ob)
