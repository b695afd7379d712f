"""FlexArm rigid-body physics against independent derivations and invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from lcgym.systems.flexarm import dynamics as arm

P = arm.ArmParameters()
DH = P.dh.table()
PI = P.vector()


def _states(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-2.5, 2.5, (n, 6)), rng.uniform(-2, 2, (n, 6)), rng.uniform(-5, 5, (n, 6))


pytestmark = pytest.mark.usefixtures("float64_torch")  # the autograd checks run in double precision


def _lagrangian_torque(q, qd, qdd, g=arm.GRAVITY):
    """tau = d/dt dL/dqd - dL/dq by torch autograd, L = T - V written from the DH chain with the
    centre-of-mass form of each link (c = h / m, I_c by the parallel-axis theorem): an
    independent path from the Newton-Euler recursion."""
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


def test_regressor_columns_are_newton_euler_with_unit_parameters():
    """Column j of the regressor is RNEA with the unit parameter vector e_j (the definition), to the
    last bit: the regressor's shared forward pass and its inward pass from link j // 10 (the links
    beyond carry nothing) do the same arithmetic."""
    q, qd, qdd = _states(10, seed=4)
    for k in range(10):
        Y = arm.regressor(DH, q[k], qd[k], qdd[k], arm.GRAVITY)
        for j in range(arm.N_PARAMS):
            e = np.zeros(arm.N_PARAMS)
            e[j] = 1.0
            np.testing.assert_array_equal(Y[:, j], arm.rnea(DH, e, q[k], qd[k], qdd[k], arm.GRAVITY))


def test_composite_rigid_body_mass_matrix_is_newton_euler_column_by_column():
    """M(q) of the composite-rigid-body algorithm against RNEA with qd = 0, qdd = e_j and no gravity
    (column j of M by definition), with the 12 kg payload beyond the flange."""
    params = P.with_payload(12.0, (0.0, 0.0, 0.2))
    q = _states(20, seed=5)[0]
    for k in range(20):
        M = arm.mass_matrix(DH, params.vector(), q[k])
        ref = np.column_stack([arm.rnea(DH, params.vector(), q[k], np.zeros(6), e, 0.0) for e in np.eye(6)])
        np.testing.assert_allclose(M, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_forward_dynamics_inverts_newton_euler():
    """qdd = forward_dynamics(tau) gives back tau through RNEA (the solve checked by the equation it
    solves, not by another solver), and the written-out Cholesky solve agrees with LAPACK's."""
    q, qd, qdd = _states(10, seed=2)
    tau = arm.inverse_dynamics(P, q, qd, qdd)
    for k in range(10):
        got = arm.forward_dynamics_compiled(DH, PI, q[k], qd[k], tau[k], arm.GRAVITY)
        np.testing.assert_allclose(got, qdd[k], rtol=1e-9, atol=1e-9)
    rng = np.random.default_rng(3)
    for n in (1, 3, 6):
        A = rng.normal(size=(n, n))
        M, b = A @ A.T + 0.1 * np.eye(n), rng.normal(size=n)
        np.testing.assert_allclose(arm.solve_spd_compiled(M, b), np.linalg.solve(M, b), rtol=1e-12, atol=1e-12)
    assert np.isnan(arm.solve_spd_compiled(np.diag([1.0, -1.0]), np.ones(2))).all()  # not positive definite


def test_forward_kinematics_is_the_product_of_the_joint_transforms():
    q = _states(1, seed=4)[0][0]
    R, p = arm.joint_transforms(DH, q)
    Rw, pw = arm.forward_kinematics(DH, q)
    T = np.eye(4)
    for i in range(6):
        Ti = np.eye(4)
        Ti[:3, :3], Ti[:3, 3] = R[i], p[i]
        T = T @ Ti
        np.testing.assert_allclose(Rw[i], T[:3, :3], atol=1e-14)
        np.testing.assert_allclose(pw[i], T[:3, 3], atol=1e-14)


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
    """Two point masses of 1 kg at (+-0.1, 0, 0.2) m: the parallel-axis result against the inertia
    of the two points about the origin, computed by hand."""
    Ic = np.diag([0.0, 2 * 0.01, 2 * 0.01])
    p = arm.link_parameters(2.0, (0.0, 0.0, 0.2), Ic)
    assert p[0] == 2.0 and p[3] == pytest.approx(0.4)
    assert p[4] == pytest.approx(2 * 0.04)  # Ixx: masses at (+-0.1, 0, 0.2): 2 * 0.2^2
    assert p[7] == pytest.approx(2 * (0.01 + 0.04))  # Iyy: 2 * (0.1^2 + 0.2^2)
    assert p[9] == pytest.approx(2 * 0.01)  # Izz: 2 * 0.1^2


