"""The RBF network of paper 002 (lcgym/rbf_expert/network.py): features, least squares, and the
paper's momentum gradient method reaching the same cost."""

import numpy as np
import pytest

from lcgym.rbf_expert.network import RBFNetwork, grid_centres

RANGES, COUNTS = [(-1.0, 1.0), (0.0, 1.0)], [10, 11]


def test_grid_and_features():
    mu = grid_centres(RANGES, COUNTS)
    assert mu.shape == (110, 2) and mu.min(axis=0).tolist() == [-1.0, 0.0] and mu.max(axis=0).tolist() == [1.0, 1.0]
    G = RBFNetwork(RANGES, COUNTS).features(mu[:3])
    assert G.shape == (3, 111) and np.allclose(G[:, -1], 1.0)
    np.testing.assert_allclose(np.diag(G[:, :3]), 1.0)  # a neuron at its own centre
    assert G[0, 1] == pytest.approx(np.exp(-((1 / 10) ** 2) / 0.07**2))  # the next centre, 0.1 away


def test_least_squares_recovers_a_network_it_can_represent():
    rng = np.random.default_rng(0)
    net = RBFNetwork(RANGES, COUNTS, beta0=2.0)
    X = rng.uniform([-1, 0], [1, 1], (4000, 2))
    theta = rng.standard_normal(111)
    y = 2.0 * net.features(X) @ theta
    net.fit(X, y)
    np.testing.assert_allclose(net.predict(X), y, atol=1e-8)
    assert net.cost_ < 1e-12


def test_momentum_method_reaches_the_least_squares_cost():
    """Eqs. (36)-(38) with Table 4's gain rules converge to the minimum that least squares finds."""
    rng = np.random.default_rng(1)
    X = rng.uniform([-1, 0], [1, 1], (3000, 2))
    y = np.sin(3 * X[:, 0]) * X[:, 1] + 0.01 * rng.standard_normal(3000)
    direct = RBFNetwork(RANGES, COUNTS, beta0=0.5).fit(X, y)
    momentum = RBFNetwork(RANGES, COUNTS, beta0=0.5, method="momentum").fit(X, y)
    assert momentum.cost_ == pytest.approx(direct.cost_, rel=1e-6)
    h = momentum.history_
    assert h[0] > 3 * h[-1] and len(h) < 2000


def test_bad_input_is_refused():
    net = RBFNetwork(RANGES, COUNTS)
    with pytest.raises(ValueError, match="dimensions"):
        net.fit(np.zeros((5, 3)), np.zeros(5))
    with pytest.raises(ValueError, match="targets"):
        net.fit(np.zeros((5, 2)), np.array([0, 1, np.nan, 0, 0]))
    with pytest.raises(ValueError, match="method"):
        RBFNetwork(RANGES, COUNTS, method="adam").fit(np.zeros((5, 2)), np.zeros(5))
