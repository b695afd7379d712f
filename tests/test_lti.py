"""physics.lti.lsim: scipy.signal.lsim's numbers (to round-off; bit for bit for one state and input), and
the steady state of a step."""

import numpy as np
import pytest
from scipy import signal

from lcgym.physics.lti import lsim


def _system(rng, n, m, p):
    A = rng.normal(size=(n, n)) - 3.0 * np.eye(n)  # stable for these seeds (checked below)
    return A, rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m))


@pytest.mark.parametrize("n, m, p", [(1, 1, 1), (2, 1, 1), (3, 1, 1), (3, 2, 2)])
def test_lsim_is_scipy_bit_for_bit(n, m, p):
    rng = np.random.default_rng(n + 10 * m)
    A, B, C, D = _system(rng, n, m, p)
    fs = 1000.0
    u = rng.normal(size=(2000, m)).cumsum(axis=0)
    x0 = rng.normal(size=n)
    t = np.arange(len(u)) / fs
    for inp in (u[:, 0] if m == 1 else u, np.zeros(len(u)) if m == 1 else np.zeros_like(u)):  # the zero input: scipy's own branch
        _, y_ref, x_ref = signal.lsim((A, B, C, D), inp, t, X0=x0)
        y, x = lsim(A, B, C, D, inp, fs, x0)
        assert y.shape == y_ref.shape and x.shape == x_ref.shape
        if n == 1 and m == 1:  # nothing to sum: bit for bit on any machine
            assert np.array_equal(y, y_ref) and np.array_equal(x, x_ref)
        # else the same sums, to round-off: numpy's vector-matrix products may sum in another order
        # by CPU (bit for bit on the machine of 2026-12-01; from the 15th digit on an AVX-512 one)
        np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-13 * np.abs(x_ref).max())
        np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-13 * np.abs(y_ref).max())


def test_lsim_step_settles_at_the_dc_gain():
    """A known limit: for a unit step, y -> D - C A^-1 B."""
    rng = np.random.default_rng(3)
    A, B, C, D = _system(rng, 3, 1, 1)
    assert np.all(np.linalg.eigvals(A).real < 0)
    y, _ = lsim(A, B, C, D, np.ones(100_000), 100.0)  # 1,000 s: many times the slowest time constant
    assert y[-1] == pytest.approx((D - C @ np.linalg.solve(A, B)).item(), rel=1e-9)


def test_lsim_refuses_nan_and_mismatched_shapes():
    A, B, C, D = np.eye(2) * -1.0, np.ones((2, 1)), np.ones((1, 2)), np.zeros((1, 1))
    u = np.ones(10)
    u[4] = np.nan
    with pytest.raises(ValueError, match="NaN or inf .* sample 4"):
        lsim(A, B, C, D, u, 100.0)
    with pytest.raises(ValueError, match="do not fit"):
        lsim(A, B, C, D, np.ones((10, 2)), 100.0)
