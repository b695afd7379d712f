"""Plots people would rather see than read: tracking errors with the scaled reference velocity (Fig. 2).

Units: the benchmark stores traces in SI (rad on a revolute axis, m on a prismatic one); each axis
is drawn in the unit its results rows carry (deg or mm, ``DISPLAY_FACTORS``), and a bar chart
whose axes differ in unit draws one panel per unit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..data import atomic_write
from ..figures import wrapped_title
from ..metrics import RANKED_BY

DISPLAY_FACTORS = {"deg": 180.0 / math.pi, "mm": 1000.0}
"""A tracking error's shown unit -> the factor from its stored SI value (rad -> deg, m -> mm)."""


def display_factor(axis: str, unit: str) -> float:
    """The factor that turns axis ``axis``'s stored error [rad or m] into ``unit`` (deg or mm)."""
    if unit not in DISPLAY_FACTORS:
        raise ValueError(f"axis {axis}: cannot draw a tracking error in {unit!r}; known units: "
                         f"{', '.join(DISPLAY_FACTORS)}")
    return DISPLAY_FACTORS[unit]


def plot_tracking_errors(results: Sequence, path: str | Path, trial_index: int = 0) -> Path:
    """One panel per scored axis: tracking error of each controller on one validation reference (the
    error the machine's bench scores, ``bench.trace``: in deg on a revolute axis, mm on a prismatic
    one), with the reference velocity scaled to the error range (dashed), like paper 000 Fig. 2."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    traces = [(r.controller, r.bench.trace(r.trials[trial_index])) for r in results]
    first = traces[0][1]
    axes = [c[len("error_"):] for c in first.columns if c.startswith("error_")]
    machine = results[0].bench.system
    shown = {a: machine.axis(a).display for a in axes}  # (factor, unit): rad -> deg, m -> mm
    fig, axs = plt.subplots(len(axes), 1, figsize=(10, 3.2 * len(axes)), sharex=True, squeeze=False)
    t = first["t"].to_numpy()
    for i, ax_name in enumerate(axes):
        ax = axs[i, 0]
        peak = 0.0
        factor, unit = shown[ax_name]
        for name, trace in traces:
            e = factor * trace[f"error_{ax_name}"].to_numpy(dtype=float)
            peak = max(peak, float(np.max(np.abs(e))))
            ax.plot(trace["t"], e, lw=0.8, label=f"{name} (RMS {np.sqrt(np.mean(e**2)):.3g} {unit})")
        vel = np.gradient(first[f"ref_{ax_name}"].to_numpy(dtype=float), t)
        if np.max(np.abs(vel)) > 0:
            ax.plot(t, vel / np.max(np.abs(vel)) * peak, "k--", lw=0.7, alpha=0.6, label="reference velocity (scaled)")
        ax.set_ylabel(f"e {ax_name} [{unit}]")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    axs[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"Tracking error on {results[0].trials[trial_index].meta.get('reference', 'validation reference')}")
    fig.tight_layout()
    try:
        atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format=(path.suffix[1:] or "png")))
    finally:
        plt.close(fig)
    return path


def method_colours(methods: Sequence[str]) -> dict[str, tuple]:
    """A fixed colour per method (matplotlib's tab10, then tab20), so a method keeps its colour in
    every figure of one page."""
    import matplotlib

    names = list(dict.fromkeys(methods))
    cmap = matplotlib.colormaps["tab10" if len(names) <= 10 else "tab20"]
    return {m: cmap(i % cmap.N) for i, m in enumerate(names)}


def rms_bar_figure(part, title: str, colours: dict | None = None, reference: str | None = None):
    """Bar chart of RMS per method, grouped by axis, on a log y-axis (the methods span decades), with
    the sample std over seeds as error bars (none for a method of one seed) and, where ``reference``
    is among the methods, a dashed line at its RMS across each group (read a bar's ratio to it off
    the log grid). Axes of different units (a rail in mm beside joints in deg) get one panel each,
    side by side, each y-axis labelled in its unit: one log scale never mixes units.

    ``part``: rows of ``report.ranking`` for one system, signal and period (columns axis, method,
    RMS, RMS_std, unit, and seeds where known); methods are drawn in the order of their first
    appearance, axes and units likewise. Returns the matplotlib Figure (the caller saves and closes it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    axes_names = list(dict.fromkeys(part["axis"]))
    unit_of = part.groupby("axis", sort=False)["unit"].first()
    groups = [(unit, [a for a in axes_names if unit_of[a] == unit]) for unit in dict.fromkeys(unit_of[axes_names])]
    methods = list(dict.fromkeys(part["method"]))
    colours = colours or method_colours(methods)
    n = max(1, len(methods))
    width = 0.8 / n
    size = (min(11.0, max(7.0, 2.2 + 0.28 * n * len(axes_names) + 0.6 * len(axes_names) + 0.8 * (len(groups) - 1))), 3.4)
    fig, panels = plt.subplots(1, len(groups), figsize=size, squeeze=False,
                               gridspec_kw={"width_ratios": [len(names) for _, names in groups]})
    table = part.set_index(["method", "axis"])
    for ax, (unit, names) in zip(panels[0], groups, strict=True):
        for j, m in enumerate(methods):
            if m not in table.index.get_level_values(0):
                continue
            rows = table.loc[m].reindex(names)
            x = np.arange(len(names)) - 0.4 + (j + 0.5) * width
            rms = rows[RANKED_BY].to_numpy(dtype=float)
            one_seed = rows["seeds"].fillna(1).to_numpy() < 2 if "seeds" in rows else np.zeros(len(names), bool)
            std = np.where(one_seed, np.nan, rows[f"{RANKED_BY}_std"].to_numpy(dtype=float))  # nan: no whisker
            lower = np.minimum(std, 0.9 * rms)  # a log axis has no zero: the bar's lower whisker stops above it
            ax.bar(x, rms, width * 0.92, yerr=[lower, std], color=colours.get(m), label=m, capsize=1.5,
                   error_kw={"elinewidth": 0.7, "alpha": 0.8})
        if reference in methods:
            ref = table.loc[reference].reindex(names)[RANKED_BY].to_numpy(dtype=float)
            for i, value in enumerate(ref):
                ax.hlines(value, i - 0.45, i + 0.45, colors="k", linestyles="--", lw=0.8,
                          label=f"{reference} (reference)" if i == 0 else None)
        ax.set_yscale("log")
        ax.set_xticks(np.arange(len(names)), names)
        ax.set_xlim(-0.55, len(names) - 0.45)
        ax.set_ylabel(f"RMS [{unit}] (log)")
        ax.grid(axis="y", which="major", alpha=0.35)
        ax.grid(axis="y", which="minor", alpha=0.12)
    if len(groups) == 1:
        panels[0, 0].set_title(title, fontsize=9)
    else:
        fig.suptitle(title, fontsize=9)
    handles = {}
    for ax in panels[0]:  # a method missing from the first panel still gets its legend entry
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, handle)
    panels[0, -1].legend(handles.values(), handles.keys(), fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5),
                         frameon=False)
    fig.tight_layout()
    return fig


