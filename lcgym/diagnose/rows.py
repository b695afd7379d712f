"""The rows of a diagnosis report: where the model fails, each candidate effect, each greedy step.

Each row is a frozen dataclass; ``to_dict`` gives its JSON form (``Diagnosis.to_dict``), with the
keys in the order of the fields and an optional field (None) left out. Residuals are in the axis's
input unit (``unit``), shares are fractions of an energy (0-1).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass


def _record(row) -> dict:
    """The JSON form of a row: its fields in order, those that are None left out (optional fields)."""
    return {f.name: getattr(row, f.name) for f in dataclasses.fields(row)
            if getattr(row, f.name) is not None or f.metadata.get("always")}


class _Row:
    def to_dict(self) -> dict:
        """The row's JSON form (module docstring)."""
        return _record(self)


class _EffectRow(_Row):
    """A row of one effect (``effect``) on one axis (``axis``)."""

    @property
    def key(self) -> str:
        """``name@axis``."""
        return f"{self.effect}@{self.axis}"


def _always(default=None):
    """A field written to the JSON even when it is None."""
    return dataclasses.field(default=default, metadata={"always": True})


@dataclass(frozen=True)
class RegionRow(_Row):
    """One operating region of one axis (``regions.region_table``): ``where`` in words, the
    residual ``RMS`` there, its ``ratio`` to the axis's overall RMS, the share of the axis's
    ``samples`` in it and of its residual ``energy``."""

    axis: str
    where: str
    RMS: float
    ratio: float
    samples: float
    energy: float


@dataclass(frozen=True)
class CandidateRow(_EffectRow):
    """One candidate effect that passes alone on one axis (``workflow``), the selected ones first.

    ``explained``: the share of the axis's held-out residual energy it removes alone
    (``RMS_before`` -> ``RMS_after``, held out). A selected one (``selected``) also has its greedy
    ``step``, the share of what was left then (``explained_at_selection``) and the held-out RMS
    before and after it at that step; ``named_as``: the effect the step named, where this curve of
    no set shape then refined its shape; ``parameters``: its nonlinear parameters, as the
    selection refined them from the grid's (``refined_from``, where they differ)."""

    effect: str
    axis: str
    family: str
    explained: float
    RMS_before: float
    RMS_after: float
    unit: str
    selected: bool
    explained_at_selection: float | None = _always()
    parameters: dict = dataclasses.field(default_factory=dict)
    step: int | None = None
    RMS_before_at_selection: float | None = None
    RMS_after_at_selection: float | None = None
    named_as: str | None = None
    refined_from: dict | None = None


@dataclass(frozen=True)
class StepScore(_EffectRow):
    """One candidate scored at one greedy step: the RMS of what it removes (``removed_RMS``), its
    share of what the axis had left (``share_of_left``) and of the axis's original error
    (``share_of_original``), and the significance rule's ``verdict`` ("passes" or why not).
    ``step``: the step, where the row stands alone (``Diagnosis.refused``)."""

    effect: str
    axis: str
    removed_RMS: float
    share_of_left: float
    share_of_original: float
    verdict: str
    step: int | None = None


@dataclass(frozen=True)
class StepRow:
    """One greedy step: each axis's held-out RMS left (``left_RMS``), the effect ``picked``
    (``name@axis``, or None: the search stopped), the earlier picks put in another form of theirs
    once this one was in (``revised``), every other form tried in place of a pick (``replacements``)
    and every candidate scored then, the most removed first (``candidates``)."""

    step: int
    left_RMS: dict
    picked: str | None
    revised: list
    replacements: list
    candidates: list[StepScore]

    def to_dict(self) -> dict:
        return {"step": self.step, "left_RMS": self.left_RMS, "picked": self.picked, "revised": self.revised,
                "replacements": self.replacements, "candidates": [c.to_dict() for c in self.candidates]}
