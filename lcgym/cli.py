"""The ``lcgym`` command. Thin: parses, calls library functions, prints.

    lcgym bench [--systems ix-v1,flexarm-v1] [--methods feedback,physical] [--seeds 0,1,2] [--quick]
                [--out results.csv] [--html DIR|OUT.html] [--no-html] [--jobs N] [--dask ADDRESS] [--resume]
                [--timeout SECONDS]
    lcgym leaderboard [results.csv] [--reference-set SET] [--config HASH] [--markdown OUT.md] [--html DIR|OUT.html]
                      [--share-of METHOD [--base METHOD]]
    lcgym simulate [--system ix|two_link|ix-v0|my_arm.toml|...] [--controller feedback,physical] [--out run.csv]
                   [--plot run.png]
    lcgym diagnose DATA --system MACHINE [--add EFFECT@AXIS ...] [--kinematics reference|measured]
                   [--validate OTHER] [--resample HZ] [--units UNITS] [--system-wins] [--json OUT.json] [--plots DIR] [--replay]
    lcgym effects [--system MACHINE] [--data DATA]
    lcgym import emps FILE.mat --out OUT.csv

MACHINE: a built-in machine (ix, flexarm, two_link), an example one (emps; cobot6, a URDF shipped with lcgym), a URDF
file (robot.urdf: its joints named in the data are the axes, the others are locked), a machine file (my_arm.toml: a URDF
with the plant it should have: hidden effects, feedback, sensors, limits; the benchmark and ``lcgym simulate`` run on
it) or module:attr naming a ``lcgym.systems.System``.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
import time
import warnings
from pathlib import Path

from .provenance import __version__


def _simulate_systems() -> tuple[str, ...]:
    """The built-in machines by name and by version (``lcgym simulate --system``; files too)."""
    from .systems import VERSIONS

    return tuple(n for m, versions in VERSIONS.items() for n in (m, *(f"{m}-{v}" for v in reversed(versions))))
DATASETS = ("emps",)  # lcgym import: readers of lcgym.datasets


def _bench_system(text: str) -> str:
    from .systems import resolve

    try:
        resolve(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _controllers(text: str) -> list[str]:
    from .simulate import SIMULATE_CONTROLLERS

    names = list(_names(text))
    bad = [c for c in names if c not in SIMULATE_CONTROLLERS]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown controller {', '.join(bad)}; choose from "
                                         f"{', '.join(SIMULATE_CONTROLLERS)} (the others run in lcgym bench)")
    return names


def _rate(text: str) -> float:
    v = _number(text, float, "a sample rate in Hz")
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"must be > 0 and finite, got {text}")
    return v


def _names(text: str) -> tuple[str, ...]:
    names = tuple(c.strip() for c in text.split(",") if c.strip())
    if not names:
        raise argparse.ArgumentTypeError(f"no name given in {text!r}")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"{', '.join(twice)} listed twice")
    return names


def _seeds(text: str) -> tuple[int, ...]:
    try:
        seeds = tuple(int(c) for c in text.split(",") if c.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"seeds must be integers, got {text!r}") from None
    if not seeds:
        raise argparse.ArgumentTypeError(f"no seed given in {text!r}")
    if any(k < 0 for k in seeds):
        raise argparse.ArgumentTypeError(f"seeds must be >= 0, got {text!r}")
    return seeds


def _number(text: str, kind: type, what: str):
    """``kind(text)``, or argparse's error "must be <what>, got '<text>'"."""
    try:
        return kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None


def _nonnegative(text: str) -> int:
    v = _number(text, int, "an integer")
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {v}")
    return v


def _positive(text: str) -> int:
    v = _number(text, int, "an integer")
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def _share(text: str) -> float:
    v = _number(text, float, "a number")
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"must be a share in (0, 1), got {text}")
    return v


def _seconds(text: str) -> float:
    v = _number(text, float, "a number of seconds")
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"must be > 0 and finite, got {text}")
    return v


def _duration(text: str) -> float:
    v = _number(text, float, "a number of seconds")
    if not 1.0 <= v <= 3600.0:
        raise argparse.ArgumentTypeError(f"must be within 1..3600 s, got {text}")
    return v


