"""The diagnosis report: printed text, JSON (``to_dict``, written by ``write_json``) and plots."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..data import atomic_write

DEG = math.pi / 180.0
NOTHING_FOUND = "no missing effect found"


@dataclass
class Diagnosis:
    """What ``diagnose`` found. ``residual`` {axis: {MA, RMS, Inf, unit}}; ``regions`` worst
    first; ``candidates`` passing candidates, best first (greedy selection order, then the rest
    by their share alone); ``after`` / ``replay`` with ``add`` / ``replay``. ``model`` is the
    fitted nominal model, ``suggested_model`` the model refitted with the selected effects,
    ``found`` every candidate effect (``name@axis``) with the nonlinear parameters the search
    chose, ready for ``model.with_effect``. ``series`` holds the reduced signals for plots."""

    system: str
    axes: tuple[str, ...]
    unit: str
    n_samples: int
    fs: float
    model_effects: list[str]
    residual: dict
    regions: list[dict]
    candidates: list[dict]
    min_explained: float
    min_rms: float
    model: object = field(repr=False, default=None)
    suggested_model: object = field(repr=False, default=None)
    series: dict = field(repr=False, default_factory=dict)
    found: dict = field(repr=False, default_factory=dict)
    after: dict | None = None
    after_model: object = field(repr=False, default=None)
    replay: dict | None = None

    @property
    def missing(self) -> list[str]:
        """``name@axis`` of the selected candidates, best first (empty: nothing found)."""
        return [f"{c['effect']}@{c['axis']}" for c in self.candidates if c["selected"]]

    def to_dict(self) -> dict:
        out = {"system": self.system, "model_effects": self.model_effects, "n_samples": self.n_samples, "fs": self.fs,
               "residual": self.residual, "regions": self.regions, "candidates": self.candidates,
               "significance": {"min_explained": self.min_explained, "min_rms": self.min_rms, "unit": self.unit,
                             "order": "greedy forward selection (selected: true), then the other passing "
                                      "candidates by explained; explained and RMS_after: the effect alone, held-out; "
                                      "explained_at_selection: share of the residual left at its greedy step"}}
        if self.after is not None:
            out["after"] = self.after
        if self.replay is not None:
            out["replay"] = self.replay
        return out

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(self.to_dict(), indent=1)))
        return path

    def text(self, n_regions: int = 4) -> str:
        """The printed report."""
        u = self.unit
        lines = [f"lcgym diagnose: system {self.system}, {self.n_samples} samples at {self.fs:g} Hz",
                 f"model: {', '.join(self.model_effects)} (least squares; residual = u - f after a 5 Hz zero-phase low-pass)",
                 "", f"residual [{u}]:", f"  {'axis':12s} {'MA':>8s} {'RMS':>8s} {'Inf':>8s}"]
        for ax in self.axes:
            r = self.residual[ax]
            lines.append(f"  {ax:12s} {r['MA']:8.4f} {r['RMS']:8.4f} {r['Inf']:8.4f}")
        lines += ["", "where the model fails worst (residual RMS there / overall):"]
        for ax in self.axes:
            for reg in [r for r in self.regions if r["axis"] == ax][:n_regions]:
                lines.append(f"  {ax:10s} {reg['where']:44s} RMS {reg['RMS']:.4f} {u} ({reg['ratio']:.2f}x, "
                             f"{100 * reg['samples']:.0f}% of samples)")
        lines += ["", "candidate missing effects (share of the axis's residual energy each removes alone on held-out"
                  " data; selected ones in the order of greedy forward selection):"]
        if not self.candidates:
            lines.append(f"  {NOTHING_FOUND} (none removes {100 * self.min_explained:.0f}% with at least "
                         f"{self.min_rms:g} {u} RMS)")
        for k, c in enumerate(self.candidates, 1):
            how = (f"selected: {100 * c['explained_at_selection']:.0f}% of what was left at its turn" if c["selected"]
                   else "not needed once the selected ones are in")
            params = ", ".join(f"{n}={_fmt(n, v)}" for n, v in c["parameters"].items())
            lines.append(f"  {k}. {c['effect']}@{c['axis']} [{c['family']}]: {100 * c['explained']:.0f}%, "
                         f"held-out RMS {c['RMS_before']:.4f} -> {c['RMS_after']:.4f} {u} "
                         f"({how}{'; ' + params if params else ''})")
        if self.candidates:
            lines.append(f"  add the selected ones: lcgym diagnose DATA --system {self.system} "
                         + " ".join(f"--add {m}" for m in self.missing))
        if self.after is not None:
            lines += ["", f"after adding {', '.join(self.after['added'])} and refitting, residual RMS [{u}]:",
                      f"  {'axis':12s} {'before':>8s} {'after':>8s} {'change':>8s}"]
            for ax in self.axes:
                b, a = self.residual[ax]["RMS"], self.after["residual"][ax]["RMS"]
                lines.append(f"  {ax:12s} {b:8.4f} {a:8.4f} {100 * (a - b) / b:+7.0f}%")
        if self.replay is not None:
            lines += ["", "replay on the plant, tracking-error RMS [deg] with the model's feedforward:",
                      f"  {'axis':12s} {'before':>8s} {'after':>8s}"]
            for ax in self.axes:
                lines.append(f"  {ax:12s} {self.replay['before'][ax]:8.4f} {self.replay['after'][ax]:8.4f}")
        return "\n".join(lines)

    def plot(self, folder: str | Path) -> list[Path]:
        """residual_time.png, residual_map.png and (with ``after``) before_after.png in ``folder``."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        s, n = self.series, len(self.axes)
        figs = []
        figs.append((self._time_panels(plt, [("residual", "residual")], velocity=True,
                                       title="Residual u - f of the fitted model"), folder / "residual_time.png"))

        fig, axs = plt.subplots(1, n, figsize=(5.5 * n, 4.2), squeeze=False)
        for i, ax_name in enumerate(self.axes):
            ax = axs[0, i]
            q, v, r = np.degrees(s["q"][:, i]), np.degrees(s["qd"][:, i]), s["residual"][:, i]
            qe, ve = np.linspace(q.min(), q.max() + 1e-9, 31), np.linspace(v.min(), v.max() + 1e-9, 21)
            total, _, _ = np.histogram2d(q, v, [qe, ve], weights=r)
            count, _, _ = np.histogram2d(q, v, [qe, ve])
            mean = np.where(count > 0, total / np.maximum(count, 1), np.nan)
            lim = np.nanmax(np.abs(mean)) if np.isfinite(mean).any() else 1.0
            im = ax.pcolormesh(qe, ve, mean.T, cmap="coolwarm", vmin=-lim, vmax=lim)
            fig.colorbar(im, ax=ax, label=f"mean residual [{self.unit}]")
            ax.set_xlabel(f"{ax_name} angle [deg]")
            ax.set_ylabel(f"{ax_name} velocity [deg/s]")
        fig.suptitle("Where the model fails: residual over (position, velocity)")
        fig.tight_layout()
        figs.append((fig, folder / "residual_map.png"))

        if "residual_after" in s:
            after = "after " + ", ".join(self.after["added"])
            figs.append((self._time_panels(plt, [("residual", "before"), ("residual_after", after)], velocity=False,
                                           title="Residual before and after adding the effects"),
                         folder / "before_after.png"))
        paths = []
        try:
            for fig, path in figs:
                atomic_write(path, lambda tmp, f=fig: f.savefig(tmp, dpi=100, format="png"))
                paths.append(path)
        finally:
            for fig, _ in figs:
                plt.close(fig)
        return paths


    def _time_panels(self, plt, series: list[tuple[str, str]], velocity: bool, title: str):
        """One panel per axis: the named residual series over time, optionally with the scaled
        reference velocity."""
        s, n = self.series, len(self.axes)
        fig, axs = plt.subplots(n, 1, figsize=(11, 3 * n), sharex=True, squeeze=False)
        for i, ax_name in enumerate(self.axes):
            ax = axs[i, 0]
            for key, label in series:
                r = s[key][:, i]
                ax.plot(s["t"], r, lw=0.7, label=f"{label} (RMS {np.sqrt(np.mean(r ** 2)):.4f} {self.unit})")
            v = s["ref_velocity"][:, i]
            if velocity and np.abs(v).max() > 0:
                r = s[series[0][0]][:, i]
                ax.plot(s["t"], v / np.abs(v).max() * np.abs(r).max(), "k--", lw=0.6, alpha=0.6,
                        label="reference velocity (scaled)")
            ax.set_ylabel(f"{ax_name} [{self.unit}]")
            ax.legend(loc="upper right", fontsize=8)
            ax.grid(alpha=0.3)
        axs[-1, 0].set_xlabel("time over all trials [s]")
        fig.suptitle(title)
        return fig


def _fmt(name: str, value: float) -> str:
    """Nonlinear parameters in readable units: angles and speeds in deg (deg/s)."""
    if name in ("q0", "width", "period"):
        return f"{value / DEG:.3g} deg"
    if name in ("eps", "vs", "v_ref"):
        return f"{value / DEG:.3g} deg/s"
    return f"{value:.3g}"