def trace_grid_figure(traces: dict, title: str, colours: dict | None = None, outlier_factor: float = 4.0, *,
                      units: Mapping[str, str]):
    """Small multiples of tracking errors: one row of panels per method, one column per axis.

    ``traces``: method -> trace frame (``t`` [s], ``ref_<axis>`` and ``error_<axis>`` [rad or m], as
    the benchmark stores them), drawn top to bottom in the dict's order. ``units``: axis -> the unit
    its error is shown in, that of its results rows (deg on a revolute axis, mm on a prismatic one;
    ``DISPLAY_FACTORS``); every axis of the traces needs one. The panels of one axis share their
    y-scale, except a method whose peak error exceeds ``outlier_factor`` times the median peak of
    that axis (feedback only, typically): it gets its own scale, said in its panel, so that it does
    not flatten the others. Each panel shows the reference velocity scaled to the panel's range
    (faint) and the trace's RMS in the axis's unit. Returns the Figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(traces)
    colours = colours or method_colours(methods)
    first = traces[methods[0]]
    axes_names = [c[len("ref_"):] for c in first.columns if c.startswith("ref_")]
    missing = [a for a in axes_names if a not in units]
    if missing:
        raise ValueError(f"trace_grid_figure: no unit for axis {', '.join(missing)} (units given for "
                         f"{', '.join(units) or 'none'})")
    factors = {a: display_factor(a, units[a]) for a in axes_names}
    fig, axs = plt.subplots(len(methods), len(axes_names), figsize=(3.9 * len(axes_names) + 0.9, 0.95 * len(methods) + 0.9),
                            sharex=True, squeeze=False)
    for j, ax_name in enumerate(axes_names):
        errors = {m: factors[ax_name] * traces[m][f"error_{ax_name}"].to_numpy(dtype=float) for m in methods}
        peaks = {m: float(np.max(np.abs(e))) if e.size else 0.0 for m, e in errors.items()}
        median = float(np.median(list(peaks.values())))
        shared = max([p for p in peaks.values() if p <= outlier_factor * median] or [max(peaks.values())]) or 1.0
        for i, m in enumerate(methods):
            ax = axs[i, j]
            tr = traces[m]
            t = tr["t"].to_numpy(dtype=float)
            own = peaks[m] > shared
            limit = 1.08 * (peaks[m] if own else shared) or 1.0
            vel = np.gradient(tr[f"ref_{ax_name}"].to_numpy(dtype=float), t) if t.size > 1 else np.zeros_like(t)
            if np.max(np.abs(vel), initial=0.0) > 0:
                ax.fill_between(t, vel / np.max(np.abs(vel)) * limit * 0.9, color="0.5", alpha=0.09, lw=0)
            ax.plot(t, errors[m], lw=0.8, color=colours.get(m))
            ax.axhline(0.0, color="0.6", lw=0.4)
            ax.set_ylim(-limit, limit)
            rms = float(np.sqrt(np.mean(errors[m] ** 2))) if errors[m].size else float("nan")
            note = f"RMS {rms:.3g}" + ("  (own y-scale)" if own else "")
            ax.text(0.99, 0.93, note, transform=ax.transAxes, ha="right", va="top", fontsize=6.5,
                    color="#b2182b" if own else "0.2", bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.75,
                                                             "pad": 1.0})
            ax.tick_params(labelsize=6.5, length=2)
            ax.grid(alpha=0.25, lw=0.4)
            if own:
                for spine in ax.spines.values():
                    spine.set_edgecolor("#b2182b")
            if j == 0:
                ax.set_ylabel(m, fontsize=7.5, rotation=0, ha="right", va="center")
            if i == 0:
                ax.set_title(f"e {ax_name} [{units[ax_name]}]", fontsize=8)
        axs[-1, j].set_xlabel("time [s]", fontsize=7)
    wrapped_title(fig, title + "; grey: reference velocity, scaled", size=8.5)
    fig.tight_layout(h_pad=0.25, w_pad=0.6)
    return fig
