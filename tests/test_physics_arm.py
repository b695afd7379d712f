"""FlexArm rigid-body physics against independent derivations and invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from lcgym.physics import arm

P = arm.ArmParameters()
DH = P.dh.table()
PI = P.vector()


def _states(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-2.5, 2.5, (n, 6)), rng.uniform(-2, 2, (n, 6)), rng.uniform(-5, 5, (n, 6))


def _lagrangian_torque(q, qd, qdd, g=arm.GRAVITY):
    """tau = d/dt dL/dqd - dL/dq by torch autograd, L = T - V written from the DH chain with the
    centre-of-mass form of each link (c = h / m, I_c by the parallel-axis theorem): an
    independent path from the Newton-Euler recursion."""
    torch.set_default_dtype(torch.float64)
    dh = torch.tensor(DH)

    def chain(qv):
        Rs, ps = [], []
        Rc, pc = torch.eye(3), torch.zeros(3)
        for i in range(6):
            d, a, al, off = dh[i]
            th = qv[i] + off
            Rz = torch.stack([torch.stack([torch.cos(th), -torch.sin(th), torch.zeros(())]),
                              torch.stack([torch.sin(th), torch.cos(th), torch.zeros(())]),
                              torch.tensor([0.0, 0.0, 1.0])])
            Rx = torch.tensor([[1.0, 0.0, 0.0], [0.0, math.cos(al), -math.sin(al)], [0.0, math.sin(al), math.cos(al)]])
            pc = pc + Rc @ (Rz @ torch.stack([a, torch.zeros(()), d]))
            Rc = Rc @ Rz @ Rx
            Rs.append(Rc)
            ps.append(pc)
        return Rs, ps

    links = []
    for i in range(6):
        k = PI[10 * i : 10 * i + 10]
        m, h = k[0], k[1:4]
        Io = np.array([[k[4], k[5], k[6]], [k[5], k[7], k[8]], [k[6], k[8], k[9]]])
        c = h / m
        links.append((m, torch.tensor(c), torch.tensor(Io - m * (c @ c * np.eye(3) - np.outer(c, c)))))

    def energies(qv, qdv):
        def poses(x):
            Rs, ps = chain(x)
            return tuple(Rs) + tuple(p + R @ lk[1] for R, p, lk in zip(Rs, ps, links, strict=True))

        out, dout = torch.func.jvp(poses, (qv,), (qdv,))
        T = torch.zeros(())
        V = torch.zeros(())
        for i, (m, _, Ic) in enumerate(links):
            R, Rd, pc, vc = out[i], dout[i], out[6 + i], dout[6 + i]
            W = R.T @ Rd  # skew(omega) in the link frame
            w = torch.stack([W[2, 1], W[0, 2], W[1, 0]])
            T = T + 0.5 * m * vc @ vc + 0.5 * w @ Ic @ w
            V = V + m * g * pc[2]
        return T, V

    qt, qdt, qddt = (torch.tensor(x) for x in (q, qd, qdd))
    dT_dqd = lambda a, b: torch.autograd.grad(energies(a, b)[0], b, create_graph=True)[0]  # noqa: E731
    Jq = torch.autograd.functional.jacobian(lambda a: dT_dqd(a, qdt.clone().requires_grad_(True)), qt)
    Jqd = torch.autograd.functional.jacobian(lambda b: dT_dqd(qt.clone().requires_grad_(True), b), qdt)
    qv = qt.clone().requires_grad_(True)
    T, V = energies(qv, qdt)
    dL_dq = torch.autograd.grad(T - V, qv)[0]
    return (Jq @ qdt + Jqd @ qddt - dL_dq).numpy()


def test_newton_euler_matches_euler_lagrange():
    q, qd, qdd = _states(4)
    tau = arm.inverse_dynamics(P, q, qd, qdd)
    for k in range(4):
        np.testing.assert_allclose(tau[k], _lagrangian_torque(q[k], qd[k], qdd[k]), rtol=1e-9, atol=1e-9)


def test_mass_matrix_symmetric_positive_definite_and_regressor_linear():
    q, qd, qdd = _states(20, seed=1)
    for k in range(20):
        M = arm.mass_matrix(DH, PI, q[k])
        np.testing.assert_allclose(M, M.T, atol=1e-10)
        assert np.linalg.eigvalsh(M).min() > 0
    Y = arm.regressor_batch(P, q, qd, qdd)
    np.testing.assert_allclose(Y @ PI, arm.inverse_dynamics(P, q, qd, qdd), rtol=1e-10, atol=1e-9)


def test_energy_is_conserved_without_damping_and_input():
    """RK4 at 0.5 ms over 2 s of free motion from a raised, spinning pose: relative drift < 1e-6."""
    q = np.array([0.3, -0.4, 0.5, 0.2, -0.8, 0.1])
    qd = np.array([0.5, -0.8, 1.0, 2.0, -1.5, 3.0])
    f = lambda x, v: arm.forward_dynamics_compiled(DH, PI, x, v, np.zeros(6), arm.GRAVITY)  # noqa: E731
    e0 = arm.energy_compiled(DH, PI, q, qd, arm.GRAVITY)
    h = 5e-4
    for _ in range(4000):
        k1v, k1a = qd, f(q, qd)
        k2v, k2a = qd + 0.5 * h * k1a, f(q + 0.5 * h * k1v, qd + 0.5 * h * k1a)
        k3v, k3a = qd + 0.5 * h * k2a, f(q + 0.5 * h * k2v, qd + 0.5 * h * k2a)
        k4v, k4a = qd + h * k3a, f(q + h * k3v, qd + h * k3a)
        q = q + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        qd = qd + h / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
    e1 = arm.energy_compiled(DH, PI, q, qd, arm.GRAVITY)
    kinetic_scale = 0.5 * qd @ arm.mass_matrix(DH, PI, q) @ qd
    assert abs(e1 - e0) < 1e-6 * max(abs(e0), kinetic_scale)


def test_payload_adds_its_gravity_torque():
    """A point payload at the flange, arm stretched forward: joints 2 and 3 carry m g times its
    horizontal distance from their axes (statics by hand)."""
    q = np.zeros(6)
    heavy = P.with_payload(20.0)
    extra = arm.inverse_dynamics(heavy, q, q, q) - arm.inverse_dynamics(P, q, q, q)
    _, pw = arm.forward_kinematics(DH, q)
    flange = pw[5]
    shoulder, elbow = pw[0], pw[1]
    assert abs(extra[0, 1]) == pytest.approx(20.0 * arm.GRAVITY * (flange[0] - shoulder[0]), rel=1e-12)
    assert abs(extra[0, 2]) == pytest.approx(20.0 * arm.GRAVITY * (flange[0] - elbow[0]), rel=1e-12)
    assert extra[0, 0] == pytest.approx(0.0, abs=1e-12)


def test_link_parameters_parallel_axis():
    """Two point masses of 1 kg at +-0.1 m on x, about the origin 0.2 m away: I_yy = 2 (0.1^2 + 0.2^2)... by hand."""
    Ic = np.diag([0.0, 2 * 0.01, 2 * 0.01])
    p = arm.link_parameters(2.0, (0.0, 0.0, 0.2), Ic)
    assert p[0] == 2.0 and p[3] == pytest.approx(0.4)
    assert p[4] == pytest.approx(2 * 0.04)  # Ixx: masses at (+-0.1, 0, 0.2): 2 * 0.2^2
    assert p[7] == pytest.approx(2 * (0.01 + 0.04))  # Iyy: 2 * (0.1^2 + 0.2^2)
    assert p[9] == pytest.approx(2 * 0.01)  # Izz: 2 * 0.1^2
