"""The leaderboard report: rankings per system, signal and axis, as text, Markdown or HTML.

What is ranked: one configuration of a results CSV (``config_hash``: budgets, systems and lcgym
code; by default the one of the newest row; other configurations in the file are named, not
mixed in), and of each (system, method, seed) cell only its newest run.

Ranking (``ranking``): rows with status ok of one reference set (validation by default), grouped
by (system, signal, period, axis, method). Each row of the CSV holds the norms of one seed over all the
set's references taken together (dwells included). MA, RMS and Inf are averaged over seeds (so
Inf is the mean of the per-seed maxima), ``RMS_std`` is the sample standard deviation of RMS over
seeds (ddof 1; 0 for one seed, where it is undefined: the text, Markdown and HTML views then show no
spread) and ``seeds`` their count; methods are ranked by mean RMS (1 = best). Each row keeps its
axis's unit (a prismatic axis's tracking error in mm beside revolute ones in deg; each axis's input
unit), and each machine's axes keep the order of its rows. Failed cells are listed separately.
Methods that learn on each reference they are scored on (``learned_on_scored``: ILC) are named as
such in every view. The Markdown and HTML pages add bar charts of RMS per method and axis (log
axis; a panel per unit where the axes' units differ), and the tracking-error traces as one small
panel per method when the CSV's traces folder is at hand; the HTML page (``page``) opens on an
overview per machine and is one self-contained file.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd

from ..data import atomic_write
from ..metrics import METRICS, PERIODS, RANKED_BY
from ..provenance import __version__
from .shares import mean_shares

KEYS = ["system", "signal", "period", "axis"]
SPREAD = f"{RANKED_BY}_std"
"""The ranking's column of the ranked norm's sample standard deviation over seeds."""
NORM_COLUMNS = [m for c in METRICS for m in ((c, SPREAD) if c == RANKED_BY else (c,))]
"""The ranking's norm columns: each of ``metrics.METRICS``, the ranked one followed by its spread."""


def select(df: pd.DataFrame, config_hash: str | None = None) -> tuple[pd.DataFrame, list[str]]:
    """Rows of one configuration per machine (``config_hash``, else each machine's newest: a file may
    collect machines benchmarked at different times), newest run per cell; and the other
    configuration hashes present in the file."""
    if df.empty:
        return df, []
    newest = df.sort_values("timestamp", kind="stable")
    if config_hash is not None and config_hash not in set(df["config_hash"]):
        raise ValueError(f"configuration {config_hash!r} not in the results; present: {sorted(set(df['config_hash']))}")
    if config_hash:
        part = newest[newest["config_hash"] == config_hash]
    else:
        per_machine = newest.groupby("system", sort=False)["config_hash"].last()
        part = newest[newest["config_hash"] == newest["system"].map(per_machine)]
    chosen = set(part["config_hash"])
    last_run = part.groupby(["system", "method", "seed"])["run_id"].transform("last")
    part = part[part["run_id"] == last_run]
    others = sorted(set(df["config_hash"]) - chosen)
    return part.sort_index(), others


