"""Training the PGNN: cost J = J_LS + mu1 R1 + mu2 R2 (eqs. 14-15, 29-30) by Algorithm 1.

Data (paper 000, V-A): the reference theta_d is the surrogate for the measured angle, kinematics
by central differences evaluated ``advance`` samples ahead (as the physical model); the measured
input u is low-pass filtered (2nd-order Butterworth, ``filter_hz``, zero phase) per trial.

Normalization of J. We minimize J_LS / N (N = number of training samples: the mean over samples
of ||u - f||^2, both axes summed) + mu1 R1 / N + mu2 R2, with ``mu1 = 10`` and ``mu2 = 1``. Paper
000 writes J_LS (eq. 15) and R1 (eq. 29) as sums over its N = 1e6 samples with mu1 = 1e-5 and
mu2 = 1; read literally (both divided by N), R1 has no effect. The paper's figures fit the usual
implementation: J_LS a per-sample mean, R1 the squared norm of the whole data set's projection, so
mu1 N = 1e-5 x 1e6 = 10 weighs R1 / N; R2 (a sum over nine constraints, not samples) keeps mu2 = 1.

R1 with minibatches. R1 = sum_i ||U_i^T g_i||^2 (eq. 29) is the squared norm of the projection of
the network output over the whole data set onto the column space of X_i(theta) (Lemma 1, at the
fixed zeta_n^0 of the initial physical fit). With X_i = U_i S V^T (eq. 21),
||U_i^T g||^2 = (X_i^T g)^T (X_i^T X_i)^+ (X_i^T g). A minibatch of B random samples estimates both
Gram factors without bias (X^T g ~ (N/B) X_b^T g_b, X^T X ~ (N/B) X_b^T X_b), so R1 / N ~
||U_b^T g_b||^2 / B, U_b the basis of eq. (21) of the batch's own X_b: consistent, with a relative
bias of order r/B (rank r <= 11, B = 1e4: about 0.1 %; tested against the full projection to 2 %).
Summed over an epoch it is each batch's exact projection: the network is kept out of what the
physical model explains on every batch it sees.

Algorithm 1: zeta starts at the least-squares physical-model fit, phi at PyTorch's default (seeded)
initialization; random 80/10/10 split of the samples; Adam (lr 1e-3), minibatches of 1e4; training
stops after ``patience`` iterations without a better validation J; the best iteration is kept.

An iteration is ``steps_per_iteration`` = 80 Adam steps: the paper's iteration is an epoch, at its
N = 1e6 80 minibatches, so its patience of five iterations waits 400 steps; a fixed step count
keeps that schedule at any N (on fewer samples an epoch is fewer steps, and the literal reading,
``steps_per_iteration=None``, stops early). Minibatches come from a new random order of the
training samples at each pass (a training split that fits one minibatch, the arm's, is that batch
at every step). ``reshuffle=False``: the split, in random order, is cut into minibatches once,
visited in a new random order at each pass, so each batch's R1 basis is computed once and no
samples are gathered per step: a cheaper step along another, equally random path. A step runs the
networks in compiled float32 kernels (``pgnn.fused``), differentiates R2's mass-matrix term only
where M is near indefinite (``network.physics_penalty``), and computes R1 without the regressor's
all-zero columns, keeping the bases of batches it sees again (validation, test, fixed batches).
Measurements: docs/methods/pgnn.md, "Training choices and what they measured"; docs/speed.md.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np
import torch

from ...physics.kinematics import lowpass_zero_phase, reference_kinematics, relay
from ...systems import System
from .network import PGNNModule
from .objective import Adam, Batch, FlatParameters, Objective, PhysicsFeatures, nonzero_columns, projection_basis
from .settings import CONSTRAINT_CONFIGS, PGNNProtocol


@dataclass
class PGNNConfig:
    """Hyperparameters; the defaults are paper 000's (V-A) unless noted."""

    hidden: tuple[int, ...] = (30, 30)
    activation: str = "tanh"
    mu1: float = 10.0  # weight of R1 / N: the paper's 1e-5 times its N = 1e6 (module docstring)
    mu2: float = 1.0  # weight of R2
    regularize: bool = True  # False: J_LS only (the paper's "PGNN with J_LS")
    filter_hz: float | None = 1.0  # low-pass of u [Hz]; None: unfiltered
    decimate: int = 1  # lcgym: train on every decimate-th sample (after filtering; the arm's 1 kHz data)
    lr: float = 1e-3
    batch_size: int = 10_000
    patience: int = 5  # iterations without improvement of the validation J
    max_epochs: int = 300  # lcgym's safety cap on iterations; the paper stops by validation only
    steps_per_iteration: int | None = 80  # lcgym: Adam steps per iteration (validation check); None: one epoch
    reshuffle: bool = True  # minibatches from a new order of the samples at each pass; False: fixed batches (faster)
    zeta_steps: str = "absolute"  # Adam on zeta itself (the paper's) or "relative" to zeta0 (``pgnn.network``)
    split: tuple[float, float, float] = (0.8, 0.1, 0.1)
    seed: int = 0
    advance: float = 1.5  # samples; as the physical model (``System.advance``; the IX's 1.5 by default)
    threads: int | None = None  # torch threads while training (None: leave as is)
    max_seconds: float | None = None  # lcgym's wall-time budget of the whole fit (see ``train``)
    # beyond the paper (off by default): extra network inputs
    derivatives: int = 2  # highest time derivative of the reference among the inputs: 3 adds jerk, 4 jerk and snap
    history: tuple[float, ...] = ()  # delays [s]: add the reference velocity d seconds ago, per axis
    periods: tuple[tuple[int, float], ...] = ()  # (axis index, period [rad]): add sin, cos(2 pi q / period)
    constraint_configs: int | None = CONSTRAINT_CONFIGS  # configurations of a batch in R2's M term; None: all

    @classmethod
    def for_system(cls, system: System, **overrides) -> PGNNConfig:
        """The defaults for a machine: the paper's, with the kinematics ``system.advance`` samples
        ahead (as its physical model), updated by the machine's settings (``PGNNProtocol``: the
        FlexArm, 1 kHz and moves of 1-2 s, trains on every 10th sample with u low-passed at 10 Hz)
        and ``overrides``."""
        own = PGNNProtocol.of(system)
        machine = {"decimate": own.decimate, "constraint_configs": own.constraint_configs}
        if own.filter_hz is not None:
            machine["filter_hz"] = own.filter_hz
        return cls(**{"advance": system.advance, **machine, **overrides})


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
    optional inputs of ``config``: the reference's jerk and snap per axis (``derivatives`` 3 or 4:
    a flexible joint's motor torque follows them; differences of qdd, low-passed as u is),
    reference velocities ``history`` seconds ago (zero before the run starts: the reference rests
    there) and sin, cos of positions over ``periods``."""
    if config.derivatives not in (2, 3, 4):
        raise ValueError(f"PGNNConfig.derivatives must be 2 (the paper's inputs), 3 (+ jerk) or 4 (+ jerk and snap), "
                         f"got {config.derivatives!r}")
    cols = np.stack([q, qd, qdd, relay(qd)], axis=2).reshape(q.shape[0], -1)
    extra = []
    derivative = qdd
    for _ in range(config.derivatives - 2):
        derivative = np.gradient(derivative, 1.0 / fs, axis=0, edge_order=1)
        extra.append(lowpass_zero_phase(derivative, fs, config.filter_hz) if config.filter_hz else derivative)
    for delay in config.history:
        d = int(round(delay * fs))
        extra.append(np.concatenate([np.zeros((min(d, len(qd)), qd.shape[1])), qd[: max(len(qd) - d, 0)]]))
    for axis, period in config.periods:
        x = 2 * np.pi * q[:, axis] / period
        extra.append(np.column_stack([np.sin(x), np.cos(x)]))
    return np.column_stack([cols, *extra])


def training_data(trials, system: System, config: PGNNConfig, zeta_n0: np.ndarray, fixed=None) -> TrainingData:
    """Kinematics of each trial's reference, network inputs, filtered input u, and the regressor
    X at zeta_n0, concatenated over trials (each trial's filter and relay run on its own, at the
    full rate, before ``config.decimate`` keeps every k-th sample). ``fixed``: a function (q, qd,
    qdd) -> (T, n_axes) [input unit], a part of the physical model held fixed (its fitted effects,
    ``PhysicalModel.effects_torque``), taken off u before the filter."""
    parts = []
    for tr in trials:
        if tr.ref is None:
            raise ValueError("PGNN: training trials need a reference (the paper's theta_d surrogate)")
        q, qd, qdd = reference_kinematics(tr.ref, tr.fs, config.advance)
        u = np.asarray(tr.u, float) if fixed is None else tr.u - fixed(q, qd, qdd)
        u = lowpass_zero_phase(u, tr.fs, config.filter_hz) if config.filter_hz else u
        k = slice(None, None, max(1, config.decimate))
        parts.append(tuple(a[k] for a in (q, qd, qdd, network_inputs(q, qd, qdd, config, tr.fs), u)))
    q, qd, qdd, inputs, u = (np.concatenate([p[i] for p in parts]) for i in range(5))
    return TrainingData(q, qd, qdd, inputs, u, system.regressor(zeta_n0, q, qd, qdd))


def train(module: PGNNModule, data: TrainingData, config: PGNNConfig, progress: bool = False,
          seconds: float | None = None) -> dict:
    """Algorithm 1 on ``module`` (in place).

    Returns a dict: ``history`` (per iteration: Adam steps so far, validation J and its terms),
    ``epochs`` (iterations run), ``seconds`` (wall time of this call), ``J_LS_test`` (on the test
    split), ``n_samples`` and ``config``. ``seconds`` (default ``config.max_seconds``): wall-time
    budget counted from the start of this call; no iteration is started unless 1.5 times the
    longest one so far still fits in it (the first always runs).
    """
    seconds = config.max_seconds if seconds is None else seconds
    if config.steps_per_iteration is not None and config.steps_per_iteration < 1:
        raise ValueError(f"steps_per_iteration must be >= 1 or None, got {config.steps_per_iteration}")
    from tqdm.auto import tqdm

    before = torch.get_num_threads()
    if config.threads:
        torch.set_num_threads(config.threads)
    params = FlatParameters(module)
    try:
        gen = torch.Generator().manual_seed(config.seed)
        n = data.u.shape[0]
        perm = torch.randperm(n, generator=gen).numpy()
        n_tr, n_va = int(config.split[0] * n), int(config.split[1] * n)
        idx = {"train": perm[:n_tr], "validation": perm[n_tr : n_tr + n_va], "test": perm[n_tr + n_va :]}
        zeta0 = module.zeta0.double().numpy()
        features = PhysicsFeatures.of(module.system, zeta0, data.q, data.qd, data.qdd, X=data.X)
        objective = Objective(module, params, features, config.mu1, config.mu2, config.regularize,
                              nonzero_columns(data.X))
        # the per-sample arrays a batch needs side by side in one float32 matrix per split, so that a
        # minibatch is one gather of whole rows (X too: the projection forms its Gram matrix in
        # float64, where the exactly dependent columns, stored with 1e-7 relative rounding, still fall
        # far below the rank cut); a linear machine's features are its regressor
        x = (torch.tensor(data.inputs, dtype=torch.float32) - module.input_mean) / module.input_std
        arrays = {"x": x.numpy(), "u": data.u, "q": data.q}
        if features is not None:
            arrays["F"] = features.F
        else:
            arrays |= {"qd": data.qd, "qdd": data.qdd}
        if config.regularize and not (features is not None and features.F is data.X):
            arrays["X"] = data.X
        shapes = {k: a.shape[1:] for k, a in arrays.items()}
        edges = np.cumsum([0] + [int(np.prod(shape)) for shape in shapes.values()])
        columns = {k: slice(a, b) for k, a, b in zip(shapes, edges[:-1], edges[1:], strict=True)}
        matrix = np.concatenate([a.reshape(n, -1) for a in arrays.values()], axis=1, dtype=np.float32)
        split = {name: np.take(matrix, rows, axis=0) for name, rows in idx.items()}
        del matrix, arrays

        def piece(rows: np.ndarray, contiguous: bool = False) -> Batch:
            """The batch of the matrix rows ``rows`` (views of its columns; ``contiguous``: copies, for
            a batch used again); a linear machine's X is its F."""
            parts = {k: rows[:, c].reshape(len(rows), *shapes[k]) for k, c in columns.items()}
            b = Batch(**({k: np.ascontiguousarray(a) for k, a in parts.items()} if contiguous else parts))
            if config.regularize and b.X is None:
                b.X = b.F
            return b

        opt = Adam(params.values, config.lr)
        history, best, best_values, stale = [], np.inf, None, 0
        t0 = time.perf_counter()
        bar = tqdm(range(config.max_epochs), desc="PGNN epochs", disable=not progress, leave=False)

        def batches(part):
            rows = split[part]
            for s in range(0, len(rows), config.batch_size):
                yield piece(rows[s : s + config.batch_size], contiguous=True)

        def known(b: Batch) -> Batch:
            """The batch with each axis's regressor (its columns that are not all zero) in float64
            and their projection basis, computed once for a batch used again (validation, test, the
            fixed training minibatches)."""
            if config.regularize:
                xs = [b.X[:, i, cols].astype(float) for i, cols in enumerate(objective.nonzero)]
                b.projection = [(x, projection_basis(x)) for x in xs]
            return b

        per_epoch = -(-len(split["train"]) // config.batch_size)
        once = ("validation", "test") if config.reshuffle and per_epoch > 1 else ("train", "validation", "test")
        fixed = {part: [known(b) for b in batches(part)] for part in once}

        def evaluate(part):
            """Sample-weighted means of (J, J_LS, R1, R2) over the batches of a split."""
            values, sizes = zip(*[(objective(b, gradient=False), len(b.u)) for b in fixed[part]], strict=True)
            return dict(zip(("J", "J_LS", "R1", "R2"), np.average(values, axis=0, weights=sizes), strict=True))

        longest = 0.0  # the longest iteration so far [s], for the budget

        def stream():
            """Training minibatches without end. ``config.reshuffle``: drawn from a new random
            order of the training samples at each pass over them; else the fixed minibatches,
            visited in a new random order at each pass. A training split that fits one minibatch
            is that batch every time (a reshuffle would change only the round-off of its sums)."""
            while per_epoch == 1:
                yield fixed["train"][0]
            if not config.reshuffle:
                while True:
                    for i in torch.randperm(per_epoch, generator=gen).tolist():
                        yield fixed["train"][i]
            rows = split["train"]
            while True:
                order = torch.randperm(len(rows), generator=gen).numpy()
                for s in range(0, len(rows), config.batch_size):
                    yield piece(np.take(rows, order[s : s + config.batch_size], axis=0))

        steps = config.steps_per_iteration or per_epoch
        source = stream()
        for epoch in bar:
            started = time.perf_counter()
            for _ in range(steps):
                objective(next(source))
                opt.step(params.grad)
            val = evaluate("validation")
            history.append({"epoch": epoch + 1, "steps": (epoch + 1) * steps,
                            **{f"{k}_validation": float(v) for k, v in val.items()}})
            j_val = val["J"]
            bar.set_postfix(J_val=f"{j_val:.3g}")
            if j_val < best - 1e-12:
                best, stale = j_val, 0
                best_values = params.values.copy()
            else:
                stale += 1
                if stale >= config.patience:
                    break
            longest = max(longest, time.perf_counter() - started)
            if seconds is not None and time.perf_counter() - t0 + 1.5 * longest > seconds:
                break
        if best_values is None:
            raise RuntimeError(f"PGNN: the validation cost was not finite in any of {len(history)} iteration(s) "
                               f"(last J = {history[-1]['J_validation']}); the training diverged")
        params.values[:] = best_values
        return {"history": history, "epochs": len(history), "seconds": time.perf_counter() - t0,
                "J_LS_test": float(evaluate("test")["J_LS"]), "n_samples": n, "config": asdict(config)}
    finally:
        params.release()
        torch.set_num_threads(before)
