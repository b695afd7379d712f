"""The PGNN of paper 000: physical model in parallel with one MLP per axis (Definitions 1-4).

    f = M_zeta(theta_d) + C_phi(theta_d)                                      (1)
    C_phi: f_i^C = g_phi_i(T(theta_d)),  T_i = [theta_i, thetad_i, thetadd_i, relay(thetad_i)]  (11)-(13)

``PGNNModule`` holds the physical parameters zeta (for the IX the 16 of Table I) and the per-axis
MLPs g_phi_i (Definition 3: affine layers with an elementwise activation, linear output). The
physical part is the machine's ``inverse_dynamics`` (``systems.System``) evaluated with torch
tensors, i.e. the same equations as the plant and the least-squares model.

Each axis's MLP sees the standardized (``input_mean``, ``input_std``) features of all axes plus
any extra inputs (history, periods), and returns that axis's f_i^C.

zeta = zeta0 + scale delta with delta starting at 0. ``zeta_steps="absolute"`` (the default, the
paper's: Adam on zeta itself): scale = 1, so that Adam's step, about lr, is lr in the parameter's own
units. ``"relative"``: scale = max(|zeta0|, 1e-3), a relative step for CoM coordinates of centimetres
and inertias of tenths alike, which holds zeta nearer zeta0. Neither makes the NN-contribution
ratio J_LS / J of Tables II/III what the paper's is (``studies/pgnn_protocol.py``; the figures in
docs/methods/pgnn.md).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

from ...systems import System
from .fused import fusable, fused_networks

ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU, "sigmoid": nn.Sigmoid}


def mlp(n_in: int, hidden: Sequence[int], activation: str) -> nn.Sequential:
    """g_phi of Definition 3: hidden layers sigma(W h + c), linear scalar output (no output bias)."""
    if activation not in ACTIVATIONS:
        raise ValueError(f"activation must be one of {sorted(ACTIVATIONS)}, got {activation!r}")
    layers, width = [], n_in
    for h in hidden:
        layers += [nn.Linear(width, h), ACTIVATIONS[activation]()]
        width = h
    layers.append(nn.Linear(width, 1, bias=False))
    return nn.Sequential(*layers)


class PGNNModule(nn.Module):
    """Physical model + per-axis networks. ``forward`` returns (f_M, f_C), each (B, n_axes)."""

    def __init__(self, system: System, zeta0: np.ndarray, n_inputs: int, hidden: Sequence[int] = (30, 30),
                 activation: str = "tanh", input_mean=None, input_std=None, zeta_steps: str = "absolute",
                 constraint_configs: int | None = None):
        super().__init__()
        if zeta_steps not in ("absolute", "relative"):
            raise ValueError(f"zeta_steps must be 'absolute' or 'relative', got {zeta_steps!r}")
        self.system = system
        self.constraint_configs = constraint_configs  # R2's configurations per batch (PGNNConfig); None: all
        zeta0 = np.asarray(zeta0, dtype=np.float32)
        self.register_buffer("zeta0", torch.tensor(zeta0))
        scale = np.ones_like(zeta0) if zeta_steps == "absolute" else np.maximum(np.abs(zeta0), 1e-3)
        self.register_buffer("zeta_scale", torch.tensor(scale))
        self.delta = nn.Parameter(torch.zeros(len(zeta0)))
        self.register_buffer("input_mean", torch.zeros(n_inputs) if input_mean is None else torch.as_tensor(input_mean))
        self.register_buffer("input_std", torch.ones(n_inputs) if input_std is None else torch.as_tensor(input_std))
        self.nets = nn.ModuleList([mlp(n_inputs, hidden, activation) for _ in system.axes])
        self.network_on = True

    @property
    def zeta(self) -> torch.Tensor:
        return self.zeta0 + self.zeta_scale * self.delta

    def physical(self, q, qd, qdd, X=None) -> torch.Tensor:
        """f^M of eq. (9), (B, n_axes) [V for the IX, N m for the arm]. A system whose parameters are
        all linear (the arm) may pass its regressor X (B, n_axes, n_params) instead: f^M = X zeta,
        the same value without evaluating the regressor again."""
        if X is not None and self.system.fully_linear:
            return X @ self.zeta.to(X.dtype)
        return self.system.inverse_dynamics(self.zeta, q, qd, qdd)

    def network(self, inputs) -> torch.Tensor:
        """f^C of eq. (13), (B, n_axes); zero when the network is switched off. The paper's networks
        (two tanh hidden layers, float32 on the CPU) run in the compiled kernels of ``pgnn.fused``,
        any other through torch."""
        if not self.network_on:
            return torch.zeros(inputs.shape[0], len(self.nets), dtype=inputs.dtype)
        x = (inputs - self.input_mean) / self.input_std
        if x.dtype == torch.float32 and all(fusable(net) for net in self.nets):
            return fused_networks(x, self.nets)
        return torch.cat([net(x) for net in self.nets], dim=1)

    def forward(self, q, qd, qdd, inputs, X=None):
        return self.physical(q, qd, qdd, X), self.network(inputs)


def physical_constraints(system: System, zeta: torch.Tensor, q: torch.Tensor, configs: int | None = None) -> torch.Tensor:
    """h of eqs. (31)-(33), each > 0 when satisfied: the parameters that are positive physically
    (IX: masses, inertias, viscous coefficients) and the smallest eigenvalue of M(theta) over the
    given configurations (evenly thinned to at most ``configs`` where set:
    ``PGNNConfig.constraint_configs``)."""
    q = _thinned(q, configs)
    return torch.cat([zeta[list(system.positive)], min_eigenvalue(system.mass_matrix(zeta, q)).min().reshape(1)])


def _thinned(q, configs: int | None):
    if configs and q.shape[0] > configs:
        return q[:: -(-q.shape[0] // configs)]
    return q


def min_eigenvalue(M):
    """Smallest eigenvalue of each symmetric matrix in M (..., n, n), torch or numpy; closed form for
    n = 2 (the IX, 25x faster than the general batched solver for 1e4 matrices)."""
    if M.shape[-1] == 2:
        a, b, c = M[..., 0, 0], M[..., 0, 1], M[..., 1, 1]
        sqrt = torch.sqrt if isinstance(M, torch.Tensor) else np.sqrt
        return 0.5 * (a + c) - sqrt(0.25 * (a - c) ** 2 + b * b)
    return torch.linalg.eigvalsh(M)[..., 0] if isinstance(M, torch.Tensor) else np.linalg.eigvalsh(M)[..., 0]


PD_MARGIN = 1e-3
"""Relative to the largest entry of M: a smallest eigenvalue above this is positive in float32 too."""


def physics_penalty(system: System, zeta: np.ndarray, q: np.ndarray, configs: int | None = None
                    ) -> tuple[float, np.ndarray]:
    """R2 of eq. (30), sum_k max(0, exp(-h_k) - 1), and its gradient with respect to zeta (numpy,
    float64; zeta (n_params,), configurations q (B, n_axes), thinned to at most ``configs``).

    The mass-matrix term and its gradient are zero while M(theta) is positive definite, as it is
    for physical parameters; differentiating it is the costly part (the arm's 6 x 6 matrices come
    from a basis of its regressor). So its smallest eigenvalue is first evaluated without a graph
    and enters as a constant when it exceeds ``PD_MARGIN`` of M's largest entry: the same penalty
    and the same gradient, d/dzeta_k = -exp(-zeta_k) for a positive parameter below zero. Otherwise
    h is ``physical_constraints`` differentiated by torch's autograd."""
    zeta, q = np.asarray(zeta, dtype=float), np.asarray(q, dtype=float)
    positive = list(system.positive)
    M = system.mass_matrix(zeta, _thinned(q, configs))
    lam = float(min_eigenvalue(M).min())
    if lam > PD_MARGIN * float(np.abs(M).max()):
        h = zeta[positive]
        excess = np.exp(-np.append(h, lam)) - 1.0
        grad = np.zeros_like(zeta)
        np.add.at(grad, positive, np.where(excess[:-1] > 0, -np.exp(-h), 0.0))
        return float(np.maximum(excess, 0.0).sum()), grad
    z = torch.tensor(zeta, requires_grad=True)
    value = torch.clamp(torch.exp(-physical_constraints(system, z, torch.from_numpy(q), configs)) - 1.0, min=0.0).sum()
    value.backward()
    return float(value.detach()), z.grad.numpy()
