"""The diagnosis report: printed text, JSON (``to_dict``, written by ``write_json``) and plots."""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..data import atomic_write
from ..figures import wrapped_title
from .rows import CandidateRow, RegionRow, StepRow, StepScore

DEG = math.pi / 180.0
NOTHING_FOUND = "no missing effect found"
MAX_PRINTED_PARAMETERS = 8  # a machine with more (a URDF's 10 per link) has its fitted parameters in the JSON only
PLOT_FILES = {
    "residual_time.png": "the residual over time, with the scaled reference velocity",
    "residual_map.png": "the mean residual over position and velocity",
    "effects.png": "the selected or added effects as fitted",
    "before_after.png": "with --add: the residual before and after",
}
"""The figures ``Diagnosis.plot`` writes (``lcgym diagnose --plots``), by file name: what each shows."""


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
    residual: dict
    regions: list[RegionRow]
    candidates: list[CandidateRow]
    min_explained: float
    min_rms: dict
    kinematics: str = ""
    identified: tuple[int, int] | None = None
    displays: dict = field(default_factory=dict)
    resampled: str | None = None
    spec: str | None = None  # the machine as the user named it (a URDF path, module:attr), for the hints
    steps: list[StepRow] = field(default_factory=list)
    stop: str = ""
    options: str = ""  # command-line options the hints repeat (--kinematics measured)
    samples: dict = field(default_factory=dict)  # what was fitted and what left out (``workflow._samples_record``)
    blocks: str = ""  # how held-out scoring split the data
    machine_file: str | None = None  # the machine file of a machine given by one (``model_tables``)
    model: object = field(repr=False, default=None)
    suggested_model: object = field(repr=False, default=None)
    series: dict = field(repr=False, default_factory=dict)
    found: dict = field(repr=False, default_factory=dict)
    after: dict | None = None
    after_model: object = field(repr=False, default=None)
    replay: dict | None = None
    validation: dict | None = None
    ranges: dict = field(default_factory=dict)

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

    def _model_tables_lines(self) -> list[str]:
        """The printed report's last part: ``model_tables`` with where they go."""
        tables = self.model_tables()
        if not tables:
            return []
        which = "added" if self.after is not None else "selected"
        package = Path(__file__).resolve().parents[1]
        if Path(self.machine_file).resolve().is_relative_to(package):  # a built-in machine's: the user's copy takes them
            where = (f"{self.system}'s machine file is lcgym's own ({self.machine_file}): paste them into a copy of its "
                     "folder and bench that (docs/own-machine-bench.md)")
        else:
            where = f"paste them into {self.spec if str(self.spec).lower().endswith('.toml') else self.machine_file}"
        return ["", f"[[model]] tables of the effects {which}: {where}; the physical model then fits their parameters "
                "and every method starts from it (docs/own-machine.md):", tables]

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(self.to_dict(), indent=1)))
        return path

    def text(self, n_regions: int = 4, n_shown: int = 3) -> str:
        """The printed report (``n_shown``: candidates per selection step, besides those that pass)."""
        unit = {ax: r["unit"] for ax, r in self.residual.items()}
        one_unit = len(set(unit.values())) == 1
        head = f" [{self.unit}]" if one_unit else ""
        col = "" if one_unit else " unit"
        w = max(12, *(len(ax) for ax in self.axes))  # the axis column, as wide as the longest joint name
        lines = [f"lcgym diagnose: system {self.system}, {self.n_samples} samples at {self.fs:g} Hz",
                 f"model: {', '.join(self.model_effects)} (least squares; residual = u - f after a 5 Hz zero-phase low-pass)",
                 f"kinematics: {self.kinematics}" if self.kinematics else None,
                 f"data: {self.resampled}" if self.resampled else None,
                 *self._samples_lines(w),
                 f"held-out scoring: {self.blocks}" if self.blocks else None,
                 (f"identified: {self.identified[0]} combinations of the model's {self.identified[1]} free parameters "
                  "(the rest keep their nominal values)") if self.identified and self.identified[0] < self.identified[1]
                 else None,
                 "", f"residual{head} (floor: the least RMS an effect must remove to count, the noise floor):",
                 f"  {'axis':{w}s} {'MA':>9s} {'RMS':>9s} {'Inf':>9s} {'floor':>9s}{col}"]
        lines = [x for x in lines if x is not None]
        for ax in self.axes:
            r = self.residual[ax]
            lines.append(f"  {ax:{w}s} {_num(r['MA'])} {_num(r['RMS'])} {_num(r['Inf'])} {_num(self.min_rms[ax])}"
                         + ("" if one_unit else f" {r['unit']}"))
        lines += ["", "where the model fails worst (residual RMS there / overall):"]
        for ax in self.axes:
            for reg in [r for r in self.regions if r.axis == ax][:n_regions]:
                lines.append(f"  {ax:{w}s} {reg.where:44s} RMS {reg.RMS:.4g} {unit[ax]} ({reg.ratio:.2f}x, "
                             f"{100 * reg.samples:.0f}% of samples)")
        lines += ["", "candidate missing effects (share of the axis's residual energy each removes alone on held-out"
                  " data; selected ones in the order of greedy forward selection):"]
        if not self.candidates:
            lines.append(f"  {NOTHING_FOUND} (none removes {100 * self.min_explained:.0f}% of its axis's residual with at "
                         "least the axis's floor)")
        for k, c in enumerate(self.candidates, 1):
            how = (f"selected at step {c.step}: {100 * c.explained_at_selection:.0f}% of what was left, "
                   f"{c.RMS_before_at_selection:.4g} -> {c.RMS_after_at_selection:.4g} {c.unit}"
                   if c.selected else "not needed once the selected ones are in")
            if c.named_as:
                how += f"; named {c.named_as}@{c.axis}, then its shape refined by this curve of no set shape"
            display = self.displays.get(c.axis, (180 / math.pi, "deg"))
            params = ", ".join(f"{n}={_fmt(n, v, display)}" for n, v in c.parameters.items())
            if c.refined_from:
                params += " (refined from " + ", ".join(f"{n}={_fmt(n, v, display)}"
                                                        for n, v in c.refined_from.items()) + ")"
            fitted = self.range_text(c.key) if c.selected else ""
            lines.append(f"  {k}. {c.key} [{c.family}]: {100 * c.explained:.0f}%, "
                         f"held-out RMS {c.RMS_before:.4g} -> {c.RMS_after:.4g} {c.unit} "
                         f"({how}{'; ' + params if params else ''}{'; fitted over ' + fitted if fitted else ''})")
        if self.candidates:
            lines.append(f"  add the selected ones: lcgym diagnose DATA --system {self.spec or self.system} "
                         + (f"{self.options} " if self.options else "") + " ".join(f"--add {m}" for m in self.missing))
        refused = self.refused()
        if refused:
            lines += ["", f"refused (removed at least {100 * self.min_explained:.0f}% of what its axis had left at some "
                      "step, but failed another rule of the significance test):"]
            wr = max(len(c.key) for c in refused)
            for c in refused:
                lines.append(f"  {c.key:{wr}s}  step {c.step}: {100 * c.share_of_left:3.0f}% "
                             f"of what was left, {100 * c.share_of_original:3.0f}% of the original: {c.verdict}")
        if self.steps:
            lines += ["", "selection step by step (held-out RMS each axis had left; the candidates that removed most of it, "
                      "share of what was left / of the original error; all of them in the JSON):"]
            for st in self.steps:
                left = ", ".join(f"{ax} {v:.4g}" + ("" if one_unit else f" {unit[ax]}") for ax, v in st.left_RMS.items())
                revised = "".join(f"; then {r}" for r in st.revised)
                lines.append(f"  step {st.step}: left {left}{head}" + (f" -> add {st.picked}" if st.picked else "")
                             + revised)
                shown = st.candidates[:n_shown]
                shown += [c for c in st.candidates[n_shown:] if c.verdict == "passes"]
                ws = max([34] + [len(c.key) for c in shown])
                for c in shown:
                    lines.append(f"    {c.key:{ws}s} {100 * c.share_of_left:4.0f}% / "
                                 f"{100 * c.share_of_original:4.0f}%  {c.verdict}")
                lines += [f"    tried {r}" for r in st.replacements]
            lines.append(f"  stopped: {self.stop}")
        if self.after is not None:
            lines += ["", f"after adding {', '.join(self.after['added'])} and refitting, residual RMS{head}:",
                      f"  {'axis':{w}s} {'before':>9s} {'after':>9s} {'change':>8s}"]
            for ax in self.axes:
                b, a = self.residual[ax]["RMS"], self.after["residual"][ax]["RMS"]
                change = f"{100 * (a - b) / b:+7.0f}%" if b > 0 else "       -"
                lines.append(f"  {ax:{w}s} {_num(b)} {_num(a)} {change}" + ("" if one_unit else f" {unit[ax]}"))
            params = self.after.get("parameters", {})
            if 0 < len(params) <= MAX_PRINTED_PARAMETERS:
                lines.append("  fitted parameters: " + ", ".join(f"{n} {v:.4g}" for n, v in params.items()))
            for e in self.after["effects"]:
                display = self.displays.get(e["effect"].partition("@")[2], (180 / math.pi, "deg"))
                fitted = self.range_text(e["effect"])
                lines.append(f"  fitted {e['effect']}: " + ", ".join(f"{n} {_fmt(n, v, display)}" for n, v in e.items()
                                                                  if n != "effect")
                             + (f" (over {fitted})" if fitted else ""))
        if self.validation is not None:
            v = self.validation
            what = f"with {', '.join(v['added'])}" if v["added"] else "with no effect added (none selected)"
            lines += ["", f"validation on {v['n_samples']} samples of other data, not fitted (the model as fitted "
                      f"above, before and {what}), residual RMS{head}:",
                      f"  {'axis':{w}s} {'before':>9s} {'after':>9s} {'change':>8s}"]
            for ax in self.axes:
                b, a = v["residual"][ax]["RMS"], v["residual_after"][ax]["RMS"]
                change = f"{100 * (a - b) / b:+7.0f}%" if b > 0 else "       -"
                lines.append(f"  {ax:{w}s} {_num(b)} {_num(a)} {change}" + ("" if one_unit else f" {unit[ax]}"))
            outside = v.get("outside", [])
            if v["added"]:
                lines.append("  outside the effects' fitted ranges (extrapolated there):" if outside else
                             "  every sample within the effects' fitted ranges")
            for o in outside:
                display = self.displays.get(o["effect"].partition("@")[2], (180 / math.pi, "deg"))
                reach = [_in_unit(x, o["variable"], display) for x in (o["min"], o["max"])]
                lines.append(f"    {o['effect']}: {o['variable']} {reach[0]} .. {reach[1]} (fitted over "
                             f"{self.range_text(o['effect'])}), {100 * o['share']:.1f}% of the samples outside")
        if self.replay is not None:
            replay_unit = self.replay["unit"]
            same = len(set(replay_unit.values())) == 1
            added = self.replay.get("after_with", [])
            lines += ["", "replay on the plant, tracking-error RMS" + (f" [{next(iter(replay_unit.values()))}]" if same else "")
                      + " with the model's feedforward, before and " + (f"with {', '.join(added)}" if added else
                                                                         "after (no effect added)") + ":",
                      f"  {'axis':{w}s} {'before':>9s} {'after':>9s}"]
            for ax in self.axes:
                lines.append(f"  {ax:{w}s} {_num(self.replay['before'][ax])} {_num(self.replay['after'][ax])}"
                             + ("" if same else f" {replay_unit[ax]}"))
        lines += self._model_tables_lines()
        return "\n".join(lines)

    def range_text(self, key: str) -> str:
        """The fitted range of effect ``key`` in the axis's display unit ("velocity -28.1 .. 28.4
        deg/s"), or "" where it has none."""
        r = self.ranges.get(key)
        if r is None:
            return ""
        display = self.displays.get(key.partition("@")[2], (180 / math.pi, "deg"))
        lo, hi = (_in_unit(x, r["variable"], display) for x in (r["lo"], r["hi"]))
        return f"{r['variable']} {lo} .. {hi}"

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

    def _samples_lines(self, w: int) -> list[str]:
        """What was fitted and what was left out (``samples``), for ``text``."""
        s = self.samples
        if not s:
            return []
        total, still = s["total"], s["standstill"]
        trimmed = (f", and {s['edges_trimmed']} more where the residual was dominated by trial edges (an unsettled start "
                   "or a move cut off)") if s["edges_trimmed"] else ""
        out = [f"samples: {total} in {s['trials']} trial(s); left out on every axis: {s['edges']} at trial edges "
               f"(the filters' first and last {s['settle_s']:.2g} s{trimmed})"]
        if any(still.values()):
            speed = {ax: _fmt("eps", v, self.displays.get(ax, (180 / math.pi, "deg"))) for ax, v in s["rest_speed"].items()}
            rest = ", ".join(f"{ax} {100 * n / total:.0f}% (below {speed[ax]})" for ax, n in still.items() if n)
            out.append(f"standstill left out of its axis's fit and score: {rest}")
        for g in s.get("repeated", []):
            trials = ", ".join(str(k) for k in g)
            out.append(f"repeated: trials {trials} repeat one trajectory; held-out blocks of one trajectory cannot tell "
                       f"a missing effect from its own quirks, so the selection is stricter: {s['strict']}"
                       if s.get("strict") else
                       f"repeated: trials {trials} repeat one trajectory; they share a fold, so that what is held out is "
                       "another motion")
        band = s.get("bandwidth")
        if band:
            out.append("bandwidth (99.9% of the energy below) [Hz]: input " + ", ".join(
                f"{ax} {f:.3g}" for ax, f in band["input"].items()) + "; position " + ", ".join(
                f"{ax} {f:.3g}" for ax, f in band["position"].items())
                + " (a candidate whose torque lies mostly where the input holds less is refused)")
        for g in s.get("proportional", []):
            out.append(f"moving in proportion: {', '.join(g['axes'])} (velocities alike to {g['alike']:.4f}): no effect "
                       "over the position is tried there, as the data cannot tell whose position it follows; a motion "
                       "that moves them independently would tell them apart")
        return out

    def plot(self, folder: str | Path) -> list[Path]:
        """Write the figures (``figures``) to ``folder`` as PNG files named by ``PLOT_FILES``; the
        paths written."""
        import matplotlib.pyplot as plt

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        figs = self.figures()
        paths = []
        try:
            for name, fig in figs.items():
                path = folder / name
                atomic_write(path, lambda tmp, f=fig: f.savefig(tmp, dpi=100, format="png"))
                paths.append(path)
        finally:
            for fig in figs.values():
                plt.close(fig)
        return paths

    def figures(self) -> dict:
        """The figures of ``PLOT_FILES`` that this report has, by file name (matplotlib figures,
        Agg; the caller closes them): residual_time.png and residual_map.png always, effects.png
        where effects were selected or added, before_after.png with ``after``. The residual is
        shown at the samples fitted and scored (``series["used"]``: the trial edges and standstill
        left out, whose residual the fit sets to zero, are gaps), and the RMS in a legend is the
        printed report's, over those samples."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        s, n = self.series, len(self.axes)
        figs = {"residual_time.png": self._time_panels(plt, [("residual", "residual")], velocity=True,
                                                       title="Residual u - f of the fitted model")}

        fig, axs = plt.subplots(1, n, figsize=(5.5 * n, 4.2), squeeze=False)
        for i, ax_name in enumerate(self.axes):
            ax = axs[0, i]
            f, pos_unit = self.displays.get(ax_name, (180 / math.pi, "deg"))
            used = s["used"][:, i]  # the residual of a sample left out is no residual (zero): not mapped
            q, v, r = f * s["q"][used, i], f * s["qd"][used, i], s["residual"][used, i]
            if not q.size:
                q = v = r = np.zeros(1)
            qe, ve = np.linspace(q.min(), q.max() + 1e-9, 31), np.linspace(v.min(), v.max() + 1e-9, 21)
            total, _, _ = np.histogram2d(q, v, [qe, ve], weights=r)
            count, _, _ = np.histogram2d(q, v, [qe, ve])
            mean = np.where(count > 0, total / np.maximum(count, 1), np.nan)
            lim = np.nanmax(np.abs(mean)) if np.isfinite(mean).any() else 1.0
            im = ax.pcolormesh(qe, ve, mean.T, cmap="coolwarm", vmin=-lim, vmax=lim)
            fig.colorbar(im, ax=ax, label=f"mean residual [{self.residual[ax_name]['unit']}]")
            ax.set_xlabel(f"{ax_name} position [{pos_unit}]")
            ax.set_ylabel(f"{ax_name} velocity [{pos_unit}/s]")
        wrapped_title(fig, "Where the model fails: mean residual over (position, velocity), at the samples fitted")
        figs["residual_map.png"] = fig

        if s.get("effects"):
            figs["effects.png"] = self._effect_panels(plt, s["effects"])
        if "residual_after" in s:
            after = "after " + ", ".join(self.after["added"])
            figs["before_after.png"] = self._time_panels(plt, [("residual", "before"), ("residual_after", after)],
                                                         velocity=False,
                                                         title="Residual before and after adding the effects")
        return figs

    def legend_rms(self, key: str, axis: str) -> float:
        """The RMS [input unit] a legend gives for series ``key`` ("residual", "residual_after") on
        ``axis``: the report's (``residual``, ``after["residual"]``)."""
        return (self.residual if key == "residual" else self.after["residual"])[axis]["RMS"]

    def _effect_panels(self, plt, curves: list[dict]):
        """One panel per added effect: its fitted torque over the variable it acts on (velocity for
        a friction, acceleration for an inertia, else position), at the samples fitted: the learned
        curve of an effect of no set shape, the fitted form of the others."""
        n = len(curves)
        fig, axs = plt.subplots(1, n, figsize=(5.0 * n, 4.0), squeeze=False)
        for ax, c in zip(axs[0], curves, strict=True):
            axis = c["effect"].partition("@")[2]
            f, unit = self.displays.get(axis, (180 / math.pi, "deg"))
            per = {"position": "", "velocity": "/s", "acceleration": "/s^2"}[c["variable"]]
            x, y = f * c["x"][c["used"]], c["torque"][c["used"]]
            order = np.argsort(x)
            ax.plot(x[order], y[order], ".", ms=2, alpha=0.5)
            ax.set_xlabel(f"{axis} {c['variable']} [{unit}{per}]")
            unit_u = self.residual[axis]["unit"]
            ax.set_ylabel(f"{ {'N': 'force', 'N m': 'torque'}.get(unit_u, 'input')} [{unit_u}]")  # a rail's is a force
            ax.set_title(f"{c['effect']} [{c['family']}]", fontsize=10)
            ax.grid(alpha=0.3)
        wrapped_title(fig, "The effects added, as fitted: torque (force) over the variable each acts on")
        return fig

    def _time_panels(self, plt, series: list[tuple[str, str]], velocity: bool, title: str):
        """One panel per axis: the named residual series over time at the samples fitted and scored
        (``series["used"]``; the others are gaps), optionally with the scaled reference velocity;
        the legend's RMS is the report's (``legend_rms``: over the same samples)."""
        s, n = self.series, len(self.axes)
        fig, axs = plt.subplots(n, 1, figsize=(11, 3 * n), sharex=True, squeeze=False)
        for i, ax_name in enumerate(self.axes):
            ax, used, unit = axs[i, 0], s["used"][:, i], self.residual[ax_name]["unit"]
            for key, label in series:
                r = np.where(used, s[key][:, i], np.nan)
                ax.plot(s["t"], r, lw=0.7, label=f"{label} (RMS {self.legend_rms(key, ax_name):.4g} {unit} over the "
                                                 f"{100 * used.mean():.0f}% of samples fitted)")
            v = s["ref_velocity"][:, i]
            if velocity and np.abs(v).max() > 0:
                r = s[series[0][0]][:, i]
                ax.plot(s["t"], v / np.abs(v).max() * np.abs(r).max(), "k--", lw=0.6, alpha=0.6,
                        label="reference velocity (scaled)")
            ax.set_ylabel(f"{ax_name} [{unit}]")
            ax.legend(loc="upper right", fontsize=8)
            ax.grid(alpha=0.3)
        axs[-1, 0].set_xlabel("time over all trials [s]")
        wrapped_title(fig, f"{title} (at the samples fitted, RMS as in the printed report; gaps: trial edges and "
                    "standstill, left out)")
        return fig




def _num(x: float) -> str:
    """A residual figure in a 9-wide column: 4 significant digits, whatever its size."""
    return f"{x:9.4g}" if x != 0 else f"{0:9d}"


def _in_unit(value: float, variable: str, display: tuple[float, str]) -> str:
    """A position, velocity or acceleration [rad or m, per s, per s^2] in the axis's display unit."""
    f, unit = display
    return f"{value * f:.3g} {unit}" + {"position": "", "velocity": "/s", "acceleration": "/s^2"}[variable]


def _fmt(name: str, value: float, display: tuple[float, str] = (180 / math.pi, "deg")) -> str:
    """Nonlinear parameters in readable units: positions and speeds in the axis's display unit
    (``display`` = (factor, unit): deg and deg/s, or mm and mm/s)."""
    f, unit = display
    if name in ("q0", "width", "period", "lo", "hi"):
        return f"{value * f:.3g} {unit}"
    if name in ("eps", "vs", "v_ref", "v_top"):
        return f"{value * f:.3g} {unit}/s"
    return f"{value:.3g}"