def _file_of(*suffixes: str):
    """``_writable`` for a file whose name must end in one of ``suffixes`` (checked before any work)."""

    def check(text: str) -> Path:
        p = _writable(text)
        if p.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(f"{p}: use a file name ending in {' or '.join(suffixes)}")
        return p

    return check


def _writable(text: str) -> Path:
    """An output file's path: its folder must exist and be writable, and it must not be a folder."""
    p = Path(text)
    if not p.parent.resolve().is_dir():
        raise argparse.ArgumentTypeError(f"folder {p.parent} does not exist")
    if p.is_dir():
        raise argparse.ArgumentTypeError(f"{p} is a folder; give a file name")
    if not os.access(p.parent.resolve(), os.W_OK):
        raise argparse.ArgumentTypeError(f"folder {p.parent} is not writable")
    return p


def _page_target(text: str) -> Path:
    """Where ``--html`` writes: a file ending in .html, or a folder (existing, or new in an existing
    folder) that gets index.html; either way the folder it goes into must be writable."""
    p = Path(text)
    if p.suffix.lower() in (".html", ".htm"):
        return _writable(text)
    if p.exists() and not p.is_dir():
        raise argparse.ArgumentTypeError(f"{p} is a file not ending in .html; give a folder or an .html file")
    folder = p if p.is_dir() else p.parent
    if not folder.resolve().is_dir():
        raise argparse.ArgumentTypeError(f"folder {folder} does not exist")
    if not os.access(folder.resolve(), os.W_OK):
        raise argparse.ArgumentTypeError(f"folder {folder} is not writable")
    return p


