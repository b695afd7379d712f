"""Speed of ``lcgym diagnose`` on a 7-DOF URDF robot: the Franka Panda with its two gripper joints
locked, 100,000 samples (issue budget: 60 s on the project's 2-core machine).

Simulates the Panda (``tests/data/panda/panda.urdf``, the seven arm joints as axes) with
``URDFPlant`` under PD feedback on seeded random point-to-point moves, with a hidden Coulomb friction
on joints 2 and 4 that the URDF lacks, cut to 100,000 samples and written to a measurement file;
then times the command as a user runs it (``lcgym diagnose FILE --system panda.urdf --json ...``,
in this process: reading the file and the URDF included) and, as a reference measured in the same
run, one least-squares fit of the nominal model on the same trials. Prints both times, their
ratio, the budget's share, and what the diagnosis selected.

Run:  .venv/bin/python benchmarks/urdf_diagnose_speed.py [--samples 100000]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from lcgym import systems
from lcgym.cli import main as cli
from lcgym.data import Trial, read_trials, write_trials
from lcgym.physics import effects as fx
from lcgym.systems.urdf_plant import URDFPlant, random_references

BUDGET_S = 60.0
PANDA = Path(__file__).resolve().parents[1] / "tests" / "data" / "panda" / "panda.urdf"
JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))


def make_file(path: Path, samples: int) -> Path:
    panda = systems.get(str(PANDA), joints=JOINTS)
    hidden = (fx.CoulombFriction("panda_joint2", Fc=1.5, eps=0.01), fx.CoulombFriction("panda_joint4", Fc=1.0, eps=0.01))
    plant = URDFPlant(panda, effects=hidden, seed=0)
    refs = random_references(panda, n=-(-samples // 20_000) + 1, duration=20.0, seed=0)
    trials, left = [], samples
    for r in plant.run(refs):
        n = min(left, r.n_samples)
        if n < 20_000:
            break
        trials.append(Trial(t=r.t[:n], ref=r.ref[:n], pos=r.pos[:n], u=r.u[:n], axes=r.axes, meta=r.meta))
        left -= n
    return write_trials(path, trials, meta={"system": panda.name})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        data = make_file(Path(tmp) / "panda.csv", args.samples)
        t_sim = time.perf_counter() - t0
        panda = systems.get(str(PANDA), joints=JOINTS)
        trials = read_trials(data, axes=panda)
        n = sum(t.n_samples for t in trials)
        t0 = time.perf_counter()
        panda.diagnosis_model(trials[0].fs).fit(trials)
        t_fit = time.perf_counter() - t0
        report = Path(tmp) / "report.json"
        t0 = time.perf_counter()
        rc = cli(["diagnose", str(data), "--system", str(PANDA), "--json", str(report)])
        t_diag = time.perf_counter() - t0
        found = [f"{c['effect']}@{c['axis']}" for c in json.loads(report.read_text())["candidates"] if c["selected"]]
    assert rc == 0
    print(f"\n{panda.description}")
    print(f"{n} samples in {len(trials)} trials (simulated in {t_sim:.1f} s)")
    print(f"lcgym diagnose:          {t_diag:6.1f} s   ({t_diag / BUDGET_S:.2f} of the {BUDGET_S:.0f} s budget)")
    print(f"nominal model fit alone: {t_fit:6.1f} s   (diagnose = {t_diag / t_fit:.1f}x one fit)")
    print(f"selected: {', '.join(found) or 'nothing'} (hidden: coulomb_friction@panda_joint2, coulomb_friction@panda_joint4)")


if __name__ == "__main__":
    main()
