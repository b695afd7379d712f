"""URDF machines (``systems/urdf.py``) and their closed-loop plant (``systems/urdf_plant.py``).

The two-link example arm is checked against a closed-form Lagrange derivation written here from
the URDF's numbers (not pinocchio), and against pinocchio's RNEA and CRBA; the Panda (vendored in
tests/data/panda) exercises locking, mimic joints and a 7-axis regressor; bad files and joint
names end in one-line errors naming them; the plant tracks a perfect feedforward, conserves
energy unforced, feels a hidden Coulomb friction by its level and reports divergence.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import scipy.linalg

from lcgym import systems
from lcgym.physics import effects as fx
from lcgym.references import AxisProfile
from lcgym.systems import SimulationDiverged
from lcgym.systems.examples import two_link_urdf
from lcgym.systems.system import REGRESSOR_MIN_ROWS
from lcgym.systems.urdf import base_parameters, from_urdf, structural_rank, urdf_robot
from lcgym.systems.urdf_plant import FeedbackGains, URDFPlant, inertia_range, loop_stable, random_references, tuned_gains

PANDA = Path(__file__).parent / "data" / "panda" / "panda.urdf"
PANDA_ARM = tuple(f"panda_joint{i}" for i in range(1, 8))
G = 9.81


def random_kinematics(system, n, seed):
    return urdf_robot(system).sample_kinematics(n, np.random.default_rng(seed))


def rnea(system, q, qd, qdd):
    """pinocchio's inverse dynamics of the reduced model, in the system's axis order."""
    robot = urdf_robot(system)
    data = robot.model.createData()
    cfg, v, a = robot.configuration(q), robot.tangent(qd), robot.tangent(qdd)
    return np.array([pin.rnea(robot.model, data, cfg[k], v[k], a[k])[robot.v_index] for k in range(len(q))])


# ------------------------------------------------------------------ closed-form two-link arm


def planar_links():
    """From the URDF's XML: per moving body (upper arm; forearm with the locked finger at 0) the
    mass [kg], centre of mass (x, z) [m] in its joint frame and I_yy about the centre of mass
    [kg m^2]; and the link length l1 [m] (shoulder to elbow)."""
    root = ET.parse(two_link_urdf()).getroot()

    def inertial(link):
        el = root.find(f"link[@name='{link}']/inertial")
        xyz = [float(v) for v in el.find("origin").get("xyz").split()]
        return float(el.find("mass").get("value")), np.array([xyz[0], xyz[2]]), float(el.find("inertia").get("iyy"))

    def origin(joint):
        xyz = [float(v) for v in root.find(f"joint[@name='{joint}']/origin").get("xyz").split()]
        return np.array([xyz[0], xyz[2]])

    m1, c1, i1 = inertial("upper_arm")
    mf, cf, jf = inertial("forearm")
    mg, cg, jg = inertial("finger")
    cg = cg + origin("finger")  # the finger's frame sits at the finger joint, locked at 0
    m2 = mf + mg
    c2 = (mf * cf + mg * cg) / m2
    i2 = jf + mf * np.sum((cf - c2) ** 2) + jg + mg * np.sum((cg - c2) ** 2)  # parallel axes, about y
    return (m1, c1, i1), (m2, c2, i2), origin("elbow")[0]


def lagrange_two_link(q, qd, qdd):
    """tau (T, 2) [N m] of the planar arm by Euler-Lagrange. Both joints turn about +y; a point
    (x, z) of a link at angle phi sits at (x cos phi + z sin phi, -x sin phi + z cos phi), so
    with beta = l1 m2 (c2x cos q2 + c2z sin q2):
    M11 = I1 + m1 |c1|^2 + I2 + m2 (l1^2 + |c2|^2) + 2 beta, M12 = I2 + m2 |c2|^2 + beta,
    M22 = I2 + m2 |c2|^2; h1 = -beta' (2 qd1 qd2 + qd2^2), h2 = beta' qd1^2 with beta' = d beta / d q2;
    V = g (m1 z1 + m2 z2)."""
    (m1, c1, i1), (m2, c2, i2), l1 = planar_links()
    q1, q2 = q[:, 0], q[:, 1]
    beta = l1 * m2 * (c2[0] * np.cos(q2) + c2[1] * np.sin(q2))
    dbeta = l1 * m2 * (-c2[0] * np.sin(q2) + c2[1] * np.cos(q2))
    delta = i2 + m2 * c2 @ c2
    m11 = i1 + m1 * c1 @ c1 + i2 + m2 * (l1**2 + c2 @ c2) + 2 * beta
    m12 = delta + beta
    h1 = dbeta * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2)
    h2 = -dbeta * qd[:, 0] ** 2
    q12 = q1 + q2
    g1 = G * (m1 * (-np.cos(q1) * c1[0] - np.sin(q1) * c1[1])
              + m2 * (-np.cos(q1) * l1 - np.cos(q12) * c2[0] - np.sin(q12) * c2[1]))
    g2 = G * m2 * (-np.cos(q12) * c2[0] - np.sin(q12) * c2[1])
    tau1 = m11 * qdd[:, 0] + m12 * qdd[:, 1] + h1 + g1
    tau2 = m12 * qdd[:, 0] + delta * qdd[:, 1] + h2 + g2
    return np.column_stack([tau1, tau2])


@pytest.fixture(scope="module")
def arm():
    return from_urdf(two_link_urdf(), joints=("shoulder", "elbow"))


@pytest.fixture(scope="module")
def panda():
    return from_urdf(PANDA, joints=PANDA_ARM)


def test_two_link_regressor_matches_lagrange_and_rnea(arm):
    q, qd, qdd = random_kinematics(arm, 200, seed=1)
    p = arm.nominal_params().to_vector()
    X = arm.regressor(None, q, qd, qdd)
    assert X.shape == (200, 2, 22)
    np.testing.assert_allclose(X @ p, lagrange_two_link(q, qd, qdd), rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(X @ p, rnea(arm, q, qd, qdd), rtol=1e-12, atol=1e-12)
    d = np.array([0.7, 0.2])  # the viscous columns are qd
    p[20:] = d
    np.testing.assert_allclose(arm.inverse_dynamics(p, q, qd, qdd), lagrange_two_link(q, qd, qdd) + d * qd, atol=1e-10)


def test_two_link_machine(arm):
    assert arm.name == "two_link"
    assert arm.axis_names == ("shoulder", "elbow")
    assert [a.kind for a in arm.axes] == ["revolute", "revolute"] and arm.input_units == ("N m", "N m")
    assert arm.param_names[:3] == ("m_shoulder", "mx_shoulder", "my_shoulder")
    assert arm.param_names[-2:] == ("d_shoulder", "d_elbow")
    names = [arm.param_names[i] for i in arm.positive]
    assert names[:4] == ["m_shoulder", "Ixx_shoulder", "Iyy_shoulder", "Izz_shoulder"] and names[-2:] == ["d_shoulder", "d_elbow"]
    np.testing.assert_allclose(arm.joint_axes(), [[0, 1, 0], [0, 1, 0]], atol=1e-15)
    assert "8 base parameters" in arm.description and "locked: finger" in arm.description
    # the finger's 0.35 kg hang on the forearm: the forearm body carries both masses
    values = arm.nominal_params().as_dict()
    assert values["m_elbow"] == pytest.approx(2.6 + 0.35) and values["m_shoulder"] == pytest.approx(4.2)
    # the example's inertia tensors are physical: positive definite, triangle inequalities
    full = pin.buildModelFromUrdf(str(two_link_urdf()))
    for inertia in list(full.inertias)[1:]:
        eig = np.linalg.eigvalsh(inertia.inertia)
        assert inertia.mass > 0 and eig.min() > 0 and 2 * eig.max() < eig.sum()
    assert systems.get(str(two_link_urdf()), joints=("shoulder", "elbow")).param_names == arm.param_names
    # by name, as an installed wheel's user gives it (no path into the source tree)
    assert systems.get("two_link", joints=("shoulder", "elbow")).param_names == arm.param_names


def test_mass_matrix_matches_crba_and_is_positive_definite(arm, panda):
    for system in (arm, panda):
        robot = urdf_robot(system)
        q = random_kinematics(system, 20, seed=2)[0]
        M = system.mass_matrix(system.nominal_params().to_vector(), q)
        data = robot.model.createData()
        for k, cfg in enumerate(robot.configuration(q)):
            ref = pin.crba(robot.model, data, cfg)
            ref = np.triu(ref) + np.triu(ref, 1).T
            np.testing.assert_allclose(M[k], ref[np.ix_(robot.v_index, robot.v_index)], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(M, np.swapaxes(M, 1, 2), atol=1e-12)
        assert np.all(np.linalg.eigvalsh(M) > 0)


def test_panda_locks_the_fingers_and_matches_rnea(panda):
    robot = urdf_robot(panda)
    assert panda.n_axes == 7 and panda.axis_names == PANDA_ARM and panda.name == "panda"
    assert robot.locked == ("panda_finger_joint1", "panda_finger_joint2") and robot.model.nv == 7
    assert len(panda.param_names) == 77
    q, qd, qdd = random_kinematics(panda, 100, seed=3)
    u = panda.inverse_dynamics(panda.nominal_params().to_vector(), q, qd, qdd)
    np.testing.assert_allclose(u, rnea(panda, q, qd, qdd), rtol=1e-11, atol=1e-11)
    # the default axes leave out the mimic-coupled fingers
    assert from_urdf(PANDA).axis_names == PANDA_ARM


def test_axis_order_is_the_joints_order(panda):
    order = (2, 0, 1, 6, 4, 3, 5)
    shuffled = from_urdf(PANDA, joints=[PANDA_ARM[i] for i in order])
    assert shuffled.axis_names == tuple(PANDA_ARM[i] for i in order)
    q, qd, qdd = random_kinematics(panda, 30, seed=4)
    X = panda.regressor(None, q, qd, qdd)
    Xs = shuffled.regressor(None, q[:, order], qd[:, order], qdd[:, order])
    cols = np.concatenate([np.arange(10 * i, 10 * i + 10) for i in order] + [70 + np.array(order)])
    np.testing.assert_array_equal(Xs, X[:, order][:, :, cols])
    assert [shuffled.param_names[c] for c in range(10)] == [panda.param_names[c] for c in cols[:10]]
    np.testing.assert_array_equal(shuffled.joint_axes(), panda.joint_axes()[list(order)])


def test_prismatic_axis_and_continuous_joint(tmp_path):
    arm3 = from_urdf(two_link_urdf(), joints=("finger", "shoulder", "elbow"))
    assert arm3.axis("finger").kind == "prismatic" and arm3.axis("finger").input_unit == "N"
    assert arm3.input_unit == "N / N m"
    np.testing.assert_allclose(arm3.joint_axes()[0], [1, 0, 0], atol=1e-15)
    q, qd, qdd = random_kinematics(arm3, 50, seed=5)
    np.testing.assert_allclose(arm3.inverse_dynamics(arm3.nominal_params().to_vector(), q, qd, qdd),
                               rnea(arm3, q, qd, qdd), atol=1e-11)
    # a continuous joint: pinocchio's (cos, sin) from an angle of any size
    text = two_link_urdf().read_text().replace('type="revolute"', 'type="continuous"', 1)
    path = tmp_path / "continuous.urdf"
    path.write_text(text)
    cont = from_urdf(path, joints=("shoulder", "elbow"))
    robot = urdf_robot(cont)
    assert robot.model.nq == 3 and cont.axis("shoulder").kind == "revolute"
    q, qd, qdd = random_kinematics(cont, 50, seed=6)
    q[:, 0] *= 3.0  # beyond +-pi
    np.testing.assert_allclose(cont.inverse_dynamics(cont.nominal_params().to_vector(), q, qd, qdd),
                               lagrange_two_link(q, qd, qdd), atol=1e-10)


def test_regressor_cache(arm):
    q, qd, qdd = random_kinematics(arm, REGRESSOR_MIN_ROWS, seed=7)
    outside = arm.regressor(None, q, qd, qdd)
    assert outside.flags.writeable and arm.regressor(None, q, qd, qdd) is not outside
    with arm.caching():
        first = arm.regressor(None, q, qd, qdd)
        assert arm.regressor(None, q.copy(), qd, qdd) is first and not first.flags.writeable
        np.testing.assert_array_equal(first, outside)
    assert arm.regressor(None, q, qd, qdd) is not first


def test_base_parameters(arm, panda):
    # planar 2R with gravity: per link the first moments in the plane and I_yy about the joint,
    # with link 2's mass folded into link 1's (6), plus two viscous coefficients
    assert base_parameters(arm) == (8, 22)
    rank, n = base_parameters(panda)
    assert (rank, n) == (50, 77) and "50 base parameters" in panda.description  # 43 inertial + 7 viscous
    # the same rank from other random samples, by QR with column pivoting
    X = panda.regressor(None, *random_kinematics(panda, 500, seed=11)).reshape(-1, 77)
    norms = np.linalg.norm(X, axis=0)
    X = X[:, norms > 1e-8 * norms.max()]
    R = scipy.linalg.qr(X / np.linalg.norm(X, axis=0), mode="r", pivoting=True)[0]
    assert np.sum(np.abs(np.diag(R)) > 1e-8 * abs(R[0, 0])) == rank
    assert structural_rank(panda.regressor(None, *random_kinematics(panda, 500, seed=12))) == rank
    assert base_parameters(panda, samples=150, seed=5)[0] == rank


# ------------------------------------------------------------------ bad input


def one_line_error(call, *needles):
    with pytest.raises(ValueError) as info:
        call()
    message = str(info.value)
    assert "\n" not in message, message
    for needle in needles:
        assert needle in message, message
    return message


@pytest.mark.bad_input
def test_bad_files(tmp_path, capfd, tally):
    broken = tmp_path / "broken.urdf"
    broken.write_text('<robot name="x"><link name="a"/><joint name="j" type="revolute">')
    one_line_error(lambda: from_urdf(broken), "broken.urdf", "does not parse")
    no_limits = tmp_path / "no_limits.urdf"
    no_limits.write_text('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
                         '<parent link="a"/><child link="b"/></joint></robot>')
    one_line_error(lambda: from_urdf(no_limits), "no_limits.urdf", "does not specify limits")
    not_urdf = tmp_path / "not_urdf.urdf"
    not_urdf.write_text("<sdf/>")
    one_line_error(lambda: from_urdf(not_urdf), "not_urdf.urdf", "<sdf>")
    one_line_error(lambda: from_urdf(tmp_path / "missing.urdf"), "missing.urdf", "no such file")
    assert "Error" not in capfd.readouterr().err  # urdfdom's complaints are in the messages, not on stderr
    tally("bad_input", 4)


@pytest.mark.bad_input
def test_bad_joints(tmp_path, tally):
    one_line_error(lambda: from_urdf(two_link_urdf(), joints=("shoulder", "wrist", "hand")), "two_link.urdf", "wrist, hand",
                   "shoulder, elbow, finger")
    one_line_error(lambda: from_urdf(two_link_urdf(), joints=("elbow", "elbow")), "named twice", "elbow")
    one_line_error(lambda: from_urdf(PANDA, joints=("panda_joint8",)), "panda_joint8 is fixed")
    one_line_error(lambda: from_urdf(PANDA, joints=(*PANDA_ARM, "panda_finger_joint2")), "panda_finger_joint2 mimics")
    one_line_error(lambda: from_urdf(PANDA, joints=(*PANDA_ARM, "panda_finger_joint1")),
                   "panda_finger_joint1 drives the mimic joint(s) panda_finger_joint2")
    # a planar joint on the root: it can be locked, not made an axis
    text = two_link_urdf().read_text().replace("<robot name=\"two_link\">", '<robot name="two_link"><link name="world"/>'
                                               '<joint name="slide" type="planar"><parent link="world"/>'
                                               '<child link="base_link"/><axis xyz="0 0 1"/></joint>')
    path = tmp_path / "planar.urdf"
    path.write_text(text)
    one_line_error(lambda: from_urdf(path, joints=("slide", "shoulder")), "planar.urdf", "slide is planar, 3 DOF")
    locked = from_urdf(path, joints=("shoulder", "elbow"))
    assert urdf_robot(locked).locked == ("slide", "finger")
    q, qd, qdd = random_kinematics(locked, 20, seed=8)
    np.testing.assert_allclose(locked.inverse_dynamics(locked.nominal_params().to_vector(), q, qd, qdd),
                               lagrange_two_link(q, qd, qdd), atol=1e-10)
    one_line_error(lambda: from_urdf(two_link_urdf(), gravity=(0, 0)), "gravity")
    tally("bad_input", 7)


def test_gravity_override(arm):
    flipped = from_urdf(two_link_urdf(), joints=("shoulder", "elbow"), gravity=(0.0, 0.0, G))
    zero = np.zeros((1, 2))
    q = np.array([[0.3, -0.2]])
    p = arm.nominal_params().to_vector()
    np.testing.assert_allclose(flipped.inverse_dynamics(p, q, zero, zero), -arm.inverse_dynamics(p, q, zero, zero), rtol=1e-12)


# ------------------------------------------------------------------ the plant


def move_profiles():
    return [AxisProfile(0.3).dwell(0.3).move(-0.8, 1.5, 6.0, 60.0).dwell(0.3).move(0.5, 1.5, 6.0, 60.0).dwell(0.2),
            AxisProfile(-0.5).dwell(0.2).move(1.2, 2.0, 8.0, 80.0).dwell(0.4).move(-0.2, 2.0, 8.0, 80.0).dwell(0.3)]


def sampled(profiles, fs, advance=0.0):
    t = np.arange(int(max(p.end_time for p in profiles) * fs) + 1) / fs
    return [np.column_stack([p.evaluate(t + advance / fs)[i] for p in profiles]) for i in range(3)]


def test_plant_tracks_a_perfect_feedforward(arm):
    fs = 1000.0
    ref = sampled(move_profiles(), fs)[0]
    ff = arm.inverse_dynamics(arm.nominal_params().to_vector(), *sampled(move_profiles(), fs, advance=arm.advance))
    plant = URDFPlant(arm, fs=fs)
    tracked = plant.run(ref, ff)
    feedback_only = plant.run(ref)
    true = np.column_stack([tracked.extra["load_shoulder"], tracked.extra["load_elbow"]])
    assert tracked.meta["system"] == "two_link" and tracked.axes == ("shoulder", "elbow")
    np.testing.assert_array_equal(tracked.ff, ff)
    assert np.abs(ref - true).max() < 1e-6  # rad; 2.2e-7 measured (2.3e-2 under feedback alone)
    assert np.abs(feedback_only.error).max() > 5e-3  # the same reference under feedback alone
    np.testing.assert_allclose(tracked.u, ff, atol=2e-3)  # the feedback has almost nothing to do


def _loop_reaction(ref: np.ndarray, gains: FeedbackGains, fs: float) -> np.ndarray:
    """What the PD outputs when the encoders read ``ref`` exactly, written out from the controller's
    definition (module docstring of ``urdf_plant``), not by the plant's kernel: -kd times the
    derivative of the measurement (zero for a loop that differentiates the error, which is zero)."""
    ts, out = 1.0 / fs, np.zeros_like(ref)
    if gains.derivative == "error":
        return out
    kd = np.asarray(gains.kd)
    held = np.vstack([ref[:1], ref[:1], ref])  # the pre-roll holds the first sample
    if gains.derivative == "measurement_fir2":
        return -kd * (held[2:] - held[:-2]) / (2 * ts)
    alpha = np.exp(-2 * np.pi * np.asarray(gains.f_lp) / fs)
    d = np.zeros(ref.shape[1])
    for k in range(ref.shape[0]):
        d = alpha * d + (1 - alpha) * (held[k + 2] - held[k + 1]) / ts
        out[k] = -kd * d
    return out


@pytest.mark.parametrize("derivative", ["error", "measurement", "measurement_fir2"])
def test_a_loop_that_reacts_to_the_motion_tracks_with_its_reference_term(arm, derivative):
    """``reference_feedback`` is the loop's output on the reference itself (against the controller's
    formula); the rigid model's feedforward plus ``loop_feedforward`` tracks exactly on every loop,
    while on a loop that differentiates the measurement the force alone leaves the error kd qd / kp;
    the bench's input residual u - f - C r of the exact run is zero."""
    from lcgym.methods.loop import loop_feedforward
    from lcgym.systems.urdf_bench import URDFBench

    fs = 1000.0
    ref = sampled(move_profiles(), fs)[0]
    force = arm.inverse_dynamics(arm.nominal_params().to_vector(), *sampled(move_profiles(), fs, advance=arm.advance))
    gains = dataclasses.replace(tuned_gains(arm, fs=fs), derivative=derivative)
    plant = URDFPlant(arm, gains=gains, fs=fs)
    np.testing.assert_allclose(plant.reference_feedback(ref), _loop_reaction(ref, gains, fs), rtol=1e-9, atol=1e-9)
    tracked = plant.run(ref, force + loop_feedforward(plant, ref))
    true = np.column_stack([tracked.extra["load_shoulder"], tracked.extra["load_elbow"]])
    assert np.abs(ref - true).max() < 1e-6  # rad
    force_alone = plant.run(ref, force)
    assert (np.abs(force_alone.error).max() > 1e-3) == (derivative != "error")
    commanded = force + loop_feedforward(plant, ref) + plant.reference_feedback(ref)
    np.testing.assert_allclose(tracked.u - commanded, 0.0, atol=2e-3)  # N m: the residual u - f - C r
    bench = URDFBench.__new__(URDFBench)
    bench.system, bench.plant, bench.axes = arm, plant, arm.axis_names
    residual = bench.tables([tracked], [force + loop_feedforward(plant, ref)])[1]
    assert residual["RMS"].max() < 2e-3 and residual["signal"].eq("input_residual").all()
    assert bench.signals[1].label == ("input residual u - f" if derivative == "error" else "input residual u - f - C r")


