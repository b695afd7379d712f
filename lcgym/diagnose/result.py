"""What ``diagnose`` found, as typed results (``Diagnosis``): its JSON (``to_dict``, ``write_json``).
Its printed text is ``report.text``, its plots ``figures.plot``; ``Diagnosis.text()`` and
``Diagnosis.plot(folder)`` call them."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..data import atomic_write
from ..physics.effects import Effect
from ..physics.model import PhysicalModel
from .rows import CandidateRow, RegionRow, StepRow, StepScore


@dataclass(frozen=True)
class Diagnosis:
    """What ``diagnose`` found. ``residual`` {axis: {MA, RMS, Inf, unit}}; ``regions`` worst
    first (``rows.RegionRow``); ``candidates`` passing candidates, best first (greedy selection
    order, then the rest by their share alone; ``rows.CandidateRow``); ``after`` / ``replay``
    with ``add`` / ``replay``. ``model`` is the
    fitted nominal model, ``suggested_model`` the model refitted with the selected effects,
    ``found`` every candidate effect (``name@axis``) with the nonlinear parameters the search
    chose (a selected one's as the selection refined them), ready for ``model.with_effect``.
    ``series`` holds the reduced signals for plots.
    ``min_rms`` {axis: noise floor [input unit]}; ``kinematics``: where the fit's kinematics came
    from; ``identified``: (rank, number) of the free linear parameters, the combinations the data
    identified (a rank-deficient regressor's base parameters); ``displays`` {axis: (factor, unit)}
    of positions in reports (deg, mm); ``resampled``: how the log was put on a uniform grid, or None.
    ``validation``: residual norms on another experiment, not fitted, before and after the effects
    (``workflow.validation``), or None. ``steps``: the greedy selection step by step (what each
    axis had left, what every candidate removed of it and its verdict; ``rows.StepRow``),
    ``stop`` why it ended. ``ranges`` {effect key: {variable, lo, hi}}: the range of the variable each
    effect beyond the nominal model acts on, over the data fitted (``workflow.fitted_ranges``); outside
    it the effect is extrapolated. ``machine_file``: the machine file of a machine given by one (its
    bench's ``source``), whose ``[[model]]`` tables of the effects found end the printed report
    (``model_tables``)."""

    system: str
    axes: tuple[str, ...]
    unit: str
    n_samples: int
    fs: float
    model_effects: list[str]
    residual: dict[str, dict[str, float | str]]  # axis -> MA, RMS, Inf, unit
    regions: list[RegionRow]
    candidates: list[CandidateRow]
    min_explained: float
    min_rms: dict[str, float]
    kinematics: str = ""
    identified: tuple[int, int] | None = None
    displays: dict[str, tuple[float, str]] = field(default_factory=dict)
    resampled: str | None = None
    spec: str | None = None  # the machine as the user named it (a URDF path, module:attr), for the hints
    steps: list[StepRow] = field(default_factory=list)
    stop: str = ""
    options: str = ""  # command-line options the hints repeat (--kinematics measured)
    samples: dict[str, Any] = field(default_factory=dict)  # what was fitted and what left out (``workflow._samples_record``)
    blocks: str = ""  # how held-out scoring split the data
    machine_file: str | None = None  # the machine file of a machine given by one (``model_tables``)
    model: PhysicalModel | None = field(repr=False, default=None)
    suggested_model: PhysicalModel | None = field(repr=False, default=None)
    series: dict[str, Any] = field(repr=False, default_factory=dict)  # reduced signals for the plots
    found: dict[str, Effect] = field(repr=False, default_factory=dict)
    after: dict[str, Any] | None = None
    after_model: PhysicalModel | None = field(repr=False, default=None)
    replay: dict[str, Any] | None = None
    validation: dict[str, Any] | None = None
    ranges: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def missing(self) -> list[str]:
        """``name@axis`` of the selected candidates, best first (empty: nothing found)."""
        return [c.key for c in self.candidates if c.selected]

    def to_dict(self) -> dict:
        out = {"system": self.system, "model_effects": self.model_effects, "n_samples": self.n_samples, "fs": self.fs,
               "kinematics": self.kinematics, "resampled": self.resampled,
               "identified": None if self.identified is None else {"rank": self.identified[0],
                                                                    "parameters": self.identified[1]},
               "residual": self.residual, "regions": [r.to_dict() for r in self.regions],
               "candidates": [c.to_dict() for c in self.candidates],
               "selection": {"steps": [st.to_dict() for st in self.steps], "stop": self.stop},
               "significance": {"min_explained": self.min_explained, "min_rms": self.min_rms,
                                "unit": {ax: r["unit"] for ax, r in self.residual.items()},
                             "order": "greedy forward selection (selected: true), then the other passing "
                                      "candidates by explained; explained and RMS_after: the effect alone, held-out; "
                                      "explained_at_selection: share of the residual left at its greedy step "
                                      "(step), held-out RMS before and after it at that step "
                                      "(RMS_before_at_selection, RMS_after_at_selection), scored at the "
                                      "grid's nonlinear parameters (refined_from, where the selection then "
                                      "refined them to parameters)"}}
        if self.ranges:
            out["fitted_ranges"] = self.ranges
        if self.after is not None:
            out["after"] = self.after
        if self.replay is not None:
            out["replay"] = self.replay
        if self.validation is not None:
            out["validation"] = self.validation
        if self.model_tables():
            out["model_tables"] = self.model_tables()
        return out

    def model_tables(self) -> str:
        """The ``[[model]]`` tables (TOML, ``systems.machine``) of the effects found (with ``--add``:
        of those added), for a machine given by a machine file; "" for any other machine or
        where nothing was found."""
        keys = self.after["added"] if self.after is not None else self.missing
        if self.machine_file is None or not keys:
            return ""
        return "\n\n".join(f'[[model]]\neffect = "{k.partition("@")[0]}"\naxis = "{k.partition("@")[2]}"' for k in keys)

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(self.to_dict(), indent=1)))
        return path

    def refused(self) -> list[StepScore]:
        """The candidates that removed at least ``min_explained`` of what their axis had left at some
        step but failed another rule (a sign, the original error, the noise floor, a simpler form),
        each once (at the step where it removed the largest share), the largest share first; each a
        row of ``steps`` with its ``step``."""
        best: dict[str, StepScore] = {}
        picked = set(self.missing)
        for st in self.steps:
            for c in st.candidates:
                if c.verdict == "passes" or c.share_of_left < self.min_explained or c.key in picked:
                    continue
                if c.key not in best or c.share_of_left > best[c.key].share_of_left:
                    best[c.key] = dataclasses.replace(c, step=st.step)
        return sorted(best.values(), key=lambda c: -c.share_of_left)

    def legend_rms(self, key: str, axis: str) -> float:
        """The RMS [input unit] a legend gives for series ``key`` ("residual", "residual_after") on
        ``axis``: the report's (``residual``, ``after["residual"]``)."""
        return (self.residual if key == "residual" else self.after["residual"])[axis]["RMS"]

    def text(self, n_regions: int = 4, n_shown: int = 3) -> str:
        """The printed report (``report.text``)."""
        from .report import text

        return text(self, n_regions, n_shown)

    def plot(self, folder: str | Path) -> list[Path]:
        """Write the figures to ``folder`` (``figures.plot``); the paths written."""
        from .figures import plot

        return plot(self, folder)

    def figures(self) -> dict:
        """The report's matplotlib figures by file name (``figures.figures``)."""
        from .figures import figures

        return figures(self)
