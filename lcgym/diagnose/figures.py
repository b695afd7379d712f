"""The diagnosis's plots (``lcgym diagnose --plots``) of a ``result.Diagnosis``: ``figures`` makes
them, ``plot`` writes them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..data import atomic_write
from ..figures import wrapped_title

PLOT_FILES = {
    "residual_time.png": "the residual over time, with the scaled reference velocity",
    "residual_map.png": "the mean residual over position and velocity",
    "effects.png": "the selected or added effects as fitted",
    "before_after.png": "with --add: the residual before and after",
}
"""The figures ``plot`` writes, by file name: what each shows."""


def plot(d, folder: str | Path) -> list[Path]:
    """Write the figures (``figures``) to ``folder`` as PNG files named by ``PLOT_FILES``; the
    paths written."""
    import matplotlib.pyplot as plt

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    figs = figures(d)
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



def figures(d) -> dict:
    """The figures of ``PLOT_FILES`` that this report has, by file name (matplotlib figures,
    Agg; the caller closes them): residual_time.png and residual_map.png always, effects.png
    where effects were selected or added, before_after.png with ``after``. The residual is
    shown at the samples fitted and scored (``series["used"]``: the trial edges and standstill
    left out, whose residual the fit sets to zero, are gaps), and the RMS in a legend is the
    printed report's, over those samples."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s, n = d.series, len(d.axes)
    figs = {"residual_time.png": _time_panels(d, plt, [("residual", "residual")], velocity=True,
                                                   title="Residual u - f of the fitted model")}

    fig, axs = plt.subplots(1, n, figsize=(5.5 * n, 4.2), squeeze=False)
    for i, ax_name in enumerate(d.axes):
        ax = axs[0, i]
        f, pos_unit = d.displays.get(ax_name, (180 / math.pi, "deg"))
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
        fig.colorbar(im, ax=ax, label=f"mean residual [{d.residual[ax_name]['unit']}]")
        ax.set_xlabel(f"{ax_name} position [{pos_unit}]")
        ax.set_ylabel(f"{ax_name} velocity [{pos_unit}/s]")
    wrapped_title(fig, "Where the model fails: mean residual over (position, velocity), at the samples fitted")
    figs["residual_map.png"] = fig

    if s.get("effects"):
        figs["effects.png"] = _effect_panels(d, plt, s["effects"])
    if "residual_after" in s:
        after = "after " + ", ".join(d.after["added"])
        figs["before_after.png"] = _time_panels(d, plt, [("residual", "before"), ("residual_after", after)],
                                                     velocity=False,
                                                     title="Residual before and after adding the effects")
    return figs



def _effect_panels(d, plt, curves: list[dict]):
    """One panel per added effect: its fitted torque over the variable it acts on (velocity for
    a friction, acceleration for an inertia, else position), at the samples fitted: the learned
    curve of an effect of no set shape, the fitted form of the others."""
    n = len(curves)
    fig, axs = plt.subplots(1, n, figsize=(5.0 * n, 4.0), squeeze=False)
    for ax, c in zip(axs[0], curves, strict=True):
        axis = c["effect"].partition("@")[2]
        f, unit = d.displays.get(axis, (180 / math.pi, "deg"))
        per = {"position": "", "velocity": "/s", "acceleration": "/s^2"}[c["variable"]]
        x, y = f * c["x"][c["used"]], c["torque"][c["used"]]
        order = np.argsort(x)
        ax.plot(x[order], y[order], ".", ms=2, alpha=0.5)
        ax.set_xlabel(f"{axis} {c['variable']} [{unit}{per}]")
        unit_u = d.residual[axis]["unit"]
        ax.set_ylabel(f"{ {'N': 'force', 'N m': 'torque'}.get(unit_u, 'input')} [{unit_u}]")  # a rail's is a force
        ax.set_title(f"{c['effect']} [{c['family']}]", fontsize=10)
        ax.grid(alpha=0.3)
    wrapped_title(fig, "The effects added, as fitted: torque (force) over the variable each acts on")
    return fig



def _time_panels(d, plt, series: list[tuple[str, str]], velocity: bool, title: str):
    """One panel per axis: the named residual series over time at the samples fitted and scored
    (``series["used"]``; the others are gaps), optionally with the scaled reference velocity;
    the legend's RMS is the report's (``legend_rms``: over the same samples)."""
    s, n = d.series, len(d.axes)
    fig, axs = plt.subplots(n, 1, figsize=(11, 3 * n), sharex=True, squeeze=False)
    for i, ax_name in enumerate(d.axes):
        ax, used, unit = axs[i, 0], s["used"][:, i], d.residual[ax_name]["unit"]
        for key, label in series:
            r = np.where(used, s[key][:, i], np.nan)
            ax.plot(s["t"], r, lw=0.7, label=f"{label} (RMS {d.legend_rms(key, ax_name):.4g} {unit} over the "
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