def test_unforced_arm_conserves_energy(arm):
    robot = urdf_robot(arm)
    data = robot.model.createData()

    def energy(q, qd):
        cfg, v = robot.configuration(q), robot.tangent(qd)
        return np.array([pin.computeKineticEnergy(robot.model, data, c, w) + pin.computePotentialEnergy(robot.model, data, c)
                         for c, w in zip(cfg, v, strict=True)])

    drift = []
    for substeps in (1, 2):
        q, qd = URDFPlant(arm, substeps=substeps).free_response([0.3, -0.4], [0.0, 0.0], np.zeros((1000, 2)))
        assert np.abs(qd).max() > 5.0  # a real swing (rad/s)
        e = energy(q, qd)
        drift.append(np.abs(e - e[0]).max())
    assert drift[1] < 1e-9  # J, against a 21 J exchange between potential and kinetic energy
    assert 10 < drift[0] / drift[1] < 25  # fourth order: 16 for half the step


def test_hidden_coulomb_friction_adds_its_level(arm):
    fs, Fc = 1000.0, 3.0
    profiles = [AxisProfile(0.0).dwell(0.5).move(0.0, 1.0, 1.0, 10.0),
                AxisProfile(-1.0).dwell(0.5).move(1.0, 0.8, 4.0, 40.0).dwell(0.2)]
    kin = sampled(profiles, fs)
    ff = arm.inverse_dynamics(arm.nominal_params().to_vector(), *sampled(profiles, fs, advance=arm.advance))
    friction = fx.CoulombFriction("elbow", Fc=Fc, eps=0.01)
    gains = tuned_gains(arm, integral_time=0.05)
    rigid = URDFPlant(arm, gains=gains).run(kin[0], ff)
    rough = URDFPlant(arm, effects=[friction], gains=gains).run(kin[0], ff)
    assert rough.meta["effects"] == ["coulomb_friction@elbow"]
    cruise = np.abs(kin[1][:, 1] - 0.8) < 1e-9  # the elbow at its top speed
    assert cruise.sum() > 1000
    du = rough.u[cruise, 1] - rigid.u[cruise, 1]
    assert abs(np.median(du) - Fc) < 0.02 * Fc
    # the shoulder stands still and carries no friction
    assert abs(np.median(rough.u[cruise, 0] - rigid.u[cruise, 0])) < 0.02 * Fc


