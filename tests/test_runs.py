"""Runs remembered inside the benchmark's cells (``lcgym.systems.runs``): a deterministic plant runs
each (reference, signals) once; what it returns is the same trial, a copy each time."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lcgym.data import Trial
from lcgym.systems import runs
from lcgym.systems.runs import remembered, remembered_runs


@dataclass
class CountingPlant:
    """u = 2 r + ff; counts the references it really ran."""

    gain: float = 2.0
    deterministic: bool = True
    ran: int = field(default=0, repr=False)  # not the configuration

    @remembered
    def run(self, references, feedforward=None):
        single = not isinstance(references, list)
        refs = [references] if single else references
        ffs = [feedforward] if single else (feedforward or [None] * len(refs))
        out = []
        for r, f in zip(refs, ffs, strict=True):
            self.ran += 1
            u = self.gain * r + (0.0 if f is None else f)
            out.append(Trial(t=np.arange(len(r)) / 100.0, ref=r, pos=r.copy(), u=u, ff=f, axes=("x",)))
        return out[0] if single else out


def _ref(k: int) -> np.ndarray:
    return np.linspace(0.0, 1.0 + k, 50)[:, None]


def test_a_run_is_made_once_and_returned_as_a_copy():
    plant = CountingPlant()
    with remembered_runs():
        a = plant.run(_ref(0))
        b = plant.run(_ref(0))
        a.u[:] = -1.0  # a caller altering its trial leaves what is kept alone
        c = plant.run(_ref(0))
    assert plant.ran == 1 and b is not c
    np.testing.assert_array_equal(c.u, 2.0 * _ref(0))
    plant.run(_ref(0))  # outside the block every run is made
    assert plant.ran == 2


def test_the_key_is_the_plant_the_reference_and_the_signals():
    plant = CountingPlant(gain=3.0)
    with remembered_runs():
        plant.run(_ref(1))
        plant.run(_ref(1), np.ones((50, 1)))  # another feedforward
        plant.run(_ref(1) + 1e-12)  # another reference
        CountingPlant(gain=4.0).run(_ref(1))  # another plant (its own count)
        plant.gain = 5.0
        plant.run(_ref(1))  # the same plant, configured otherwise
    assert plant.ran == 4


def test_lists_run_only_what_is_missing_and_keep_their_order():
    plant = CountingPlant(gain=6.0)
    with remembered_runs():
        plant.run(_ref(2))
        out = plant.run([_ref(3), _ref(2), _ref(4)], [None, None, np.ones((50, 1))])
    assert plant.ran == 3
    np.testing.assert_array_equal(out[1].u, 6.0 * _ref(2))
    np.testing.assert_array_equal(out[2].u, 6.0 * _ref(4) + 1.0)


def test_a_plant_with_noise_runs_every_time():
    plant = CountingPlant(gain=7.0, deterministic=False)
    with remembered_runs():
        plant.run(_ref(5))
        plant.run(_ref(5))
    assert plant.ran == 2


def test_only_the_last_runs_are_kept(monkeypatch):
    monkeypatch.setattr(runs, "SIZE", 2)
    plant = CountingPlant(gain=8.0)
    with remembered_runs():
        for k in (6, 7, 8, 6):
            plant.run(_ref(k))
    assert plant.ran == 4 and len(runs._store()) <= 2
