"""The picture an environment's ``render()`` returns: the episode so far, per axis."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..data import Trial


def render_episode(trial: Trial | None, title: str, axes: Sequence[str],
                   display: Sequence[tuple[float, str]] | None = None, columns: Sequence[int] | None = None,
                   error: np.ndarray | None = None) -> np.ndarray:
    """RGB image (H, W, 3) of the reference and the tracking error of each of ``axes`` so far;
    ``display``: per axis (factor, unit) from SI to the plotted unit (default deg, ``Axis.display``);
    ``columns``: the trial's columns of ``axes`` (default the first ones); ``error``: the tracking
    error (T, n_axes of the trial) to plot (default ``trial.error``, reference - encoder);
    ``trial`` None: the empty axes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig, axs = plt.subplots(2, len(axes), figsize=(4 * len(axes), 4.5), dpi=80, sharex=True, squeeze=False)
    fig.suptitle(title, fontsize=9)
    columns = list(range(len(axes))) if columns is None else list(columns)
    if trial is not None and error is None:
        error = trial.error
    for i, ax_name in enumerate(axes):
        top, bottom = axs[0, i], axs[1, i]
        scale, unit = display[i] if display is not None else (180 / np.pi, "deg")
        if trial is not None:
            top.plot(trial.t, scale * trial.ref[:, columns[i]], lw=0.8)
            bottom.plot(trial.t, scale * error[:, columns[i]], lw=0.8, color="C1")
        top.set_title(ax_name, fontsize=9)
        top.set_ylabel(f"reference [{unit}]", fontsize=8)
        bottom.set_ylabel(f"error [{unit}]", fontsize=8)
        bottom.set_xlabel("time [s]", fontsize=8)
    fig.tight_layout()
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    image = np.asarray(canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    return image
