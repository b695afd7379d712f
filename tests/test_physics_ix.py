"""The IX rigid-body model checked against an independent derivation and physical invariants.

* Independent derivation: kinetic and potential energy built from the body kinematics (rotation
  matrices, CoM positions, inertia tensors), differentiated by torch autograd (Euler-Lagrange),
  compared with M and H of systems/ix/dynamics.py (the paper's closed form).
* Christoffel consistency: the velocity terms of H equal C(q, qd) qd computed from M alone, and
  Mdot - 2C is skew-symmetric.
* Energy conservation of the unforced, undamped system; the paper's printed h2 sign breaks it.
* Lemma 1: X(zeta_n) zeta_l = f and X = grad_{zeta_l} f (eq. 17).
"""

import math

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp

from lcgym.systems.ix import dynamics as ix

P = ix.IXParameters()


pytestmark = pytest.mark.usefixtures("float64_torch")  # the autograd checks run in double precision
RNG = np.random.default_rng(0)


def _rot_x(a):
    c, s = torch.cos(a), torch.sin(a)
    one, zero = torch.ones_like(a), torch.zeros_like(a)
    return torch.stack([torch.stack([one, zero, zero]), torch.stack([zero, c, -s]), torch.stack([zero, s, c])])


def _rot_y(a):
    c, s = torch.cos(a), torch.sin(a)
    one, zero = torch.ones_like(a), torch.zeros_like(a)
    return torch.stack([torch.stack([c, zero, s]), torch.stack([zero, one, zero]), torch.stack([-s, zero, c])])


def lagrangian_parts(q, qd, p: ix.IXParameters, y2=0.123):
    """T and V from first principles (world z up; R02 = Ry(th2), R03 = Ry(th2) Rx(th3)).

    Inertia tensors about each CoM in body axes, products J_ab = +int(a b dm). y2 is arbitrary:
    the model must not depend on it.
    """
    R2 = _rot_y(q[0])
    R3 = R2 @ _rot_x(q[1])
    w2 = qd[0] * torch.tensor([0.0, 1.0, 0.0])  # world frame
    w3 = w2 + qd[1] * (R2 @ torch.tensor([1.0, 0.0, 0.0]))
    c2_body = torch.tensor([p.x2, y2, p.z2])
    c3_body = torch.tensor([p.x3, p.y3, p.z3])
    I2 = torch.diag(torch.tensor([0.3, p.J2yy, 0.7]))  # only J2yy can matter: the propeller spins about y
    I3 = torch.tensor([[p.J3xx, -p.J3xy, -p.J3xz], [-p.J3xy, p.J3yy, -p.J3yz], [-p.J3xz, -p.J3yz, p.J3zz]])

    def body(R, w, c_body, m, inertia):
        v = torch.linalg.cross(w, R @ c_body)  # CoM velocity, rotation about the origin
        return 0.5 * m * (v @ v) + 0.5 * w @ (R @ inertia @ R.T) @ w, m * ix.G * (R @ c_body)[2]

    T2, V2 = body(R2, w2, c2_body, p.m2, I2)
    T3, V3 = body(R3, w3, c3_body, p.m3, I3)
    return T2 + T3, V2 + V3


def euler_lagrange(q, qd, p):
    """M, gravity g = dV/dq, and velocity terms c = d/dt(dT/dqd) - dT/dq - M qdd (autograd)."""
    q = torch.tensor(q, requires_grad=True)
    qd = torch.tensor(qd, requires_grad=True)
    T, V = lagrangian_parts(q, qd, p)
    dT_dqd = torch.autograd.grad(T, qd, create_graph=True)[0]
    M = torch.stack([torch.autograd.grad(dT_dqd[i], qd, retain_graph=True)[0] for i in range(2)])
    mixed = torch.stack([torch.autograd.grad(dT_dqd[i], q, retain_graph=True)[0] for i in range(2)])
    dT_dq = torch.autograd.grad(T, q, retain_graph=True)[0]
    g = torch.autograd.grad(V, q)[0]
    c = mixed @ qd - dT_dq
    return M.detach().numpy(), g.detach().numpy(), c.detach().numpy()


