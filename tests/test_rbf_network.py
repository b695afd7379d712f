"""The RBF network of paper 002 (lcgym/methods/rbf_expert/network.py): features, least squares, and the
paper's momentum gradient method reaching the same cost."""

import numpy as np
import pytest

from lcgym.methods.rbf_expert.network import RBFNetwork, grid_centres

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


@pytest.mark.bad_input
def test_bad_input_is_refused():
    net = RBFNetwork(RANGES, COUNTS)
    with pytest.raises(ValueError, match="dimensions"):
        net.fit(np.zeros((5, 3)), np.zeros(5))
    with pytest.raises(ValueError, match="targets"):
        net.fit(np.zeros((5, 2)), np.array([0, 1, np.nan, 0, 0]))
    with pytest.raises(ValueError, match="method"):
        RBFNetwork(RANGES, COUNTS, method="adam").fit(np.zeros((5, 2)), np.zeros(5))


def test_momentum_and_least_squares_agree_with_ridge_and_support():
    """The same regularized problem (ridge, safety rule's supported neurons) for both solvers."""
    rng = np.random.default_rng(2)
    X = rng.uniform([-1, 0], [0.2, 1], (3000, 2))  # data on part of the grid only
    y = np.cos(2 * X[:, 0]) + 0.01 * rng.standard_normal(3000)
    kw = dict(beta0=1.5, support=1.0, ridge=3.0)
    direct = RBFNetwork(RANGES, COUNTS, **kw).fit(X, y)
    momentum = RBFNetwork(RANGES, COUNTS, method="momentum", **kw).fit(X, y)
    assert momentum.cost_ == pytest.approx(direct.cost_, rel=1e-5)
    assert 0 < direct.supported_.sum() < direct.supported_.size
    np.testing.assert_array_equal(direct.theta_[:-1][~direct.supported_], 0.0)


def test_prediction_fades_to_zero_outside_the_training_data():
    """Section 4.1's safety rule: inside the data confidence 1, far from it 0 and so the prediction."""
    rng = np.random.default_rng(3)
    X = rng.uniform([-1, 0], [0, 1], (2000, 2))
    net = RBFNetwork(RANGES, COUNTS, support=1.0, ridge=1.0).fit(X, 1.0 + X[:, 1])
    inside, far = np.array([[-5 / 9, 0.5]]), np.array([[0.8, 0.5]])  # inside: at a neuron centre
    assert net.confidence(inside)[0] == 1.0 and net.predict(inside)[0] == pytest.approx(1.5, abs=0.15)
    assert net.confidence(far)[0] < 1e-6 and abs(net.predict(far)[0]) < 1e-6
    assert net.outside(np.vstack([inside, far])).tolist() == [False, True]
    assert net.predict(np.array([[np.nan, 0.5]]))[0] == 0.0  # no input, no prediction


def test_separable_activations_equal_the_distance_formula():
    net = RBFNetwork([(-1, 1), (0, 1), (-0.1, 1)], [5, 4, 3])
    X = np.random.default_rng(4).uniform(-1, 1, (7, 3))
    mu = grid_centres(net.ranges, net.counts)
    direct = np.exp(-((X[:, None, :] - mu[None]) ** 2).sum(axis=2) / 0.07**2)
    np.testing.assert_allclose(net.activations(X), direct, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(net.activations(X, np.array([3, 17])), direct[:, [3, 17]], rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(net.total_activation(X), direct.sum(axis=0), rtol=1e-10, atol=1e-300)
