"""Plots people would rather see than read: tracking errors with the scaled reference velocity (Fig. 2)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..data import atomic_write


def plot_tracking_errors(results: Sequence, path: str | Path, trial_index: int = 0) -> Path:
    """One panel per scored axis: tracking error of each controller on one validation reference (the
    error the machine's bench scores, ``bench.trace``: in deg), with the reference velocity scaled to
    the error range (dashed), like paper 000 Fig. 2."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    traces = [(r.controller, r.bench.trace(r.trials[trial_index])) for r in results]
    first = traces[0][1]
    axes = [c[len("error_"):] for c in first.columns if c.startswith("error_")]
    fig, axs = plt.subplots(len(axes), 1, figsize=(10, 3.2 * len(axes)), sharex=True, squeeze=False)
    t = first["t"].to_numpy()
    for i, ax_name in enumerate(axes):
        ax = axs[i, 0]
        peak = 0.0
        for name, trace in traces:
            e = np.degrees(trace[f"error_{ax_name}"].to_numpy(dtype=float))
            peak = max(peak, float(np.max(np.abs(e))))
            ax.plot(trace["t"], e, lw=0.8, label=f"{name} (RMS {np.sqrt(np.mean(e**2)):.3f} deg)")
        vel = np.gradient(first[f"ref_{ax_name}"].to_numpy(dtype=float), t)
        if np.max(np.abs(vel)) > 0:
            ax.plot(t, vel / np.max(np.abs(vel)) * peak, "k--", lw=0.7, alpha=0.6, label="reference velocity (scaled)")
        ax.set_ylabel(f"e {ax_name} [deg]")
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