def _machine_help() -> str:
    """The forms ``diagnose --system`` and ``effects --system`` take (``systems.get``)."""
    from .systems import BUILT_IN, EXAMPLES, URDF_EXAMPLES

    return (f"a built-in machine ({', '.join(BUILT_IN)}), an example one ({', '.join([*EXAMPLES, *URDF_EXAMPLES])}), "
            "a URDF file (robot.urdf: the data's pos_<joint> columns name its axes), a machine file (my_arm.toml: a "
            "URDF with its plant) or module:attr naming a lcgym.systems.System")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="lcgym", description="Learning feedforward control benchmark suite")
    parser.add_argument("--version", action="version", version=f"lcgym {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    bench = sub.add_parser("bench", help="run methods on systems over seeds; append MA/RMS/Inf to a results CSV")
    bench.add_argument("--systems", type=_names, help="comma-separated machines: built-in ones with their version, "
                       "ix-v0, or without it: the newest (default: every built-in machine's newest, ix-v1,flexarm-v1,"
                       "two_link-v0,emps_sim-v0); a machine file (my_arm.toml: a URDF with its hidden effects, feedback, "
                       "sensors), a URDF or module:attr")
    bench.add_argument("--methods", type=_names,
                       help="comma-separated method ids or module:Class (default: every registered method that runs "
                       "on the machine: on a machine file or URDF every one but basic, paper002-* and paper000-pgnn, "
                       "the FlexArm's and the IX's; the learners start from the file's physical model with its "
                       "[[model]] tables)")
    bench.add_argument("--seeds", type=_seeds,
                       help="comma-separated seeds (default 0,1,2; --quick: 0): the seeds of the references "
                       "(a machine file's too) and of the learners")
    bench.add_argument("--quick", action="store_true",
                       help="small budgets: 1 seed, 2 references of about 20 s of moves per set (a machine file's: "
                       "point-to-point moves of its [references] table), the learners on a share of their budgets")
    bench.add_argument("--out", type=_writable, default=Path("results.csv"),
                       help="results CSV (appended; the traces go to OUT.traces/, one folder per configuration; a "
                       "machine file's rows name it by its path as given)")
    bench.add_argument("--html", type=_page_target, metavar="DIR|OUT.html",
                       help="the leaderboard page of the run's rows (default: the results CSV's name with .html)")
    bench.add_argument("--no-html", action="store_true", help="write no page")
    bench.add_argument("--jobs", type=_positive, help="parallel cells (the run's own worker processes, one thread "
                       "each, stopped with it on Ctrl-C or SIGTERM; default: one per CPU core this process may use, "
                       "at most one per cell)")
    bench.add_argument("--dask", metavar="ADDRESS", help="run the cells on this Dask scheduler (tcp://host:port)")
    bench.add_argument("--resume", action="store_true", help="skip cells already stored with the same configuration")
    bench.add_argument("--timeout", type=_seconds, metavar="SECONDS",
                       help="per-cell time limit of a method (fit, learn, feedforward, runs); a cell past it fails")
    board = sub.add_parser("leaderboard", help="rank the methods of a results CSV")
    board.add_argument("csv", nargs="?", type=Path, default=Path("results.csv"),
                       help="results CSV of lcgym bench (default results.csv); a machine file's rows rank as any "
                            "machine's, under the file's path")
    board.add_argument("--reference-set", choices=("validation", "train", "test"), default="validation",
                       help="the references the rows are scored on (default validation: those no method trained "
                            "on; a machine file's are drawn from its [references] table as a built-in's are)")
    board.add_argument("--config", metavar="HASH",
                       help="configuration hash to rank (default: the newest run's; a run on a changed "
                       "machine file or another lcgym has another)")
    board.add_argument("--markdown", type=_writable, help="write a Markdown page (figures beside it)")
    board.add_argument("--html", type=_page_target, metavar="DIR|OUT.html",
                       help="write the leaderboard page: DIR/index.html, or OUT.html (one file, figures inside)")
    board.add_argument("--share-of", metavar="METHOD",
                       help="print paper 002's Table 6: each method's share of what METHOD changed against --base")
    board.add_argument("--base", metavar="METHOD", default="basic", help="the start the shares are taken from (basic)")
    sim = sub.add_parser("simulate", help="fit controllers on training runs and simulate validation references")
    sim.add_argument("--system", type=_bench_system, default="ix", metavar="MACHINE",
                     help=f"a benchmark machine: {', '.join(_simulate_systems())}, or a machine file (.toml: its plant "
                          "with its [[hidden]] effects, feedback and sensors) or URDF (its rigid body, default loop)")
    sim.add_argument("--controller", type=_controllers, default=["feedback", "physical"],
                     help="controller name or comma-separated list (feedback, physical, pgnn, pgnn-ls; basic on flexarm; "
                          "physical on a machine file: its model with its [[model]] tables)")
    sim.add_argument("--seed", type=_nonnegative, default=0, help="seed of the reference sets (default 0)")
    sim.add_argument("--n-train", type=_positive, default=8, help="training references (the runs the controllers fit)")
    sim.add_argument("--n-validation", type=_positive, default=4, help="validation references")
    sim.add_argument("--duration", type=_duration, default=40.0,
                     help="moving time of each reference [s] (the IX's; a machine file's: random point-to-point moves "
                          "of its [references] table within the URDF's joint limits); a final rest of a few seconds "
                          "follows (an arm reference is one TCP line out and back)")
    sim.add_argument("--out", type=_file_of(".csv", ".parquet", ".pq"),
                     help="measurement file (.csv or .parquet) of the validation runs")
    sim.add_argument("--plot", type=_file_of(".png", ".pdf", ".svg"),
                     help="PNG (or PDF, SVG) of tracking errors with the scaled reference velocity")
    diag = sub.add_parser("diagnose", help="compare the physical model with measurements; find the missing effect")
    diag.add_argument("data", type=Path, help="measurement file (.csv or .parquet; docs/measurement-format.md)")
    diag.add_argument("--system", required=True, metavar="MACHINE", help=_machine_help())
    diag.add_argument("--add", action="append", default=[], metavar="EFFECT@AXIS",
                      help="add this effect to the model, refit, show before/after (repeatable; AXIS a joint "
                           "of the machine, a machine file's or URDF's by its joint name; lcgym effects lists the "
                           "effects; on a machine file the report ends with the [[model]] tables to paste)")
    diag.add_argument("--json", type=_writable, metavar="OUT.json", help="write the report as JSON")
    diag.add_argument("--plots", type=Path, metavar="DIR",
                      help="write residual_time.png (the residual over time), residual_map.png (over position and "
                           "velocity), effects.png (the effects selected or added, as fitted) and, with --add, "
                           "before_after.png")
    diag.add_argument("--replay", action="store_true",
                      help="re-run the plant the data were simulated on with the model before/after (a log of lcgym "
                           "simulate on ix or a machine file: its sidecar records the plant)")
    diag.add_argument("--min-explained", type=_share, default=0.1, help="significance: the share of an axis's residual energy a "
                      "candidate must remove on held-out data to be selected (default 0.1; any machine)")
    diag.add_argument("--kinematics", choices=("reference", "measured"), default="reference",
                      help="velocity and acceleration from the reference corrected by the measured error (default; "
                           "a file without ref_ columns uses the measured position) or from the measured position")
    diag.add_argument("--resample", type=_rate, metavar="HZ",
                      help="the rate of the uniform grid a log with non-uniform time stamps is put on (linear "
                           "interpolation; default the log's own: its mean step between gaps)")
    diag.add_argument("--validate", type=Path, metavar="OTHER",
                      help="another measurement file of the machine: residuals there, not fitted, before and after "
                           "(read as the data are: resampled to their rate where its time stamps are not uniform at it)")
    diag.add_argument("--units", metavar="UNITS",
                      help="the unit of the logs' positions (pos_, ref_) where they are not rad and m: deg (revolute "
                           "axes), mm (prismatic axes of a machine file or URDF), or both as deg,mm; rad or m confirm "
                           "SI for a log that looks otherwise (default: its JSON sidecar's \"units\", else rad and m)")
    diag.add_argument("--system-wins", action="store_true",
                      help="read a log whose sidecar names another machine as a log of --system (its other columns "
                           "are left out)")
    imp = sub.add_parser("import", help="convert a public benchmark's files into a measurement file")
    imp.add_argument("dataset", choices=DATASETS, help="emps: the EMPS benchmark's DATA_EMPS*.mat files")
    imp.add_argument("file", type=Path, help="the data set's file")
    imp.add_argument("--out", required=True, type=_file_of(".csv", ".parquet", ".pq"), help="measurement file to write")
    eff = sub.add_parser("effects", help="list the effects diagnose can rank and add (a machine file's [[model]] "
                         "takes the same names), and those a machine file's [[hidden]] takes")
    eff.add_argument("--system", metavar="MACHINE", help=_machine_help() + " (default ix)")
    eff.add_argument("--data", type=Path, help="a measurement file whose pos_<joint> columns name a URDF's axes")
    return parser


def cmd_diagnose(args) -> int:
    from .data import MeasurementFileError, read_trials
    from .diagnose import DiagnoseOptions, diagnose
    from .diagnose.layout import DataTooShort
    from .diagnose.machines import check_log_axes
    from .diagnose.workflow import bridged_gap

    if args.plots is not None:  # the folder must be creatable: check before any work
        existing = next(p for p in (args.plots, *args.plots.parents) if p.exists())
        if not existing.is_dir():
            raise ValueError(f"--plots {args.plots}: {existing} exists and is not a folder")
        try:  # a folder can be made in it: make one and remove it
            os.rmdir(tempfile.mkdtemp(prefix=".lcgym-check-", dir=existing))
        except OSError as exc:
            raise ValueError(f"--plots {args.plots}: cannot make a folder in {existing} ({exc.strerror})") from None
    system = _machine(args.system, args.data)
    for path in (args.data, *([args.validate] if args.validate is not None else [])):
        check_log_axes(path, system, args.system, system_wins=args.system_wins)  # a log of another machine
    rate = args.resample or "auto"  # a log with jitter or dropouts is put on uniform grids (its own rate by default)
    trials = read_trials(args.data, axes=system, min_samples=100, resample=rate, max_gap=bridged_gap(),
                         units=args.units)
    # the validation log is read as the data were: on their grid's rate where it is not uniform at it
    other = None if args.validate is None else read_trials(args.validate, axes=system, min_samples=100,
                                                           resample=args.resample or trials[0].fs,
                                                           max_gap=bridged_gap(), units=args.units)
    try:
        options = DiagnoseOptions(add=args.add, replay=args.replay, kinematics=args.kinematics,
                                  min_explained=args.min_explained)
        report = diagnose(trials, system, options, progress=sys.stderr.isatty(), spec=args.system, validate=other)
    except DataTooShort as exc:
        raise MeasurementFileError(f"{args.data}: column 't': {exc}") from None
    print(report.text())
    if args.plots is not None:  # plots first, JSON last: a failure leaves no report behind
        for path in report.plot(args.plots):
            print(f"wrote {path}")
    if args.json:
        print(f"wrote {report.write_json(args.json)}")
    return 0


def _machine(spec: str, data: Path | None):
    """The machine of ``--system``; a URDF's axes are the joints the data file names."""
    from . import systems
    from .data import file_axes

    is_urdf = str(spec).lower().endswith(".urdf") or str(spec) in systems.URDF_EXAMPLES
    joints = file_axes(data) if data is not None and is_urdf else None
    return systems.get(spec, joints=joints)


def cmd_import(args) -> int:
    from . import datasets
    from .data import write_trials

    trial = getattr(datasets, args.dataset)(args.file)
    write_trials(args.out, [trial], meta=trial.meta)
    print(f"wrote {args.out}: {trial.n_samples} samples at {trial.fs:g} Hz, axes {', '.join(trial.axes)} "
          f"(lcgym diagnose {args.out} --system {args.dataset})")
    return 0


def cmd_effects(args) -> int:
    """Two lists: the effects diagnose ranks and ``--add`` accepts (``candidates_for``; a machine file's
    ``[[model]]`` takes the same names), and those a machine file's ``[[hidden]]`` accepts
    (``machine.hidden_effects``: what the plant simulates), with what is in one list only and why."""
    from .diagnose.candidates import candidates_for
    from .physics.plant_effects import refusal
    from .systems.machine import hidden_effects
    from .systems.urdf import urdf_robot

    system = _machine(args.system or "ix", args.data)
    cands = candidates_for(system)
    model = system.diagnosis_model(fs=system.fs or 1000.0).parts()
    print(f"effects diagnose ranks and --add accepts on {system.name} (axes: {', '.join(system.axis_names)})"
          + (", the default machine; --system names another (my_arm.toml, a .urdf, ...)" if args.system is None else "")
          + "; a machine file's [[model]] tables take the same names, without values (the model's fit finds them):")
    for cand in cands:
        searched = [*cand.grid, *([cand.period] if cand.period else [])]
        print(f"  {cand.name:30s} [{cand.family}] {_summary(cand.effect)}"
              + (f" (searched: {', '.join(searched)})" if searched else ""))
    print(f"the model already has: {', '.join(model)}"
          + (f"; and from {system.name}'s [[model]] tables: {', '.join(system.model_effects)}" if system.model_effects
             else ""))

    hidden = hidden_effects(system)
    try:
        urdf_robot(system)
    except ValueError:  # the IX, the FlexArm, a machine of Python: their plants are their own
        print(f"\na machine file's [[hidden]] (a URDF machine's plant, docs/own-machine-bench.md) accepts: "
              f"{', '.join(hidden)} (lcgym effects --system my_arm.toml compares them with what diagnose ranks there)")
        return 0
    print(f"\neffects a machine file's [[hidden]] accepts on {system.name} (the plant simulates them; "
          "docs/own-machine-bench.md):")
    for name, cls in hidden.items():
        print(f"  {name:30s} {_summary(cls)}")
    ranked = {c.name for c in cands}
    plant_only = [n for n in hidden if n not in ranked]
    if plant_only:
        print("only in this list (diagnose does not rank them):")
        for name in plant_only:
            why = ("the model already has it" if name in model else
                   "plant only: diagnose fits a curve of no set shape instead" if hidden[name].plant_only else
                   f"not a candidate on {system.name}")
            print(f"  {name:30s} {why}")
    model_only = [c for c in cands if c.name not in hidden]
    if model_only:
        print("only in the first list (the plant cannot simulate them):")
        for cand in model_only:
            print(f"  {cand.name:30s} {refusal(cand.effect)}")
    return 0


def _summary(effect: type, limit: int = 100) -> str:
    """The first sentence of an effect's docstring, on one line of at most ``limit`` characters (cut
    at a word, with "..."); a sentence that leads into a formula (ends with ":") ends with "." here."""
    doc = " ".join((effect.__doc__ or "").strip().split("\n\n")[0].split())
    first = re.split(r"(?<=[.:])\s", doc, maxsplit=1)[0]
    first = first[:-1] + "." if first.endswith(":") else first
    if len(first) <= limit:
        return first
    return first[:limit - 3].rsplit(" ", 1)[0].rstrip(",;:(") + "..."


def cmd_simulate(args) -> int:
    import pandas as pd

    from .data import write_trials
    from .leaderboard.plots import plot_tracking_errors
    from .simulate import metric_table, simulate
    from .systems import resolve

    results = simulate(args.controller, system=args.system, seed=args.seed, n_train=args.n_train,
                       n_validation=args.n_validation, duration=args.duration)
    table = metric_table(results)
    with pd.option_context("display.float_format", "{:.4f}".format, "display.width", 120):
        print(f"{resolve(args.system).name}, {args.n_validation} validation reference{'s' if args.n_validation > 1 else ''} "
              f"(seed {args.seed}), norms MA, RMS, Inf (paper 000, Kon et al. 2025, eqs. (34)-(36); lcgym.metrics):")
        print(table.to_string(index=False))
    if args.out:
        trials = [t for r in results for t in r.trials]
        write_trials(args.out, trials, meta={"system": args.system, "seed": args.seed})
        print(f"wrote {args.out} ({len(trials)} trial{'s' if len(trials) != 1 else ''})")
    if args.plot:
        plot_tracking_errors(results, args.plot)
        print(f"wrote {args.plot}")
    return 0


def cmd_bench(args) -> int:
    from .leaderboard.page import write_html
    from .leaderboard.report import format_summary, format_text, select
    from .leaderboard.runner import BenchConfig, BenchStopped, run_benchmark, stop_on_sigterm
    from .leaderboard.store import read_results

    start = time.perf_counter()
    chosen = {k: v for k, v in (("systems", args.systems), ("methods", args.methods), ("seeds", args.seeds)) if v}
    config = BenchConfig.quick(**chosen) if args.quick else BenchConfig(**chosen)
    try:
        with stop_on_sigterm():
            summary = run_benchmark(config, args.out, jobs=args.jobs, dask=args.dask, resume=args.resume,
                                    timeout=args.timeout)
    except BenchStopped as stop:
        print(f"\nlcgym bench: {stop}", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print(f"\nlcgym bench: stopped; every finished cell is in {args.out}; add --resume to run the rest",
              file=sys.stderr)
        return 130
    df, _ = select(read_results(args.out), config.config_hash())
    print(format_text(df))
    page = None if args.no_html else write_html(df, args.html or args.out.with_suffix(".html"), source=str(args.out))
    print(f"\n{format_summary(df)}")
    print(f"\nrun {summary['run_id']}: {summary['cells_run']} cells run, {summary['cells_skipped']} skipped "
          f"(--resume), {summary['cells_failed']} failed in {time.perf_counter() - start:.0f} s")
    print(f"results: {args.out.resolve()} (lcgym leaderboard {args.out} prints them again)")
    if page is not None:
        print(f"page:    {Path(page).resolve()}")
    return 0


def cmd_leaderboard(args) -> int:
    from .leaderboard.page import write_html
    from .leaderboard.report import format_shares, format_text, select, write_markdown
    from .leaderboard.store import read_results

    if not args.csv.exists():
        raise ValueError(f"{args.csv}: no such results file (run lcgym bench first)")
    df, others = select(read_results(args.csv), args.config)
    print(format_text(df, args.reference_set))
    if args.share_of:
        print(format_shares(df, args.share_of, args.base, args.reference_set))
    if others:
        print(f"\n(the file also holds configuration(s) {', '.join(others)}: choose one with --config)")
    if args.markdown:
        print(f"wrote {write_markdown(df, args.markdown, args.reference_set, source=str(args.csv))}")
    if args.html:
        print(f"wrote {write_html(df, args.html, args.reference_set, source=str(args.csv))}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    commands = {"simulate": cmd_simulate, "bench": cmd_bench, "leaderboard": cmd_leaderboard,
                "diagnose": cmd_diagnose, "effects": cmd_effects, "import": cmd_import}

    def show_warning(message, category, filename, lineno, file=None, line=None):  # one line, no source
        print(f"lcgym {args.command}: warning: {message}", file=sys.stderr)

    try:
        with warnings.catch_warnings():
            warnings.showwarning = show_warning
            return commands[args.command](args)
    except BrokenPipeError:  # the reader went away (lcgym effects | head): nothing left to say
        sys.stderr.close()
        return 0
    except (ValueError, OSError, RuntimeError) as exc:
        print(f"lcgym {args.command}: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
