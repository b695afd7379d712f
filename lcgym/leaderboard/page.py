"""The leaderboard's HTML page: one self-contained file that opens on an overview per machine.

``render(df, reference_set, source)`` returns the page's text; ``write_html`` writes it.
What it shows, top to bottom:

- provenance in one line: the CSV's file name (never a path of the machine that made it), the
  configuration hash(es), lcgym version(s), git commit(s), the number of runs, the reference set and
  how the numbers are aggregated (mean over seeds, +- the sample standard deviation over seeds);
- the overview, one table per machine (system), under a line naming its best method (the
  geometric mean of its tracking-error ratios, ``report.summary``) and, where that one learns on
  the references it is scored on, the best that predicts for a reference it has not run: a row
  per method, a column per axis of the tracking error (and of the TCP position error where the CSV
  has it), period ``all``; each cell "RMS +- std" (the RMS alone for one seed; "2 of 3 seeds"
  where a cell failed) in the column's own unit (its axis's: deg on a revolute axis, mm on a
  prismatic one), its background coloured by the ratio RMS / RMS of
  ``report.REFERENCE_METHOD`` (the physical model; each column's best where the CSV lacks it) on a
  log scale, green better, red worse (``ratio_colour``), the lowest RMS per column bold with a
  marker; the last columns are the geometric mean of the row's ratios, the learner's share of the
  learnable (``shares``: 1 all that per-reference ILC learns on its base, 0 its base; the mean over
  the columns, each column's in the cell's tooltip) and the plant trials the method learned from;
  a method that learns on each reference it is scored on (ILC, ``report.learned_on_scored``) is
  marked, and the marker explained under the legend. Clicking a
  column header sorts the rows by it (a few lines of inline JavaScript, no library);
- the details per machine: a compact table per (signal, period) with MA, RMS +- std and Inf per
  axis (each axis headed with its unit), seeds, plant trials, env steps and fit seconds
  (collapsible; the tracking error open), the bar charts of RMS on a log axis (a panel per unit
  where the axes' units differ) and the tracking-error traces as one small panel per method and
  axis, each axis in its unit;
- failed cells with their errors.

Everything is inline: CSS, the sorting script and the figures (PNG as base64 ``data:`` URIs), so the
file works alone from a ``file://`` URL with no network. Every string taken from the CSV is
escaped with ``html.escape``.
"""

from __future__ import annotations

import base64
import html
import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..data import atomic_write
from ..metrics import METRICS, RANKED_BY
from ..provenance import __version__
from .report import (
    KEYS,
    REFERENCE_METHOD,
    SCORED_NOTE,
    SHARE_NOTE,
    SPREAD,
    bar_figures,
    count_text,
    failures,
    gain_text,
    learned_on_scored,
    method_order,
    notes,
    provenance,
    ranking,
    summary,
    trace_figures,
)

POSITION_UNITS = ("deg", "mdeg", "rad", "mrad", "mm", "um", "µm", "m")
"""Units of a position error: the overview's columns are the axes of the signals measured in them
(period ``all``), how well each method tracks; the first such signal of a machine is its own
tracking error, whose table opens."""
PERIOD_LABELS = {"all": "whole trial", "dynamic": "while the reference moves", "static": "at rest"}
SATURATION_DECADES = 1.5
"""Ratios beyond 10**+-1.5 (about 32x better or worse) get the full colour."""
GREEN, WHITE, RED = (np.array(c, dtype=float) for c in ((26, 152, 80), (255, 255, 255), (215, 48, 39)))
LEGEND_RATIOS = (1 / 30, 1 / 10, 1 / 3, 1, 3, 10, 30)

e = html.escape


def page_path(path: str | Path) -> Path:
    """The page's file: ``path`` itself where it ends in .html (or .htm), else ``path/index.html``
    (``path`` a folder, existing or to be made in an existing parent folder)."""
    path = Path(path)
    if path.suffix.lower() in (".html", ".htm"):
        if path.is_dir():
            raise ValueError(f"{path} is a folder, not a page file")
        return path
    if path.exists() and not path.is_dir():
        raise ValueError(f"{path} is neither a folder nor a file ending in .html")
    if not path.parent.resolve().is_dir():
        raise ValueError(f"cannot write the page into {path}: folder {path.parent} does not exist")
    return path / "index.html"


