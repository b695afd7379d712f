"""The picture an environment's ``render()`` returns: the episode so far, per axis.

``render_mode="rgb_array"``: ``render()`` returns the picture (H, W, 3) uint8.
``render_mode="human"``: the env shows the picture in a matplotlib window (``HumanWindow``) at
each reset, every ``HUMAN_EVERY`` samples and at each episode's end, and ``render()`` shows it now;
with a non-interactive matplotlib backend (a server, a test run) nothing is drawn on screen and the
last picture is kept in ``HumanWindow.image``.
"""

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
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure  # not pyplot: leaves the user's backend and figures alone

    fig = Figure(figsize=(4 * len(axes), 4.5), dpi=80)
    canvas = FigureCanvasAgg(fig)
    axs = fig.subplots(2, len(axes), sharex=True, squeeze=False)
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
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


HUMAN_EVERY = 500
"""Samples between two pictures of ``render_mode="human"`` (1 s on the IX, 0.5 s at 1 kHz)."""

RENDER_MODES = ("rgb_array", "human")


def checked_render_mode(render_mode: str | None) -> str | None:
    if render_mode not in (None, *RENDER_MODES):
        raise ValueError(f"render_mode must be None, 'rgb_array' or 'human', got {render_mode!r}")
    return render_mode


class HumanWindow:
    """A matplotlib window showing an env's latest picture (``render_mode="human"``)."""

    def __init__(self, fps: float = 4.0):
        self.fps = fps
        self.image: np.ndarray | None = None
        self._figure = self._artist = None

    def show(self, image: np.ndarray) -> None:
        self.image = image
        import matplotlib
        from matplotlib.backends import BackendFilter, backend_registry

        if matplotlib.get_backend().lower() not in backend_registry.list_builtin(BackendFilter.INTERACTIVE):
            return  # no screen to draw on: keep the picture only
        import matplotlib.pyplot as plt

        if self._figure is None or not plt.fignum_exists(self._figure.number):
            self._figure, ax = plt.subplots(figsize=(image.shape[1] / 80, image.shape[0] / 80), dpi=80)
            ax.set_axis_off()
            self._artist = ax.imshow(image)
            self._figure.tight_layout(pad=0)
            plt.show(block=False)
        else:
            self._artist.set_data(image)
        plt.pause(1.0 / self.fps)

    def close(self) -> None:
        if self._figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self._figure)
            self._figure = None


def rendered(render_mode: str | None, window: HumanWindow | None, picture) -> np.ndarray | None:
    """What an env's ``render()`` returns: the picture ``picture()`` for "rgb_array"; for "human"
    the picture shown in ``window`` and None; None without a render mode."""
    if render_mode is None:
        return None
    image = picture()
    if render_mode == "human":
        window.show(image)
        return None
    return image


def human_frame_due(render_mode: str | None, k: int, ended: bool) -> bool:
    """Whether a "human" env draws after the step that reached reference sample ``k``."""
    return render_mode == "human" and (ended or k % HUMAN_EVERY == 0)
