"""Error norms of paper 000, eqs. (34)-(36) (lcgym/metrics.py), against hand computations.

MA = mean |x|, RMS = sqrt(mean x^2), Inf = max |x|, along time, one value per axis.
"""

import math

import numpy as np
import pandas as pd
import pytest

from lcgym.data import Trial
from lcgym.metrics import METRICS, input_residual_table, norms, norms_table, tracking_error_table

AXES = ("propeller", "roll")


def test_norms_1d_hand_computed():
    n = norms([3.0, -4.0])
    assert set(n) == set(METRICS) == {"MA", "RMS", "Inf"}
    assert float(n["MA"]) == pytest.approx(3.5, rel=1e-15)
    assert float(n["RMS"]) == pytest.approx(math.sqrt(12.5), rel=1e-15)
    assert float(n["Inf"]) == pytest.approx(4.0, rel=1e-15)


def test_norms_1d_with_sign_change_and_zero():
    x = [1.0, -2.0, 0.0, 2.0, -5.0]
    n = norms(x)
    assert float(n["MA"]) == pytest.approx(10.0 / 5)  # (1+2+0+2+5)/5
    assert float(n["RMS"]) == pytest.approx(math.sqrt(34.0 / 5))  # (1+4+0+4+25)/5
    assert float(n["Inf"]) == pytest.approx(5.0)  # |-5|: the negative extreme counts


def test_norms_single_sample_and_constant():
    n = norms([-0.7])
    assert [float(n[m]) for m in METRICS] == pytest.approx([0.7, 0.7, 0.7])
    n = norms(np.full(9, -2.5))
    assert [float(n[m]) for m in METRICS] == pytest.approx([2.5, 2.5, 2.5])


def test_norms_per_column_2d():
    x = np.array([[1.0, -6.0], [-3.0, 0.0], [2.0, 2.0], [0.0, 4.0]])
    n = norms(x)
    for m in METRICS:
        assert n[m].shape == (2,)
    np.testing.assert_allclose(n["MA"], [6.0 / 4, 12.0 / 4])
    np.testing.assert_allclose(n["RMS"], [math.sqrt(14.0 / 4), math.sqrt(56.0 / 4)])
    np.testing.assert_allclose(n["Inf"], [3.0, 6.0])


def test_norms_ordering_on_random_signal():
    """MA <= RMS <= Inf always, and RMS^2 = MA^2 + variance of |x|."""
    x = np.random.default_rng(3).normal(size=(200, 3))
    n = norms(x)
    assert np.all(n["MA"] <= n["RMS"]) and np.all(n["RMS"] <= n["Inf"])
    np.testing.assert_allclose(n["RMS"] ** 2, n["MA"] ** 2 + np.var(np.abs(x), axis=0), rtol=1e-12)


@pytest.mark.bad_input
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_norms_rejects_non_finite(bad):
    with pytest.raises(ValueError):
        norms([1.0, bad, 2.0])
    x = np.zeros((5, 2))
    x[3, 1] = bad
    with pytest.raises(ValueError):
        norms(x)


@pytest.mark.bad_input
@pytest.mark.parametrize("empty", [[], np.zeros((0,)), np.zeros((0, 2))])
def test_norms_rejects_empty(empty):
    with pytest.raises(ValueError, match="empty"):
        norms(empty)


def _trial(err_rad: np.ndarray, u=None, seed=0) -> Trial:
    n = err_rad.shape[0]
    rng = np.random.default_rng(seed)
    ref = rng.uniform(-1, 1, size=(n, 2))
    u = np.zeros((n, 2)) if u is None else u
    return Trial(t=np.arange(n) / 100.0, ref=ref, pos=ref - err_rad, u=u, axes=AXES)


def test_tracking_error_table_in_degrees():
    # propeller: constant error 0.01 rad; roll: errors +-0.02 rad and 0
    e1 = np.column_stack([np.full(4, 0.01), [0.02, -0.02, 0.0, 0.0]])
    table = tracking_error_table([_trial(e1)], label="ctrl-A")
    assert isinstance(table, pd.DataFrame)
    assert list(table["axis"]) == list(AXES)
    assert set(table["unit"]) == {"deg"}
    assert set(table["signal"]) == {"tracking_error"}
    assert set(table["label"]) == {"ctrl-A"}
    prop = table.set_index("axis").loc["propeller"]
    roll = table.set_index("axis").loc["roll"]
    d = 180.0 / math.pi
    assert prop["MA"] == pytest.approx(0.01 * d, rel=1e-9)
    assert prop["RMS"] == pytest.approx(0.01 * d, rel=1e-9)
    assert prop["Inf"] == pytest.approx(0.01 * d, rel=1e-9)
    assert roll["MA"] == pytest.approx(0.01 * d, rel=1e-9)  # (0.02+0.02)/4
    assert roll["RMS"] == pytest.approx(math.sqrt(2 * 0.02**2 / 4) * d, rel=1e-9)
    assert roll["Inf"] == pytest.approx(0.02 * d, rel=1e-9)
    assert prop["Inf"] == pytest.approx(0.5729577951308232, rel=1e-12)  # 0.01 rad in deg


