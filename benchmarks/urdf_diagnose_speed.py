"""Speed of ``lcgym diagnose`` on real-sized robot logs (issue budget: 60 s each on the project's
2-core machines), and where the time goes.

Two logs, simulated with ``URDFPlant`` and shaped like the real ones the diagnosis was tried on
(``lcgym.logs``), Coulomb friction hidden on every joint:

- ``cobot``: lcgym's six-joint arm logged at 100 Hz with jittered stamps (each up to 4 ms off its
  grid) and no reference, 17,000 samples (about 170 s in 8 runs);
- ``panda``: the Franka Panda's seven joints (``tests/data/panda``) at 1 kHz, 20,000 samples in
  one run with four logging dropouts of 8.5-8.8 ms, no reference;
- ``panda_runs``: the Panda's seven joints, three runs of 25 s logged at 200 Hz with jittered
  stamps (each up to 1 ms off its grid), no reference: issue 49's size (15,000 samples).

Each log is written to a CSV file and diagnosed as a user runs it (``lcgym diagnose FILE --system
URDF --json ...``, in this process: reading the file, resampling and the URDF included), ``--runs``
times. As a reference measured in the same run, one least-squares fit of the nominal model on the
same trials. Prints the medians, their ratio, the budget's share, the effects selected, and a
profile of one diagnosis by stage (cumulative seconds of the functions that make the stages).

Run:  .venv/bin/python benchmarks/urdf_diagnose_speed.py [--runs 3] [--logs cobot,panda,panda_runs]
"""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import io
import json
import math
import pstats
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from lcgym import logs, systems
from lcgym.cli import main as cli
from lcgym.data import read_trials, write_trials
from lcgym.diagnose.workflow import bridged_gap
from lcgym.physics import effects as fx
from lcgym.systems.examples import COBOT6_FRICTION
from lcgym.systems.urdf_plant import URDFPlant, random_references

BUDGET_S = 60.0
PANDA = Path(__file__).resolve().parents[1] / "tests" / "data" / "panda" / "panda.urdf"
PANDA_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
STAGES = {  # stage -> the function whose cumulative time it is (file suffix, function name)
    "read the log, put it on a grid": ("data.py", "read_trials"),
    "nominal fit, masks, reductions (prepare)": ("search.py", "prepare"),
    "the search (rank)": ("search.py", "rank"),
    "  score candidates, every step": ("search.py", "score_candidate"),
    "  refine picks (Nelder-Mead)": ("search.py", "refine"),
    "  revisit picks' other forms": ("search.py", "_other_form"),
    "  of these three: reduce columns": ("search.py", "__call__"),
    "  of these three: least squares per fold": ("search.py", "evaluate"),
    "  of these three: spectral peaks": ("search.py", "period_peaks"),
}


def cobot_log(folder: Path, samples: int = 17_000) -> Path:
    cobot = systems.get("cobot6")
    hidden = tuple(fx.CoulombFriction(j, Fc=f, eps=e) for j, (f, e) in zip(cobot.axis_names, COBOT6_FRICTION, strict=True))
    runs = URDFPlant(cobot, effects=hidden, seed=0, encoder_resolution=2 * math.pi / 2**18).run(
        random_references(cobot, n=8, duration=21.0, seed=0))
    rng = np.random.default_rng(0)
    trials, left = [], samples
    for r in runs:
        tr = logs.without_reference(logs.jittered(r, 100.0, 0.004, rng))
        tr = logs.cut(tr, 0.0, tr.t[min(left, tr.n_samples) - 1] + 1e-9) if left < tr.n_samples else tr
        trials.append(tr)
        left -= tr.n_samples
        if left <= 0:
            break
    return write_trials(folder / "cobot.csv", trials)


