"""ILC on a FlexArm base (lcgym/systems/flexarm/learning.py): the kept trial is never measured worse
than the base, the update leaves the base alone where nothing is measured and hands the feedback's
torque to the feedforward, and a predicted error enters the same update as a measured one."""

import numpy as np
import pytest

from lcgym.methods.ilc.method import iterate
from lcgym.systems.flexarm.learning import (
    PREDICTED,
    ArmILCConfig,
    ArmLaw,
    load_inertia,
    loop_responses,
    measure,
    update,
)
from lcgym.systems.flexarm.nominal import BasicFeedforward
from lcgym.systems.flexarm.plant import FlexArmPlant
from lcgym.systems.flexarm.references import MOVING, arm_reference_set
from lcgym.systems.learning import Signals, best_trial

FS = 1000.0


@pytest.fixture(scope="module")
def line():
    return arm_reference_set("validation", 0, 1, FS)[0]


@pytest.fixture(scope="module")
def learned(line):
    """One update on Basic's torque and offset (a base with something to learn), on FlexArm-v1."""
    plant, nominal = FlexArmPlant.of_version("v1"), BasicFeedforward()
    basic = nominal.compute(line.positions, line.fs)
    loop = ArmLaw(plant, nominal, 1, ArmILCConfig(q_hz=6.0)).loop(line, Signals(basic["tau_ff"], basic["reference_offset"]))
    return plant, nominal, basic, loop, iterate(loop, line, 1, MOVING)


def test_best_trial_is_never_measured_worse_than_the_base_on_any_scored_axis():
    rng = np.random.default_rng(0)
    cols = [*MOVING, 6]
    for _ in range(500):
        history = rng.uniform(0.5, 1.5, size=(rng.integers(1, 8), 7))
        k = best_trial(history, cols)
        assert np.all(history[k, cols] <= history[0, cols])
        eligible = [j for j in range(len(history)) if np.all(history[j, cols] <= history[0, cols])]
        assert k in eligible and k == min(eligible, key=lambda j: (history[j, cols] / history[0, cols]).sum())
    # an unscored joint may grow
    history = np.ones((2, 7))
    history[1, cols] = 0.5
    history[1, 0] = 9.0
    assert best_trial(history, cols) == 1


def test_learning_keeps_a_trial_measured_no_worse_than_the_base(learned):
    _, _, basic, _, out = learned
    h = np.asarray(out.history)
    assert out.used == len(out.history) == len(out.true_history) == 2 and h.shape == (2, 7)
    k = out.best
    assert np.all(h[k, [*MOVING, 6]] <= h[0, [*MOVING, 6]])
    f, o = out.tried[k]
    assert out.signals.feedforward is f and out.signals.offset is o
    assert np.array_equal(out.tried[0][0], basic["tau_ff"])  # trial 0 is the base itself
    # on Basic the encoder ILC has something to learn: the measured error falls
    assert k > 0 and h[k, 6] < h[0, 6]


def test_nothing_measured_leaves_the_base_unchanged(line):
    nominal = BasicFeedforward()
    basic = nominal.compute(line.positions, line.fs)
    f0, o0 = basic["tau_ff"], basic["reference_offset"]
    zero = np.zeros_like(f0)
    for cfg in (ArmILCConfig(), ArmILCConfig(offset=True), ArmILCConfig(torque="lcs")):
        f, o = update(nominal, f0, o0, {"motor": zero, "feedback": zero, "acceleration": zero, "e_pl": zero}, FS, cfg,
                      base=f0)
        np.testing.assert_allclose(f, f0, atol=1e-12)
        np.testing.assert_allclose(o, o0, atol=1e-15)


def test_the_feedforward_takes_over_a_constant_feedback_torque(line):
    """u_fb = C e_m: with no motor error left, a held feedback torque moves into f as it is (Q has
    unit gain at DC and the edges are held), and the offset stays."""
    nominal = BasicFeedforward()
    basic = nominal.compute(line.positions, line.fs)
    f0, o0 = basic["tau_ff"], basic["reference_offset"]
    c = np.array([0.0, 1.5, -0.7, 0.0, 0.2, 0.0])
    zero = np.zeros_like(f0)
    f, o = update(nominal, f0, o0, {"motor": zero, "feedback": zero + c, "acceleration": zero}, FS, ArmILCConfig(),
                  base=f0)
    np.testing.assert_allclose(f - f0, zero + c, atol=1e-9)
    np.testing.assert_array_equal(o, o0)


def test_loop_model_motor_and_load_agree_at_low_frequency():
    """P_lm -> 1 at low frequency (the load follows the motor through a stiff spring), and P_m ~
    1 / (J s^2 + D s) with J = Jm + M / N^2, D = Dm + Dl / N^2 there (motor and reflected load move
    as one)."""
    nominal = BasicFeedforward()
    n = 20000
    M = load_inertia(nominal.arm_params, np.zeros((3, 6)))
    resp = loop_responses(nominal, n, FS, inertia=M)
    w = 2 * np.pi * np.fft.rfftfreq(n, 1 / FS)
    k = int(np.searchsorted(w, 2 * np.pi * 0.5))  # 0.5 Hz
    np.testing.assert_allclose(np.abs(resp["P_lm"][k, :3]), 1.0, rtol=1e-2)
    d = nominal.drive
    N = np.asarray(d.N)
    J, D = np.asarray(d.Jm) + M / N**2, np.asarray(d.Dm) + np.asarray(d.Dl) / N**2
    rigid = 1.0 / np.abs(-J * w[k] ** 2 + 1j * w[k] * D)
    np.testing.assert_allclose(np.abs(resp["P_m"][k, :3]), rigid[:3], rtol=0.01)


def test_a_predicted_error_enters_the_same_update_as_the_measured_one(learned, line):
    plant, nominal, basic, loop, _ = learned
    f0, o0 = basic["tau_ff"], basic["reference_offset"]
    trial = plant.run(line, f0, np.asarray(nominal.drive.N) * o0)
    measured = measure(trial, line, nominal, f0, o0, plant.accel_offset)
    f_m, o_m = update(nominal, f0, o0, measured, FS, PREDICTED, base=f0)
    f_p, o_p = loop.predicted(measured["e_pl"].copy())
    np.testing.assert_array_equal(f_m, f_p)
    np.testing.assert_array_equal(o_m, o_p)
    assert not np.allclose(f_p, f0)  # the error did move it