def ratio_colour(ratio: float) -> str | None:
    """Background colour (CSS hex) for a ratio RMS / RMS_reference: white at 1, green below, red above,
    on a log scale saturating at ``SATURATION_DECADES``; None for a ratio that is not a positive number."""
    if not (np.isfinite(ratio) and ratio > 0):
        return None
    t = float(np.clip(np.log10(ratio) / SATURATION_DECADES, -1.0, 1.0))
    rgb = WHITE + abs(t) * 0.8 * ((GREEN if t < 0 else RED) - WHITE)
    return "#" + "".join(f"{int(round(v)):02x}" for v in rgb)


def _pm(mean: float, std: float, seeds: int) -> str:
    """"mean ± std" with three significant digits of the mean and the std to the same decimals; the
    mean alone for one seed (whose standard deviation is undefined, not 0)."""
    if not np.isfinite(mean):
        return "–"
    std = 0.0 if not np.isfinite(std) else std
    decimals = 3 if mean == 0 else 2 - int(np.floor(np.log10(abs(mean))))
    if decimals > 7 or abs(mean) >= 1e5:
        return f"{mean:.3g}" + (f" ± {std:.2g}" if seeds >= 2 else "")
    decimals = max(0, decimals)
    return f"{mean:.{decimals}f}" + (f" ± {std:.{decimals}f}" if seeds >= 2 else "")


def _joined_units(part: pd.DataFrame) -> str:
    """The units of ranking rows, in order of appearance: "deg", or "mm, deg"."""
    return ", ".join(dict.fromkeys(map(str, part["unit"])))


def _method(name: str, scored: set) -> str:
    """A method's row header: its name, marked where it learned on the references it is scored on."""
    mark = (f"<sup class='scored' title='{e(SCORED_NOTE)}'>†</sup>" if name in scored else "")
    return f"<th scope='row' class='method'>{e(name)}{mark}</th>"


def _num(v: float, count: bool = False) -> str:
    if v is None or not np.isfinite(v):
        return "–"
    if count:
        return f"{v:,.0f}" if abs(v - round(v)) < 1e-9 or abs(v) >= 100 else f"{v:,.1f}"
    return f"{v:.3g}"


def _value(v: float) -> str:
    """A cell's sort key (``data-value``): the number in full, empty for a missing one."""
    return repr(float(v)) if v is not None and np.isfinite(v) else ""


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]+", "-", str(text)).strip("-") or "x"


def _provenance(df: pd.DataFrame, reference_set: str, source: str) -> str:
    seeds = sorted({int(s) for s in df.loc[df["status"] == "ok", "seed"]}) if not df.empty else []
    stamps = pd.to_datetime(df["timestamp"], errors="coerce", utc=True).dropna() if not df.empty else pd.Series([])
    newest = f" · newest row {stamps.max():%Y-%m-%d %H:%M} UTC" if len(stamps) else ""
    name = Path(source).name if source else "(results frame, no file)"
    runs = df["run_id"].nunique() if not df.empty else 0
    configs = ", ".join(sorted({str(v) for v in df["config_hash"].dropna()})) if "config_hash" in df else ""
    return (f"<b>{e(name)}</b>: {e(provenance(df))} · configuration <code>{e(configs or 'unknown')}</code> · "
            f"{runs} run(s), seeds {e(', '.join(map(str, seeds)) or 'none')}{newest} · {e(reference_set)} references · "
            f"mean over seeds, ± sample std over seeds; counts over seeds as their range · this page: lcgym "
            f"{e(__version__)}")


def _ratios(values: pd.Series, reference: float | None) -> pd.Series:
    base = reference if reference is not None and np.isfinite(reference) and reference > 0 else values[values > 0].min()
    return values / base if base and np.isfinite(base) else values * np.nan