def panda_log(folder: Path, samples: int = 20_000) -> Path:
    panda = systems.get(str(PANDA), joints=PANDA_JOINTS)
    hidden = tuple(fx.CoulombFriction(f"panda_joint{i}", Fc=f, eps=0.005)
                   for i, f in zip(range(1, 8), (3.0, 3.0, 2.0, 2.0, 1.2, 1.0, 0.8), strict=True))
    run = URDFPlant(panda, effects=hidden, seed=0).run(random_references(panda, n=1, duration=samples / 1000 + 1.0,
                                                                         seed=0))[0]
    run = logs.cut(run, 0.0, samples / 1000)
    rng = np.random.default_rng(0)
    gaps = [(t, rng.uniform(0.0085, 0.0088)) for t in sorted(rng.uniform(2.0, samples / 1000 - 2.0, 4))]
    return write_trials(folder / "panda.csv", [logs.without_reference(logs.drop(run, gaps))])


def panda_runs_log(folder: Path) -> Path:
    panda = systems.get(str(PANDA), joints=PANDA_JOINTS)
    hidden = tuple(fx.CoulombFriction(j, Fc=f, eps=0.005) for j, f in zip(PANDA_JOINTS, (3.0, 3.0, 2.0, 2.0, 1.2, 1.0, 0.8),
                                                                          strict=True))
    runs = URDFPlant(panda, effects=hidden, seed=0).run(random_references(panda, n=3, duration=25.0, seed=0))
    rng = np.random.default_rng(0)
    return write_trials(folder / "panda_runs.csv", [logs.without_reference(logs.jittered(r, 200.0, 0.001, rng))
                                                   for r in runs])


def profile(args: list[str]) -> list[tuple[str, float]]:
    """Cumulative seconds of each stage of one diagnosis (``STAGES``)."""
    prof = cProfile.Profile()
    with contextlib.redirect_stdout(io.StringIO()):
        prof.enable()
        cli(args)
        prof.disable()
    stats = pstats.Stats(prof).stats
    total = sum(v[3] for k, v in stats.items() if k[2] == "cmd_diagnose")
    out = [("the whole diagnosis (lcgym diagnose)", total)]
    for stage, (file, name) in STAGES.items():
        out.append((stage, sum(v[3] for k, v in stats.items() if k[0].endswith(file) and k[2] == name)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--logs", default="cobot,panda")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name in args.logs.split(","):
            if name == "cobot":
                data, urdf = cobot_log(folder), "cobot6"
            else:
                data, urdf = (panda_log if name == "panda" else panda_runs_log)(folder), str(PANDA)
            machine = systems.get(urdf, joints=None if name == "cobot" else PANDA_JOINTS)
            trials = read_trials(data, axes=machine, resample="auto", max_gap=bridged_gap())  # as the CLI reads it
            n = sum(t.n_samples for t in trials)
            t0 = time.perf_counter()
            machine.diagnosis_model(trials[0].fs).fit(trials)
            t_fit = time.perf_counter() - t0
            report = folder / "report.json"
            command = ["diagnose", str(data), "--system", urdf, "--json", str(report)]
            seconds = []
            for _ in range(args.runs):
                t0 = time.perf_counter()
                with contextlib.redirect_stdout(io.StringIO()):  # the report: its JSON is read below
                    assert cli(command) == 0
                seconds.append(time.perf_counter() - t0)
            found = [f"{c['effect']}@{c['axis']}" for c in json.loads(report.read_text())["candidates"] if c["selected"]]
            med = statistics.median(seconds)
            print(f"\n{name}: {n} samples at {trials[0].fs:g} Hz in {len(trials)} trial(s), {machine.n_axes} axes")
            print(f"  lcgym diagnose: median {med:6.1f} s over {args.runs} runs ({', '.join(f'{s:.1f}' for s in seconds)}; "
                  f"{med / BUDGET_S:.2f} of the {BUDGET_S:.0f} s budget)")
            print(f"  one nominal fit: {t_fit:6.2f} s (diagnose = {med / t_fit:.0f}x one fit)")
            print(f"  selected: {', '.join(found) or 'nothing'}")
            print("  where the time goes (one more run, profiled; the profiler's overhead included):")
            for stage, s in profile(command):
                print(f"    {stage:40s} {s:6.1f} s")


if __name__ == "__main__":
    main()
