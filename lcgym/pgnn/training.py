"""Training the PGNN: cost J = J_LS + mu1 R1 + mu2 R2 (eqs. 14-15, 29-30) by Algorithm 1.

Data (paper 000, V-A): the reference theta_d is the surrogate for the measured angle, kinematics
by central differences evaluated ``advance`` samples ahead (as the physical model); the measured
input u is low-pass filtered (2nd-order Butterworth, ``filter_hz``, zero phase) per trial.

Normalization of J. We minimize J / N (N = number of training samples), i.e. the mean over
samples of ||u - f||^2 (both axes summed), plus mu1 R1 / N plus mu2 R2 / N. The paper's weights
mu1 = 1e-5 and mu2 = 1 refer to the summed J; dividing everything by N keeps their meaning, so
we use mu1 on R1 / N and mu2 / N on R2.

R1 with minibatches. R1 = sum_i ||U_i^T g_i||^2 (eq. 29) is the squared norm of the projection of
the network output over the whole data set onto the column space of X_i(theta) (Lemma 1, at the
fixed zeta_n^0 of the initial physical fit). With X_i = U_i S V^T, ||U_i^T g||^2 =
(X_i^T g)^T (X_i^T X_i)^-1 (X_i^T g). A random minibatch of B samples estimates both Gram
factors without bias: X^T g ~ (N/B) X_b^T g_b and X^T X ~ (N/B) X_b^T X_b, so R1 / N ~
||U_b^T g_b||^2 / B with U_b the orthonormal basis of the batch's X_b of eq. (21) (rank-revealing SVD). This ratio
estimator is consistent, with a bias of order 1/B relative (11 columns against B = 1e4 rows:
negligible); summed over an epoch it is the exact projection of each batch, so the network is
kept out of what the physical model can explain on every batch it sees.

Algorithm 1: zeta starts at the best physical-model fit (least squares), phi at PyTorch's default
initialization (seeded); random 80/10/10 split of the samples; Adam (lr 1e-3), minibatches of 1e4;
each epoch loops over all training minibatches; training stops after ``patience`` epochs without
improvement of J on the validation split, and the best epoch's parameters are kept.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np
import torch

from ..physics.kinematics import lowpass_zero_phase, reference_kinematics, relay
from ..physics.system import RigidBodySystem
from .network import PGNNModule, physics_penalty


@dataclass
class PGNNConfig:
    """Hyperparameters; the defaults are paper 000's (V-A) unless noted."""

    hidden: tuple[int, ...] = (30, 30)
    activation: str = "tanh"
    mu1: float = 1e-5  # weight of R1 (on R1 / N)
    mu2: float = 1.0  # weight of R2 (applied as mu2 / N)
    regularize: bool = True  # False: J_LS only (the paper's "PGNN with J_LS")
    filter_hz: float | None = 1.0  # low-pass of u [Hz]; None: unfiltered
    lr: float = 1e-3
    batch_size: int = 10_000
    patience: int = 5
    max_epochs: int = 300  # lcgym's safety cap; the paper stops by validation only
    split: tuple[float, float, float] = (0.8, 0.1, 0.1)
    seed: int = 0
    advance: float = 1.5  # samples; as physics.model.PhysicalModel
    threads: int | None = None  # torch threads while training (None: leave as is)
    max_seconds: float | None = None  # lcgym's wall-time cap: stop after the epoch that passes it
    # beyond the paper (both off by default): extra network inputs
    history: tuple[float, ...] = ()  # delays [s]: add the reference velocity d seconds ago, per axis
    periods: tuple[tuple[int, float], ...] = ()  # (axis index, period [rad]): add sin, cos(2 pi q / period)