def test_tabulated_force_follows_its_curve(arm):
    """A linear table over velocity is a viscous friction (exactly, inside its grid)."""
    u = np.tile([0.0, 2.0], (300, 1))
    table = fx.TabulatedForce("elbow", "velocity", -20.0, 20.0, (-30.0, 30.0))
    a = URDFPlant(arm, effects=[table], substeps=2).free_response([0.2, 0.1], [0.0, 0.0], u)
    b = URDFPlant(arm, effects=[fx.ViscousFriction("elbow", d=1.5)], substeps=2).free_response([0.2, 0.1], [0.0, 0.0], u)
    np.testing.assert_allclose(a[0], b[0], atol=1e-12)


def test_true_parameters_differ_from_the_urdf(arm):
    """A plant on a rigid body other than the URDF's: the nominal vector reproduces the URDF, its
    viscous entries act as viscous friction, a heavier forearm sags further under feedback."""
    p = arm.nominal_params().to_vector()
    u = np.tile([1.0, 0.5], (300, 1))
    start = ([0.2, 0.1], [0.0, 0.0])
    np.testing.assert_allclose(URDFPlant(arm, parameters=p).free_response(*start, u)[0],  # the same to round-off
                               URDFPlant(arm).free_response(*start, u)[0], rtol=0, atol=1e-12)
    damped = p.copy()
    damped[20:] = (0.8, 0.3)
    visc = [fx.ViscousFriction("shoulder", d=0.8), fx.ViscousFriction("elbow", d=0.3)]
    np.testing.assert_allclose(URDFPlant(arm, parameters=damped).free_response(*start, u)[0],
                               URDFPlant(arm, effects=visc).free_response(*start, u)[0], atol=1e-13)
    heavy = p.copy()
    heavy[10:14] *= 1.5  # forearm mass and first moments
    hold = np.zeros((500, 2))
    sag = [np.abs(URDFPlant(arm, parameters=x).run(hold).error[-1]) for x in (p, heavy)]
    assert np.all(sag[1] > 1.2 * sag[0])


