"""The ``lcgym`` command. Thin: parses, calls library functions, prints.

    lcgym simulate --system ix --controller feedback,physical --out run.csv --plot run.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

SYSTEMS = ("ix",)


def _controllers(text: str) -> list[str]:
    from .baselines import CONTROLLERS

    names = [c.strip() for c in text.split(",") if c.strip()]
    bad = [c for c in names if c not in CONTROLLERS]
    if not names or bad:
        raise argparse.ArgumentTypeError(f"unknown controller {', '.join(bad) or text!r}; choose from {', '.join(CONTROLLERS)}")
    return names


def _nonnegative(text: str) -> int:
    v = int(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {v}")
    return v


def _positive(text: str) -> int:
    v = int(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def _writable(text: str) -> Path:
    p = Path(text)
    if not p.parent.resolve().is_dir():
        raise argparse.ArgumentTypeError(f"folder {p.parent} does not exist")
    return p


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="lcgym", description="Learning feedforward control benchmark suite")
    sub = parser.add_subparsers(dest="command", required=True)
    sim = sub.add_parser("simulate", help="fit controllers on training runs and simulate validation references")
    sim.add_argument("--system", choices=SYSTEMS, default="ix")
    sim.add_argument("--controller", type=_controllers, default=["feedback", "physical"],
                     help="controller name or comma-separated list (feedback, physical)")
    sim.add_argument("--seed", type=_nonnegative, default=0)
    sim.add_argument("--n-train", type=_positive, default=8, help="training references")
    sim.add_argument("--n-validation", type=_positive, default=4, help="validation references")
    sim.add_argument("--duration", type=float, default=40.0,
                     help="moving time of each reference [s]; a final rest of a few seconds follows")
    sim.add_argument("--out", type=_writable, help="measurement file (.csv or .parquet) of the validation runs")
    sim.add_argument("--plot", type=_writable, help="PNG of tracking errors with the scaled reference velocity")
    return parser


def cmd_simulate(args) -> int:
    import pandas as pd

    from .data import write_trials
    from .leaderboard.plots import plot_tracking_errors
    from .simulate import metric_table, simulate

    if not 1.0 <= args.duration <= 3600.0:
        raise SystemExit(f"lcgym simulate: --duration must be within 1..3600 s, got {args.duration}")
    results = simulate(args.controller, seed=args.seed, n_train=args.n_train, n_validation=args.n_validation,
                       duration=args.duration)
    table = metric_table(results)
    with pd.option_context("display.float_format", "{:.4f}".format, "display.width", 120):
        print(f"IX, {args.n_validation} validation references (seed {args.seed}), norms of eqs. (34)-(36):")
        print(table.to_string(index=False))
    if args.out:
        trials = [t for r in results for t in r.trials]
        write_trials(args.out, trials, meta={"system": args.system, "seed": args.seed})
        print(f"wrote {args.out} ({len(trials)} trials)")
    if args.plot:
        plot_tracking_errors(results, args.plot)
        print(f"wrote {args.plot}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.command == "simulate":
            return cmd_simulate(args)
    except (ValueError, OSError, RuntimeError) as exc:
        print(f"lcgym {args.command}: {exc}", file=sys.stderr)
        return 1
    return 2


if __name__ == "__main__":
    sys.exit(main())