@dataclass
class TrainingData:
    """Per-sample arrays: kinematics (N, n_axes) each, network inputs (N, n_inputs), target u
    (N, n_axes), regressor X (N, n_axes, n_linear)."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    inputs: np.ndarray
    u: np.ndarray
    X: np.ndarray = field(repr=False)


def network_inputs(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, config: PGNNConfig, fs: float) -> np.ndarray:
    """Network input of one run, (T, n_inputs): T(theta_d) of eq. (11) per axis, [theta, thetad,
    thetadd, relay(thetad)] (relay of eq. 12, carried across the run's samples), then the
    optional inputs of ``config``: reference velocities ``history`` seconds ago (zero before the
    run starts: the reference rests there) and sin, cos of positions over ``periods``."""
    cols = np.stack([q, qd, qdd, relay(qd)], axis=2).reshape(q.shape[0], -1)
    extra = []
    for delay in config.history:
        d = int(round(delay * fs))
        extra.append(np.concatenate([np.zeros((min(d, len(qd)), qd.shape[1])), qd[: max(len(qd) - d, 0)]]))
    for axis, period in config.periods:
        x = 2 * np.pi * q[:, axis] / period
        extra.append(np.column_stack([np.sin(x), np.cos(x)]))
    return np.column_stack([cols, *extra])


def training_data(trials, system: RigidBodySystem, config: PGNNConfig, zeta_n0: np.ndarray) -> TrainingData:
    """Kinematics of each trial's reference, network inputs, filtered input u, and the regressor
    X at zeta_n0, concatenated over trials (each trial's filter and relay run on its own)."""
    parts = []
    for tr in trials:
        q, qd, qdd = reference_kinematics(tr.ref, tr.fs, config.advance)
        u = lowpass_zero_phase(tr.u, tr.fs, config.filter_hz) if config.filter_hz else np.asarray(tr.u, float)
        parts.append((q, qd, qdd, network_inputs(q, qd, qdd, config, tr.fs), u))
    q, qd, qdd, inputs, u = (np.concatenate([p[i] for p in parts]) for i in range(5))
    return TrainingData(q, qd, qdd, inputs, u, system.regressor(zeta_n0, q, qd, qdd))


def column_space(X: torch.Tensor, rtol: float = 1e-7) -> torch.Tensor:
    """U of eq. (21): an orthonormal basis (B, r) of the column space of X (B, n_linear), r its
    numerical rank. Columns are scaled to unit norm first (inertia and damping columns differ by
    orders of magnitude); zero columns (a parameter absent from this axis) and exactly dependent
    ones (IX: X_J2yy = X_J3yy + X_J3zz on the propeller) drop out with their zero singular values."""
    X = X.double()
    Xs = X / X.norm(dim=0).clamp_min(1e-300)
    U, S, _ = torch.linalg.svd(Xs, full_matrices=False)
    return U[:, S > rtol * S[0]] if S.numel() and S[0] > 0 else U[:, :0]


def _batch_projection(X_b: torch.Tensor, g_b: torch.Tensor) -> torch.Tensor:
    """sum over axes of ||U_b^T g_b||^2 / B, U_b = column_space of the batch's X_b (B, n_axes, n_linear)."""
    total = g_b.new_zeros(())
    for i in range(g_b.shape[1]):
        U = column_space(X_b[:, i, :]).to(g_b.dtype)
        total = total + ((U.T @ g_b[:, i]) ** 2).sum()
    return total / g_b.shape[0]


def train(module: PGNNModule, data: TrainingData, config: PGNNConfig, progress: bool = False) -> dict:
    """Algorithm 1 on ``module`` (in place). Returns the history and the wall time."""
    from tqdm.auto import tqdm

    before = torch.get_num_threads()
    if config.threads:
        torch.set_num_threads(config.threads)
    try:
        gen = torch.Generator().manual_seed(config.seed)
        n = data.u.shape[0]
        perm = torch.randperm(n, generator=gen).numpy()
        n_tr, n_va = int(config.split[0] * n), int(config.split[1] * n)
        idx = {"train": perm[:n_tr], "validation": perm[n_tr : n_tr + n_va], "test": perm[n_tr + n_va :]}
        t = {k: torch.tensor(getattr(data, k), dtype=torch.float32) for k in ("q", "qd", "qdd", "inputs", "u")}
        t["X"] = torch.from_numpy(data.X)  # float64: its rank decides the projection
        opt = torch.optim.Adam(module.parameters(), lr=config.lr)
        history, best, best_state, stale = [], np.inf, None, 0
        t0 = time.perf_counter()
        bar = tqdm(range(config.max_epochs), desc="PGNN epochs", disable=not progress, leave=False)

        def cost(sel, grad: bool):
            f_m, f_c = module(t["q"][sel], t["qd"][sel], t["qdd"][sel], t["inputs"][sel])
            j_ls = ((t["u"][sel] - f_m - f_c) ** 2).sum(dim=1).mean()
            if not config.regularize:
                return j_ls, j_ls.detach(), j_ls.new_zeros(()), j_ls.new_zeros(())
            r1 = _batch_projection(t["X"][sel], f_c)
            r2 = physics_penalty(module.system, module.zeta, t["q"][sel]) / n
            return j_ls + config.mu1 * r1 + config.mu2 * r2, j_ls.detach(), r1.detach(), r2.detach()

        for epoch in bar:
            module.train()
            order = idx["train"][torch.randperm(n_tr, generator=gen).numpy()]
            for start in range(0, n_tr, config.batch_size):
                sel = torch.as_tensor(order[start : start + config.batch_size])
                opt.zero_grad()
                total, *_ = cost(sel, True)
                total.backward()
                opt.step()
            module.eval()
            with torch.no_grad():
                va = [cost(torch.as_tensor(idx["validation"][s : s + config.batch_size]), False)
                      for s in range(0, n_va, config.batch_size)]
                j_val = float(np.mean([float(v[0]) for v in va]))
                row = {"epoch": epoch + 1, "J_validation": j_val, "J_LS_validation": float(np.mean([float(v[1]) for v in va])),
                       "R1_validation": float(np.mean([float(v[2]) for v in va])),
                       "R2_validation": float(np.mean([float(v[3]) for v in va]))}
            history.append(row)
            bar.set_postfix(J_val=f"{j_val:.3g}")
            if j_val < best - 1e-12:
                best, stale = j_val, 0
                best_state = {k: v.detach().clone() for k, v in module.state_dict().items()}
            else:
                stale += 1
                if stale >= config.patience:
                    break
            if config.max_seconds is not None and time.perf_counter() - t0 > config.max_seconds:
                break
        module.load_state_dict(best_state)
        with torch.no_grad():
            te = [cost(torch.as_tensor(idx["test"][s : s + config.batch_size]), False)
                  for s in range(0, len(idx["test"]), config.batch_size)]
        return {"history": history, "epochs": len(history), "seconds": time.perf_counter() - t0,
                "J_LS_test": float(np.mean([float(v[1]) for v in te])), "n_samples": n, "config": asdict(config)}
    finally:
        torch.set_num_threads(before)