def test_noise_quantization_and_saturation(arm):
    fs = 1000.0
    ref = sampled(move_profiles(), fs)[0]
    plant = URDFPlant(arm, encoder_resolution=1e-4, noise_rms=2e-5, u_max=(40.0, 7.0), seed=3)
    tr = plant.run(ref)
    again = URDFPlant(arm, encoder_resolution=1e-4, noise_rms=2e-5, u_max=(40.0, 7.0), seed=3).run(ref)
    np.testing.assert_array_equal(tr.pos, again.pos)  # seeded
    assert np.abs(tr.u[:, 1]).max() == pytest.approx(7.0)  # the elbow saturates
    true = np.column_stack([tr.extra["load_shoulder"], tr.extra["load_elbow"]])
    residual = tr.pos - np.round(true / 1e-4) * 1e-4
    assert 1.5e-5 < residual.std() < 2.5e-5


@pytest.mark.fault
def test_divergence_is_reported(arm, tally):
    ref = np.zeros((2000, 2))
    ff = np.zeros((2000, 2))
    ff[500:, 1] = 2000.0  # N m on the elbow: far beyond what the feedback can hold
    with pytest.raises(SimulationDiverged, match=r"two_link: reference-0: the simulation diverged at t = 0\.\d+ s.*elbow"):
        URDFPlant(arm).run(ref, ff)
    # far beyond the sampled loop's limit
    unstable = FeedbackGains(kp=(6e5, 6e5), kd=(0.0, 0.0), ki=(0.0, 0.0), filtered="derivative")
    assert not loop_stable(unstable, inertia_range(urdf_robot(arm))[1], 1000.0).any()
    assert loop_stable(tuned_gains(arm), inertia_range(urdf_robot(arm))[1], 1000.0).all()
    with pytest.raises(SimulationDiverged, match="diverged"):
        URDFPlant(arm, gains=unstable, preroll=0.0).run(np.full((3000, 2), 0.1))
    tally("fault", 2)


