"""What makes a PGNN training step cheaper (``lcgym.pgnn``), each as a ratio to the plain
implementation measured in the same run, one torch thread (as the benchmark's cells):

* the tanh of the hidden layers, forward and backward on a (1e4, 30) float32 batch: torch's own
  against ``pgnn.network.Tanh`` (numpy's tanh on CPU);
* R2 (eq. 30) with its gradient: eq. (30) differentiated in full (``physical_constraints``) against
  ``physics_penalty`` (the mass-matrix term as a constant while M is clearly positive definite);
  IX-v1 on 1e4 configurations, FlexArm-v1 on its 16 per batch;
* R1's projection with its gradient (``pgnn.training._batch_projection``) on a FlexArm batch of
  4,000 samples: every column and the basis computed per step, against the all-zero columns left
  out and the basis of a batch used again (validation, a training split that fits one batch).

Run:  .venv/bin/python benchmarks/pgnn_speed.py
"""

from __future__ import annotations

import time

import numpy as np
import torch

from lcgym import systems
from lcgym.pgnn.network import Tanh, physical_constraints, physics_penalty
from lcgym.pgnn.training import _batch_projection, nonzero_columns, projection_basis
from lcgym.systems.flexarm import motor


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


if __name__ == "__main__":
    main()
