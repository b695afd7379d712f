"""Speed of ``lcgym diagnose`` on 100,000 samples (issue budget: 30 s on the project's 2-core machine).

Writes a measurement file of feedback-only runs of the default IX plant (all hidden effects)
cut to 100,000 samples, then times the command as a user runs it (``lcgym diagnose FILE
--system ix --json ...``, in this process, file reading included) and, as a reference measured in
the same run, one least-squares fit of the nominal model on the same trials (the least any
comparison of model and data costs). Prints both times and the ratios to the budget and to
the reference.

Run:  .venv/bin/python benchmarks/diagnose_speed.py [--samples 100000]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from lcgym.cli import main as cli
from lcgym.data import Trial, read_trials, write_trials
from lcgym.physics.model import PhysicalModel
from lcgym.systems.ix import IX
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import reference_set

BUDGET_S = 30.0


def make_file(path: Path, samples: int) -> Path:
    runs = IXPlant().run(reference_set("train", 0, 8))
    trials, left = [], samples
    for r in runs:
        n = min(left, r.n_samples)
        if n < 2500:
            break
        trials.append(Trial(t=r.t[:n], ref=r.ref[:n], pos=r.pos[:n], u=r.u[:n], axes=r.axes, meta=r.meta))
        left -= n
    return write_trials(path, trials, meta={"system": "ix"})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data = make_file(Path(tmp) / "runs.csv", args.samples)
        trials = read_trials(data, axes=IX)
        n = sum(t.n_samples for t in trials)
        PhysicalModel(IX, positions="measured").fit(trials[:1])  # compile the regressor once (numba cache)
        t0 = time.perf_counter()
        PhysicalModel(IX, positions="measured").fit(trials)
        t_fit = time.perf_counter() - t0
        t0 = time.perf_counter()
        rc = cli(["diagnose", str(data), "--system", "ix", "--json", str(Path(tmp) / "report.json")])
        t_diag = time.perf_counter() - t0
    assert rc == 0
    print(f"\n{n} samples in {len(trials)} trials")
    print(f"lcgym diagnose:          {t_diag:6.1f} s   ({t_diag / BUDGET_S:.2f} of the {BUDGET_S:.0f} s budget)")
    print(f"nominal model fit alone: {t_fit:6.1f} s   (diagnose = {t_diag / t_fit:.1f}x one fit)")


if __name__ == "__main__":
    main()
