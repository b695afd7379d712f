"""What every figure of lcgym shares: a title that fits its figure."""

from __future__ import annotations

import textwrap


def wrapped_title(fig, text: str, size: float = 12.0) -> None:
    """``text`` as the figure's title, wrapped to the figure's width (a line of about 0.6 em per
    character at ``size`` [pt]), then the panels laid out below it (``tight_layout``): a long title
    on a narrow figure (one axis) would otherwise run past both edges."""
    width = max(20, int(fig.get_figwidth() * 72 / (0.6 * size)))  # characters per line
    fig.suptitle(textwrap.fill(text, width), fontsize=size)
    fig.tight_layout()
