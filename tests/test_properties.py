"""Property-based tests (hypothesis): the error norms, the jerk-limited reference generator and
the measurement-file reader hold their promises for any valid input hypothesis can find, and
refuse any corruption of a valid file with an error that names the column and the row."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from lcgym.data import MeasurementFileError, Trial, read_trials, write_trials
from lcgym.metrics import norms
from lcgym.references import AxisProfile
from lcgym.systems.ix import IX

PROFILE = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
signals = st.integers(1, 3).flatmap(lambda n: arrays(np.float64, st.tuples(st.integers(1, 200), st.just(n)),
                                                     elements=finite))


# ---------------------------------------------------------------------------------------------
# metrics: paper 000 eqs. (34)-(36)
# ---------------------------------------------------------------------------------------------


@PROFILE
@given(x=signals, c=st.floats(-1e150, 1e150, allow_nan=False), seed=st.integers(0, 2**32 - 1))
def test_norms_order_scaling_permutation_and_repetition(x, c, seed):
    n = norms(x)
    tol = 1e-12 * (1 + np.abs(x).max())
    assert np.all(n["MA"] >= 0) and np.all(n["MA"] <= n["RMS"] + tol) and np.all(n["RMS"] <= n["Inf"] + tol)
    scaled = norms(c * x)
    for m in ("MA", "RMS", "Inf"):
        np.testing.assert_allclose(scaled[m], abs(c) * n[m], rtol=1e-9, atol=1e-300)
    shuffled = norms(x[np.random.default_rng(seed).permutation(len(x))])
    twice = norms(np.concatenate([x, x]))
    for m in ("MA", "RMS", "Inf"):
        np.testing.assert_allclose(shuffled[m], n[m], rtol=1e-9, atol=tol)
        np.testing.assert_allclose(twice[m], n[m], rtol=1e-9, atol=tol)


@PROFILE
@given(x=signals, where=st.integers(0, 10**6), bad=st.sampled_from([np.nan, np.inf, -np.inf]))
def test_norms_refuse_any_non_finite_sample(x, where, bad, tally):
    tally("bad_input")
    x = x.copy()
    x.flat[where % x.size] = bad
    with pytest.raises(ValueError, match="NaN or inf"):
        norms(x)


# ---------------------------------------------------------------------------------------------
# the reference generator: third-order (jerk-limited) moves
# ---------------------------------------------------------------------------------------------


def log_uniform(lo: float, hi: float):
    return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: 10.0**e)


@PROFILE
@given(x0=st.floats(-1.0, 1.0), d=log_uniform(1e-6, 10.0), sign=st.sampled_from([-1.0, 1.0]),
       v=log_uniform(0.03, 3.0), a=log_uniform(0.1, 10.0), j=log_uniform(0.3, 300.0))
def test_any_move_respects_its_limits_and_ends_at_rest_on_target(x0, d, sign, v, a, j):
    target = x0 + sign * d
    p = AxisProfile(x0).move(target, v, a, j)
    t = np.linspace(0.0, p.end_time, 4001)
    x, vel, acc = p.evaluate(t)
    assert np.max(np.abs(vel)) <= v * (1 + 1e-9) and np.max(np.abs(acc)) <= a * (1 + 1e-9)
    assert np.max(np.abs(np.diff(acc) / np.diff(t))) <= j * 1.02  # jerk by finite differences
    xe, ve, ae = p.evaluate(np.array([p.end_time, p.end_time + 1.0]))
    assert np.all(xe == target) and np.all(ve == 0) and np.all(ae == 0)
    roundoff = 1e-14 * (abs(x0) + d)
    assert np.all(sign * (x - x0) >= -roundoff) and np.all(sign * (target - x) >= -roundoff)  # no overshoot


# ---------------------------------------------------------------------------------------------
# the measurement-file reader
# ---------------------------------------------------------------------------------------------

AXES = ("propeller", "roll")


def trial_of(values: np.ndarray, fs: float) -> Trial:
    n = len(values)
    return Trial(t=np.arange(n) / fs, ref=values[:, 0:2], pos=values[:, 2:4], u=values[:, 4:6], axes=AXES,
                 ff=values[:, 6:8])


trials = st.tuples(st.integers(3, 60), st.sampled_from([100.0, 500.0, 1000.0])).flatmap(
    lambda nf: st.tuples(arrays(np.float64, (nf[0], 8), elements=st.floats(-3.0, 3.0, width=32)), st.just(nf[1])))


@PROFILE
@given(data=trials, suffix=st.sampled_from([".csv", ".parquet"]))
def test_any_written_trial_reads_back(tmp_path, data, suffix):
    values, fs = data
    path = tmp_path / f"m{suffix}"
    write_trials(path, [trial_of(values, fs)], meta={"system": "ix"})
    back = read_trials(path, axes=IX)
    assert len(back) == 1
    rtol = 1e-9 if suffix == ".csv" else 0.0  # CSV keeps 10 significant digits, Parquet every bit
    np.testing.assert_allclose(np.column_stack([back[0].ref, back[0].pos, back[0].u, back[0].ff]), values,
                               rtol=rtol, atol=0)
    assert back[0].fs == pytest.approx(fs, rel=1e-9)


BAD_TOKENS = st.sampled_from(["nan", "NaN", "inf", "-inf", "", "abc", "1.0.0", "0x10", "--1", "1e999"])
COLUMNS = ("ref_propeller", "ref_roll", "pos_propeller", "pos_roll", "u_propeller", "u_roll")


@PROFILE
@given(data=trials, row=st.integers(0, 10**6), column=st.sampled_from(COLUMNS), token=BAD_TOKENS)
def test_any_corrupt_cell_is_named_by_column_and_row(tmp_path, data, row, column, token, tally):
    tally("bad_input")
    values, fs = data
    path = tmp_path / "m.csv"
    write_trials(path, [trial_of(values, fs)])
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    r = 1 + row % (len(lines) - 1)  # data row r (1 = the first after the header)
    cells = lines[r].split(",")
    cells[header.index(column)] = token
    lines[r] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MeasurementFileError) as exc:
        read_trials(path, axes=IX)
    message = str(exc.value)
    assert path.name in message and repr(column) in message.replace('"', "'") and f"row {r}" in message, message