def test_tracking_error_table_pools_trials():
    """Trials are taken together (sample-weighted), not averaged per trial."""
    a = _trial(np.column_stack([np.full(1, 0.03), np.zeros(1)]), seed=1)  # 1 sample, 0.03 rad
    b = _trial(np.column_stack([np.zeros(3), np.full(3, -0.01)]), seed=2)  # 3 samples, 0 rad
    table = tracking_error_table([a, b]).set_index("axis")
    d = math.degrees(1.0)
    assert table.loc["propeller", "MA"] == pytest.approx(0.03 / 4 * d, rel=1e-9)
    assert table.loc["propeller", "Inf"] == pytest.approx(0.03 * d, rel=1e-9)
    assert table.loc["roll", "MA"] == pytest.approx(0.03 / 4 * d, rel=1e-9)
    assert table.loc["roll", "RMS"] == pytest.approx(math.sqrt(3 * 1e-4 / 4) * d, rel=1e-9)


def test_input_residual_table_in_volts():
    n = 4
    u = np.column_stack([[1.0, 2.0, 3.0, 4.0], [0.5, 0.5, -0.5, -0.5]])
    f = np.column_stack([[1.0, 1.0, 1.0, 1.0], [0.0, 0.0, 0.0, 0.0]])
    tr = _trial(np.zeros((n, 2)), u=u)
    table = input_residual_table([tr], [f], label="ff").set_index("axis")
    assert set(table["unit"]) == {"V"}
    assert set(table["signal"]) == {"input_residual"}
    # propeller eps = u - f = 0, 1, 2, 3
    assert table.loc["propeller", "MA"] == pytest.approx(1.5)
    assert table.loc["propeller", "RMS"] == pytest.approx(math.sqrt(14.0 / 4))
    assert table.loc["propeller", "Inf"] == pytest.approx(3.0)
    # roll eps = u: 0.5 in magnitude; no deg conversion of volts
    assert [table.loc["roll", m] for m in METRICS] == pytest.approx([0.5, 0.5, 0.5])


def test_input_residual_table_with_one_unit_per_axis():
    """A machine of a prismatic and a revolute axis: N on the one, N m on the other, per row."""
    tr = _trial(np.zeros((2, 2)), u=np.array([[3.0, -1.0], [-3.0, 1.0]]))
    table = input_residual_table([tr], [np.zeros((2, 2))], unit=("N", "N m")).set_index("axis")
    assert table.loc["propeller", "unit"] == "N" and table.loc["roll", "unit"] == "N m"
    assert [table.loc["propeller", m] for m in METRICS] == pytest.approx([3.0, 3.0, 3.0])


@pytest.mark.bad_input
@pytest.mark.parametrize("unit", [("N",), ("N", "N m", "V"), ("N", ""), ("N", None)])
def test_norms_table_rejects_units_that_do_not_fit_the_axes(unit):
    with pytest.raises(ValueError, match=r"one per axis \(2: propeller, roll\)"):
        norms_table(np.ones((3, 2)), AXES, "input_residual", unit)


def test_input_residual_sign_is_u_minus_f():
    """eps = u - f, not u alone nor u + f (the norms cannot tell u - f from f - u)."""
    u = np.column_stack([np.linspace(-2, 2, 5), np.linspace(3, 4, 5)])
    tr = _trial(np.zeros((5, 2)), u=u)
    table = input_residual_table([tr], [u.copy()])
    np.testing.assert_allclose(table[list(METRICS)].to_numpy(), 0.0, atol=1e-15)
    table = input_residual_table([tr], [np.zeros_like(u)]).set_index("axis")
    assert table.loc["roll", "Inf"] == pytest.approx(4.0)


def test_input_residual_pools_trials():
    a = _trial(np.zeros((2, 2)), u=np.full((2, 2), 2.0))
    b = _trial(np.zeros((2, 2)), u=np.full((2, 2), -1.0))
    table = input_residual_table([a, b], [np.ones((2, 2)), np.ones((2, 2))]).set_index("axis")
    # eps = 1, 1, -2, -2
    assert table.loc["propeller", "MA"] == pytest.approx(1.5)
    assert table.loc["propeller", "RMS"] == pytest.approx(math.sqrt(10.0 / 4))
    assert table.loc["propeller", "Inf"] == pytest.approx(2.0)


@pytest.mark.bad_input
def test_tables_reject_nan():
    e = np.zeros((3, 2))
    e[1, 0] = np.nan
    with pytest.raises(ValueError):
        tracking_error_table([_trial(e)])
    f = np.zeros((3, 2))
    f[2, 1] = np.nan
    with pytest.raises(ValueError):
        input_residual_table([_trial(np.zeros((3, 2)))], [f])


@pytest.mark.bad_input
def test_input_residual_rejects_mismatched_counts():
    """Two trials with one feedforward must not silently drop the second trial."""
    trials = [_trial(np.zeros((3, 2)), u=np.full((3, 2), k + 1.0)) for k in range(2)]
    with pytest.raises(ValueError):
        input_residual_table(trials, [np.zeros((3, 2))])


@pytest.mark.bad_input
def test_input_residual_rejects_wrong_feedforward_shape():
    tr = _trial(np.zeros((3, 2)), u=np.ones((3, 2)))
    with pytest.raises(ValueError):
        input_residual_table([tr], [np.zeros((3, 1))])  # one column for two axes
