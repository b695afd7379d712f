"""The leaderboard page (``lcgym leaderboard CSV --html DIR``) in a real browser.

Headless Chromium (``lcgym.leaderboard.browser``: Playwright for Python driving the system's
``chromium``) opens the page by its ``file://`` URL at 1280 x 800 and checks that the overview
tables are on the first screen, that clicking a header sorts the rows, that every image loads,
that nothing is logged as an error and that no request leaves ``file:`` and ``data:`` URLs. Once on
a page built from a small synthetic CSV (with traces and a failed cell whose error is markup), once
on the shipped ``results/leaderboard.csv``, and once on a user's machine with a prismatic axis (a
rail in mm beside two joints in deg: each view in each axis's unit and scale).

Without Playwright or Chromium the browser tests are skipped, saying which is missing, unless
``LCGYM_REQUIRE_BROWSER=1`` (the CI sets it): then they fail.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lcgym.cli import main
from lcgym.leaderboard.browser import VIEWPORT, BrowserUnavailable, chromium_path, open_page
from lcgym.leaderboard.page import page_path, ratio_colour, write_html
from lcgym.leaderboard.report import select
from lcgym.leaderboard.runner import trace_path
from lcgym.leaderboard.store import append_rows, read_results
from lcgym.metrics import norms

REPO = Path(__file__).resolve().parents[1]
SHIPPED = REPO / "results" / "leaderboard.csv"
EVIL = "<script>alert('x')</script> & <img src=missing.png onerror=alert(1)>"

# RMS [deg or mm] per (system, axis, method); the geometric mean of the ratios to physical ranks
# beta before alpha on ix-v1, while alpha is best on the propeller: sorting by that column moves rows.
SYNTHETIC = {
    ("ix-v1", "tracking_error", "propeller"): {"feedback": 0.4, "physical": 0.08, "alpha": 0.01, "beta": 0.05},
    ("ix-v1", "tracking_error", "roll"): {"feedback": 0.5, "physical": 0.1, "alpha": 0.2, "beta": 0.03},
    ("flexarm-v1", "tracking_error", "j2"): {"feedback": 0.17, "physical": 0.007, "alpha": 0.03, "beta": 0.009},
    ("flexarm-v1", "tcp_position_error", "tcp"): {"feedback": 4.4, "physical": 0.2, "alpha": 0.9, "beta": 0.3},
}


SIGNALS = {"tracking_error": ("tracking error", "deg"), "tcp_position_error": ("TCP position error", "mm")}
"""signal -> (label, unit) as the benches declare them."""


def _synthetic_csv(folder: Path) -> Path:
    """A results CSV of two seeds per cell, their traces, and one failed cell with markup in its error."""
    out = folder / "leaderboard.csv"
    folder.mkdir()
    provenance = {"run_id": "r1", "lcgym_version": "0.1.0", "git_commit": "abc123def456",
                  "timestamp": "2026-12-02T10:00:00+00:00", "config_hash": "feedc0ffee12"}
    rows = []
    for (system, signal, axis), methods in SYNTHETIC.items():
        for method, rms in methods.items():
            for seed in (0, 1):
                value = rms * (1 + 0.05 * seed)
                for reference_set in ("train", "validation"):
                    rows.append({**provenance, "system": system, "method": method, "seed": seed,
                                 "reference_set": reference_set, "axis": axis, "signal": signal, "period": "all",
                                 "signal_label": SIGNALS[signal][0], "unit": SIGNALS[signal][1],
                                 "MA": 0.8 * value, "RMS": value, "Inf": 3 * value,
                                 "plant_trials": 4, "env_steps": 0, "fit_seconds": 0.5, "status": "ok", "error": ""})
    rows.append({**provenance, "system": "ix-v1", "method": "evil", "seed": 0, "status": "failed", "error": EVIL})
    append_rows(out, rows)
    t = np.arange(0.0, 2.0, 0.01)
    for (system, _signal, _axis), methods in SYNTHETIC.items():
        axes = [a for (s, sig, a) in SYNTHETIC if s == system and sig == "tracking_error"]
        for method in methods:
            frame = {"t": t}
            for k, a in enumerate(axes):
                rms = SYNTHETIC[(system, "tracking_error", a)][method]
                frame[f"ref_{a}"] = np.sin(np.pi * t + k)
                frame[f"error_{a}"] = np.radians(rms * np.sqrt(2) * np.sin(3 * np.pi * t + k))
            path = trace_path(out, system, method, 0)
            path.parent.mkdir(exist_ok=True)
            pd.DataFrame(frame).astype("float32").to_parquet(path, index=False)
    return out


def _browser_or_skip() -> None:
    try:
        import playwright.sync_api  # noqa: F401

        chromium_path()
    except (ImportError, BrowserUnavailable) as exc:
        reason = f"no browser for the page test: {exc} (Playwright for Python and Debian's chromium)"
        if os.environ.get("LCGYM_REQUIRE_BROWSER") == "1":
            pytest.fail(f"LCGYM_REQUIRE_BROWSER=1 but {reason}")
        pytest.skip(reason)


def _column(page, table: int, col: int) -> list:
    """The cells of one column of the table-th overview table, top to bottom: the sort key
    (``data-value``) as a number, or the text where the cell has none (the method's name)."""
    return page.evaluate(
        """([t, c]) => [...document.querySelectorAll('table.overview')[t].tBodies[0].rows].map(r => {
               const v = r.cells[c].getAttribute('data-value');
               return v === null ? r.cells[c].textContent : (v === '' ? null : parseFloat(v)); })""",
        [table, col])


def _check_in_browser(html_file: Path, inspect=None) -> dict:
    """Open the page at 1280 x 800 and check the first screen, sorting, images, console and requests;
    ``inspect(page)``, where given, reads the page first (its result is the answer's "inspected")."""
    with open_page(html_file) as (page, log):
        inspected = inspect(page) if inspect else None
        width, height = VIEWPORT
        boxes = [t.bounding_box() for t in page.query_selector_all("table.overview")]
        assert boxes, "no overview table"
        for box in boxes:
            assert box["x"] >= 0 and box["y"] >= 0, box
            assert box["x"] + box["width"] <= width and box["y"] + box["height"] <= height, \
                f"overview table {box} is not on the first screen {width} x {height}"
        # sort each overview table by its first axis column: ascending, then descending
        order = {}
        for t, table in enumerate(page.query_selector_all("table.overview")):
            header = table.query_selector("th[data-col='1']")
            before = _column(page, t, 0)
            header.click()
            ascending = _column(page, t, 1)
            assert ascending == sorted(ascending) and header.get_attribute("aria-sort") == "ascending"
            after = _column(page, t, 0)
            header.click()
            descending = _column(page, t, 1)
            assert descending == sorted(descending, reverse=True) and header.get_attribute("aria-sort") == "descending"
            order[table.get_attribute("data-system")] = (before, after)
        images = page.evaluate("() => [...document.images].map(i => [i.alt, i.complete, i.naturalWidth])")
        assert images and all(done and w > 0 for _alt, done, w in images), images
        assert not log.console_errors and not log.page_errors, (log.console_errors, log.page_errors)
        assert all(u.startswith(("file:", "data:")) for u in log.requests), log.requests
        return {"order": order, "images": [a for a, _, _ in images], "inspected": inspected}


def test_page_of_a_synthetic_csv_in_the_browser(tmp_path, capsys):
    _browser_or_skip()
    csv = _synthetic_csv(tmp_path / "made")
    site = tmp_path / "site"
    assert main(["leaderboard", str(csv), "--html", str(site)]) == 0
    page = site / "index.html"
    text = page.read_text()
    assert str(tmp_path) not in text and "leaderboard.csv" in text  # named by file name, not by path
    assert "feedc0ffee12" in text and "abc123def456" in text
    assert EVIL not in text and "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;" in text
    assert "http://" not in text and "https://" not in text  # nothing to fetch: no CDN, no font
    seen = _check_in_browser(page)
    before, after = seen["order"]["ix-v1"]
    assert before[:2] == ["beta", "alpha"] and after[0] == "alpha"  # the click moved the rows
    assert {"ix-v1_traces", "flexarm-v1_traces", "ix-v1_tracking_error"} <= set(seen["images"])


def test_page_of_the_shipped_results_in_the_browser(tmp_path):
    _browser_or_skip()
    df, _others = select(read_results(SHIPPED))
    page = write_html(df, tmp_path / "results", source=str(SHIPPED))
    assert page == tmp_path / "results" / "index.html"
    text = page.read_text()
    assert str(REPO) not in text and ">leaderboard.csv<" in text
    seen = _check_in_browser(page)
    assert {f"{s}_traces" for s in set(df["system"])} <= set(seen["images"])


def test_page_path_takes_a_folder_or_an_html_file(tmp_path):
    assert page_path(tmp_path / "board.html") == tmp_path / "board.html"
    assert page_path(tmp_path / "site") == tmp_path / "site" / "index.html"
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(ValueError, match="neither a folder nor"):
        page_path(tmp_path / "notes.txt")
    with pytest.raises(ValueError, match="does not exist"):
        page_path(tmp_path / "missing" / "site")


def test_ratio_colours_green_below_one_red_above_white_at_one():
    assert ratio_colour(1.0) == "#ffffff" and ratio_colour(0.0) is None and ratio_colour(float("nan")) is None
    green, red = ratio_colour(0.1), ratio_colour(10.0)
    assert int(green[3:5], 16) > int(green[1:3], 16) and int(red[1:3], 16) > int(red[3:5], 16)
    assert ratio_colour(1e-6) == ratio_colour(1e-3)  # saturated beyond 10**-1.5


def test_counts_read_as_integers_or_their_range_and_provenance_is_the_csvs(tmp_path):
    """Plant-trial counts that differ between seeds show as "30–31", not as their mean 30.5; equal
    ones as one integer. The header says the rows' lcgym version and commit are the CSV's (the rows
    were written by lcgym 0.1.0 here) and names the lcgym that made the page."""
    from lcgym.leaderboard.report import write_markdown
    from lcgym.provenance import __version__

    csv = _synthetic_csv(tmp_path / "results")
    df = read_results(csv)
    df.loc[(df["method"] == "alpha") & (df["seed"] == 1), "plant_trials"] = 5
    page = write_html(df, tmp_path / "page.html", source=str(csv)).read_text()
    text = write_markdown(df, tmp_path / "README.md", source=str(csv)).read_text()
    for shown in (page, text):
        assert "rows written by lcgym 0.1.0 at commit abc123def456, runs of 2026-12-02" in shown
    assert ">4–5<" in page and ">4.5<" not in page  # the mean stays the cell's sort key (data-value)
    assert "| 4–5 |" in text and "| 4.5 |" not in text
    assert f"this page: lcgym {__version__}" in page and f"this page made by lcgym {__version__}" in text
    beta_row = next(line for line in text.splitlines() if "| beta |" in line)
    assert "| 4 |" in beta_row


def test_the_page_and_the_summary_name_both_winners(tmp_path):
    """Where the best method learns on the references it is scored on (ILC, marked †), the page's
    overview and the summary also name the best that predicts for a reference it has not run."""
    from lcgym.leaderboard.report import format_summary, summary

    csv = _synthetic_csv(tmp_path / "results")
    df = read_results(csv)
    df.loc[df["method"] == "beta", "method"] = "ilc"  # beta, the best, becomes ILC
    table = summary(df).set_index("system")
    table = table[table["best"] == "ilc"]
    assert len(table) and not table["predicting"].isin(["ilc", ""]).any()
    page = write_html(df, tmp_path / "page.html", source=str(csv)).read_text()
    text = format_summary(df)
    for system, r in table.iterrows():
        assert "best <b>ilc†</b>" in page and f"best for an unseen reference <b>{r['predicting']}</b>" in page
        assert any(line.split()[0] == system and f"best for a reference it has not run: {r['predicting']}," in line
                   for line in text.splitlines()[1:])
    df = df[df["method"] != "ilc"]  # the best predicts: one winner, no second line
    assert "best for" not in format_summary(df) and "best for" not in write_html(df, tmp_path / "p2.html").read_text()


def test_a_mean_over_fewer_seeds_says_so_in_the_overview(tmp_path):
    """A method whose cell failed on one seed: its overview cells say over how many of the machine's
    seeds their mean is taken; the others' cells say nothing."""
    csv = _synthetic_csv(tmp_path / "results")
    df = read_results(csv)
    df = df[~((df["method"] == "alpha") & (df["seed"] == 1))]
    page = write_html(df, tmp_path / "page.html", source=str(csv)).read_text()
    assert page.count(">1 of 2 seeds</small>") == sum(1 for k in SYNTHETIC if "alpha" in SYNTHETIC[k])
    assert "of 2 seeds</small>" not in page.replace(">1 of 2 seeds</small>", "")


def test_a_methods_note_reaches_the_text_the_markdown_and_the_page(tmp_path):
    """A note a method left on its cell (the rl safeguard's) is listed once per cell everywhere."""
    from lcgym.leaderboard.report import format_text, write_markdown

    csv = _synthetic_csv(tmp_path / "results")
    df = read_results(csv)
    note = "rl: residual dropped on roll (it raised the training references' tracking error)"
    df.loc[(df["method"] == "alpha") & (df["seed"] == 0) & (df["status"] == "ok"), "note"] = note
    page = write_html(df, tmp_path / "page.html", source=str(csv)).read_text()
    text = write_markdown(df, tmp_path / "README.md", source=str(csv)).read_text()
    for shown in (page, text, format_text(df)):
        assert shown.count("alpha / seed 0: rl: residual dropped on roll") == 2  # ix-v1 and flexarm-v1


RAIL = "rail_arm.toml"  # a user's machine file, as lcgym bench names it
RAIL_UNITS = {"rail": ("mm", "N", 1000.0), "shoulder": ("deg", "N m", 180 / np.pi), "elbow": ("deg", "N m", 180 / np.pi)}
"""axis -> (tracking-error unit, input unit, factor from the stored SI trace: m -> mm, rad -> deg)."""
RAIL_SCALES = {"feedback": 10.0, "physical": 1.0, "ilc": 0.1}


def _rail_csv(folder: Path) -> Path:
    """One seed of a rail (prismatic) / shoulder / elbow machine: each method's trace with known errors
    in m and rad, and its tracking-error rows the norms of that trace in mm and deg (as if the
    validation set were that one reference), input-residual rows in N and N m."""
    out = folder / "rail.csv"
    folder.mkdir()
    base = {"run_id": "r1", "seed": 0, "period": "all", "plant_trials": 2, "env_steps": 0, "fit_seconds": 0.1,
            "status": "ok", "error": "", "lcgym_version": "0.1.0", "git_commit": "abc123def456",
            "timestamp": "2026-12-02T10:00:00+00:00", "config_hash": "0a11ce0a11ce", "system": RAIL}
    t = np.arange(0.0, 2.0, 0.01)
    rows = []
    for method, scale in RAIL_SCALES.items():
        frame = {"t": t}
        for k, axis in enumerate(RAIL_UNITS):
            size = 1.43e-5 if axis == "rail" else 1.3e-3  # m: RMS about 0.0101 mm; rad: about 0.053 deg
            frame[f"ref_{axis}"] = 0.2 * np.sin(np.pi * t + k)
            frame[f"error_{axis}"] = scale * size * (1 + 0.3 * k) * np.sin(3 * np.pi * t + k)
        trace = pd.DataFrame(frame).astype("float32")
        path = trace_path(out, RAIL, method, 0)
        path.parent.mkdir(exist_ok=True)
        trace.to_parquet(path, index=False)
        for axis, (unit, input_unit, factor) in RAIL_UNITS.items():
            shown = norms(factor * trace[f"error_{axis}"].to_numpy(dtype=float))
            for reference_set in ("train", "validation"):
                rows.append({**base, "method": method, "reference_set": reference_set, "axis": axis,
                             "signal": "tracking_error", "signal_label": "tracking error", "unit": unit,
                             **{m: float(v) for m, v in shown.items()},
                             "base": "physical" if method == "ilc" else ""})
                rows.append({**base, "method": method, "reference_set": reference_set, "axis": axis,
                             "signal": "input_residual", "signal_label": "input residual u - f", "unit": input_unit,
                             "MA": scale, "RMS": 1.2 * scale,
                             "Inf": 3 * scale})
    append_rows(out, rows)
    return out


def _figures_drawn(monkeypatch) -> dict:
    """Record the trace grids and bar charts the page draws: their panels' titles, y-labels and texts
    (the images themselves are PNGs the browser cannot read back as text)."""
    from lcgym.leaderboard import plots

    drawn = {"traces": [], "bars": []}

    def panels(fig):
        return [{"title": ax.get_title(), "ylabel": ax.get_ylabel(), "texts": [t.get_text() for t in ax.texts]}
                for ax in fig.axes]

    def traces(traces, *args, **kwargs):
        fig = trace_grid(traces, *args, **kwargs)
        drawn["traces"].append({"methods": list(traces), "panels": panels(fig)})
        return fig

    def bars(part, *args, **kwargs):
        fig = bar(part, *args, **kwargs)
        drawn["bars"].append({"signal": part["signal"].iloc[0], "panels": panels(fig)})
        return fig

    trace_grid, bar = plots.trace_grid_figure, plots.rms_bar_figure
    monkeypatch.setattr(plots, "trace_grid_figure", traces)
    monkeypatch.setattr(plots, "rms_bar_figure", bars)
    return drawn


READ_UNITS = """() => ({
    overview: [...document.querySelectorAll('table.overview thead th[data-col]')].map(
        th => [th.firstChild.textContent, th.querySelector('small') ? th.querySelector('small').textContent : '']),
    rows: Object.fromEntries([...document.querySelectorAll('table.overview tbody tr')].map(
        r => [r.cells[0].firstChild.textContent, [...r.cells].slice(1).map(c => c.textContent)])),
    marked: [...document.querySelectorAll('table.overview tbody th.method sup.scored')].map(
        s => s.parentElement.firstChild.textContent),
    heading: document.querySelector('section.machine h3').textContent,
    groups: [...document.querySelectorAll('table.details')].map(
        t => [...t.querySelectorAll('th.group')].map(th => th.textContent)),
    summaries: [...document.querySelectorAll('details > summary')].map(s => s.textContent),
    cells: [...document.querySelectorAll('td')].map(td => td.textContent),
    legend: document.querySelector('p.legend').textContent,
})"""


def test_page_of_a_machine_with_a_prismatic_axis_in_the_browser(tmp_path, monkeypatch):
    """A rail (prismatic, mm) beside a shoulder and an elbow (revolute, deg): every view says each
    axis's own unit, the trace panels convert m to mm and rad to deg (the rail's trace RMS is the
    table's mm figure, not m x 57.3), one seed shows no ± part, and ILC is marked as learned on the
    references it is scored on."""
    _browser_or_skip()
    csv = _rail_csv(tmp_path / "made")
    drawn = _figures_drawn(monkeypatch)
    page = tmp_path / "board.html"
    assert main(["leaderboard", str(csv), "--html", str(page)]) == 0
    seen = _check_in_browser(page, lambda p: p.evaluate(READ_UNITS))
    dom = seen["inspected"]
    axes = list(RAIL_UNITS)  # the machine's order, in every view
    assert dom["overview"][1:4] == [["rail", "mm"], ["shoulder", "deg"], ["elbow", "deg"]]
    assert dom["groups"][0] == ["rail [mm]", "shoulder [deg]", "elbow [deg]"]  # details, tracking error
    assert dom["groups"][1] == ["rail [N]", "shoulder [N m]", "elbow [N m]"]  # details, input residual
    assert "tracking error [mm, deg] per axis" in dom["heading"]
    assert any(s.startswith("tracking error") and s.endswith("[mm, deg]") for s in dom["summaries"])
    assert any(s.startswith("input residual") and s.endswith("[N, N m]") for s in dom["summaries"])
    assert not any("±" in c for c in dom["cells"]), "one seed: no ± part"
    assert dom["marked"] == ["ilc"] and "ilc: learned on each reference it is scored on" in dom["legend"]
    assert {f"{RAIL}_traces", f"{RAIL}_tracking_error", f"{RAIL}_input_residual"} <= set(seen["images"])

    # the figures the page embeds: the trace panels in each axis's unit and scale
    (grid,) = drawn["traces"]
    assert [p["title"] for p in grid["panels"][:3]] == ["e rail [mm]", "e shoulder [deg]", "e elbow [deg]"]
    for i, method in enumerate(grid["methods"]):
        for j, axis in enumerate(axes):
            panel = grid["panels"][i * len(axes) + j]
            rms = float(panel["texts"][0].split()[1])
            table = float(dom["rows"][method][j].lstrip("★"))
            assert rms == pytest.approx(table, rel=1e-9), (method, axis, panel["texts"], dom["rows"][method])
    assert float(dom["rows"]["physical"][0]) == pytest.approx(0.0101, rel=0.02)  # the rail in mm, not m x 57.3
    labels = {b["signal"]: [p["ylabel"] for p in b["panels"]] for b in drawn["bars"]}  # a panel per unit
    assert labels == {"tracking_error": ["RMS [mm] (log)", "RMS [deg] (log)"],
                      "input_residual": ["RMS [N] (log)", "RMS [N m] (log)"]}


def test_one_seed_shows_no_spread_and_ilc_is_marked_in_the_text_and_markdown(tmp_path):
    """The text and Markdown leaderboards: RMS_std empty where a method has one seed (its std is
    undefined, not 0), a number where it has two; each axis's unit; ILC named as learned on the
    references it is scored on."""
    from lcgym.leaderboard.report import format_text, write_markdown

    csv = _rail_csv(tmp_path / "made")
    df = read_results(csv)
    again = df[df["method"] == "feedback"].assign(seed=1, RMS=lambda d: d["RMS"] * 1.1)
    df = pd.concat([df, again], ignore_index=True)
    text = format_text(df)
    assert "ilc: learned on each reference it is scored on" in text
    section = text.split(f"{RAIL} / tracking_error / rail\n")[1].split("\n\n")[0].splitlines()
    header, rows = section[0].split(), {r.split()[1]: r.split() for r in section[1:]}
    assert header[:10] == ["rank", "method", "base", "vs_base", "share", "MA", "RMS", "RMS_std", "Inf", "unit"]
    assert len(rows["feedback"]) == len(header) and rows["feedback"][9] == "mm"  # two seeds: a spread
    assert len(rows["physical"]) == len(header) - 1 and rows["physical"][8] == "mm"  # one seed: none
    assert rows["ilc"][2] == "physical" and rows["ilc"][3].endswith("x")  # its gain over its base
    assert float(rows["ilc"][3].rstrip("x")) == pytest.approx(float(rows["ilc"][6]) / float(rows["physical"][6]), abs=0.006)
    assert rows["ilc"][4] == "1.00" and rows["physical"][4] == rows["feedback"][4] == "–"  # ILC is the bound
    assert f"{RAIL} / input_residual / rail" in text and f"{RAIL} / input_residual / elbow" in text
    md = write_markdown(df, tmp_path / "board.md", source=str(csv)).read_text()
    assert "`ilc`: learned on each reference it is scored on" in md
    table = md.split(f"## {RAIL} / tracking_error / shoulder\n")[1].split("\n\n")[0].splitlines()
    cells = {r.split("|")[2].strip(): [c.strip() for c in r.split("|")[1:-1]] for r in table[2:]}
    assert cells["physical"][7] == "" and cells["feedback"][7] != "" and cells["physical"][9] == "deg"
