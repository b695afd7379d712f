"""The results the docs quote in their tables are those of the shipped ``results/leaderboard.csv``.

The docs' tables of the full run (``docs/leaderboard.md``, the method pages) are written from the
shipped CSV by hand; after a rerun of ``lcgym bench`` a stale row is easy to miss (it happened: the
IX's ``rl`` row kept a run's figures that ``results/`` no longer had). Each "RMS +- std" cell of a
table row that names a method must be that method's validation RMS over seeds and its standard
deviation (``leaderboard.report.ranking``) on some machine, signal, period and axis of the shipped
file, to the digits the docs print.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from lcgym.leaderboard.report import ranking
from lcgym.leaderboard.store import read_results

ROOT = Path(__file__).resolve().parents[1]
MEAN_STD = re.compile(r"(?<![\w.])(\d+\.(\d+)) \+- (\d+\.\d+)(?![\w.])")


def table_rows(page: Path):
    """(line number, cells) of every markdown table row of a page, the header's separator aside."""
    for number, line in enumerate(page.read_text().splitlines(), 1):
        if line.startswith("|") and not set(line) <= set("|-: "):
            yield number, [c.strip() for c in line.strip().strip("|").split("|")]


@pytest.fixture(scope="module")
def shipped():
    """{method: set of (decimals, "RMS", "std") strings} of the shipped file's validation rankings."""
    table = ranking(read_results(ROOT / "results" / "leaderboard.csv"), "validation")
    quoted: dict[str, set] = {}
    for method, rms, std in zip(table["method"], table["RMS"], table["RMS_std"], strict=True):
        quoted.setdefault(method, set()).update((d, f"{rms:.{d}f}", f"{std:.{d}f}") for d in range(2, 8))
    return quoted


def quoted_cells(pages, methods, root: Path = ROOT):
    """(page relative to ``root``, line, method, (decimals, mean, std)) of every "mean +- std" cell in
    a table row that names a method."""
    for page in pages:
        for number, cells in table_rows(page):
            method = next((c.split()[0] for c in cells if c and c.split()[0] in methods), None)
            if method is None:
                continue
            for cell in cells:
                for mean, decimals, std in MEAN_STD.findall(cell):
                    yield page.relative_to(root), number, method, (len(decimals), mean, std)


def test_every_quoted_result_is_in_the_shipped_file(shipped):
    pages = sorted((ROOT / "docs").rglob("*.md"))
    found = list(quoted_cells(pages, shipped))
    assert len(found) >= 40, f"expected the leaderboard's tables, found {len(found)} quoted cells"
    stale = [f"{page}:{line} {method} {mean} +- {std}" for page, line, method, (_, mean, std) in found
             if (len(mean.split(".")[1]), mean, std) not in shipped[method]]
    assert not stale, "docs quote results the shipped results/leaderboard.csv does not have:\n" + "\n".join(stale)


def test_a_stale_cell_is_found(shipped, tmp_path):
    """The check itself: a row whose figures are not in the file is reported."""
    (tmp_path / "docs").mkdir()
    page = tmp_path / "docs" / "page.md"
    page.write_text("| method | propeller |\n|---|---|\n| rl | 0.086 +- 0.003 |\n| ilc | 0.0274 +- 0.0016 |\n")
    found = list(quoted_cells([page], shipped, root=tmp_path))
    assert [(m, key in shipped[m]) for _, _, m, key in found] == [("rl", False), ("ilc", True)]
