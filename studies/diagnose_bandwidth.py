"""What the data's spectra show (docs/diagnosis.md, "Only what the data can show"): the bandwidths the
report gives, as logged and behind a logger's low-pass, and the spectral rule on a gear ripple.

1. The IX with a gear ripple of 2 deg period on the propeller (two training references, the case of
   ``tests/test_spectra.py``): what the ripple removes held-out and what share of its torque lies
   where the input holds less, on the input as logged and low-passed (zero phase) at 1 and 2 Hz.
2. The bandwidths (99.9 % of the energy) of the IX's input as logged and low-passed, and of the
   simulated cobot's (three runs of 25 s, logged at 200 Hz with 1 ms jitter) unfiltered and behind a
   causal 2 Hz (torques) / 3 Hz (positions) low-pass.

Run:  .venv/bin/python studies/diagnose_bandwidth.py
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from lcgym import logs, systems
from lcgym.diagnose import diagnose
from lcgym.diagnose.spectra import bandwidths
from lcgym.physics import effects as fx
from lcgym.physics.kinematics import lowpass_zero_phase
from lcgym.systems.examples import COBOT6_FRICTION
from lcgym.systems.ix import IX
from lcgym.systems.ix.plant import IXPlant
from lcgym.systems.ix.references import reference_set
from lcgym.systems.urdf_plant import URDFPlant, random_references


def ripple_rows() -> None:
    ripple = fx.GearHarmonic.from_amplitudes("propeller", 0.15, 0.7, 0.06, 2.0, velocity_gain=0.5, period=2 * math.pi / 180)
    runs = IXPlant(effects=(ripple,)).run(reference_set("train", 0, 2))
    for hz in (None, 2.0, 1.0):
        trials = runs if hz is None else [dataclasses.replace(r, u=lowpass_zero_phase(r.u, r.fs, hz)) for r in runs]
        rep = diagnose(trials, IX)
        first = [c for c in rep.steps[0].candidates if c.effect == "gear_harmonic" and c.axis == "propeller"]
        band = rep.samples["bandwidth"]["input"]
        print(f"IX input {'as logged' if hz is None else f'low-passed at {hz:g} Hz'}: bandwidth "
              + ", ".join(f"{a} {f:.3g} Hz" for a, f in band.items())
              + f"; gear_harmonic@propeller removes {100 * first[0]['share_of_left']:.0f}% held-out: "
              + f"{first[0]['verdict']}; selected: {', '.join(rep.missing) or 'nothing'}")


def cobot_rows() -> None:
    cobot = systems.get("cobot6")
    hidden = tuple(fx.CoulombFriction(j, Fc=f, eps=e) for j, (f, e) in zip(cobot.axis_names, COBOT6_FRICTION, strict=True))
    runs = URDFPlant(cobot, effects=hidden, seed=0, encoder_resolution=2 * math.pi / 2**18).run(
        random_references(cobot, n=3, duration=25.0, seed=0))
    rng = np.random.default_rng(0)
    for label, filt in (("unfiltered", lambda r: r), ("torques 2 Hz, positions 3 Hz", lambda r: logs.lowpassed(r, 2.0, 3.0))):
        trials = [logs.jittered(filt(r), 200.0, 0.001, rng) for r in runs]
        lengths = [tr.n_samples for tr in trials]
        for what in ("u", "pos"):
            b = bandwidths(np.concatenate([getattr(tr, what) for tr in trials]), lengths, 200.0)
            print(f"cobot at 200 Hz, {label}: {'input' if what == 'u' else 'position'} bandwidth "
                  f"{b.min():.3g}-{b.max():.3g} Hz")


if __name__ == "__main__":
    ripple_rows()
    cobot_rows()