def _tracked(table: pd.DataFrame, system: str) -> list[str]:
    """The signals of ``system``'s ranking rows measured in a unit of position (``POSITION_UNITS``), in
    the rows' order: its tracking error first."""
    part = table[table["system"] == system]
    units = part.groupby("signal", sort=False)["unit"].agg(lambda u: set(map(str, u)))
    return [s for s, used in units.items() if used <= set(POSITION_UNITS)]


def _labels(df: pd.DataFrame) -> dict[str, str]:
    """Each signal's label as its bench declared it (the rows' ``signal_label``)."""
    return dict(zip(df["signal"].astype(str), df["signal_label"].astype(str), strict=True))


def _winners(winners: pd.DataFrame | None, system: str, scored: set) -> str:
    """The line naming a machine's best method (its tracking error's geometric mean over the axes,
    ``report.summary``) and, where that one learns on the references it is scored on, the best that
    predicts for a reference it has not run."""
    if winners is None or system not in winners.index:
        return ""
    r = winners.loc[system]
    dagger = "†" if r["best"] in scored else ""

    def gain(ratio: float) -> str:
        return f" {1 / ratio:.1f}× below {e(r['against'])}" if r["against"] and np.isfinite(ratio) and ratio < 1 else ""

    text = f"best <b>{e(r['best'])}{dagger}</b>{gain(r['ratio'])}"
    tip = f"best: {r['best']}, {gain_text(r['best'], r['ratio'], r['against'])}"
    if r["predicting"] and r["predicting"] != r["best"]:
        text += f" · best for an unseen reference <b>{e(r['predicting'])}</b>{gain(r['predicting_ratio'])}"
        tip += (f"; the best that predicts for a reference it has not run: {r['predicting']}, "
                f"{gain_text(r['predicting'], r['predicting_ratio'], r['against'])}")
    return f"<p class='winners' title='{e(tip)}'>{text}</p>"