def ranking(df: pd.DataFrame, reference_set: str = "validation") -> pd.DataFrame:
    """Mean norms over seeds and the rank by RMS per (system, signal, axis); each machine's axes in the
    order of its rows (the machine's own order). ``vs_base``: a learner's RMS over its base's;
    ``share``: its share of the learnable, from the means (``shares.mean_shares``)."""
    ok = df[(df["status"] == "ok") & (df["reference_set"] == reference_set)]
    if ok.empty:
        return pd.DataFrame(columns=[*KEYS, "rank", "method", "base", "vs_base", "share", *NORM_COLUMNS, "unit", "seeds"])
    # the means over seeds summed in seed order, not in the order the cells finished (a parallel run's):
    # else two methods of equal values can differ in the last bit and their tie be broken by chance
    g = ok.sort_values("seed", kind="stable").groupby([*KEYS, "method"], sort=False)
    norms = {c: (c, "mean") for c in METRICS} | {SPREAD: (RANKED_BY, "std")}
    table = g.agg(**{c: norms[c] for c in NORM_COLUMNS},
                  unit=("unit", "first"), base=("base", "first"), seeds=("seed", "nunique"),
                  plant_trials=("plant_trials", "mean"),
                  plant_trials_min=("plant_trials", "min"), plant_trials_max=("plant_trials", "max"),
                  env_steps=("env_steps", "mean"), env_steps_min=("env_steps", "min"),
                  env_steps_max=("env_steps", "max"), fit_seconds=("fit_seconds", "mean")).reset_index()
    table[SPREAD] = table[SPREAD].fillna(0.0)
    table["base"] = table["base"].fillna("").astype(str)
    table["vs_base"] = _versus_base(table)
    table["share"] = mean_shares(table, KEYS)
    table["rank"] = table.groupby(KEYS)[RANKED_BY].rank(method="min").astype(int)
    # signals in the order the rows give them (each bench's declared order), periods in PERIODS' order
    order = {"signal": {s: i for i, s in enumerate(dict.fromkeys(ok["signal"]))},
             "period": {p: i for i, p in enumerate(PERIODS)}}
    # each machine's axes in the order its rows give them (the machine's: rail, shoulder, elbow), not alphabetical
    seen = {key: i for i, key in enumerate(dict.fromkeys(zip(ok["system"], ok["signal"], ok["axis"], strict=True)))}
    table["axis_order"] = [seen[key] for key in zip(table["system"], table["signal"], table["axis"], strict=True)]
    table = table.sort_values(["system", "signal", "period", "axis_order", "rank", "method"],
                              key=lambda c: c.map(order[c.name]) if c.name in order else c, kind="stable")
    return table[[*KEYS, "rank", "method", "base", "vs_base", "share", *NORM_COLUMNS, "unit", "seeds", "plant_trials",
                  "env_steps", "fit_seconds", *COUNT_RANGES]].reset_index(drop=True)


def _versus_base(table: pd.DataFrame) -> pd.Series:
    """Per ranking row, its RMS / the RMS of its base's row (the method named as its ``base``,
    "physical" or "basic", on the same system, signal, period and axis): below 1, the learner
    improved on what it built on. NaN for a method with no base or whose base was not run."""
    rms = table.set_index([*KEYS, "method"])[RANKED_BY]
    keys = list(zip(*(table[k] for k in KEYS), table["base"], strict=True))
    base = [rms.get(k, np.nan) if k[-1] else np.nan for k in keys]
    return pd.Series(table[RANKED_BY].to_numpy() / np.asarray(base, dtype=float), index=table.index)


COUNT_RANGES = ("plant_trials_min", "plant_trials_max", "env_steps_min", "env_steps_max")
"""``ranking``'s columns of the counts' least and greatest value over seeds (their mean, for sorting,
is ``plant_trials`` and ``env_steps``)."""


def count_text(low: float, high: float) -> str:
    """A count over seeds as people read it: one integer, or the range "low-high" where seeds differ."""
    if not (np.isfinite(low) and np.isfinite(high)):
        return "–"
    return f"{low:,.0f}" if low == high else f"{low:,.0f}–{high:,.0f}"


def provenance(df: pd.DataFrame) -> str:
    """Where the rows of a results frame come from, as the rows say (which may not be the lcgym
    that reads them): the lcgym version(s) and commit(s) that wrote them and the dates of their runs."""
    def joined(col: str) -> str:
        values = sorted({str(v) for v in df[col].dropna()}) if col in df else []
        return ", ".join(values) or "unknown"

    stamps = pd.to_datetime(df["timestamp"], errors="coerce", utc=True).dropna() if "timestamp" in df else pd.Series([])
    days = sorted({f"{t:%Y-%m-%d}" for t in stamps})
    when = f", runs of {days[0]}" + (f" to {days[-1]}" if len(days) > 1 else "") if days else ""
    return f"rows written by lcgym {joined('lcgym_version')} at commit {joined('git_commit')}{when}"


