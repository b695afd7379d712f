"""What the data's spectra can show (``lcgym.diagnose.spectra``): a ripple the input holds passes,
one a logger's low-pass took out of the input is refused, and a bandwidth follows a filter."""

import math

import numpy as np
from scipy.signal import butter, lfilter

from lcgym.diagnose.spectra import UNHELD_SHARE, bandwidths, power_spectra, unheld_share

FS = 200.0


def _motion(seconds: float = 30.0, seed: int = 0):
    """A slow random motion's torque (mostly below 1 Hz) plus broadband noise of 1 % of its RMS, and
    a 15 Hz ripple of 5 % of its RMS."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    slow = sum(rng.normal() * np.sin(2 * math.pi * f * t + rng.uniform(0, 6)) for f in (0.2, 0.35, 0.5, 0.8))
    noise = 0.01 * slow.std() * rng.standard_normal(t.size)
    ripple = 0.05 * slow.std() * np.sin(2 * math.pi * 15.0 * t)
    return slow, noise, ripple


def _lowpass(x, hz):
    b, a = butter(2, hz, fs=FS)
    return lfilter(b, a, x)


def test_a_ripple_the_input_holds_passes_and_one_filtered_out_is_refused():
    slow, noise, ripple = _motion()
    held, _ = unheld_share(ripple, slow + noise + ripple, [slow.size], FS)
    assert held < 0.05
    filtered = _lowpass(slow + noise + ripple, 2.0)
    share, above = unheld_share(ripple, filtered, [slow.size], FS)
    assert share > UNHELD_SHARE and 10.0 < above < 20.0
    # the slow part of the motion is held by the filtered input: no refusal for it
    assert unheld_share(0.3 * slow, filtered, [slow.size], FS)[0] < 0.05


def test_a_bandwidth_falls_with_a_loggers_filter():
    slow, noise, ripple = _motion()
    raw = bandwidths((slow + noise + ripple)[:, None], [slow.size], FS)[0]
    filtered = bandwidths(_lowpass(slow + noise + ripple, 2.0)[:, None], [slow.size], FS)[0]
    assert filtered < 2.0 < raw


def test_spectra_of_several_trials_weigh_them_by_length():
    rng = np.random.default_rng(1)
    a, b = rng.standard_normal(4000), 3 * rng.standard_normal(2000)
    f, P = power_spectra(np.concatenate([a, b])[:, None], [4000, 2000], FS)
    _, Pa = power_spectra(a[:, None], [4000], FS)
    _, Pb = power_spectra(b[:, None], [2000], FS)
    assert np.allclose(P, (4000 * Pa + 2000 * Pb) / 6000)


def test_a_ripple_filtered_out_of_the_input_is_refused_where_held_out_scores_would_let_it_through():
    """The IX with a gear ripple of 2 deg period on the propeller: named from the input as logged;
    once the input is low-passed at 1 Hz the ripple's low-speed remnants still pass the held-out
    rules, but most of the torque it would add lies where the input holds nothing, and it is refused."""
    import dataclasses

    from lcgym.diagnose import diagnose
    from lcgym.physics import effects as fx
    from lcgym.physics.kinematics import lowpass_zero_phase
    from lcgym.systems.ix import IX
    from lcgym.systems.ix.plant import IXPlant
    from lcgym.systems.ix.references import reference_set

    ripple = fx.GearHarmonic.from_amplitudes("propeller", 0.15, 0.7, 0.06, 2.0, velocity_gain=0.5, period=2 * math.pi / 180)
    runs = IXPlant(effects=(ripple,)).run(reference_set("train", 0, 2))
    raw = diagnose(runs, IX)
    assert raw.missing == ["gear_harmonic@propeller"]
    filtered = diagnose([dataclasses.replace(r, u=lowpass_zero_phase(r.u, r.fs, 1.0)) for r in runs], IX)
    assert "gear_harmonic@propeller" not in filtered.missing
    verdicts = [c.verdict for c in filtered.steps[0].candidates
                if c.effect == "gear_harmonic" and c.axis == "propeller"]
    assert verdicts and verdicts[0].startswith("not in the input's spectrum"), verdicts
    assert filtered.samples["bandwidth"]["input"]["propeller"] < 2.0 < raw.samples["bandwidth"]["input"]["propeller"]