def _overview(table: pd.DataFrame, fails: pd.DataFrame, system: str, scored: set, labels: dict[str, str],
              winners: pd.DataFrame | None = None) -> str:
    """One machine's overview table (or a note where it has no tracking rows); ``scored``: the methods
    to mark as learned on the references they are scored on; ``labels``: the signals' labels;
    ``winners``: ``report.summary``'s rows, by system (its line names the best method, and the best
    that predicts for a reference it has not run)."""
    tracked = _tracked(table, system)
    part = table[(table["system"] == system) & (table["period"] == "all") & table["signal"].isin(tracked)]
    if part.empty:
        return f"<section class='machine'><h3>{e(system)}</h3><p class='muted'>no tracking-error rows</p></section>"
    columns = [(s, a) for s in tracked for a in dict.fromkeys(part.loc[part["signal"] == s, "axis"])]
    methods = method_order(part[part["signal"] == tracked[0]]) or method_order(part)
    methods += [m for m in dict.fromkeys(part["method"]) if m not in methods]
    cells = part.set_index(["signal", "axis", "method"]).sort_index()
    has_reference = REFERENCE_METHOD in set(part["method"])
    ratio_of, best_of = {}, {}
    for col in columns:
        rms = cells.loc[col, RANKED_BY] if col in cells.index.droplevel(2) else pd.Series(dtype=float)
        ref = rms.get(REFERENCE_METHOD) if has_reference else None
        ratio_of[col] = _ratios(rms, ref)
        best_of[col] = rms.idxmin() if len(rms) else None
    rows = []
    for m in methods:
        ratios = [ratio_of[c].get(m, np.nan) for c in columns]
        finite = [r for r in ratios if np.isfinite(r) and r > 0]
        summary = float(np.exp(np.mean(np.log(finite)))) if len(finite) == len(columns) else np.nan
        own = part[part["method"] == m]
        trials = (own["plant_trials"].mean(), count_text(own["plant_trials_min"].min(), own["plant_trials_max"].max()))
        versus = own["vs_base"].to_numpy(dtype=float) if "vs_base" in own else np.array([np.nan])
        gain = (float(np.exp(np.mean(np.log(versus)))) if len(versus) == len(columns) and np.isfinite(versus).all()
                and (versus > 0).all() else np.nan, str(own["base"].iloc[0]) if "base" in own and len(own) else "")
        # its share of the learnable (``shares``) in each of the overview's columns, in their order
        of = own.set_index(["signal", "axis"])["share"]
        learnable = [float(of.get(c, np.nan)) for c in columns]
        rows.append((m, ratios, summary, trials, gain, learnable))
    rows.sort(key=lambda r: (not np.isfinite(r[2]), r[2] if np.isfinite(r[2]) else 0.0))
    ref_name = f"{REFERENCE_METHOD}" if has_reference else "the column's best"
    head = ["<th data-col='0' class='method' scope='col'>method</th>"]
    unit_of = part.groupby(["signal", "axis"], sort=False)["unit"].first()
    for i, (signal, axis) in enumerate(columns, start=1):
        unit = str(unit_of[(signal, axis)])
        label = labels.get(signal, str(signal))
        kind = "" if signal == tracked[0] else f"{label.split(' ')[0]}, "
        head.append(f"<th data-col='{i}' scope='col' title='{e(label)}, RMS ± std [{e(unit)}]'>"
                    f"{e(str(axis))}<small>{e(kind)}{e(unit)}</small></th>")
    n = len(columns)
    head.append(f"<th data-col='{n + 1}' scope='col' aria-sort='ascending' title='geometric mean over the columns of RMS / "
                f"RMS of {e(ref_name)}: for a learner built on the physical model, its gain over its base (a learner "
                f"on another base gives its ratio to that base below)'>× {e(REFERENCE_METHOD if has_reference else 'best')}"
                f"<small>geo. mean</small></th>")
    head.append(f"<th data-col='{n + 2}' scope='col' title='{e(SHARE_NOTE)}; the mean over the columns (each "
                f"column's in the tooltip of the cell)'>share</th>")
    head.append(f"<th data-col='{n + 3}' scope='col' title='closed-loop plant runs the method learned from, over "
                f"seeds (their range where seeds differ)'>trials<small>plant</small></th>")
    body = []
    most = int(part["seeds"].max()) if len(part) else 0  # the seeds the machine ran; a cell's mean may have fewer
    for m, ratios, summary, trials, (gain, base), learnable in rows:
        tds = [_method(str(m), scored)]
        for col, ratio in zip(columns, ratios, strict=True):
            key = (*col, m)
            if key not in cells.index:
                tds.append("<td data-value=''>–</td>")
                continue
            r = cells.loc[key]
            colour = ratio_colour(ratio)
            best = best_of[col] == m
            style = f" style='background:{colour}'" if colour else ""
            tip = f"{ratio:.3g} × {ref_name}; {int(r['seeds'])} seed(s)" if np.isfinite(ratio) else f"{int(r['seeds'])} seed(s)"
            mark = "<span class='best' aria-label='lowest RMS'>★</span>" if best else ""
            fewer = (f"<small class='fewer' title='a mean over fewer seeds than the machine ran: a cell failed'>"
                     f"{int(r['seeds'])} of {most} seeds</small>" if int(r["seeds"]) < most else "")
            tds.append(f"<td data-value='{_value(r[RANKED_BY])}'{style} title='{e(tip)}' class='{'top' if best else ''}'>"
                       f"{mark}{e(_pm(r[RANKED_BY], r[SPREAD], int(r['seeds'])))}{fewer}</td>")
        times = "×" if np.isfinite(summary) else ""
        other_base = (f"<small title='geometric mean of RMS / RMS of its base, {e(base)}'>{e(_num(gain))}× {e(base)}"
                      f"</small>" if base and base != REFERENCE_METHOD and np.isfinite(gain) else "")
        tds.append(f"<td data-value='{_value(summary)}' class='ratio'>{e(_num(summary))}{times}{other_base}</td>")
        finite = [x for x in learnable if np.isfinite(x)]
        mean = float(np.mean(finite)) if finite else np.nan
        per_column = ", ".join(f"{a} {'–' if not np.isfinite(x) else f'{x:.2f}'}" for (_, a), x in zip(columns, learnable,
                                                                                                       strict=True))
        tip = f" title='{e(per_column)}'" if finite else ""
        tds.append(f"<td data-value='{_value(mean)}' class='share'{tip}>{e(_num(mean) if finite else '–')}</td>")
        tds.append(f"<td data-value='{_value(trials[0])}' class='count'>{e(trials[1])}</td>")
        body.append("<tr>" + "".join(tds) + "</tr>")
    failed = fails[fails["system"] == system]
    note = ""
    if not failed.empty:
        listed = ", ".join(f"{r['method']} (seed {r['seed']})" for r in failed.to_dict("records"))
        note = f"<p class='failnote'>failed cells, not ranked: {e(listed)} (see <a href='#failed'>below</a>)</p>"
    shown = " and ".join(f"{labels.get(s, s)} [{_joined_units(part[part['signal'] == s])}]" for s in tracked)
    return (f"<section class='machine' id='overview-{_slug(system)}'><h3>{e(str(system))} "
            f"<span class='muted'>· {e(shown)} per axis, RMS ± std</span></h3>{_winners(winners, system, scored)}"
            f"<table class='sortable overview' data-system='{e(system)}'><thead><tr>{''.join(head)}</tr></thead>"
            f"<tbody>{''.join(body)}</tbody></table>{note}</section>")


