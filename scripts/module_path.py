"""The path of one benchmark cell and of one diagnosis through lcgym's modules.

Counts, while one cell (``runner.run_cell``, the first in a fresh process) or one diagnosis (``lcgym diagnose`` of feedback-only
IX runs) runs, how often the call path enters each lcgym module from another file (a call into a
function of the module whose caller lives elsewhere), and how often pinocchio parses a URDF. It
answers "how often does a cell pass through ``systems/__init__.py`` and ``physics/model.py``", the
measure of issue 50, for the code this checkout holds (run it in a worktree of an older commit to
compare).

Run:  .venv/bin/python scripts/module_path.py [--cell two_link-v0 ilc 0] [--top 12]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
from collections import Counter
from pathlib import Path

import lcgym

ROOT = Path(lcgym.__file__).resolve().parent
WATCHED = ("systems/__init__.py", "physics/model.py")


def traced(run) -> tuple[Counter, int]:
    """Module entries (caller in another file; a module's own import-time code not counted) and
    pinocchio URDF parses made by ``run()``."""
    import pinocchio as pin

    entries: Counter = Counter()
    parses = 0
    parse = pin.buildModelFromUrdf

    def counted(*args, **kwargs):  # a Boost.Python function: the profiler does not see its calls
        nonlocal parses
        parses += 1
        return parse(*args, **kwargs)

    def profile(frame, event, arg):
        if event != "call":
            return
        here = frame.f_code.co_filename
        caller = frame.f_back.f_code.co_filename if frame.f_back else ""
        if here != caller and here.startswith(str(ROOT)) and frame.f_code.co_name != "<module>":
            entries[str(Path(here).resolve().relative_to(ROOT))] += 1

    pin.buildModelFromUrdf = counted
    sys.setprofile(profile)
    try:
        run()
    finally:
        sys.setprofile(None)
        pin.buildModelFromUrdf = parse
    return entries, parses


def cell(system: str, method: str, seed: int) -> None:
    from lcgym.leaderboard.runner import BenchConfig, run_cell

    config = BenchConfig.quick(systems=(system,), methods=(method,))
    rows, _ = run_cell(config.systems[0], method, seed, config, single_thread=True)
    assert rows[0]["status"] == "ok", rows[0]["error"]


def diagnosis() -> None:
    from lcgym.cli import main as cli
    from lcgym.data import write_trials
    from lcgym.systems.ix.plant import IXPlant
    from lcgym.systems.ix.references import reference_set

    with tempfile.TemporaryDirectory() as tmp:
        data = write_trials(Path(tmp) / "runs.csv", IXPlant().run(reference_set("train", 0, 2, 20.0)),
                            meta={"system": "ix"})
        with contextlib.redirect_stdout(io.StringIO()):
            assert cli(["diagnose", str(data), "--system", "ix", "--json", str(Path(tmp) / "d.json")]) == 0


def report(what: str, entries: Counter, parses: int, top: int) -> None:
    print(f"\n{what}: {sum(entries.values())} module entries over {len(entries)} modules, "
          f"{parses} URDF parse(s) by pinocchio")
    for name in WATCHED:
        print(f"  {name:28s} {entries.get(name, 0):8d}")
    print("  busiest:")
    for name, n in entries.most_common(top):
        print(f"  {name:28s} {n:8d}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cell", nargs=3, default=("two_link-v0", "ilc", "0"), metavar=("SYSTEM", "METHOD", "SEED"))
    parser.add_argument("--top", type=int, default=12)
    args = parser.parse_args()
    system, method, seed = args.cell
    # the first of each in this process, as in a fresh benchmark worker: machines are loaded as it needs them
    report(f"cell {system} / {method} / {seed}", *traced(lambda: cell(system, method, int(seed))), args.top)
    report("diagnosis of two IX runs", *traced(diagnosis), args.top)


if __name__ == "__main__":
    main()