@pytest.mark.parametrize("k", range(6))
def test_mass_and_bias_match_independent_lagrangian(k):
    q = RNG.uniform(-math.pi, math.pi, 2)
    qd = RNG.normal(0, 1.0, 2)
    p = P.to_vector()
    M_ref, g_ref, c_ref = euler_lagrange(q, qd, P)
    np.testing.assert_allclose(ix.mass_matrix(p, q), M_ref, rtol=1e-12, atol=1e-12)
    h = ix.bias_torque(p, q, qd)
    h_static = ix.bias_torque(p, q, np.zeros(2))
    np.testing.assert_allclose(h_static, g_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(h - h_static, c_ref, rtol=1e-10, atol=1e-12)


def test_inverse_dynamics_is_euler_lagrange_with_viscous_friction():
    q, qd, qdd = RNG.normal(size=(3, 2))
    M_ref, g_ref, c_ref = euler_lagrange(q, qd, P)
    tau_ref = M_ref @ qdd + c_ref + g_ref + np.array([P.d2, P.d3]) * qd
    np.testing.assert_allclose(ix.inverse_dynamics(P.to_vector(), q, qd, qdd), tau_ref, rtol=1e-12)


def _mass_torch(p, q):
    return ix.mass_matrix(torch.tensor(p), q)


def test_velocity_terms_follow_from_mass_matrix_christoffel():
    """h_vel = C qd with C_ij = sum_k Gamma_ijk qd_k, Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i)."""
    p = P.to_vector()
    for _ in range(5):
        q = torch.tensor(RNG.uniform(-3, 3, 2), requires_grad=True)
        qd = torch.tensor(RNG.normal(size=2))
        M = _mass_torch(p, q)
        dM = torch.stack(
            [torch.stack([torch.autograd.grad(M[i, j], q, retain_graph=True)[0] for j in range(2)]) for i in range(2)]
        )  # dM[i, j, k] = d M_ij / d q_k
        gamma = 0.5 * (dM + dM.permute(0, 2, 1) - dM.permute(2, 0, 1))
        C = torch.einsum("ijk,k->ij", gamma, qd)
        qn = q.detach().numpy()
        h_vel = ix.bias_torque(p, qn, qd.numpy()) - ix.bias_torque(p, qn, np.zeros(2))
        np.testing.assert_allclose((C @ qd).numpy(), h_vel, rtol=1e-11, atol=1e-13)
        Mdot = torch.einsum("ijk,k->ij", dM, qd)
        skew = (Mdot - 2 * C).numpy()
        np.testing.assert_allclose(skew, -skew.T, atol=1e-12)


def test_mass_matrix_positive_definite_over_range():
    p = P.to_vector()
    g = np.linspace(-math.pi, math.pi, 25)
    q = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    M = ix.mass_matrix(p, q)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    np.testing.assert_allclose(M, np.swapaxes(M, -1, -2))


def _simulate_energy(p, t_end=30.0):
    def rhs(_, s):
        return np.concatenate([s[2:], ix.forward_dynamics(p, s[:2], s[2:], np.zeros(2))])

    s0 = np.array([0.4, -0.9, 0.8, -1.1])
    sol = solve_ivp(rhs, (0, t_end), s0, method="DOP853", rtol=1e-12, atol=1e-12, dense_output=False)
    E = ix.energy(p, sol.y[:2].T, sol.y[2:].T)
    kinetic0 = 0.5 * s0[2:] @ ix.mass_matrix(p, s0[:2]) @ s0[2:]
    return np.max(np.abs(E - E[0])) / kinetic0


def test_energy_conserved_without_damping_and_input():
    p = P.to_vector()
    p[ix.D2] = p[ix.D3] = 0.0
    assert _simulate_energy(p) < 1e-8


def test_printed_h2_gravity_sign_has_no_potential():
    """Paper eq. (7) prints +g(...) sin th2 in h2. That field has non-zero curl; the corrected one
    has none (d g2/d th3 = d g3/d th2), i.e. only the corrected sign derives from a potential."""
    p = P.to_vector()

    def gravity(q, printed):
        g = ix.bias_torque(p, q, np.zeros(2))
        if printed:  # flip the sign of the -g a sin th2 term
            a = p[ix.M2] * p[ix.Z2] + p[ix.M3] * (p[ix.Z3] * np.cos(q[1]) + p[ix.Y3] * np.sin(q[1]))
            g = g + np.array([2 * ix.G * a * np.sin(q[0]), 0.0])
        return g

    def curl(q, printed, h=1e-6):
        d2_3 = (gravity(q + [0, h], printed)[0] - gravity(q - [0, h], printed)[0]) / (2 * h)
        d3_2 = (gravity(q + [h, 0], printed)[1] - gravity(q - [h, 0], printed)[1]) / (2 * h)
        return d2_3 - d3_2

    q = np.array([0.7, 0.5])
    assert abs(curl(q, printed=False)) < 1e-7
    assert abs(curl(q, printed=True)) > 1e-2


def test_regressor_lemma1_linear_and_gradient():
    p = P.to_vector()
    q, qd, qdd = RNG.normal(size=(3, 50, 2))
    X = ix.regressor(p[ix.N_LINEAR :], q, qd, qdd)
    assert X.shape == (50, 2, ix.N_LINEAR)
    np.testing.assert_allclose(X @ p[: ix.N_LINEAR], ix.inverse_dynamics(p, q, qd, qdd), rtol=1e-12, atol=1e-12)
    # eq. (17): X = gradient of f with respect to zeta_l (torch autograd through the same code)
    pt = torch.tensor(p, requires_grad=True)
    f = ix.inverse_dynamics(pt, torch.tensor(q[0]), torch.tensor(qd[0]), torch.tensor(qdd[0]))
    for axis in range(2):
        grad = torch.autograd.grad(f[axis], pt, retain_graph=True)[0].numpy()
        np.testing.assert_allclose(grad[: ix.N_LINEAR], X[0, axis], rtol=1e-12, atol=1e-14)
    # the model must not depend on y2 (translational invariance): no such parameter exists
    assert "y2" not in ix.PARAM_NAMES


def test_numpy_and_torch_agree():
    p = P.to_vector()
    q, qd, qdd = RNG.normal(size=(3, 20, 2))
    out_np = ix.inverse_dynamics(p, q, qd, qdd)
    out_t = ix.inverse_dynamics(torch.tensor(p), torch.tensor(q), torch.tensor(qd), torch.tensor(qdd))
    np.testing.assert_allclose(out_t.numpy(), out_np, rtol=1e-14)


def test_values_by_hand():
    """m22 and m33 of eq. (5) by hand for the default IXParameters.

    m22(th3) = 0.96275 + 0.1027 cos^2 th3 + 0.009 sin 2 th3, so m22(0) = 1.06545 and
    m22(90 deg) = 0.96275 (the spec quotes [0.98, 1.07]; its lower end is not reproduced by its
    own formula); m33 = 0.80 + 3 (0.04^2 + 0.05^2) = 0.8123.
    """
    p = P.to_vector()
    M = ix.mass_matrix(p, np.array([[0.3, 0.0], [0.3, math.pi / 2]]))
    np.testing.assert_allclose(M[:, 0, 0], [1.06545, 0.96275], rtol=1e-12)
    np.testing.assert_allclose(M[:, 1, 1], 0.8123, rtol=1e-12)