def _legend(has_reference: bool, scored: list[str]) -> str:
    """The overview's key: what a cell and its colour say, and the marker of ``scored``'s methods."""
    ref = REFERENCE_METHOD if has_reference else "the column's best"
    swatches = "".join(f"<span style='background:{ratio_colour(r)}'>{r:.2g}×</span>" for r in LEGEND_RATIOS)
    marked = (f" <span class='scored-note'><sup class='scored'>†</sup> {e(', '.join(scored))}: {e(SCORED_NOTE)}.</span>"
              if scored else "")
    return (f"<p class='legend'>Cell: RMS ± std over seeds (RMS alone for one seed), period all, in the column's unit. "
            f"Colour: RMS / RMS of <b>{e(ref)}</b> (log scale) <span class='swatches'>{swatches}</span> "
            f"<span class='best'>★</span> lowest per column. Click a header to sort.{marked}</p>")


def _details_table(part: pd.DataFrame, scored: set) -> str:
    """Methods x axes (RMS ± std coloured like the overview, MA, Inf; each axis in its unit) and the
    methods' costs; ``scored``: the methods to mark as learned on the references they are scored on."""
    axes_names = list(dict.fromkeys(part["axis"]))
    unit_of = part.groupby("axis", sort=False)["unit"].first()  # each axis its own: mm on a rail, deg on a joint
    methods = method_order(part)
    cells = part.set_index(["axis", "method"]).sort_index()
    has_reference = REFERENCE_METHOD in set(part["method"])
    head1 = ["<th rowspan='2' data-col='0' class='method' scope='col'>method</th>"]
    head2 = []
    col = 1
    shown = [RANKED_BY, *(m for m in METRICS if m != RANKED_BY)]  # the ranked norm first, with its spread
    for a in axes_names:
        head1.append(f"<th colspan='{len(shown)}' class='group' scope='colgroup'>{e(str(a))} [{e(str(unit_of[a]))}]</th>")
        for i, m in enumerate(shown):
            head2.append(f"<th data-col='{col + i}' scope='col'>{e(m)}{' ± std' if m == RANKED_BY else ''}</th>")
        col += len(shown)
    for label, tip in (("seeds", "seeds averaged"), ("trials", "plant trials learned from, mean over seeds"),
                       ("env steps", "environment steps, mean over seeds"), ("fit s", "fit and learn wall time [s], mean")):
        head1.append(f"<th rowspan='2' data-col='{col}' scope='col' title='{e(tip)}'>{e(label)}</th>")
        col += 1
    ratio_of, best_of = {}, {}
    for a in axes_names:
        rms = cells.loc[a, RANKED_BY]
        ratio_of[a] = _ratios(rms, rms.get(REFERENCE_METHOD) if has_reference else None)
        best_of[a] = rms.idxmin()
    body = []
    for m in methods:
        tds = [_method(str(m), scored)]
        for a in axes_names:
            if (a, m) not in cells.index:
                tds += ["<td data-value=''>–</td>"] * len(shown)
                continue
            r = cells.loc[(a, m)]
            colour = ratio_colour(ratio_of[a].get(m, np.nan))
            style = f" style='background:{colour}'" if colour else ""
            best = best_of[a] == m
            mark = "<span class='best' aria-label='lowest RMS'>★</span>" if best else ""
            tds.append(f"<td data-value='{_value(r[RANKED_BY])}'{style} class='{'top' if best else ''}'>{mark}"
                       f"{e(_pm(r[RANKED_BY], r[SPREAD], int(r['seeds'])))}</td>")
            tds += [f"<td data-value='{_value(r[x])}'>{e(_num(r[x]))}</td>" for x in shown[1:]]
        first = part[part["method"] == m].iloc[0]
        tds.append(f"<td data-value='{_value(float(first['seeds']))}' class='count'>{e(_num(float(first['seeds']), True))}</td>")
        for c in ("plant_trials", "env_steps"):
            text = count_text(first[f"{c}_min"], first[f"{c}_max"])
            tds.append(f"<td data-value='{_value(float(first[c]))}' class='count'>{e(text)}</td>")
        tds.append(f"<td data-value='{_value(float(first['fit_seconds']))}' class='count'>"
                   f"{e(_num(float(first['fit_seconds'])))}</td>")
        body.append("<tr>" + "".join(tds) + "</tr>")
    return (f"<table class='sortable details'><thead><tr>{''.join(head1)}</tr><tr>{''.join(head2)}</tr></thead>"
            f"<tbody>{''.join(body)}</tbody></table>")


