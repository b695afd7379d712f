"""MkDocs hooks: the results page of the site, built from the shipped ``results/leaderboard.csv``.

The page is ``lcgym.leaderboard.page.write_html``'s, read the way ``lcgym leaderboard`` reads a
results file (``store.read_results``, then ``report.select``: the newest configuration, the newest
run per cell). It is made when MkDocs collects the site's files (``on_files``), so that
``leaderboard.md``'s link to ``results/index.html`` is a link to a file of the site, which
``mkdocs build --strict`` checks like any other, and ``mkdocs serve`` shows it too.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "leaderboard.csv"
SITE_FOLDER = "results"  # the page is results/index.html of the site

_tmp: tempfile.TemporaryDirectory | None = None


def build_results_page(folder: Path) -> Path:
    """Write the results page into ``folder`` (made if missing) and return the page's path."""
    from lcgym.leaderboard.page import write_html
    from lcgym.leaderboard.report import select
    from lcgym.leaderboard.store import read_results

    df, _ = select(read_results(RESULTS))
    return write_html(df, folder, source=str(RESULTS))


def on_files(files, config):
    global _tmp
    _tmp = tempfile.TemporaryDirectory(prefix="lcgym-docs-")
    folder = Path(_tmp.name) / SITE_FOLDER
    page = build_results_page(folder)
    if page != folder / "index.html":
        raise RuntimeError(f"write_html wrote {page}, not {folder / 'index.html'}")
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        files.append(File.generated(config, f"{SITE_FOLDER}/{path.relative_to(folder).as_posix()}", abs_src_path=str(path)))
    return files


def on_post_build(config):
    global _tmp
    if _tmp is not None:
        _tmp.cleanup()
        _tmp = None
