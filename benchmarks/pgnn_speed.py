"""What makes a PGNN training step cheaper (``lcgym.methods.pgnn``), each as a ratio to the plain
implementation measured in the same run, one torch thread (as the benchmark's cells):

* the IX's two networks (paper 000's: 16 inputs, two tanh layers of 30) forward and backward on a
  batch of 1e4 samples: torch's autograd (``nn.Sequential``) against the compiled float32 kernels
  of ``pgnn.fused``; with ``--alternatives`` also ``torch.compile`` of the same networks (its
  compile time printed apart) and the BLAS matrix products alone;
* R2 (eq. 30) with its gradient: eq. (30) differentiated in full by torch's autograd
  (``physical_constraints``) against ``physics_penalty`` (numpy, the mass-matrix term as a constant
  while M is clearly positive definite); IX-v1 on 1e4 configurations, FlexArm-v1 on its 16 per batch;
* R1's projection with its gradient (``pgnn.objective.batch_projection``) on a FlexArm batch of
  4,000 samples: every column and the basis computed per step, against the all-zero columns left
  out and the basis of a batch used again (validation, a training split that fits one batch);
* where a whole training step of the IX PGNN goes (batch 1e4, one torch thread, as the
  benchmark's cells): the step (``pgnn.training.train`` run for 60 and for 10 steps, the
  difference per step) and the parts of its cost function with their gradients in closed form
  (``pgnn.objective``): the networks, the physical model, R1, R2, the batch's gather and Adam's update.

Run:  .venv/bin/python benchmarks/pgnn_speed.py [--alternatives]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from lcgym import systems
from lcgym.methods.pgnn.fused import fused_networks, tanh_array
from lcgym.methods.pgnn.network import PGNNModule, mlp, physical_constraints, physics_penalty
from lcgym.methods.pgnn.objective import (
    Adam,
    Batch,
    FlatParameters,
    Objective,
    PhysicsFeatures,
    batch_projection,
    nonzero_columns,
    projection_basis,
)
from lcgym.methods.pgnn.training import PGNNConfig, TrainingData, network_inputs, train
from lcgym.systems.flexarm import motor
from lcgym.systems.ix import IX


def per_call(f, repeat: int = 5, number: int = 50) -> float:
    """Best of ``repeat`` means over ``number`` calls [s]."""
    f()
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(number):
            f()
        best = min(best, (time.perf_counter() - t) / number)
    return best


def ratio_line(label: str, plain, faster) -> None:
    a, b = per_call(plain), per_call(faster)
    print(f"{label:52s} {1e3 * a:8.3f} ms  {1e3 * b:8.3f} ms  {a / b:6.1f}x")


def r2_ratio(name: str, rng, n: int = 10_000) -> None:
    system = systems.get(name)
    zeta0 = system.nominal_params().to_vector()
    zeta = torch.tensor(zeta0, requires_grad=True)
    q = rng.uniform(-1.5, 1.5, (n, system.n_axes))
    qt = torch.from_numpy(q)

    configs = PGNNConfig.for_system(system).constraint_configs  # the machine's thinning of R2's configurations

    def full():
        torch.clamp(torch.exp(-physical_constraints(system, zeta, qt, configs)) - 1.0, min=0.0).sum().backward()

    ratio_line(f"R2 with its gradient, {name}", full, lambda: physics_penalty(system, zeta0, q, configs))


def networks(rng, alternatives: bool, n: int = 10_000) -> None:
    """The IX's two networks forward + backward: torch's autograd against ``pgnn.fused``."""
    nets = [mlp(16, (30, 30), "tanh") for _ in range(2)]
    x = torch.tensor(rng.normal(size=(n, 16)), dtype=torch.float32)
    dy = torch.tensor(rng.normal(size=(n, 2)), dtype=torch.float32)

    def autograd(f=lambda x: torch.cat([net(x) for net in nets], dim=1)):
        return lambda: (f(x) * dy).sum().backward()

    ratio_line("networks forward + backward, autograd / fused", autograd(),
               lambda: (fused_networks(x, nets) * dy).sum().backward())
    if not alternatives:
        return
    t = time.perf_counter()
    compiled = torch.compile(lambda x: torch.cat([net(x) for net in nets], dim=1))
    autograd(compiled)()
    print(f"  torch.compile of the networks: compiled in {time.perf_counter() - t:.1f} s "
          f"(an empty cache: TORCHINDUCTOR_CACHE_DIR set to a new folder)")
    ratio_line("networks forward + backward, torch.compile / fused", autograd(compiled),
               lambda: (fused_networks(x, nets) * dy).sum().backward())
    products = []  # forward x W per layer; backward: each weight's gradient, each hidden input's gradient
    for net in nets:
        widths = [layer.weight.shape for layer in net if isinstance(layer, torch.nn.Linear)]
        for k, (out, inp) in enumerate(widths):
            products += [((n, inp), (inp, out)), ((inp, n), (n, out))]
            if k > 0:
                products.append(((n, out), (out, inp)))
    mats = [(torch.randn(*a), torch.randn(*b)) for a, b in products]
    flops = sum(2 * a[0] * a[1] * b[1] for a, b in products)
    ratio_line(f"their {len(products)} matrix products alone (BLAS) / fused", lambda: [torch.mm(a, b) for a, b in mats],
               lambda: (fused_networks(x, nets) * dy).sum().backward())
    print(f"  ({flops / 1e6:.0f} MFLOP per pass)")
    h = rng.normal(size=(n, 30)).astype(np.float32)
    th = torch.from_numpy(h)
    ratio_line("tanh of (1e4, 30) float32, numpy / fused.tanh32", lambda: np.tanh(h), lambda: tanh_array(h))
    ratio_line("tanh of (1e4, 30) float32, torch / fused.tanh32", lambda: torch.tanh(th), lambda: tanh_array(h))


def step_parts(rng, n: int = 100_000) -> None:
    """The IX PGNN's training step and the parts of its cost (module docstring), one thread."""
    q, qd, qdd = rng.uniform(-1.5, 1.5, (n, 2)), rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    zeta0 = IX.nominal_params().to_vector()
    config = PGNNConfig(max_epochs=1, patience=1)
    inputs = network_inputs(q, qd, qdd, config, 500.0)
    data = TrainingData(q, qd, qdd, inputs, rng.normal(size=(n, 2)), IX.regressor(zeta0[IX.n_linear:], q, qd, qdd))

    def fit(steps: int) -> float:
        module = PGNNModule(IX, zeta0, inputs.shape[1])
        t = time.perf_counter()
        train(module, data, PGNNConfig(max_epochs=1, patience=1, steps_per_iteration=steps))
        return time.perf_counter() - t

    fit(5)
    step = (min(fit(60) for _ in range(3)) - min(fit(10) for _ in range(3))) / 50
    b = config.batch_size
    module = PGNNModule(IX, zeta0, inputs.shape[1])
    params = FlatParameters(module)
    features = PhysicsFeatures.of(IX, zeta0, q, qd, qdd)
    rows = rng.permutation(n)[:b]
    f32 = {k: np.asarray(v[rows], dtype=np.float32) for k, v in (("q", q), ("x", inputs), ("F", features.F), ("X", data.X))}
    batch = Batch(x=f32["x"], u=np.zeros((b, 2), np.float32), q=f32["q"], F=f32["F"], X=f32["X"])
    objective = Objective(module, params, features, 10.0, 1.0, True, nonzero_columns(data.X))
    r = rng.normal(size=(b, 2)).astype(np.float32)
    # the training split's matrix as ``train`` lays it out: x, u, q, F, X side by side, float32
    matrix = np.concatenate([a.reshape(n, -1) for a in (inputs, data.u, q, features.F, data.X)], axis=1, dtype=np.float32)
    adam = Adam(params.values, 1e-3)

    def networks():
        _, backward = objective._networks(batch.x, True)
        backward(r)

    def physical():
        _, backward = objective._physical(batch, True)
        backward(r)

    parts = {
        "the networks (fused kernels)": networks,
        "the physical model (features)": physical,
        "R1 with the batch's basis": lambda: batch_projection(batch.X, r, objective.nonzero, gradient=True),
        "R2": lambda: physics_penalty(IX, objective.zeta(), batch.q),
        "the batch's gather (whole rows)": lambda: np.take(matrix, rows, axis=0),
        "Adam's update": lambda: adam.step(params.grad),
    }
    print(f"\nIX PGNN training step, batch {b:,}, one torch thread: {1e3 * step:.2f} ms; its parts with their gradients:")
    total = 0.0
    for label, f in parts.items():
        cost = per_call(f, number=20)
        total += cost
        print(f"  {label:32s} {1e3 * cost:6.2f} ms ({cost / step:.0%})")
    print(f"  {'the rest':32s} {1e3 * (step - total):6.2f} ms ({1 - total / step:.0%}): J_LS, the sums of the gradients, "
          f"the validation passes")
    params.release()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--alternatives", action="store_true",
                        help="also torch.compile of the networks (slow to compile) and the BLAS products alone")
    args = parser.parse_args()
    torch.set_num_threads(1)
    rng = np.random.default_rng(0)
    print(f"{'':52s} {'plain':>11s}  {'lcgym':>11s}  ratio")
    networks(rng, args.alternatives)
    for name in ("ix-v1", "flexarm-v1"):
        r2_ratio(name, rng)

    q, qd, qdd = rng.normal(size=(3, 4000, 6))
    X = motor.regressor(None, q, qd, qdd).astype(np.float32)
    g = rng.normal(size=(4000, 6))
    columns = nonzero_columns(X)
    known = [(X[:, i, c].astype(float), projection_basis(X[:, i, c])) for i, c in enumerate(columns)]
    plain = lambda: batch_projection(X, g, gradient=True)  # noqa: E731
    ratio_line("R1 projection + gradient, arm: zero columns out", plain,
               lambda: batch_projection(X, g, columns, gradient=True))
    ratio_line("R1 projection + gradient, arm: basis known", plain,
               lambda: batch_projection(X, g, columns, known, gradient=True))
    step_parts(rng)


if __name__ == "__main__":
    main()
