"""The radial-basis-function network of paper 002, section 3.4 (eqs. 31-38).

One network maps a normalized input x (2 or 3 dimensions, each in about [-1, 1]) to a prediction

    e_hat(x) = beta0 theta^T Gamma(x),  Gamma = [f_r(x, mu_1, sigma), ..., f_r(x, mu_N, sigma), 1]   (31)-(33)
    f_r(x, mu, sigma) = exp(-||x - mu||^2 / sigma^2)                                                 (34)

with N = prod(m_d) neurons on a uniform grid over the ranges of each dimension (Table 5), one width
sigma (0.07), and beta0 the magnitude normalization of the predicted signal. The prediction is
linear in theta, so the cost V_T = 1/2 sum (e - e_hat)^2 (eq. 35) has one minimum:

* ``method="lstsq"`` (default): the minimum-norm least-squares solution, directly;
* ``method="momentum"``: the paper's gradient method with momentum, eqs. (36)-(38), with the
  heuristic gain rules of Table 4 (``MomentumRules``); ``history_`` holds V_T per iteration.

Both reach the same cost (tested). scikit-learn style: ``fit(X, y)`` then ``predict(X)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MomentumRules:
    """Table 4 of paper 002: gamma_0 = 7.5e-3, eta_0 = 0; after 1-5 consecutive decreases of V_T,
    eta += 20 gamma_0 (then held); after 1-3 consecutive increases eta halves, after the 4th eta = 0,
    from the 5th gamma halves and eta = 100 gamma. ``iterations``: at most; stop when the relative
    decrease of V_T stays below ``tol`` for 10 iterations."""

    gamma0: float = 7.5e-3
    iterations: int = 2000
    tol: float = 1e-9


def grid_centres(ranges: list[tuple[float, float]], counts: list[int]) -> np.ndarray:
    """Neuron centres (N, D): every combination of ``counts[d]`` points uniform over ``ranges[d]``."""
    axes = [np.linspace(lo, hi, n) for (lo, hi), n in zip(ranges, counts, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))


class RBFNetwork:
    """One RBF network (eqs. 31-34). ranges, counts: the neuron grid per input dimension; sigma: the
    width; beta0: output scale (the prediction is beta0 theta^T Gamma); method: "lstsq" or "momentum".
    ``fit`` sets ``theta_`` (N + 1,), ``cost_`` (V_T at the end) and, for "momentum", ``history_``."""

    def __init__(self, ranges, counts, sigma: float = 0.07, beta0: float = 1.0, method: str = "lstsq",
                 rules: MomentumRules | None = None):
        self.ranges = ranges
        self.counts = counts
        self.sigma = sigma
        self.beta0 = beta0
        self.method = method
        self.rules = rules

    def features(self, X: np.ndarray) -> np.ndarray:
        """Gamma (T, N + 1) of eq. (33) for inputs X (T, D)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        mu = grid_centres(list(self.ranges), list(self.counts))
        if X.shape[1] != mu.shape[1]:
            raise ValueError(f"RBFNetwork: inputs have {X.shape[1]} dimensions, the neuron grid {mu.shape[1]}")
        d2 = ((X[:, None, :] - mu[None, :, :]) ** 2).sum(axis=2)
        return np.column_stack([np.exp(-d2 / self.sigma**2), np.ones(X.shape[0])])

    def fit(self, X: np.ndarray, y: np.ndarray) -> RBFNetwork:
        if self.method not in ("lstsq", "momentum"):
            raise ValueError(f"method must be 'lstsq' or 'momentum', got {self.method!r}")
        G = self.features(X)
        y = np.asarray(y, dtype=float).ravel()
        if G.shape[0] != y.size or not np.all(np.isfinite(y)):
            raise ValueError(f"RBFNetwork.fit: {G.shape[0]} inputs but {y.size} targets, or targets not finite")
        if self.method == "lstsq":
            self.theta_, *_ = np.linalg.lstsq(self.beta0 * G, y, rcond=None)
        else:
            self.theta_, self.history_ = self._momentum(G, y, self.rules or MomentumRules())
        self.cost_ = self.cost(X, y)
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        """e_hat (T,) of eq. (31)."""
        return self.beta0 * self.features(X) @ self.theta_

    def cost(self, X: np.ndarray, y: np.ndarray) -> float:
        """V_T of eq. (35)."""
        r = np.asarray(y, dtype=float).ravel() - self.predict(X)
        return 0.5 * float(r @ r)

    def _momentum(self, G: np.ndarray, y: np.ndarray, rules: MomentumRules) -> tuple[np.ndarray, list[float]]:
        """Eqs. (36)-(38) with Table 4's gains: theta_{h+1} = theta_h + Y_h V_Gamma + eta_h (theta_h -
        theta_{h-1}), V_Gamma = sum Gamma e / beta0, Y_h = diag(gamma_h, ..., gamma_h, gamma_h / 100)."""
        n = G.shape[1]
        theta = prev = np.zeros(n)
        gamma, eta = rules.gamma0, 0.0
        scale = np.full(n, 1.0)
        scale[-1] = 0.01  # the offset's gain is gamma / 100 (eq. 37)
        e = y - self.beta0 * G @ theta
        cost = [0.5 * float(e @ e)]
        ups = downs = flat = 0
        for _ in range(rules.iterations):
            v = G.T @ e / self.beta0  # eq. (36)
            theta, prev = theta + gamma * scale * v + eta * (theta - prev), theta  # eq. (38)
            e = y - self.beta0 * G @ theta
            cost.append(0.5 * float(e @ e))
            if cost[-1] < cost[-2]:  # Table 4
                downs, ups = downs + 1, 0
                if downs <= 5:
                    eta += 20 * rules.gamma0
            else:
                ups, downs = ups + 1, 0
                if ups <= 3:
                    eta /= 2
                elif ups == 4:
                    eta = 0.0
                else:
                    gamma /= 2
                    eta = 100 * gamma
            flat = flat + 1 if abs(cost[-2] - cost[-1]) <= rules.tol * cost[-2] else 0
            if flat >= 10:
                break
        return theta, cost
