"""Headless Chromium for the leaderboard page: the one launch used by the page's browser test and by
``scripts/leaderboard_screenshot.py``.

It drives the system's Chromium (Debian's ``chromium`` package; ``$LCGYM_CHROMIUM`` names another
binary) through Playwright for Python (``pip install playwright``; Playwright's own browser download
is not needed). Offline flags: no background networking, component updates, sync or QUIC, so the
browser itself sends no request while the page is open.
"""

from __future__ import annotations

import os
import shutil
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

CHROMIUM_ARGS = ("--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync")
VIEWPORT = (1280, 800)
"""The first screen [CSS px]: width, height."""


class BrowserUnavailable(RuntimeError):
    """Playwright for Python or a Chromium binary is missing; the message says which and how to get it."""


def chromium_path() -> str:
    """The Chromium binary: ``$LCGYM_CHROMIUM``, else ``chromium`` or ``chromium-browser`` on PATH."""
    named = os.environ.get("LCGYM_CHROMIUM")
    if named:
        if not (shutil.which(named) or Path(named).is_file()):
            raise BrowserUnavailable(f"LCGYM_CHROMIUM={named}: no such program")
        return shutil.which(named) or named
    for name in ("chromium", "chromium-browser"):
        found = shutil.which(name)
        if found:
            return found
    raise BrowserUnavailable("no chromium on PATH (Debian/Ubuntu: apt-get install chromium; or set LCGYM_CHROMIUM)")


@dataclass
class PageLog:
    """What the page did while open: console errors, uncaught exceptions, and every requested URL."""

    console_errors: list[str] = field(default_factory=list)
    page_errors: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)


@contextmanager
def open_page(html_file: str | Path, viewport: tuple[int, int] = VIEWPORT):
    """Open a local HTML file by its ``file://`` URL in headless Chromium at ``viewport`` [CSS px],
    wait for its load event (images included), and yield (Playwright page, ``PageLog``)."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        raise BrowserUnavailable("Playwright for Python is not installed (pip install playwright)") from None
    executable = chromium_path()
    url = Path(html_file).resolve().as_uri()
    log = PageLog()
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=executable, args=list(CHROMIUM_ARGS))
        try:
            page = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
            page.on("console", lambda msg: log.console_errors.append(msg.text) if msg.type == "error" else None)
            page.on("pageerror", lambda exc: log.page_errors.append(str(exc)))
            page.on("request", lambda req: log.requests.append(req.url))
            page.goto(url, wait_until="load")
            yield page, log
        finally:
            browser.close()


def screenshot(html_file: str | Path, png: str | Path, viewport: tuple[int, int] = VIEWPORT) -> Path:
    """PNG of the page's first screen (``viewport`` [CSS px], device scale 1); returns its path."""
    png = Path(png)
    with open_page(html_file, viewport) as (page, _log):
        page.screenshot(path=str(png), full_page=False)
    return png