def _carriage(tmp_path, mass: float):
    path = tmp_path / f"carriage_{mass:g}.urdf"
    path.write_text(f"""<robot name="carriage"><link name="base"/>
      <link name="slide"><inertial><mass value="{mass}"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
      </inertial></link>
      <joint name="x" type="prismatic"><parent link="base"/><child link="slide"/><axis xyz="1 0 0"/>
      <limit lower="0" upper="0.3" effort="100" velocity="0.5"/></joint></robot>""")
    return from_urdf(path, joints=("x",))


def test_rotor_inertia_is_added_mass_on_a_prismatic_axis(tmp_path):
    """J on a slide is J more kg of slide (M + J) qdd = u, and the URDF's own model stays as it was."""
    u = np.column_stack([20.0 * np.sin(np.arange(2000) / 150.0)])
    light = _carriage(tmp_path, 20.0)
    rotor = URDFPlant(light, effects=[fx.RotorInertia("x", J=5.0)], substeps=2)
    heavy = URDFPlant(_carriage(tmp_path, 25.0), substeps=2)
    a, b = rotor.free_response([0.1], [0.0], u), heavy.free_response([0.1], [0.0], u)
    assert np.abs(a[0] - a[0][0]).max() > 0.05  # it moves (m)
    np.testing.assert_allclose(a[0], b[0], atol=1e-12)
    np.testing.assert_allclose(a[1], b[1], atol=1e-11)
    assert urdf_robot(light).model.armature[0] == 0.0  # the system's model is untouched


