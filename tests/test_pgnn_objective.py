"""The PGNN's cost and gradient in closed form (``pgnn.objective``) against torch's autograd of the
same cost written with torch operations, and its Adam against ``torch.optim.Adam``."""

import dataclasses

import numpy as np
import pytest
import torch

from lcgym import systems
from lcgym.methods.pgnn.network import PGNNModule, physical_constraints
from lcgym.methods.pgnn.objective import Adam, Batch, FlatParameters, Objective, PhysicsFeatures, nonzero_columns


def torch_cost(module, b: Batch, mu1, mu2, columns):
    """J of ``pgnn.training`` by torch operations: J_LS / B + mu1 R1 / B + mu2 R2 (R2 of eq. 30 in
    full, the mass-matrix term differentiated too), R1 by least
    squares (the pseudo-inverse of X with unit-norm columns, singular values below 1e-6 of the largest
    dropped: the rank of eq. 21 as ``projection_basis`` keeps it; an independent route to ||U^T g||^2)."""
    t = {k: torch.from_numpy(getattr(b, k)) for k in ("q", "x", "u")}
    kin = [torch.from_numpy(getattr(b, k)) for k in ("qd", "qdd")]
    f_m = module.system.inverse_dynamics(module.zeta, t["q"], *kin)
    f_c = torch.cat([net(t["x"]) for net in module.nets], dim=1)
    B = len(b.u)
    j_ls = ((t["u"] - f_m - f_c) ** 2).sum() / B
    r1 = f_c.new_zeros((), dtype=torch.float64)
    for i, cols in enumerate(columns):
        X = torch.from_numpy(b.X[:, i, cols].astype(float))
        X = X / X.norm(dim=0).clamp_min(1e-300)  # a column zero in float32 stays zero
        g = f_c[:, i].double()
        coef = torch.linalg.pinv(X, rtol=1e-6) @ g
        r1 = r1 + ((X @ coef) ** 2).sum()
    r2 = torch.clamp(torch.exp(-physical_constraints(module.system, module.zeta, t["q"])) - 1.0, min=0.0).sum()
    return j_ls + mu1 * r1.float() / B + mu2 * r2


def setup(machine, hidden=(30, 30), activation="tanh", n=3000, seed=0, push=False):
    system = systems.get(machine)
    rng = np.random.default_rng(seed)
    q, qd, qdd = (rng.uniform(-1.5, 1.5, (n, system.n_axes)) for _ in range(3))
    zeta0 = system.nominal_params().to_vector()
    torch.manual_seed(seed)
    module = PGNNModule(system, zeta0, 4 * system.n_axes, hidden, activation)
    with torch.no_grad():
        module.delta.copy_(torch.tensor(0.01 * zeta0 * rng.normal(size=zeta0.size)))
        if push:  # a positive parameter below zero: R2 active with a gradient
            module.delta[system.positive[0]] = -1.2 * float(zeta0[system.positive[0]])
    x = np.concatenate([q, qd, qdd, np.tanh(qd)], axis=1).astype(np.float32)
    X = system.regressor(zeta0[system.n_linear :], q, qd, qdd)
    u = system.inverse_dynamics(zeta0, q, qd, qdd) + 0.1 * rng.normal(size=(n, system.n_axes))
    b = Batch(x=x, u=u.astype(np.float32), q=q.astype(np.float32), qd=qd.astype(np.float32),
              qdd=qdd.astype(np.float32), X=X.astype(np.float32))
    return system, module, b, zeta0, X


