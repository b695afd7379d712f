"""Plots people would rather see than read: tracking errors with the scaled reference velocity (Fig. 2)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..data import atomic_write


def plot_tracking_errors(results: Sequence, path: str | Path, trial_index: int = 0) -> Path:
    """One panel per axis: tracking error [deg] of each controller on one validation reference,
    with the reference velocity scaled to the error range (dashed), like paper 000 Fig. 2."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    first = results[0].trials[trial_index]
    fig, axs = plt.subplots(len(first.axes), 1, figsize=(10, 3.2 * len(first.axes)), sharex=True)
    for i, ax_name in enumerate(first.axes):
        ax = axs[i]
        peak = 0.0
        for r in results:
            tr = r.trials[trial_index]
            e = np.degrees(tr.error[:, i])
            peak = max(peak, float(np.max(np.abs(e))))
            ax.plot(tr.t, e, lw=0.8, label=f"{r.controller} (RMS {np.sqrt(np.mean(e**2)):.3f} deg)")
        vel = np.gradient(first.ref[:, i], first.t)
        if np.max(np.abs(vel)) > 0:
            ax.plot(first.t, vel / np.max(np.abs(vel)) * peak, "k--", lw=0.7, alpha=0.6, label="reference velocity (scaled)")
        ax.set_ylabel(f"e {ax_name} [deg]")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("time [s]")
    fig.suptitle(f"Tracking error on {first.meta.get('reference', 'validation reference')}")
    fig.tight_layout()
    try:
        atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format=(path.suffix[1:] or "png")))
    finally:
        plt.close(fig)
    return path