def _png(fig) -> str:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    try:
        fig.savefig(buf, dpi=100, format="png")
    finally:
        plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _figure(stem: str, caption: str, fig) -> str:
    """An inline PNG (its title is drawn in the figure; the caption is the image's tooltip)."""
    return f"<figure><img src='data:image/png;base64,{_png(fig)}' alt='{e(stem)}' title='{e(caption)}'></figure>"


def render(df: pd.DataFrame, reference_set: str = "validation", source: str = "") -> str:
    """The page's HTML text (module docstring). ``df``: rows of ``report.select``; ``source``: the
    results CSV's path, where the traces are looked for (``runner.trace_path``)."""
    from .plots import method_colours

    missing = [c for c in ("system", "method", "seed", "status", "reference_set", "run_id") if c not in df.columns]
    if missing:
        raise ValueError(f"results frame lacks column(s) {', '.join(missing)}")
    table = ranking(df, reference_set)
    fails = failures(df)
    systems = list(dict.fromkeys(table["system"])) + [s for s in dict.fromkeys(fails["system"])
                                                       if s not in set(table["system"])]
    colours = method_colours(sorted({str(m) for m in df["method"]}))
    scored = learned_on_scored(table["method"])
    winners = summary(df, reference_set).set_index("system")
    labels = _labels(df)
    out = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
           f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
           f"<title>lcgym leaderboard</title><style>{CSS}</style></head><body>",
           "<header><h1>lcgym leaderboard</h1>"
           f"<nav>{''.join(f'<a href=#details-{_slug(s)}>{e(str(s))}</a>' for s in systems)}"
           f"{'<a href=#failed>failed cells</a>' if not fails.empty else ''}</nav></header>",
           f"<p class='provenance'>{_provenance(df, reference_set, source)}</p>"]
    if table.empty:
        out.append(f"<p class='muted'>No ranked rows: no cell with status ok on the {e(reference_set)} references.</p>")
    else:
        out.append("<section id='overview'>" + _legend(REFERENCE_METHOD in set(table["method"]), scored)
                   + "<div class='machines'>" + "".join(_overview(table, fails, s, set(scored), labels, winners)
                                                        for s in systems)
                   + "</div></section>")
    trace_of = {system: _figure(stem, caption, fig)
                for system, stem, caption, fig in (trace_figures(df, source, colours, reference_set) if source else ())}
    bar_of: dict[str, list[str]] = {}
    for system, stem, caption, fig in bar_figures(df, reference_set, colours):
        bar_of.setdefault(system, []).append(_figure(stem, caption, fig))
    for system in systems:
        out.append(f"<section class='system' id='details-{_slug(system)}'><h2>{e(str(system))}: details</h2>")
        part = table[table["system"] == system]
        for (signal, period), sub in part.groupby(["signal", "period"], sort=False):
            label = labels.get(signal, str(signal))
            units = _joined_units(sub)
            is_open = " open" if (signal == next(iter(_tracked(table, system)), None) and period == "all") else ""
            out.append(f"<details{is_open}><summary>{e(label)} <code>{e(str(signal))}</code>, "
                       f"{e(PERIOD_LABELS.get(period, str(period)))} [{e(units)}]</summary>"
                       + _details_table(sub.drop(columns=[k for k in KEYS if k != "axis"]), set(scored)) + "</details>")
        figs = bar_of.get(system, []) + ([trace_of[system]] if system in trace_of else [])
        if figs:
            out.append("<h3>Figures</h3><div class='figures'>" + "".join(figs) + "</div>")
        out.append("</section>")
    said = notes(df)
    if not said.empty:
        out.append("<section id='notes'><h2>Notes of the methods</h2><ul>")
        out += [f"<li>{e(str(r['system']))} / {e(str(r['method']))} / seed {e(str(r['seed']))}: {e(str(r['note']))}</li>"
                for r in said.to_dict("records")]
        out.append("</ul></section>")
    if not fails.empty:
        out.append("<section id='failed'><h2>Failed cells</h2><table class='failed'><thead><tr><th>system</th>"
                   "<th>method</th><th>seed</th><th>error</th></tr></thead><tbody>")
        out += [f"<tr><td>{e(str(r['system']))}</td><td>{e(str(r['method']))}</td><td>{e(str(r['seed']))}</td>"
                f"<td><code>{e(str(r['error']))}</code></td></tr>" for r in fails.to_dict("records")]
        out.append("</tbody></table></section>")
    out.append("<footer>Each CSV row holds one seed's norms over all references of the set taken together; "
               "MA, RMS and Inf are means over seeds (Inf: the mean of the per-seed maxima), ± the sample "
               "standard deviation of RMS over seeds. Generated by <code>lcgym leaderboard --html</code>.</footer>")
    out.append(f"<script>{SCRIPT}</script></body></html>")
    return "\n".join(out) + "\n"