@pytest.mark.parametrize("machine, closed_form, hidden, activation, push", [
    ("ix", True, (30, 30), "tanh", False),  # the IX's quadratic expansion, the compiled networks
    ("ix", True, (30, 30), "tanh", True),
    ("ix", False, (30, 30), "tanh", False),  # f^M by autograd
    ("flexarm", True, (30, 30), "tanh", False),  # linear in all parameters: F = X
    ("flexarm", True, (8,), "relu", True),  # a network the kernels do not compute
])
def test_cost_and_gradient_equal_autograd(machine, closed_form, hidden, activation, push):
    system, module, b, zeta0, X = setup(machine, hidden, activation, push=push)
    features = PhysicsFeatures.of(system, zeta0, b.q.astype(float), b.qd.astype(float), b.qdd.astype(float))
    assert features is not None
    if closed_form:
        b.F = features.F
    else:
        features = None
    mu1, mu2 = 10.0, 1.0
    columns = nonzero_columns(X)
    reference = torch_cost(module, b, mu1, mu2, columns)
    reference.backward()
    expected = np.concatenate([p.grad.numpy().ravel() for p in module.parameters()])
    named = dict(module.named_parameters())
    for p in module.parameters():
        p.grad = None

    params = FlatParameters(module)
    J, j_ls, r1, r2 = Objective(module, params, features, mu1, mu2, True, columns)(b)
    assert J == pytest.approx(float(reference.detach()), rel=2e-5)
    assert (r2 > 0) == push
    # the flat gradient back in the module's order
    got = {name: params.grad[view].reshape(p.shape) for (name, p), view in
           zip(((n, p) for p in params.params for n, q in named.items() if q is p), params._views, strict=True)}
    got = np.concatenate([got[name].ravel() for name in named])
    scale = np.abs(expected).max()
    np.testing.assert_allclose(got, expected, rtol=0, atol=2e-4 * scale)
    delta = slice(0, len(zeta0))
    np.testing.assert_allclose(got[delta], expected[delta], rtol=0, atol=1e-4 * np.abs(expected[delta]).max())
    params.release()


def test_expansion_of_the_ix_is_its_inverse_dynamics_and_a_wrong_flag_is_caught():
    """F theta(zeta) is the IX's eqs. 2-9 at any zeta (the expansion is exact, degree 2); a machine
    that claims degree 2 but is not gets no expansion (its f^M goes through autograd)."""
    system, _, b, zeta0, _ = setup("ix")
    q, qd, qdd = (getattr(b, k).astype(float) for k in ("q", "qd", "qdd"))
    features = PhysicsFeatures.of(system, zeta0, q, qd, qdd)
    rng = np.random.default_rng(3)
    for _ in range(3):
        zeta = zeta0 * (1 + 0.3 * rng.normal(size=zeta0.size))
        theta, jac = features.theta(zeta)
        exact = system.inverse_dynamics(zeta, q, qd, qdd)
        np.testing.assert_allclose(features.F.astype(float) @ theta, exact, atol=1e-5 * np.abs(exact).max())
        # the Jacobian by central differences
        h = 1e-6
        numeric = np.stack([(features.theta(zeta + h * e)[0] - features.theta(zeta - h * e)[0]) / (2 * h)
                            for e in np.eye(zeta.size)], axis=1)
        np.testing.assert_allclose(jac, numeric, atol=1e-8)

    def regressor(z, q, qd, qdd, columns=None):  # the IX's, times a factor not polynomial in z3
        return system.regressor(z, q, qd, qdd, **({} if columns is None else {"columns": columns})) * np.exp(3 * z[-1])

    wrong = dataclasses.replace(system, name="ix-wrong", regressor=regressor,
                                inverse_dynamics=lambda p, *kin: system.inverse_dynamics(p, *kin) * np.exp(3 * p[-1]))
    assert PhysicsFeatures.of(wrong, zeta0, q, qd, qdd) is None


def test_adam_is_torchs():
    rng = np.random.default_rng(2)
    values = rng.normal(size=500).astype(np.float32)
    p = torch.nn.Parameter(torch.tensor(values.copy()))
    opt = torch.optim.Adam([p], lr=1e-3)
    ours = Adam(values, 1e-3)
    for _ in range(50):
        g = rng.normal(size=500).astype(np.float32)
        p.grad = torch.tensor(g)
        opt.step()
        ours.step(g)
    np.testing.assert_allclose(values, p.detach().numpy(), rtol=0, atol=1e-6)
