"""How the diagnosis does on a URDF robot it was not developed on: the Franka Panda (7 axes, fingers
locked) with a friction of no textbook shape on joint 3, with and without a one-sided spring on
joint 6, and with no hidden effect, each logged as a position-only log (no reference columns) at
1 kHz and at 250 Hz with jittered time stamps that are resampled (``data.regularize``).

The plant runs at 1 kHz (``URDFPlant``, PD feedback, 18-bit encoders); a 250 Hz log is every 4th
sample with up to 20 % of a step of jitter. Prints per case the effects selected, the first
candidates with their share alone and their parameters, and the wall time of the diagnosis.

Run:  .venv/bin/python studies/diagnose_urdf.py
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from lcgym import systems
from lcgym.data import Trial, regularize
from lcgym.diagnose import diagnose
from lcgym.physics import effects as fx
from lcgym.systems.urdf_plant import URDFPlant, random_references

PANDA = Path(__file__).resolve().parents[1] / "tests" / "data" / "panda" / "panda.urdf"
JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))


def friction(v):
    """N m: a level of 1.2 rising with speed, a hump at low speed; no library formula."""
    return 1.2 * np.tanh(v / 0.03) * (1 + 0.3 * np.abs(v)) + 0.4 * np.exp(-((v / 0.1) ** 2)) * np.tanh(v / 0.01)


def cases() -> dict[str, list]:
    rubbing = fx.TabulatedForce.from_function("panda_joint3", "velocity", friction, -2.5, 2.5, 801)
    return {"friction on joint 3": [rubbing],
            "friction on joint 3 + spring on joint 6": [rubbing, fx.CableSpring("panda_joint6", k=3.0, q0=math.radians(120),
                                                                                 width=math.radians(4))],
            "no hidden effect": []}


def log(runs, fs: float, rng) -> list[Trial]:
    """Position-only trials at ``fs`` (every k-th sample of the 1 kHz runs), jittered and resampled."""
    k = int(round(runs[0].fs / fs))
    out = []
    for r in runs:
        t = r.t[::k] + rng.uniform(-0.2, 0.2, r.t[::k].size) / fs
        out.extend(regularize(Trial(t=t, ref=None, pos=r.pos[::k], u=r.u[::k], axes=r.axes), fs))
    return out


def main() -> None:
    panda = systems.get(str(PANDA), joints=JOINTS)
    print(panda.description)
    rows = []
    for name, hidden in tqdm(cases().items(), desc="cases"):
        runs = URDFPlant(panda, effects=tuple(hidden), encoder_resolution=2 * math.pi / 2**18, seed=1).run(
            random_references(panda, n=3, duration=20.0, seed=3))
        for fs in (1000.0, 250.0):
            trials = log(runs, fs, np.random.default_rng(0))
            t0 = time.perf_counter()
            report = diagnose(trials, panda)
            rows.append((name, fs, report, time.perf_counter() - t0))
    for name, fs, report, seconds in rows:
        print(f"\n{name}, {fs:g} Hz log: selected {', '.join(report.missing) or 'nothing'} ({seconds:.1f} s)")
        for c in report.candidates[:4]:
            params = ", ".join(f"{k}={v:.3g}" for k, v in c.parameters.items())
            print(f"    {c.effect}@{c.axis}: {100 * c.explained:.0f}% alone, selected {c.selected}"
                  + (f"; {params}" if params else ""))


if __name__ == "__main__":
    main()
