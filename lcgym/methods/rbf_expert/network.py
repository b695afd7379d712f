"""The radial-basis-function network of paper 002, section 3.4 (eqs. 31-38).

One network maps a normalized input x (2 or 3 dimensions, each in about [-1, 1]) to a prediction

    e_hat(x) = beta0 theta^T Gamma(x),  Gamma = [f_r(x, mu_1, sigma), ..., f_r(x, mu_N, sigma), 1]   (31)-(33)
    f_r(x, mu, sigma) = exp(-||x - mu||^2 / sigma^2)                                                 (34)

with N = prod(m_d) neurons on a uniform grid over the ranges of each dimension (Table 5), one width
sigma (0.07), and beta0 the magnitude normalization of the predicted signal. The prediction is
linear in theta, so the cost V_T = 1/2 sum (e - e_hat)^2 (eq. 35) has one minimum:

* ``method="lstsq"`` (default): the least-squares solution, directly (minimum norm without a
  ridge, the normal equations by Cholesky with one);
* ``method="momentum"``: the paper's gradient method with momentum, eqs. (36)-(38), with the
  heuristic gain rules of Table 4 (``MomentumRules``); ``history_`` holds V_T per iteration.

Both reach the same cost (tested). ``ridge`` (lambda, default 0) adds 1/2 lambda beta0^2 ||theta||^2 to
the cost of both (the same problem; lambda counts as that many training samples at a neuron's
centre): the training inputs of one trajectory set lie on thin curves of the input space, and
without it neurons that see data only at their flank get huge weights of opposite sign that blow
up between the curves (measured on the FlexArm with 3D networks, 8 training lines, no ridge:
|theta| up to 2e5, predictions on new lines 100x the error, and the arm driven out of its safe
range). scikit-learn style: ``fit(X, y)`` then ``predict(X)``.

Prediction safety (section 4.1: "as the uncertainty grows, the prediction tends to zero"), used when
``support`` is given. The rule:

* a neuron is *supported* when the training inputs excite it with a total activation
  sum_j Gamma_m(x_j) >= ``support`` (about that many training samples at its centre); the others
  keep theta_m = 0 and are not fitted;
* the confidence of an input, c(x) = min(1, A(x) / A_0), with A(x) the summed activation of the
  supported neurons and A_0 half the median of A over the training inputs: 1 inside the data, falling
  to 0 with the distance from it (as the Gaussians do), 0 far outside the grid or for a NaN input;
* the network's features are c(x) Gamma(x), in training and prediction alike (the problem stays
  linear in theta): its output, the offset theta_0 included, fades to zero outside the data.

``outside(X)``: inputs with c(x) < 1, the share a report gives for a new trajectory.
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
    width; beta0: output scale (the prediction is beta0 theta^T Gamma); method: "lstsq" or
    "momentum"; support: the safety rule's threshold (module docstring; None: plain network).
    ``fit`` sets ``theta_`` (N + 1,), ``cost_`` (V_T at the end), ``supported_`` (N,) bool and, for
    "momentum", ``history_``."""

    def __init__(self, ranges, counts, sigma: float = 0.07, beta0: float = 1.0, method: str = "lstsq",
                 rules: MomentumRules | None = None, support: float | None = None, ridge: float = 0.0):
        self.ranges = ranges
        self.counts = counts
        self.sigma = sigma
        self.beta0 = beta0
        self.method = method
        self.rules = rules
        self.support = support
        self.ridge = ridge

    def _per_dimension(self, X: np.ndarray) -> list[np.ndarray]:
        """exp(-(x_d - mu_d)^2 / sigma^2) (m_d, T) for each dimension d; NaN inputs give 0. The grid
        makes eq. (34) a product over dimensions, so a neuron's activation is the product of these."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if X.shape[1] != len(self.counts):
            raise ValueError(f"RBFNetwork: inputs have {X.shape[1]} dimensions, the neuron grid {len(self.counts)}")
        return [np.nan_to_num(np.exp(-((np.linspace(lo, hi, n)[:, None] - X[None, :, d]) ** 2) / self.sigma**2))
                for d, ((lo, hi), n) in enumerate(zip(self.ranges, self.counts, strict=True))]

    def activations(self, X: np.ndarray, neurons: np.ndarray | None = None) -> np.ndarray:
        """f_r(x, mu_m, sigma) (T, N) of eq. (34) for inputs X (T, D), neurons in ``grid_centres``
        order; only the columns of ``neurons`` (indices) when given."""
        g = self._per_dimension(X)
        if neurons is None:
            out = g[0]
            for gd in g[1:]:
                out = (out[:, None, :] * gd[None, :, :]).reshape(-1, out.shape[1])
            return out.T
        idx = np.unravel_index(np.asarray(neurons), tuple(self.counts))
        out = g[0][idx[0]]  # (n, T)
        for gd, i in zip(g[1:], idx[1:], strict=True):
            out *= gd[i]
        return out.T

    def total_activation(self, X: np.ndarray) -> np.ndarray:
        """sum_j f_r(x_j, mu_m, sigma) (N,) over the inputs X, without forming the (T, N) matrix."""
        g = self._per_dimension(X)
        out = g[0]
        for gd in g[1:-1]:
            out = (out[:, None, :] * gd[None, :, :]).reshape(-1, out.shape[1])
        return (out @ g[-1].T).ravel() if len(g) > 1 else out.sum(axis=1)

    def features(self, X: np.ndarray) -> np.ndarray:
        """Gamma (T, N + 1) of eq. (33), times the confidence c(x) once fitted with ``support``; the
        columns of unsupported neurons are zero (their theta is 0)."""
        G, cols = self._design(X)
        full = np.zeros((G.shape[0], cols.size))
        full[:, cols] = G
        return full

    def _design(self, X: np.ndarray, a: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The nonzero columns of ``features`` and which they are (bool (N + 1,)); ``a``: the
        activations of the supported neurons if already computed."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if getattr(self, "supported_", None) is None:
            a = self.activations(X)
            return np.column_stack([a, np.ones(a.shape[0])]), np.ones(a.shape[1] + 1, dtype=bool)
        if a is None:
            a = self.activations(X, np.flatnonzero(self.supported_))
        c = self._confidence(a)
        G = np.empty((a.shape[0], a.shape[1] + 1), order="F")  # a is column-major too: no transposing copy
        np.multiply(a, c[:, None], out=G[:, :-1])
        G[:, -1] = c
        return G, np.append(self.supported_, True)

    def fit(self, X: np.ndarray, y: np.ndarray) -> RBFNetwork:
        if self.method not in ("lstsq", "momentum"):
            raise ValueError(f"method must be 'lstsq' or 'momentum', got {self.method!r}")
        X = np.atleast_2d(np.asarray(X, dtype=float))
        y = np.asarray(y, dtype=float).ravel()
        if X.shape[0] != y.size or not np.all(np.isfinite(y)) or not np.all(np.isfinite(X)):
            raise ValueError(f"RBFNetwork.fit: {X.shape[0]} inputs but {y.size} targets, or values not finite")
        self.supported_, a = None, None
        if self.support is not None:
            self.supported_ = self.total_activation(X) >= self.support
            a = self.activations(X, np.flatnonzero(self.supported_))
            self.a0_ = 0.5 * float(np.median(a.sum(axis=1))) if a.size else 0.0
        G, cols = self._design(X, a)
        self.theta_ = np.zeros(cols.size)
        if self.method == "lstsq":
            self.theta_[cols] = self._least_squares(G, y)
        else:
            self.theta_[cols], self.history_ = self._momentum(G, y, self.rules or MomentumRules())
        r = y - self.beta0 * G @ self.theta_[cols]
        self.cost_ = 0.5 * float(r @ r)  # V_T of eq. (35)
        return self

    def _least_squares(self, G: np.ndarray, y: np.ndarray) -> np.ndarray:
        """argmin ||y - beta0 G theta||^2 + ridge beta0^2 ||theta||^2: the normal equations
        (G^T G + ridge I) theta = G^T y / beta0 by Cholesky when the ridge makes them positive
        definite, else the minimum-norm solution (SVD)."""
        if self.ridge > 0:
            from scipy.linalg import solve

            H = G.T @ G
            H[np.diag_indices_from(H)] += self.ridge
            return solve(H, G.T @ y / self.beta0, assume_a="pos")
        return np.linalg.lstsq(G, y / self.beta0, rcond=None)[0]

    def predict(self, X: np.ndarray) -> np.ndarray:
        """e_hat (T,) of eq. (31)."""
        G, cols = self._design(X)
        return self.beta0 * G @ self.theta_[cols]

    def confidence(self, X: np.ndarray) -> np.ndarray:
        """c(x) (T,) of the safety rule (1 everywhere without ``support``)."""
        if getattr(self, "supported_", None) is None:
            return np.ones(np.atleast_2d(X).shape[0])
        return self._confidence(self.activations(X, np.flatnonzero(self.supported_)))

    def outside(self, X: np.ndarray) -> np.ndarray:
        """Inputs outside the training data (T,) bool: c(x) < 1."""
        return self.confidence(X) < 1.0

    def _confidence(self, a: np.ndarray) -> np.ndarray:
        if self.a0_ <= 0:
            return np.zeros(a.shape[0])
        return np.minimum(1.0, a.sum(axis=1) / self.a0_)

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
        lam = self.ridge * self.beta0**2

        def objective(e, theta):
            return 0.5 * float(e @ e) + 0.5 * lam * float(theta @ theta)

        e = y - self.beta0 * G @ theta
        cost = [objective(e, theta)]
        ups = downs = flat = 0
        for _ in range(rules.iterations):
            v = G.T @ e / self.beta0 - self.ridge * theta  # eq. (36), plus the ridge term's gradient
            theta, prev = theta + gamma * scale * v + eta * (theta - prev), theta  # eq. (38)
            e = y - self.beta0 * G @ theta
            cost.append(objective(e, theta))
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