def write_html(df: pd.DataFrame, path: str | Path, reference_set: str = "validation", source: str = "") -> Path:
    """The leaderboard page (``render``): one self-contained HTML file (CSS, JS and figures
    inline), opening on an overview per machine, then the details. ``path``: a file ending in
    ``.html`` or a folder (created if its parent exists; the page is ``path/index.html``).
    ``source``: the results CSV's path, for its traces folder; the page names its file name only.
    Every string from the CSV is escaped. Written atomically; returns the page's path."""
    target = page_path(path)
    text = render(df, reference_set, source)
    target.parent.mkdir(exist_ok=True)
    atomic_write(target, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return target


CSS = """
:root{--fg:#1d2430;--muted:#5b6472;--line:#d9dee5;--head:#f3f5f8;--accent:#1f5fbf}
*{box-sizing:border-box}
body{font:14px/1.4 system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif;color:var(--fg);
 margin:0 auto;max-width:1260px;padding:10px 18px 40px}
header{display:flex;align-items:baseline;gap:18px;flex-wrap:wrap}
h1{font-size:20px;margin:0}
h2{font-size:17px;margin:28px 0 8px;border-bottom:1px solid var(--line);padding-bottom:3px}
h3{font-size:14px;margin:0 0 4px}
h3 .muted{font-weight:400;font-size:12.5px}
nav a{color:var(--accent);text-decoration:none;margin-right:12px;font-size:13px}
code{font:12px ui-monospace,SFMono-Regular,Menlo,Consolas,monospace}
.provenance{color:var(--muted);font-size:12.5px;margin:3px 0 6px}
.provenance b{color:var(--fg)}
.legend{font-size:12.5px;color:var(--muted);margin:4px 0 8px}
.swatches span{display:inline-block;padding:0 5px;font-size:11px;color:var(--fg);border:1px solid var(--line);margin-left:-1px}
.best{color:#0b5d1e;font-size:11px;margin-right:3px}
sup.scored{color:#8a4b00;font-weight:600;margin-left:1px}
.scored-note{display:block;margin-top:2px}
.machines{display:flex;flex-wrap:wrap;gap:8px 12px;align-items:flex-start}
table{border-collapse:collapse;font-variant-numeric:tabular-nums}
th,td{border:1px solid var(--line);padding:2px 7px;text-align:right;white-space:nowrap}
thead th{background:var(--head);font-weight:600;vertical-align:bottom}
thead th small{display:block;font-weight:400;color:var(--muted);font-size:11px}
th[data-col]{cursor:pointer;user-select:none}
th[data-col]:hover{background:#e6ebf2}
th[aria-sort=ascending]::after{content:" ▲";font-size:9px;color:var(--accent)}
th[aria-sort=descending]::after{content:" ▼";font-size:9px;color:var(--accent)}
th.method,td.method{text-align:left}
tbody th{font-weight:500}
td.top{font-weight:700}
td.ratio,td.count,td.share{color:var(--muted)}
td.ratio small{display:block;font-size:11px}
td small.fewer{display:block;font-size:10px;color:var(--muted)}
p.winners{margin:0 0 2px;font-size:11px;white-space:nowrap;overflow:hidden;text-overflow:ellipsis}
table.overview{font-size:11.5px}
table.overview th,table.overview td{padding:1px 3px}
table.details{font-size:12.5px;margin:4px 0 10px}
details{margin:4px 0}
summary{cursor:pointer;font-weight:600;padding:2px 0}
.failnote{color:#a4281c;font-size:12px;margin:3px 0}
.muted{color:var(--muted)}
.figures{display:flex;flex-direction:column;gap:14px}
figure{margin:0}
figure img{max-width:100%;height:auto;display:block}
table.failed td{text-align:left;white-space:normal}
footer{margin-top:30px;color:var(--muted);font-size:12px}
"""

SCRIPT = """
(function(){
  function key(row, col){
    var cell = row.cells[col], v = cell.getAttribute('data-value');
    if (v === null) return cell.textContent.trim().toLowerCase();
    return v === '' ? NaN : parseFloat(v);
  }
  function sortTable(table, th){
    var col = parseInt(th.getAttribute('data-col'), 10);
    var asc = th.getAttribute('aria-sort') !== 'ascending';
    table.querySelectorAll('th[data-col]').forEach(function(h){ h.removeAttribute('aria-sort'); });
    th.setAttribute('aria-sort', asc ? 'ascending' : 'descending');
    var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
    rows.sort(function(a, b){
      var x = key(a, col), y = key(b, col);
      if (typeof x === 'number' && typeof y === 'number'){
        if (isNaN(x) || isNaN(y)) return isNaN(x) - isNaN(y);  /* missing values last */
        return asc ? x - y : y - x;
      }
      var c = String(x).localeCompare(String(y));
      return asc ? c : -c;
    });
    rows.forEach(function(r){ body.appendChild(r); });
  }
  document.querySelectorAll('table.sortable').forEach(function(table){
    table.querySelectorAll('th[data-col]').forEach(function(th){
      th.tabIndex = 0;
      th.addEventListener('click', function(){ sortTable(table, th); });
      th.addEventListener('keydown', function(ev){
        if (ev.key === 'Enter' || ev.key === ' ') { ev.preventDefault(); sortTable(table, th); }
      });
    });
  });
})();
"""
