"""The IX plant: integrator convergence, consistency with the model, safety and sensors."""

import math

import numpy as np
import pytest

from lcgym.physics import effects as fx
from lcgym.physics.model import PhysicalModel
from lcgym.systems.ix import IX
from lcgym.systems.ix.effects import PositionDependentFriction
from lcgym.systems.ix.plant import ENCODER_RESOLUTION, IXPlant, SimulationDiverged, default_hidden_effects
from lcgym.systems.ix.references import random_moves

DEG = math.pi / 180


@pytest.fixture(scope="module")
def ref():
    return random_moves("test-move", np.random.default_rng(5), duration=8)


def load(trial):
    return np.column_stack([trial.extra["load_propeller"], trial.extra["load_roll"]])


def rms_deg(e):
    return np.degrees(np.sqrt(np.mean(e**2, axis=0)))


def test_integrator_converges_as_step_shrinks(ref):
    """All default effects on, quantization off (it would turn round-off into count flips)."""
    truth = load(IXPlant(substeps=80, encoder_resolution=(0, 0)).run(ref))
    err = {n: np.degrees(np.abs(load(IXPlant(substeps=n, encoder_resolution=(0, 0)).run(ref)) - truth).max())
           for n in (1, 2, 4, 8)}
    assert err[1] > err[2] > err[4] > err[8]
    assert err[4] / err[8] > 3  # second order: halving the step divides the error by about 4
    assert err[1] < 1e-4  # deg, at the default; one roll encoder count is 0.0119 deg


def test_rigid_plant_tracks_with_exact_model_feedforward(ref):
    """Plant and model share one implementation: the model's inverse dynamics on the rigid plant
    leaves only the zero-order-hold error, orders of magnitude below feedback-only errors."""
    plant = IXPlant(effects=(), encoder_resolution=(0, 0))
    exact = plant.run(ref, PhysicalModel(IX).predict(ref))
    fb_only = plant.run(ref)
    assert np.all(rms_deg(exact.error) < 2e-5)
    assert np.all(rms_deg(fb_only.error) > 0.1)


@pytest.mark.parametrize(
    "effect",
    [
        fx.CableSpring("roll", k=0.22),
        fx.CableInertia("roll", dJ=0.06),
        fx.GearHarmonic.from_amplitudes("propeller", 0.14, 0.7, 0.06, 2.0, velocity_gain=0.5),
        fx.CableDrape.from_amplitude("roll", 0.18, 0.3),
        PositionDependentFriction("roll", 0.075, 0.03, 0.06),
        fx.ViscousFriction("propeller", 0.5),
        fx.StribeckFriction("propeller", dF=0.07),
    ],
    ids=lambda e: e.key,
)
def test_each_effect_same_in_plant_and_model(ref, effect):
    """An effect in the plant is cancelled by the same effect in the model's feedforward (same
    sign, same formula), and it does matter when the model lacks it."""
    plant = IXPlant(effects=(effect,), encoder_resolution=(0, 0))
    with_effect = rms_deg(plant.run(ref, PhysicalModel(IX, effects=(effect,)).predict(ref)).error)
    without = rms_deg(plant.run(ref, PhysicalModel(IX).predict(ref)).error)
    i = IX.effect(effect).index
    assert with_effect[i] < 1e-4 and without[i] > 10 * with_effect[i]


def test_encoder_quantization(ref):
    tr = IXPlant().run(ref)
    for i, res in enumerate(ENCODER_RESOLUTION):
        counts = tr.pos[:, i] / res
        np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)


def test_input_saturates_at_5_volt(ref):
    ff = np.full_like(ref.positions, 3.0)
    ff[::2] = -3.0  # large, fast alternating feedforward: total input hits the limit
    tr = IXPlant().run(ref, ff)
    assert np.max(np.abs(tr.u)) == pytest.approx(5.0)


@pytest.mark.fault
def test_unstable_feedback_stops_with_state():
    from dataclasses import replace

    from lcgym.systems.ix.plant import IX_GAINS

    ref = random_moves("unstable", np.random.default_rng(1), duration=5)
    plant = IXPlant(gains=replace(IX_GAINS, kp=(-170.0, 120.0)))
    with pytest.raises(SimulationDiverged, match=r"unstable: the IX plant left its safe range .* angles"):
        plant.run(ref)


@pytest.mark.bad_input
def test_bad_feedforward_is_refused(ref):
    ff = np.zeros_like(ref.positions)
    ff[17, 1] = np.nan
    with pytest.raises(ValueError, match="sample 17"):
        IXPlant().run(ref, ff)
    with pytest.raises(ValueError, match="shape"):
        IXPlant().run(ref, ff[:-1])


def test_batch_equals_single_runs():
    refs = [random_moves(f"r{i}", np.random.default_rng(i), duration=4) for i in range(3)]
    plant = IXPlant()
    batch = plant.run(refs)
    for r, b in zip(refs, batch, strict=True):
        single = plant.run(r)
        np.testing.assert_array_equal(single.pos, b.pos)
        np.testing.assert_array_equal(single.u, b.u)


def test_every_default_effect_changes_the_run(ref):
    base = IXPlant().run(ref)
    effects = default_hidden_effects()
    for k in range(len(effects)):
        reduced = IXPlant(effects=effects[:k] + effects[k + 1 :]).run(ref)
        assert np.max(np.abs(reduced.u - base.u)) > 1e-3, effects[k].key


@pytest.mark.bad_input
def test_flexible_drive_needs_less_motor_inertia_than_axis():
    with pytest.raises(ValueError, match="motor inertia"):
        IXPlant(effects=(fx.DrivetrainFlexibility("roll", Jm=5.0),))


@pytest.mark.bad_input
def test_duplicate_effect_rejected():
    with pytest.raises(ValueError, match="twice"):
        IXPlant(effects=(fx.CableSpring("roll", k=0.1), fx.CableSpring("roll", k=0.2)))
