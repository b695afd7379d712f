"""The cost J of Algorithm 1 (paper 000) on a minibatch and its gradient in closed form, and the
Adam update, without autograd: what one training step of ``pgnn.training.train`` computes.

    J = J_LS / B + mu1 R1 / B + mu2 R2            (eqs. 14-15, 29-30; normalized as ``pgnn.training``)
    J_LS = sum_b ||u_b - f^M_b - f^C_b||^2,   R1 = sum_i ||U_i^T g_i||^2,   R2 = sum_k max(0, exp(-h_k) - 1)

Why by hand: on a minibatch of 1e4 samples torch's autograd spent most of a step outside the
networks, on one pass over memory per elementwise operation of the physical model (the IX's
eqs. 4-9, 179 products a step) and on dispatching some 300 small operations forward and back
(docs/speed.md). Each term's gradient is short:

* dJ/df^C = -2 r / B + mu1 dR1/dg and dJ/df^M = -2 r / B, with r = u - f^M - f^C (B, n_axes);
* R1 of axis i is ||W_i^T X_i^T g_i||^2 with W_i W_i^T = (X_i^T X_i)^+ (``projection_basis``), so
  dR1/dg_i = 2 X_i W_i W_i^T X_i^T g_i (float64, as the Gram matrix);
* the networks' weights: the compiled kernels of ``pgnn.fused`` given dJ/df^C (torch's autograd for
  a network they do not compute);
* zeta: the physical model is linear in a few products of its parameters (``PhysicsFeatures``):
  f^M = F theta(zeta) with F per sample, precomputed once, so dJ/dzeta = (d theta/d zeta)^T F^T
  dJ/df^M. A machine linear in all its parameters has F = X, theta = zeta; the IX (degree 2 in the
  centres of mass, ``System.nonlinear``) has F from the exact quadratic expansion of
  its regressor. Any other machine's f^M goes through torch's autograd;
* R2, a function of the 16-odd parameters only: ``network.physics_penalty``.

``tests/test_pgnn_objective.py`` checks J and every gradient against torch's autograd of the same
cost, and the Adam update against ``torch.optim.Adam``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ...physics.model import QuadraticDesign
from ...systems import System
from .fused import TILE, _scratch, backward_kernel, forward_kernel, fusable, to_tiles
from .network import PGNNModule, physics_penalty

# -- R1: the projection of the network output onto the physical model's column space --------------

def projection_basis(X: np.ndarray, rtol: float = 1e-6) -> np.ndarray:
    """W (n_linear, r) with W W^T = (X^T X)^+ on the column space of X (B, n_linear), float64.

    The pseudo-inverse keeps the numerical rank r of eq. (21) (singular values above ``rtol`` of the
    largest) after scaling the columns to unit norm (inertia and damping columns differ by orders of
    magnitude): zero columns (a parameter absent from this axis) and exactly dependent ones (IX:
    X_J2yy = X_J3yy + X_J3zz on the propeller) add no direction."""
    X = np.asarray(X, dtype=float)
    scale = np.linalg.norm(X, axis=0)
    scale = np.where(scale > 0, scale, 1.0)  # a zero column stays zero
    lam, V = np.linalg.eigh((X.T @ X) / np.outer(scale, scale))
    keep = lam > (rtol**2) * max(lam.max(initial=0.0), 1e-300)
    return V[:, keep] / np.sqrt(lam[keep]) / scale[:, None]


def projected_norm2(X: np.ndarray, g: np.ndarray, W: np.ndarray | None = None, gradient: bool = False):
    """||U^T g||^2 with U of eq. (21) the orthonormal basis of the column space of X (B, n_linear);
    computed as c^T G^+ c with c = X^T g, G = X^T X (``projection_basis``; ``W`` where already known).
    ``gradient``: also its gradient with respect to g, 2 X G^+ c. Float64 throughout."""
    X = np.asarray(X, dtype=float)
    W = projection_basis(X) if W is None else W
    v = (np.asarray(g, dtype=float) @ X) @ W
    value = float(v @ v)
    return (value, 2.0 * (X @ (W @ v))) if gradient else value


def nonzero_columns(X: np.ndarray) -> list[np.ndarray]:
    """Per axis, the indices of the regressor columns that are not zero everywhere in X
    (N, n_axes, n_linear): the only ones a projection needs."""
    X = np.asarray(X)
    return [np.flatnonzero(np.any(X[:, i, :] != 0, axis=0)) for i in range(X.shape[1])]


def batch_projection(X_b: np.ndarray, g_b: np.ndarray, columns=None, known=None, gradient: bool = False):
    """R1 / B of a minibatch: sum over axes of ||U_b^T g_b||^2 / B, X_b (B, n_axes, n_linear), g_b
    (B, n_axes). ``columns[i]``: axis i's regressor columns that are not zero everywhere in the data
    (the others add nothing; None: all); ``known[i]``: (X_i in float64, its ``projection_basis``) of a
    batch seen before. ``gradient``: also d(R1 / B)/dg_b (B, n_axes)."""
    B, n_axes = g_b.shape
    total, grad = 0.0, np.empty((B, n_axes)) if gradient else None
    for i in range(n_axes):
        X, W = known[i] if known is not None else (X_b[:, i, slice(None) if columns is None else columns[i]], None)
        out = projected_norm2(X, g_b[:, i], W, gradient)
        if gradient:
            total += out[0]
            grad[:, i] = out[1] / B
        else:
            total += out
    return (total / B, grad) if gradient else total / B


# -- the physical model as features times products of parameters -----------------------------------

@dataclass
class PhysicsFeatures:
    """f^M(zeta) = F theta(zeta) per sample: F (N, n_axes, K) depends on the data only, and each
    theta_k = zeta[linear[k]] prod_{i in monomials[k]} zeta_n[i] (a monomial of degree <= 2 in zeta_n).

    ``linear``: the index in zeta of each term's linear parameter; ``monomials``: each term's indices
    into zeta_n (empty, one, or two)."""

    F: np.ndarray
    linear: np.ndarray
    monomials: tuple[tuple[int, ...], ...]
    n_linear: int
    n_nonlinear: int

    def __post_init__(self):
        # each monomial's two factors as indices into (zeta_n, 1): a missing factor is the 1
        pairs = [(mono + (self.n_nonlinear,) * 2)[:2] for mono in self.monomials]
        self._factors = np.array(pairs, dtype=int).reshape(-1, 2).T

    @classmethod
    def of(cls, system: System, zeta: np.ndarray, q, qd, qdd, X: np.ndarray | None = None) -> PhysicsFeatures | None:
        """The features of ``system`` on the samples (q, qd, qdd), each (N, n_axes), or None where its
        model is not linear in products of its parameters (its f^M then goes through autograd).
        ``zeta``: parameters at which the expansion is checked against ``system.inverse_dynamics``;
        ``X``: the regressor on these samples where already evaluated (a linear machine's F)."""
        n = system.n_linear
        if system.fully_linear:
            X = system.regressor(np.zeros(0), q, qd, qdd) if X is None else X
            return cls(np.asarray(X, dtype=np.float32), np.arange(n), ((),) * n, n, 0)
        if not system.nonlinear.quadratic:
            return None
        n_nonlinear = len(zeta) - n

        def evaluate(z, columns=None):
            return system.regressor(z, q, qd, qdd, **({} if columns is None else {"columns": columns}))

        design = QuadraticDesign(evaluate, n_nonlinear, columns=system.nonlinear.columns)
        terms = [((), design.c), *(((i,), b) for i, b in enumerate(design.b)), *design.a.items()]
        columns, linear, monomials = [], [], []
        for monomial, term in terms:
            if term is None:
                continue
            idx, values = term
            axis, j = np.unravel_index(idx, design.shape)
            for k in np.unique(j):
                column = np.zeros((values.shape[0], design.shape[0]))
                column[:, axis[j == k]] = values[:, j == k]
                columns.append(column)
                linear.append(k)
                monomials.append(tuple(monomial))
        features = cls(np.stack(columns, axis=2).astype(np.float32), np.array(linear), tuple(monomials), n, n_nonlinear)
        return features if features._expands(system, np.asarray(zeta, float), q, qd, qdd) else None

    def _expands(self, system, zeta, q, qd, qdd, rows: int = 2000) -> bool:
        """Whether F theta reproduces ``system.inverse_dynamics`` (to float32 accuracy) at zeta and at
        zeta with its nonlinear part moved: a check that the model is what the flag says."""
        moved = zeta.copy()
        moved[self.n_linear :] += np.random.default_rng(0).normal(0, 0.05, self.n_nonlinear)
        take = slice(None, None, max(1, len(q) // rows))
        F = self.F[take].astype(float)
        for z in (zeta, moved):
            exact = system.inverse_dynamics(z, q[take], qd[take], qdd[take])
            if not np.allclose(F @ self.theta(z)[0], exact, rtol=0, atol=1e-5 * max(np.abs(exact).max(), 1e-12)):
                return False
        return True

    def theta(self, zeta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """theta(zeta) (K,) and its Jacobian d theta/d zeta (K, len(zeta)), float64."""
        zeta = np.asarray(zeta, dtype=float)
        n, K = self.n_linear, len(self.linear)
        z = np.append(zeta[n:], 1.0)
        i, j = self._factors
        weight = z[i] * z[j]
        theta = zeta[self.linear] * weight
        jac = np.zeros((K, len(zeta) + 1))  # the last column collects the 1's derivative, dropped
        rows = np.arange(K)
        jac[rows, self.linear] = weight
        np.add.at(jac, (rows, n + i), zeta[self.linear] * z[j])  # z_i^2: both factors add, 2 z_i
        np.add.at(jac, (rows, n + j), zeta[self.linear] * z[i])
        return theta, jac[:, : len(zeta)]


# -- the parameters in one flat vector, and Adam on it ----------------------------------------------

class FlatParameters:
    """The module's parameters as views of one float32 vector ``values`` (its gradient: ``grad``),
    so that Adam is a few operations on whole vectors and the kernels read the weights in place.

    Layout: delta, then for the paper's networks (``fusable``) the weights stacked over axes as the
    kernels take them (W1 (A, h1, n), b1, W2, b2, w3; ``stacked``), else each network's parameters
    in the module's order. While it lives the module's parameters share its memory; ``release``
    gives them their own memory again."""

    def __init__(self, module: PGNNModule):
        self.module = module
        self.fused = all(fusable(net) for net in module.nets)
        nets = module.nets
        if self.fused:
            groups = [[module.delta]] + [[net[i].weight if name == "weight" else net[i].bias for net in nets]
                                         for i, name in ((0, "weight"), (0, "bias"), (2, "weight"), (2, "bias"),
                                                         (4, "weight"))]
        else:
            groups = [[module.delta], list(nets.parameters())]
        params = [p for group in groups for p in group]
        self.values = np.concatenate([p.detach().numpy().astype(np.float32).ravel() for p in params])
        self.grad = np.zeros_like(self.values)
        self.params, self._views, offset = params, [], 0
        for p in params:
            size = p.numel()
            self._views.append(slice(offset, offset + size))
            p.data = torch.from_numpy(self.values[offset : offset + size].reshape(p.shape))
            offset += size
        self.delta, self.delta_grad = self.values[self._views[0]], self.grad[self._views[0]]
        if self.fused:
            A, (h1, n), h2 = len(nets), nets[0][0].weight.shape, nets[0][2].weight.shape[0]
            shapes = [(A, h1, n), (A, h1), (A, h2, h1), (A, h2), (A, h2)]
            edges = np.cumsum([self._views[0].stop] + [int(np.prod(s)) for s in shapes])
            self.stacked = [self.values[a:b].reshape(s) for a, b, s in zip(edges[:-1], edges[1:], shapes, strict=True)]
            self.stacked_grad = [self.grad[a:b].reshape(s) for a, b, s in zip(edges[:-1], edges[1:], shapes, strict=True)]

    def network_grads_from_torch(self) -> None:
        """Copy the networks' ``.grad`` (left by torch's autograd) into ``grad``."""
        for p, view in zip(self.params[1:], self._views[1:], strict=True):
            self.grad[view] = 0.0 if p.grad is None else p.grad.numpy().ravel()
            p.grad = None

    def release(self) -> None:
        for p in self.params:
            p.data = p.data.clone()


class Adam:
    """``torch.optim.Adam`` (no weight decay, no amsgrad) on a flat float32 vector, in place: the
    same formula and order of operations, with the moments as two more vectors."""

    def __init__(self, values: np.ndarray, lr: float, betas=(0.9, 0.999), eps: float = 1e-8):
        self.values, self.lr, self.betas, self.eps = values, lr, betas, eps
        self.m, self.v, self.t = np.zeros_like(values), np.zeros_like(values), 0
        self._scratch = np.empty_like(values)

    def step(self, grad: np.ndarray) -> None:
        b1, b2 = self.betas
        self.t += 1
        self.m += np.float32(1 - b1) * (grad - self.m)  # torch's lerp
        self.v *= np.float32(b2)
        np.multiply(grad, grad, out=self._scratch)
        self.v += np.float32(1 - b2) * self._scratch
        step_size = self.lr / (1 - b1**self.t)
        denom = np.sqrt(self.v, out=self._scratch)
        denom /= np.float32(np.sqrt(1 - b2**self.t))
        denom += np.float32(self.eps)
        self.values -= np.float32(step_size) * (self.m / denom)


# -- the cost of a batch and its gradient -----------------------------------------------------------

@dataclass
class Batch:
    """The arrays of a minibatch (float32, rows = samples): standardized network inputs x (B, n_in),
    target u (B, A), configurations q (B, A) for R2, and either physics features F (B, A, K) or the
    kinematics (qd, qdd) for autograd; X (B, A, n_linear): the regressor at zeta_n^0 for R1;
    ``projection``: per axis (X_i float64, its basis) where computed once for a batch used again."""

    x: np.ndarray
    u: np.ndarray
    q: np.ndarray
    F: np.ndarray | None = None
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None
    X: np.ndarray | None = None
    projection: list | None = None


class Objective:
    """J of a batch and, on request, its gradient in ``params.grad`` (module docstring)."""

    def __init__(self, module: PGNNModule, params: FlatParameters, features: PhysicsFeatures | None,
                 mu1: float, mu2: float, regularize: bool, nonzero=None):
        self.module, self.params, self.features = module, params, features
        self.mu1, self.mu2, self.regularize, self.nonzero = mu1, mu2, regularize, nonzero
        self.zeta0 = module.zeta0.numpy().astype(np.float32)
        self.scale = module.zeta_scale.numpy().astype(np.float32)

    def zeta(self) -> np.ndarray:
        return self.zeta0 + self.scale * self.params.delta  # as PGNNModule.zeta, float32

    def __call__(self, b: Batch, gradient: bool = True) -> tuple[float, float, float, float]:
        """(J, J_LS, R1, R2) normalized as ``pgnn.training``; with ``gradient`` dJ/d(parameters) is
        written into ``params.grad``."""
        B = len(b.u)
        f_m, physics_backward = self._physical(b, gradient)
        f_c, network_backward = self._networks(b.x, gradient)
        r = b.u - f_m - f_c
        j_ls = float((r * r).sum(dtype=np.float32)) / B
        dfm = r * np.float32(-2.0 / B) if gradient else None
        dfc = dfm
        r1 = r2 = 0.0
        if self.regularize:
            out = batch_projection(b.X, f_c, self.nonzero, b.projection, gradient)
            r1, dr1 = out if gradient else (out, None)
            if gradient:
                dfc = dfm + (self.mu1 * dr1).astype(np.float32)
        if gradient:
            self.params.grad[:] = 0.0
            network_backward(dfc)
            physics_backward(dfm)
        if self.regularize:
            r2 = self._penalty(b.q, gradient)
        return j_ls + self.mu1 * r1 + self.mu2 * r2, j_ls, r1, r2

    def _physical(self, b: Batch, gradient: bool):
        """f^M (B, A) and a function that adds dJ/d delta given dJ/df^M."""
        zeta = self.zeta()
        if self.features is not None:
            theta, jac = self.features.theta(zeta)
            f_m = b.F @ theta.astype(np.float32)  # (B, A, K) @ (K,)

            def backward(dfm):
                dtheta = np.tensordot(b.F, dfm, axes=([0, 1], [0, 1]))
                self.params.delta_grad[:] += (jac.T @ dtheta).astype(np.float32) * self.scale
            return f_m, backward
        delta = self.module.delta
        with torch.enable_grad() if gradient else torch.no_grad():
            out = self.module.system.inverse_dynamics(self.module.zeta, *(torch.from_numpy(a) for a in (b.q, b.qd, b.qdd)))

        def backward(dfm):
            (g,) = torch.autograd.grad(out, delta, grad_outputs=torch.from_numpy(np.ascontiguousarray(dfm)))
            self.params.delta_grad[:] += g.numpy()
        return out.detach().numpy(), backward

    def _networks(self, x: np.ndarray, gradient: bool):
        """f^C (B, A) and a function that writes the networks' gradients given dJ/df^C."""
        p = self.params
        if p.fused:
            B, A = len(x), len(self.module.nets)
            W1, b1, W2, b2, w3 = p.stacked
            s = _scratch.take(W1.shape[2], A, W1.shape[1], W2.shape[1], -(-B // TILE))
            to_tiles(x, s["x"], False)
            y = np.empty((A, s["x"].shape[0], TILE), dtype=np.float32)
            forward_kernel(s["x"], W1, b1, W2, b2, w3, s["a1"], s["a2"], y)
            if not gradient:
                _scratch.give(s)

            def backward(dfc):
                to_tiles(np.ascontiguousarray(dfc, dtype=np.float32), s["dy"], True)
                backward_kernel(s["x"], W2, w3, s["a1"], s["a2"], s["dy"], *p.stacked_grad, s["d1"], s["d2"])
                _scratch.give(s)
            return y.reshape(A, -1)[:, :B].T, backward
        with torch.enable_grad() if gradient else torch.no_grad():
            xt = torch.from_numpy(np.ascontiguousarray(x))
            out = torch.cat([net(xt) for net in self.module.nets], dim=1)

        def backward(dfc):
            out.backward(torch.from_numpy(np.ascontiguousarray(dfc, dtype=np.float32)))
            p.network_grads_from_torch()
        return out.detach().numpy(), backward

    def _penalty(self, q: np.ndarray, gradient: bool) -> float:
        """R2 (eq. 30); mu2 times its gradient is added to ``params.grad``."""
        r2, grad = physics_penalty(self.module.system, self.zeta(), q, self.module.constraint_configs)
        if gradient:
            self.params.delta_grad[:] += (self.mu2 * grad * self.scale).astype(np.float32)
        return r2