def test_asymmetric_friction_and_offset_in_the_plant(arm, tmp_path):
    """Equal levels and no viscous asymmetry are the Coulomb friction; an offset is a constant
    table; on a slide pushed forward, the forward level acts and the backward one does not."""
    u = np.tile([0.0, 3.0], (400, 1))
    run = lambda *e: URDFPlant(arm, effects=list(e), substeps=4).free_response([0.2, 0.1], [0.0, 0.0], u)  # noqa: E731
    same = run(fx.AsymmetricFriction("elbow", Fc_pos=1.0, Fc_neg=1.0, eps=0.05))
    np.testing.assert_allclose(same[0], run(fx.CoulombFriction("elbow", Fc=1.0, eps=0.05))[0], atol=1e-12)
    constant = fx.TabulatedForce("elbow", "position", -10.0, 10.0, (-0.7, -0.7))
    np.testing.assert_allclose(run(fx.Offset("elbow", c=-0.7))[0], run(constant)[0], atol=1e-12)
    slide, push = _carriage(tmp_path, 20.0), np.full((500, 1), 30.0)  # N: a = 1.5 m/s^2 without friction
    travel = {}
    for label, levels in (("free", (0.0, 0.0)), ("forward", (10.0, 0.0)), ("backward", (0.0, 10.0))):
        effects = [fx.AsymmetricFriction("x", Fc_pos=levels[0], Fc_neg=levels[1], eps=1e-3)] if any(levels) else []
        q = URDFPlant(slide, effects=effects, substeps=8).free_response([0.0], [0.0], push)[0][:, 0]
        travel[label] = q[-1] - q[0]
    assert travel["free"] == pytest.approx(0.5 * 1.5 * 0.5**2, rel=0.01)  # x = a t^2 / 2 over 0.5 s
    assert travel["forward"] == pytest.approx(0.5 * 1.0 * 0.5**2, rel=0.01)  # (30 - 10) N / 20 kg
    assert travel["backward"] == pytest.approx(travel["free"], rel=1e-3)


