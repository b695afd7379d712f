"""EMPS-v0 (``lcgym.systems.emps_sim``): the published numbers, its controller checked against
closed-form steady states and its stability test against simulation, and the sim-to-real study on
files of the benchmark's layout."""

import dataclasses
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import scipy.io

import lcgym  # noqa: F401  (registers the ids)
from lcgym import systems
from lcgym.physics import effects as fx
from lcgym.systems.feedback import FeedbackGains
from lcgym.systems.urdf_plant import URDFPlant, loop_stable

ROOT = Path(__file__).resolve().parents[1]
G_TAU, KP, KV = 35.15, 160.18, 243.45  # N/V, 1/s, V s/m: the description's eq. (6)-(7)
FV_POS, FV_NEG, FC_POS, FC_NEG = 166.7061, 240.4236, 20.1440, 20.6277  # eq. (12), Sec. 4.2
M = 95.154


@pytest.fixture(scope="module")
def plant():
    return systems.resolve("emps_sim").bench().plant


def test_the_machine_carries_the_published_numbers(plant):
    g = plant.gains
    assert g.kp[0] == pytest.approx(G_TAU * KP * KV, rel=1e-5) and g.kd[0] == pytest.approx(G_TAU * KV, rel=1e-5)
    assert g.derivative == "measurement_fir2" and plant.u_max[0] == pytest.approx(10 * G_TAU)
    assert plant.fs == 1000.0 and plant.encoder_resolution[0] == 5e-8
    assert plant.system.nominal_params().to_vector()[0] == pytest.approx(M)
    viscous = next(e for e in plant.effects if isinstance(e, fx.ViscousFriction))
    asym = next(e for e in plant.effects if isinstance(e, fx.AsymmetricFriction))
    assert viscous.d + asym.dFv == pytest.approx(FV_POS, abs=1e-9) and viscous.d - asym.dFv == pytest.approx(FV_NEG, abs=1e-9)
    assert (asym.Fc_pos, asym.Fc_neg) == (FC_POS, FC_NEG)
    assert gym.spec("lcgym/EMPS-v0").kwargs["machine"] == "emps_sim"


def _ramp(v: float, seconds: float = 2.5, fs: float = 1000.0) -> np.ndarray:
    """Standstill for 0.5 s, then a ramp at v [m/s] within the 0-0.25 m travel."""
    t = np.arange(int(seconds * fs)) / fs
    return ((0.02 if v > 0 else 0.23) + v * np.clip(t - 0.5, 0.0, None))[:, None]


@pytest.mark.parametrize("v", [0.1, -0.05])
def test_ramp_steady_state_error_is_the_closed_form(plant, v):
    """On a ramp at speed v the loop settles where the controller's force kp e - kd v (its velocity
    estimate is exact on a ramp) balances the friction: e = (F(v) + kd v) / kp, F(v) = Fv+- v +-
    Fc+-. The same plant differentiating the error instead has no kd v term: e = F(v) / kp."""
    ref = _ramp(v)
    friction = (FV_POS * v + FC_POS) if v > 0 else (FV_NEG * v - FC_NEG)
    kp, kd = plant.gains.kp[0], plant.gains.kd[0]
    run = plant.run(ref)
    e_end = run.ref[-500:, 0] - run.extra["load_x"][-500:]
    assert np.mean(e_end) == pytest.approx((friction + kd * v) / kp, rel=2e-3)
    on_error = dataclasses.replace(plant.gains, derivative="error")
    other = URDFPlant(plant.system, effects=plant.effects, gains=on_error, fs=plant.fs, u_max=plant.u_max,
                      encoder_resolution=plant.encoder_resolution).run(ref)
    e_other = other.ref[-500:, 0] - other.extra["load_x"][-500:]
    assert np.mean(e_other) == pytest.approx(friction / kp, rel=2e-2)