def share_table(df: pd.DataFrame, of: str, base: str, reference_set: str = "validation") -> pd.DataFrame:
    """Paper 002's Table 6 for every method: per (system, signal, period), the RMS over the signal's
    axes together (sqrt of the mean square of the per-axis RMS: the axes have equal sample counts)
    of ``base``, of ``of`` and of each method, and each method's share of what ``of`` changed:
    |RMS - RMS_base| / |RMS_of - RMS_base| [%] as the paper computes it (a worsening counts like an
    improvement), and the signed (RMS_base - RMS) / (RMS_base - RMS_of) [%]. Signals whose rows have
    periods other than ``all`` only (the paper's errors)."""
    table = ranking(df, reference_set)
    periodic = set(table.loc[table["period"] != "all", "signal"])
    table = table[table["signal"].isin(periodic)]
    methods = set(table["method"])
    for name, role in ((of, "--share-of"), (base, "--base")):
        if name not in methods:
            present = ", ".join(sorted(methods)) or "none"
            raise ValueError(f"{role} {name}: no such method among the rows with periods ({present})")
    stacked = (table.assign(ms=table["RMS"] ** 2).groupby(["system", "signal", "period", "method"], sort=False)["ms"]
               .mean().pow(0.5).rename("RMS").reset_index())
    rows = []
    for (system, signal, period), part in stacked.groupby(["system", "signal", "period"], sort=False):
        rms = dict(zip(part["method"], part["RMS"], strict=True))
        if of not in rms or base not in rms:
            continue
        change = rms[of] - rms[base]
        for method, value in rms.items():
            share = abs(value - rms[base]) / abs(change) * 100 if change else np.nan
            signed = (rms[base] - value) / (rms[base] - rms[of]) * 100 + 0.0 if change else np.nan  # + 0.0: no -0
            rows.append({"system": system, "signal": signal, "period": period, "method": method, "RMS": value,
                         "share": share, "signed_share": signed})
    return pd.DataFrame(rows)