@pytest.mark.bad_input
def test_plant_refuses_what_it_cannot_simulate(arm, tally):
    for effect, why in ((fx.Stiction("elbow"), "internal state"), (fx.CableInertia("elbow", dJ=0.1), "needs qdd"),
                        (fx.DrivetrainFlexibility("shoulder"), "adds states")):
        with pytest.raises(ValueError, match=why):
            URDFPlant(arm, effects=[effect])
    with pytest.raises(ValueError, match="no axis 'wrist'"):
        URDFPlant(arm, effects=[fx.CoulombFriction("wrist", Fc=1.0)])
    with pytest.raises(ValueError, match="too stiff"):
        URDFPlant(arm, effects=[fx.CoulombFriction("elbow", Fc=50.0, eps=1e-5)])
    with pytest.raises(ValueError, match=r"shape \(T >= 2, 2\)"):
        URDFPlant(arm).run(np.zeros((100, 3)))
    with pytest.raises(ValueError, match="rotor inertia must be >= 0"):
        URDFPlant(arm, effects=[fx.RotorInertia("elbow", J=-0.1)])
    tally("bad_input", 7)


def test_random_references_stay_within_the_limits(arm, panda):
    for system in (arm, panda):
        robot = urdf_robot(system)
        refs = random_references(system, n=2, duration=5.0, seed=1)
        assert len(refs) == 2 and refs[0].axes == system.axis_names
        for r in refs:
            assert r.positions.shape[1] == system.n_axes and r.n_samples > 5000
            assert np.all(r.positions >= robot.lower) and np.all(r.positions <= robot.upper)
            assert np.all(np.abs(r.velocities) <= 0.5 * robot.velocity + 1e-9)
        np.testing.assert_array_equal(random_references(system, n=1, duration=5.0, seed=1)[0].positions, refs[0].positions)
    tr = URDFPlant(panda).run(random_references(panda, duration=3.0, seed=2)[0])
    assert URDFPlant(str(two_link_urdf()), joints=("elbow", "shoulder")).system.axis_names == ("elbow", "shoulder")
    assert tr.meta["reference"] == "panda-2-0" and np.abs(tr.error).max() < math.radians(5)