@pytest.mark.parametrize("scale, stable", [(1.0, True), (0.1, True), (0.05, False), (20.0, False)])
def test_loop_stability_of_the_two_sample_derivative_matches_simulation(plant, scale, stable):
    """``loop_stable``'s verdict on the EMPS's loop (kd scaled) is what a simulation of the rigid
    carriage shows: a step's error dies out or grows."""
    g = plant.gains
    gains = FeedbackGains(g.kp, (g.kd[0] * scale,), filtered="derivative", derivative="measurement_fir2")
    assert loop_stable(gains, [M], plant.fs)[0] == stable
    bare = URDFPlant(plant.system, gains=gains, fs=plant.fs, max_error=10.0, preroll=0.0)
    ref = np.full((1500, 1), 0.1)
    ref[:5] = 0.1 - 1e-4  # a 0.1 mm step after 5 ms
    try:
        run = bare.run(ref)
        late = np.abs(run.ref[-200:, 0] - run.extra["load_x"][-200:]).max()
        grew = late > 1e-4
    except systems.SimulationDiverged:
        grew = True
    assert grew == (not stable)


def test_sim_to_real_study_on_files_of_the_benchmark_layout(plant, tmp_path):
    """The study reads two runs of the benchmark's layout (here made by EMPS-v0 itself, the second
    with pulses logged in volts and included in vir): it reports a near-zero difference for both,
    and a plot."""
    for name, seed in (("DATA_EMPS.mat", 0), ("DATA_EMPS_PULSES.mat", 1)):
        ref = systems.resolve("emps_sim").bench().references("validation", seed, 1, 6.0)[0]
        pulses = np.zeros((ref.n_samples, 1))
        extra = {}
        if "PULSES" in name:
            pulses[1000::1500] = 2.0  # V
            extra = {"pulses_N": pulses}
        run = plant.run(ref, pulses * G_TAU)
        scipy.io.savemat(tmp_path / name, {"t": run.t[:, None], "qm": run.pos, "qg": run.ref, "vir": run.u / G_TAU,
                                           "gtau": np.array([[G_TAU]]), **extra})
    out = subprocess.run([sys.executable, str(ROOT / "studies" / "emps_sim_to_real.py"), "--data", str(tmp_path),
                          "--out", str(tmp_path / "s2r.png")], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    lines = [line for line in out.stdout.splitlines() if line.startswith("{")]
    assert len(lines) == 3 and (tmp_path / "s2r.png").stat().st_size > 10_000
    import json

    figures = [json.loads(line) for line in lines]
    for f in figures[:2]:
        assert f["force_rms_difference_relative"] < 1e-6 and f["error_rms_difference_relative"] < 1e-6
    assert figures[2]["pulses_as"] == "N" and figures[2]["force_rms_difference_relative"] > 0.01


def test_rl_reports_a_prismatic_axis_in_mm(tmp_path):
    """The rl method's training curve and safeguard figures carry the axis's display unit: mm on the
    EMPS's carriage (the RMS in metres times 1000, not read as radians)."""
    from lcgym.methods.rl import RLConfig, RLFeedforward

    machine = systems.get("emps_sim")
    bench = systems.resolve("emps_sim").bench()
    refs = bench.references("train", 0, n=1, duration=2.0)
    trials = bench.run(refs)
    rl = RLFeedforward(RLConfig(total_steps=2 * refs[0].n_samples + 512, num_envs=1, cache_dir=str(tmp_path),
                                hyperparameters={"n_steps": 512, "batch_size": 512, "n_epochs": 1}), system=machine)
    rl.fit(trials).learn(bench.plant, refs[0])
    assert list(rl.curve_.columns) == ["env_steps", "return", "rms_x_mm"] and len(rl.curve_) >= 1
    base_m = rl._training_rms(bench.plant, np.zeros(1, dtype=bool))[0, 0]  # the base alone [m]
    assert rl.safeguard_["base"][0] == pytest.approx(1000.0 * base_m, rel=1e-4, abs=1e-6)
    # mm: on the physical base with its velocity feedforward the carriage follows to micrometres (read as
    # radians, the metres would show 57.3x, not 1000x, their value: below 2e-4)
    assert 5e-4 < rl.safeguard_["base"][0] < 5.0
