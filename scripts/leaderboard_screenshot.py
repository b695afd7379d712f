"""Write the leaderboard page of a results CSV and a PNG of its first screen.

    python scripts/leaderboard_screenshot.py results/leaderboard.csv OUT_DIR [--width 1280 --height 800]
        [--reference-set validation] [--config HASH]

writes OUT_DIR/index.html (``lcgym leaderboard CSV --html OUT_DIR``) and OUT_DIR/first_screen.png,
the page as headless Chromium shows it at width x height CSS px (``lcgym.leaderboard.browser``:
Playwright for Python and the system's ``chromium``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from lcgym.leaderboard.browser import VIEWPORT, BrowserUnavailable, screenshot
from lcgym.leaderboard.page import write_html
from lcgym.leaderboard.report import select
from lcgym.leaderboard.store import read_results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("csv", type=Path, help="results CSV (lcgym bench --out)")
    parser.add_argument("out", type=Path, help="folder for index.html and first_screen.png (made if missing)")
    parser.add_argument("--width", type=int, default=VIEWPORT[0], help="viewport width [CSS px]")
    parser.add_argument("--height", type=int, default=VIEWPORT[1], help="viewport height [CSS px]")
    parser.add_argument("--reference-set", choices=("validation", "train", "test"), default="validation")
    parser.add_argument("--config", metavar="HASH", help="configuration hash to rank (default: the newest run's)")
    args = parser.parse_args(argv)
    if not args.csv.is_file():
        parser.error(f"{args.csv}: no such results file")
    if args.width <= 0 or args.height <= 0:
        parser.error("--width and --height must be positive")
    args.out.mkdir(parents=True, exist_ok=True)
    df, _others = select(read_results(args.csv), args.config)
    page = write_html(df, args.out, args.reference_set, source=str(args.csv))
    try:
        png = screenshot(page, args.out / "first_screen.png", (args.width, args.height))
    except BrowserUnavailable as exc:
        print(f"leaderboard_screenshot: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {page}\nwrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