def format_shares(df: pd.DataFrame, of: str, base: str, reference_set: str = "validation") -> str:
    """``share_table`` as text: one block per system and signal, a row per period and method."""
    table = share_table(df, of, base, reference_set)
    out = [f"\nshare of what {of} changed against {base} (paper 002 Table 6: |RMS - RMS_{base}| / "
           f"|RMS_{of} - RMS_{base}|; signed: whether the method moved the error the way {of} did)"]
    units = {key: ", ".join(dict.fromkeys(map(str, u.dropna()))) for key, u in df.groupby(["system", "signal"])["unit"]}
    for (system, signal), part in table.groupby(["system", "signal"], sort=False):
        unit = units.get((system, signal), "")  # each unit of the signal's axes
        out.append(f"\n{system} / {signal} [{unit}] (RMS over its axes together)")
        out.append(part.drop(columns=["system", "signal"]).to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    return "\n".join(out)


def failures(df: pd.DataFrame) -> pd.DataFrame:
    bad = df[df["status"] == "failed"]
    return bad[["system", "method", "seed", "error"]].drop_duplicates().reset_index(drop=True)


def notes(df: pd.DataFrame) -> pd.DataFrame:
    """What methods said of their cells (the ``note`` column), one row per system, method and seed."""
    if "note" not in df:
        return pd.DataFrame(columns=["system", "method", "seed", "note"])
    said = df[(df["status"] == "ok") & df["note"].fillna("").astype(str).str.strip().ne("")]
    said = said[["system", "method", "seed", "note"]].drop_duplicates()
    # by machine, method and seed, whatever order the cells finished in
    return said.sort_values(["system", "method", "seed"], kind="stable").reset_index(drop=True)


def _sections(table: pd.DataFrame):
    """(system, signal, axis), part per section; a signal of one period is titled "signal (period)"."""
    for (system, signal, period, axis), part in table.groupby(KEYS, sort=False):
        yield (system, signal if period == "all" else f"{signal} ({period})", axis), part.drop(columns=KEYS)


def learned_on_scored(methods: Iterable[str]) -> list[str]:
    """The methods among ``methods`` (as the results name them) that learn on each reference they are
    scored on (their class's ``learns_on_scored_references``, ``methods.protocol.Controller``: ILC
    iterates on every validation reference before it is scored): their rows show what learning on
    the task itself reaches, not a prediction for references never seen. Only the built-in methods'
    classes are asked; a user's ``module:Class`` is not imported to read a results file."""
    from ..methods import CONTROLLERS  # light: the methods import their heavy dependencies when used

    scored = {name for name, cls in CONTROLLERS.items() if cls.learns_on_scored_references}
    return [m for m in dict.fromkeys(map(str, methods)) if (m.rpartition("@")[0] or m) in scored]


SCORED_NOTE = ("learned on each reference it is scored on (it runs the plant on that very reference before "
               "it is scored), not a prediction for unseen references")
"""What the views say of the methods of ``learned_on_scored``."""
SHARE_NOTE = ("share: a learner's share of the learnable, (base - method) / (base - ILC on that base) in RMS; 1 is all "
              "that per-reference ILC learns, 0 its base; empty where ILC is no better than the base")
"""What the views say of the ``share`` column (``shares``)."""


def format_text(df: pd.DataFrame, reference_set: str = "validation") -> str:
    """Plain-text leaderboard, one table per system, signal and axis; an empty ``RMS_std`` is a
    method of one seed (no spread)."""
    table = ranking(df, reference_set)
    out = [f"lcgym leaderboard ({reference_set} references; mean over seeds, counts as their range over seeds)",
           SHARE_NOTE]
    scored = learned_on_scored(table["method"])
    if scored:
        out.append(f"{', '.join(scored)}: {SCORED_NOTE}")
    for (system, signal, axis), part in _sections(table):
        out.append(f"\n{system} / {signal} / {axis}")
        out.append(_as_shown(part).to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    said = notes(df)
    if not said.empty:
        out.append("\nnotes of the methods:")
        out += [f"  {r['system']} / {r['method']} / seed {r['seed']}: {r['note']}" for r in said.to_dict("records")]
    fails = failures(df)
    if not fails.empty:
        out.append("\nfailed cells:")
        out += [f"  {r['system']} / {r['method']} / seed {r['seed']}: {str(r['error'])[:160]}"
                for r in fails.to_dict("records")]
    return "\n".join(out)


def summary(df: pd.DataFrame, reference_set: str = "validation") -> pd.DataFrame:
    """Per machine, the method with the lowest RMS tracking error, against the physical model: a
    method's ``ratio`` is the geometric mean over the machine's tracked axes of its RMS / the RMS of
    ``REFERENCE_METHOD`` (per axis, so that deg and mm axes weigh alike). ``best``: the lowest ratio
    (the lowest mean rank where the machine has no physical-model row: ``against`` empty, ratio
    NaN); ``runner_up`` and ``runner_up_ratio``: the next; ``axes``: the best's RMS per axis as
    "axis RMS unit" text; ``predicting``, ``predicting_ratio``, ``predicting_axes``: the same of the
    best method that predicts for a reference it has not run (not ``learned_on_scored``: the best
    itself where it is one). Machines in the leaderboard's order."""
    table = ranking(df, reference_set)
    table = table[(table["signal"] == "tracking_error") & (table["period"] == "all")]
    rows = []
    for system, part in table.groupby("system", sort=False):
        rms = part.pivot_table(index="method", columns="axis", values=RANKED_BY, sort=False)
        against = REFERENCE_METHOD if REFERENCE_METHOD in rms.index else ""
        if against:
            ratio = np.exp(np.log(rms / rms.loc[against]).mean(axis=1)).sort_values(kind="stable")
        else:
            ratio = pd.Series(np.nan, index=method_order(part))
        units = part.drop_duplicates("axis").set_index("axis")["unit"]
        best = str(ratio.index[0])
        scored = set(learned_on_scored(ratio.index))
        predicting = next((str(m) for m in ratio.index if str(m) not in scored), "")

        rows.append({"system": system, "best": best, "ratio": float(ratio.iloc[0]), "against": against,
                     "runner_up": str(ratio.index[1]) if len(ratio) > 1 else "",
                     "runner_up_ratio": float(ratio.iloc[1]) if len(ratio) > 1 else np.nan, "axes": _axes_text(rms, units, best),
                     "predicting": predicting, "predicting_ratio": float(ratio[predicting]) if predicting else np.nan,
                     "predicting_axes": _axes_text(rms, units, predicting)})
    return pd.DataFrame(rows, columns=["system", "best", "ratio", "against", "runner_up", "runner_up_ratio", "axes",
                                       "predicting", "predicting_ratio", "predicting_axes"])


def _axes_text(rms: pd.DataFrame, units: pd.Series, method: str) -> str:
    """A method's RMS per axis as "axis RMS unit" text ("" for no method)."""
    return ", ".join(f"{a} {rms.loc[method, a]:.3g} {units[a]}" for a in rms.columns) if method else ""


def gain_text(method: str, ratio: float, against: str) -> str:
    """A method's gain over the physical model as the summary says it."""
    if not against:
        return "(no physical-model row to compare with)"
    if method == against:
        return "the physical model itself"
    return f"{1 / ratio:.1f}x lower than the physical model's" if ratio <= 1 else f"{ratio:.2f}x the physical model's RMS"


def format_summary(df: pd.DataFrame, reference_set: str = "validation") -> str:
    """``summary`` as one line per machine: the best method, its gain over the physical model, its RMS;
    where that method learns on the references it is scored on, a second line names the best that
    predicts for a reference it has not run."""
    table = summary(df, reference_set)
    if table.empty:
        return f"no {reference_set} tracking errors to summarize"
    width, name = max(len(s) for s in table["system"]), max(len(m) for m in table["best"])
    lines = [f"best on each machine ({reference_set} references, RMS tracking error; several axes: the geometric "
             "mean of the per-axis ratios):"]
    for r in table.to_dict("records"):
        if not r["against"]:
            gain = "(no physical-model row to compare with)"
        elif r["best"] == r["against"]:
            gain = "no method beats the physical model" + (
                f" ({r['runner_up']}: {r['runner_up_ratio']:.2f}x its RMS)" if r["runner_up"] else "")
        else:
            gain = f"{1 / r['ratio']:.1f}x lower than the physical model's"
        if learned_on_scored([r["best"]]):
            gain += " (learned on the references it is scored on)"
        lines.append(f"  {r['system']:<{width}}  {r['best']:<{name}}  {gain}; {r['axes']}")
        if r["predicting"] and r["predicting"] != r["best"]:
            lines.append(f"  {r['system']:<{width}}  best for a reference it has not run: {r['predicting']}, "
                         f"{gain_text(r['predicting'], r['predicting_ratio'], r['against'])}; {r['predicting_axes']}")
    return "\n".join(lines)


def _as_shown(part: pd.DataFrame) -> pd.DataFrame:
    """``ranking`` rows as the text and Markdown tables show them: the counts as ``count_text`` writes
    them (their ranges' columns dropped), ``RMS_std`` empty for a method of one seed (its
    standard deviation is undefined, not 0), and the base and the RMS / the base's as "0.52x" ("–"
    for a method with no base)."""
    counts = {c: [count_text(lo, hi) for lo, hi in zip(part[f"{c}_min"], part[f"{c}_max"], strict=True)]
              for c in ("plant_trials", "env_steps")}
    spread = ["" if seeds < 2 else f"{std:.4g}" for std, seeds in zip(part[SPREAD], part["seeds"], strict=True)]
    versus = ["–" if not np.isfinite(v) else f"{v:.2f}x" for v in part["vs_base"]]
    shares = ["–" if not np.isfinite(v) else f"{v:.2f}" for v in part["share"]]
    base = [b or "–" for b in part["base"]]
    return part.drop(columns=list(COUNT_RANGES)).assign(**counts, **{SPREAD: spread}, base=base, vs_base=versus,
                                                        share=shares)


REFERENCE_METHOD = "physical"
"""The method the overview's ratios and the bar charts' dashed lines refer to: the physical model's
feedforward (where a CSV lacks it, the page takes each column's best)."""


def method_order(table: pd.DataFrame) -> list[str]:
    """Methods of ranking rows, best first: by mean rank over the rows' axes, then by mean RMS."""
    if table.empty:
        return []
    score = table.groupby("method", sort=False).agg(rank=("rank", "mean"), rms=(RANKED_BY, "mean"))
    return list(score.sort_values(["rank", "rms"], kind="stable").index)


def bar_figures(df: pd.DataFrame, reference_set: str = "validation", colours: dict | None = None):
    """(system, file stem, caption, Figure) per (system, signal): RMS per method and axis on a log axis, with
    the seed spread (``plots.rms_bar_figure``; period ``all``, the periods' rows are in the tables).
    A signal whose axes differ in unit (mm on a rail, deg on the joints) is one figure with a panel
    per unit."""
    from .plots import method_colours, rms_bar_figure

    table = ranking(df, reference_set)
    table = table[table["period"] == "all"]
    colours = colours or method_colours(sorted(set(table["method"])))
    for (system, signal), part in table.groupby(["system", "signal"], sort=False):
        order = {m: i for i, m in enumerate(method_order(part))}
        part = part.sort_values("method", key=lambda c: c.map(order), kind="stable")
        caption = (f"{system}: {signal} RMS per axis\n({reference_set} references; bars: mean over seeds, "
                   f"whiskers: +- std over seeds)")
        yield system, f"{system}_{signal}", caption, rms_bar_figure(part, caption, colours, REFERENCE_METHOD)


def trace_figures(df: pd.DataFrame, csv_path: str | Path, colours: dict | None = None,
                  reference_set: str = "validation"):
    """(system, file stem, caption, Figure) per system whose traces are beside the CSV (each row's
    own configuration's, ``runner.stored_trace``): the tracking error of each method on the first
    validation reference of the lowest seed, one small panel per method and axis (``plots.trace_grid_figure``), methods
    best first by their tracking-error rank. Each axis is drawn in the unit of its tracking-error
    rows (deg or mm; the traces are stored in rad or m); an axis without such rows is left out."""
    from .plots import method_colours, trace_grid_figure
    from .runner import stored_trace

    ok = df[df["status"] == "ok"]
    table = ranking(df, reference_set)
    colours = colours or method_colours(sorted(set(ok["method"])))
    for system, part in ok.groupby("system", sort=False):
        seed = int(part["seed"].min())
        ranked = method_order(table[(table["system"] == system) & (table["signal"] == "tracking_error")
                                    & (table["period"] == "all")])
        methods = ranked + [m for m in dict.fromkeys(part["method"]) if m not in ranked]
        configs = part[part["seed"] == seed].groupby("method")["config_hash"].last() if "config_hash" in part else {}
        traces = {m: stored_trace(csv_path, system, m, seed, configs.get(m)) for m in methods}
        rows = part[part["signal"] == "tracking_error"]
        units = rows.groupby("axis", sort=False)["unit"].first().to_dict()
        keep = ["t", *(f"{kind}_{a}" for a in units for kind in ("ref", "error"))]
        traces = {m: pd.read_parquet(p) for m, p in traces.items() if p is not None}
        traces = {m: frame[[c for c in keep if c in frame.columns]] for m, frame in traces.items()}
        if not traces or not any(c.startswith("ref_") for c in next(iter(traces.values())).columns):
            continue
        shown = "; ".join(f"{', '.join(a for a in units if units[a] == u)} in {u}" for u in dict.fromkeys(units.values()))
        caption = f"{system}: tracking error ({shown}) on the first validation reference, seed {seed}"
        yield system, f"{system}_traces", caption, trace_grid_figure(traces, caption, colours, units=units)


def _save_figures(figures, folder: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    paths = []
    for _system, stem, _caption, fig in figures:
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / f"{stem}.png"
        try:
            atomic_write(path, lambda tmp, f=fig: f.savefig(tmp, dpi=100, format="png"))
        finally:
            plt.close(fig)
        paths.append(path)
    return paths


def bar_charts(df: pd.DataFrame, folder: Path, reference_set: str = "validation") -> list[Path]:
    """One PNG per (system, signal) in ``folder``: RMS per method, grouped by axis, log axis, with the
    seed spread (``bar_figures``)."""
    return _save_figures(bar_figures(df, reference_set), Path(folder))


def trace_plots(df: pd.DataFrame, csv_path: str | Path, folder: Path) -> list[Path]:
    """One PNG per system in ``folder``: the methods' tracking errors as small multiples, with the
    scaled reference velocity (like paper 000, Fig. 9; ``trace_figures``)."""
    return _save_figures(trace_figures(df, csv_path), Path(folder))


def write_markdown(df: pd.DataFrame, path: str | Path, reference_set: str = "validation", source: str = "") -> Path:
    """Markdown page: one ranking table per system/signal/axis; bar charts and, when the CSV's
    traces are at hand (``source``), tracking-error traces beside the page."""
    path = Path(path)
    folder = path.parent / f"{path.stem}_figures"
    figures = bar_charts(df, folder, reference_set) + (trace_plots(df, source, folder) if source else [])
    table = ranking(df, reference_set)
    lines = [f"# lcgym leaderboard\n\n{_provenance(df, reference_set, source)}"
             + (f" Generated by `lcgym leaderboard {source} --markdown {path}`." if source else "") + "\n"]
    lines.append(f"{SHARE_NOTE[0].upper()}{SHARE_NOTE[1:]}.\n")
    scored = learned_on_scored(table["method"])
    if scored:
        lines.append(f"{', '.join(f'`{m}`' for m in scored)}: {SCORED_NOTE}.\n")
    for (system, signal, axis), part in _sections(table):
        lines.append(f"\n## {system} / {signal} / {axis}\n")
        cols = ["rank", "method", "base", "vs_base", "share", *NORM_COLUMNS, "unit", "seeds", "plant_trials",
                "env_steps", "fit_seconds"]
        lines.append("| " + " | ".join(cols) + " |")
        lines.append("|" + "---|" * len(cols))
        for r in _as_shown(part).to_dict("records"):
            lines.append("| " + " | ".join(_cell(r[c]) for c in cols) + " |")
    lines.append("\n## Figures\n")
    lines += [f"![{p.stem}]({p.parent.name}/{p.name})" for p in figures]
    said = notes(df)
    if not said.empty:
        lines.append("\n## Notes of the methods\n")
        lines += [f"- {r['system']} / {r['method']} / seed {r['seed']}: {r['note']}" for r in said.to_dict("records")]
    fails = failures(df)
    if not fails.empty:
        lines.append("\n## Failed cells\n")
        lines += [f"- {r['system']} / {r['method']} / seed {r['seed']}: {r['error']}" for r in fails.to_dict("records")]
    atomic_write(path, lambda tmp: Path(tmp).write_text("\n".join(lines) + "\n"))
    return path


def _provenance(df: pd.DataFrame, reference_set: str, source: str) -> str:
    configs = ", ".join(sorted(set(map(str, df["config_hash"]))))
    return (f"{reference_set.capitalize()} references; mean over seeds, +- is the sample standard deviation "
            f"over seeds (RMS_std, empty for one seed); counts are integers, or their range over seeds. "
            f"{'From ' + source + ': ' if source else ''}"
            f"configuration {configs}, {df['run_id'].nunique()} run(s), {provenance(df)}; this page made by lcgym "
            f"{__version__}.")


def _cell(v) -> str:
    if isinstance(v, float):
        return "" if np.isnan(v) else f"{v:.4g}"
    return str(v)
