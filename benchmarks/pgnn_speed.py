"""What makes a PGNN training step cheaper (``lcgym.pgnn``), each as a ratio to the plain
implementation measured in the same run, one torch thread (as the benchmark's cells):

* the tanh of the hidden layers, forward and backward on a (1e4, 30) float32 batch: torch's own
  against ``pgnn.network.Tanh`` (numpy's tanh on CPU);
* R2 (eq. 30) with its gradient: eq. (30) differentiated in full (``physical_constraints``) against
  ``physics_penalty`` (the mass-matrix term as a constant while M is clearly positive definite);
  IX-v1 on 1e4 configurations, FlexArm-v1 on its 16 per batch;
* R1's projection with its gradient (``pgnn.training._batch_projection``) on a FlexArm batch of
  4,000 samples: every column and the basis computed per step, against the all-zero columns left
  out and the basis of a batch used again (validation, a training split that fits one batch);
* where a whole training step of the IX PGNN goes (batch 1e4, two torch threads, as
  ``benchmarks/pgnn_tables.py``'s fits): the step (``pgnn.training.train`` run for 60 and for 10
  steps, the difference per step), the two axes' networks forward and backward, and their 16
  matrix products alone (the arithmetic any float32 implementation of the paper's MLPs does),
  each as a share of the step, and what they come to over the 9,760 steps the N = 1e6 fit takes
  to early stopping (``docs/speed.md``).

Run:  .venv/bin/python benchmarks/pgnn_speed.py
"""

from __future__ import annotations

import time

import numpy as np
import torch

from lcgym import systems
from lcgym.pgnn.network import PGNNModule, Tanh, physical_constraints, physics_penalty
from lcgym.pgnn.training import (
    PGNNConfig,
    TrainingData,
    _batch_projection,
    network_inputs,
    nonzero_columns,
    projection_basis,
    train,
)
from lcgym.systems.flexarm import motor
from lcgym.systems.ix import IX

STEPS_TO_EARLY_STOPPING = 9_760
"""Adam steps of the IX PGNN with J on N = 1e6 to early stopping: 122 iterations of 80 (docs/speed.md)."""


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
    zeta = torch.tensor(system.nominal_params().to_vector(), dtype=torch.float32, requires_grad=True)
    q = torch.tensor(rng.uniform(-1.5, 1.5, (n, system.n_axes)), dtype=torch.float32)

    def full():
        torch.clamp(torch.exp(-physical_constraints(system, zeta, q)) - 1.0, min=0.0).sum().backward()

    ratio_line(f"R2 with its gradient, {name}", full, lambda: physics_penalty(system, zeta, q).backward())


def step_parts(rng, n: int = 100_000, threads: int = 2) -> None:
    """The IX PGNN's training step and what of it the networks take (module docstring)."""
    before = torch.get_num_threads()
    torch.set_num_threads(threads)
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
    module = PGNNModule(IX, zeta0, inputs.shape[1])
    x = torch.tensor(inputs[: config.batch_size], dtype=torch.float32)
    nets = per_call(lambda: module.network(x).sum().backward(), number=20)
    products = []  # forward x W per layer; backward: each weight's gradient, each hidden input's gradient
    for net in module.nets:
        widths = [layer.weight.shape for layer in net if isinstance(layer, torch.nn.Linear)]
        for k, (out, inp) in enumerate(widths):
            products += [((len(x), inp), (inp, out)), ((inp, len(x)), (len(x), out))]
            if k > 0:
                products.append(((len(x), out), (out, inp)))
    mats = [(torch.randn(*a), torch.randn(*b)) for a, b in products]
    matmul = per_call(lambda: [torch.mm(a, b) for a, b in mats], number=20)
    flops = sum(2 * a[0] * a[1] * b[1] for a, b in products)
    torch.set_num_threads(before)
    print(f"\nIX PGNN training step, batch {len(x):,}, {threads} torch threads: {1e3 * step:.2f} ms "
          f"(x {STEPS_TO_EARLY_STOPPING:,} steps: {step * STEPS_TO_EARLY_STOPPING:.0f} s)")
    print(f"  the networks forward + backward {1e3 * nets:.2f} ms ({nets / step:.0%} of the step; "
          f"x {STEPS_TO_EARLY_STOPPING:,}: {nets * STEPS_TO_EARLY_STOPPING:.0f} s)")
    print(f"  their {len(products)} matrix products alone {1e3 * matmul:.2f} ms ({matmul / step:.0%}; "
          f"{flops / matmul / 1e9:.0f} GFLOP/s; x {STEPS_TO_EARLY_STOPPING:,}: {matmul * STEPS_TO_EARLY_STOPPING:.0f} s)")


def main() -> None:
    torch.set_num_threads(1)
    rng = np.random.default_rng(0)
    print(f"{'':52s} {'plain':>11s}  {'lcgym':>11s}  ratio")

    x = torch.tensor(rng.normal(size=(10_000, 30)), dtype=torch.float32, requires_grad=True)
    ours = Tanh()
    ratio_line("tanh forward + backward, (1e4, 30) float32", lambda: torch.tanh(x).sum().backward(),
               lambda: ours(x).sum().backward())

    for name in ("ix-v1", "flexarm-v1"):
        r2_ratio(name, rng)

    q, qd, qdd = rng.normal(size=(3, 4000, 6))
    X = torch.tensor(motor.regressor(None, q, qd, qdd), dtype=torch.float32)
    g = torch.tensor(rng.normal(size=(4000, 6)), dtype=torch.float32, requires_grad=True)
    columns = nonzero_columns(X)
    known = [(X[:, i, c].double(), projection_basis(X[:, i, c])) for i, c in enumerate(columns)]
    plain = lambda: _batch_projection(X, g).backward()  # noqa: E731
    ratio_line("R1 projection + gradient, arm: zero columns out", plain, lambda: _batch_projection(X, g, columns).backward())
    ratio_line("R1 projection + gradient, arm: basis known", plain,
               lambda: _batch_projection(X, g, columns, known).backward())
    step_parts(rng)


if __name__ == "__main__":
    main()