def test_flexible_arm_conserves_energy_without_damping_friction_and_input():
    """Eqs. (1)-(2) with D = F = 0 and u = 0: load + motor kinetic, gravity and spring energy is
    constant (RK4, 0.1 ms, 0.3 s through several joint-resonance periods)."""
    zero = np.zeros(6)
    drive = arm.DriveParameters(Dm=zero, Fmc=zero, DJ=zero, Dl=zero, Flc=zero).table()
    N = drive[0]
    ql = np.array([0.2, -0.3, 0.4, 0.3, -0.6, 0.2])
    x = np.concatenate([ql, [0.3, -0.5, 0.6, 1.0, -1.0, 2.0], N * ql + 0.002 * N, N * np.array([0.2, 0.1, 0.0, 0.5, 0.3, 1.0])])
    f = lambda s: arm.flexible_derivatives_compiled(DH, PI, drive, s, zero, arm.GRAVITY, 1e-3)  # noqa: E731
    e0 = arm.flexible_energy_compiled(DH, PI, drive, x, arm.GRAVITY)
    h = 1e-4
    for _ in range(3000):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    e1 = arm.flexible_energy_compiled(DH, PI, drive, x, arm.GRAVITY)
    assert abs(e1 - e0) < 1e-6 * abs(e0)


def test_stiff_joints_reach_the_rigid_limit():
    """Rigid limit of eqs. (1)-(2): at the spring deflection where motor and load accelerate
    together (what infinitely stiff joints enforce), the load acceleration equals the rigid
    forward dynamics with the motor inertia reflected (N^2 Jm added to the diagonal of M) and
    the motor torque geared up (N u)."""
    drive = arm.DriveParameters(Fmc=np.zeros(6), Flc=np.zeros(6), Dm=np.zeros(6), Dl=np.zeros(6)).table()
    N, Jm = drive[0], drive[1]
    q = np.array([0.1, -0.2, 0.3, 0.2, -0.4, 0.1])
    u = np.array([20.0, -30.0, 10.0, 0.5, 0.3, 0.1])
    # rigid: (M + N^2 Jm) qdd + b = N u
    M = arm.mass_matrix(DH, PI, q) + np.diag(N**2 * Jm)
    qdd_rigid = np.linalg.solve(M, N * u - arm.bias_torques(DH, PI, q, np.zeros(6), arm.GRAVITY))
    # flexible: solve for the spring deflection that makes motor and load accelerate together
    stiff = drive
    def acc_gap(defl):
        x = np.concatenate([q, np.zeros(6), N * (q + defl), np.zeros(6)])
        d = arm.flexible_derivatives_compiled(DH, PI, stiff, x, u, arm.GRAVITY, 1e-3)
        return d[6:12] - d[18:24] / N, d[6:12]
    defl = np.zeros(6)
    for _ in range(3):  # the gap is linear in the deflection: Newton converges in one step
        J = np.column_stack([(acc_gap(defl + 1e-7 * e)[0] - acc_gap(defl)[0]) / 1e-7 for e in np.eye(6)])
        defl = defl - np.linalg.solve(J, acc_gap(defl)[0])
    np.testing.assert_allclose(acc_gap(defl)[1], qdd_rigid, rtol=1e-6, atol=1e-8)


def test_accelerometer_reads_acceleration_minus_gravity_in_the_sensor_frame():
    """Against finite differences of the sensor point's position along a smooth motion."""
    offset = np.array([0.03, -0.02, 0.05])
    w0 = np.array([0.7, 1.1, 0.9, 1.7, 1.3, 2.1])

    def q_of(t):
        return 0.4 * np.sin(w0 * t), 0.4 * w0 * np.cos(w0 * t), -0.4 * w0**2 * np.sin(w0 * t)

    def sensor_position(t):
        Rw, pw = arm.forward_kinematics(DH, q_of(t)[0])
        return pw[5] + Rw[5] @ offset

    for t in (0.3, 1.1, 2.0):
        h = 1e-4
        acc = (sensor_position(t + h) - 2 * sensor_position(t) + sensor_position(t - h)) / h**2
        Rw, _ = arm.forward_kinematics(DH, q_of(t)[0])
        expected = Rw[5].T @ (acc - np.array([0.0, 0.0, -arm.GRAVITY]))
        got = arm.specific_force_compiled(DH, *q_of(t), offset, arm.GRAVITY)
        np.testing.assert_allclose(got, expected, atol=2e-5 * max(1.0, np.abs(expected).max()))
