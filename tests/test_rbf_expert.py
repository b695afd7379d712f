"""Paper 002's NN predictor (lcgym/methods/rbf_expert): motion influence, preprocessing, expert logic,
the predictor on a known error, and the ``rbf-expert`` method on both systems."""

import math

import numpy as np
import pytest
from scipy import ndimage

from lcgym.methods.rbf_expert.expert import fill_short_gaps, keep_long_runs, network_types
from lcgym.methods.rbf_expert.influence import PAPER_PHI, influence_matrix, motion_influence, task_influence
from lcgym.methods.rbf_expert.predictor import RBFExpertConfig, RBFExpertPredictor
from lcgym.methods.rbf_expert.preprocess import Preprocessor, arctan_ratio
from lcgym.references import AxisProfile, sample
from lcgym.systems.flexarm import FLEXARM
from lcgym.systems.flexarm import dynamics as arm
from lcgym.systems.flexarm.dynamics import joint_axes
from lcgym.systems.flexarm.references import MOVING, arm_reference_set


def test_table1_rules_give_eq25_among_the_moving_joints():
    """The FlexArm's TCP lines: joints 2, 3, 5 parallel, 2 and 3 turning opposite ways, 2 and 5 the
    same: the same entries as eq. (25) of the paper's robot."""
    phi = task_influence(arm_reference_set("train", 0, 2), FLEXARM.joint_axes())
    m = list(MOVING)
    np.testing.assert_array_equal(phi[np.ix_(m, m)], PAPER_PHI[np.ix_(m, m)])
    np.testing.assert_array_equal(np.diag(phi), 1.0)
    assert phi[0, 1] == 0 and phi[1, 0] == 0  # joint 1 vertical, joint 2 horizontal: perpendicular


def test_parallel_joints_that_move_independently_do_not_influence_each_other():
    """Beyond Table 1: the two-link arm's shoulder and elbow are parallel, but its random moves turn
    them independently: Phi = I; joints turning in proportion keep the paper's entry."""
    from lcgym import systems
    from lcgym.methods.rbf_expert.influence import rotation_directions

    machine = systems.resolve("two_link")
    refs = machine.bench().references("train", 0, 2, 20.0)
    np.testing.assert_array_equal(task_influence(refs, machine.system.joint_axes()), np.eye(2))
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal(1000), rng.standard_normal(1000)
    np.testing.assert_array_equal(rotation_directions([np.column_stack([a, b])]), [[1, 0], [0, 1]])
    np.testing.assert_array_equal(rotation_directions([np.column_stack([a, -2 * a + 0.1 * b])]), [[1, -1], [-1, 1]])


def test_table1_rules_on_hand_made_axes():
    axes = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0]], dtype=float)
    same = np.ones((3, 3))
    np.testing.assert_array_equal(influence_matrix(axes, same), [[1, -1, 0], [-1, 1, 0], [0, 0, 1]])
    opposite = np.array([[1, -1, 1], [-1, 1, 1], [1, 1, 1]], dtype=float)
    np.testing.assert_array_equal(influence_matrix(axes, opposite), [[1, 1, 0], [1, 1, 0], [0, 0, 1]])
    z = joint_axes(arm.HOME)
    np.testing.assert_allclose(np.linalg.norm(z, axis=1), 1.0)
    np.testing.assert_allclose(z[0], [0, 0, 1])


def test_motion_influence_is_linear_in_the_references():
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.standard_normal((5, 6)) for _ in range(3))
    Q, Qd, Qdd = motion_influence(PAPER_PHI, q, qd, qdd)
    np.testing.assert_allclose(Q[:, 1], q[:, 1] - q[:, 2] + q[:, 4])
    np.testing.assert_allclose(Qdd, qdd @ PAPER_PHI.T)


def test_preprocessing_section_3_2():
    t = np.linspace(0, 2 * math.pi, 2001)
    Q, Qd, Qdd = np.sin(t) * 3, np.cos(t) * 3, -np.sin(t) * 3
    Qd[:100] = Qdd[:100] = 0.0  # a rest: not viable
    e = 0.2 * np.cos(t)
    pre = Preprocessor().fit(Q, Qd, Qdd, e)
    v = pre.transform(Q, Qd, Qdd)
    assert pre.beta0_ == pytest.approx(0.2) and pre.scale_ == pytest.approx([3, 3, 3], rel=1e-5)
    assert not v["viable"][:100].any() and v["viable"][100:].all()
    assert np.all(np.abs(v["v33"][v["viable"]]) <= 1)
    np.testing.assert_allclose(arctan_ratio(np.array([1.0, 0.0, -1.0]), np.array([1.0, -2.0, 1.0])), [0.5, -1.0, -0.5])
    # eq. (29): within each v33 level the largest |v22| of the training data is 1
    level = pre._level(v["v33"])
    for lv in np.unique(level[v["viable"]]):
        sel = v["viable"] & (level == lv)
        assert np.max(np.abs(v["v22"][sel])) == pytest.approx(1.0)
    fast = pre.transform(2 * Q, 2 * Qd, 2 * Qdd)  # twice the training speed: outside the unit range
    assert np.nanmax(np.abs(fast["v22"])) == pytest.approx(2.0)


def test_morphology_equals_scipy_dilate_and_erode():
    rng = np.random.default_rng(0)
    for _ in range(100):
        m = rng.random(120) < rng.uniform(0.2, 0.9)
        for n in (1, 2, 3, 7):
            np.testing.assert_array_equal(keep_long_runs(m, n), ndimage.binary_opening(m, np.ones(n)))
            padded = ndimage.binary_closing(np.pad(m, n), np.ones(n), border_value=0)[n:-n]
            np.testing.assert_array_equal(fill_short_gaps(m, n), padded)


def test_expert_logic_follows_table3_on_a_move_and_back():
    """Out (+ velocity) and back (- velocity), each accelerating then decelerating, with a long
    cruise: networks 1, 2 on the way out, 4, 3 back, none while cruising or at rest."""
    ref = sample("move", [AxisProfile(0.0).dwell(0.3).move(1.0, 0.5, 2.0, 20.0).dwell(0.3).move(0.0, 0.5, 2.0, 20.0)],
                 1000.0)
    qd, qdd = ref.velocities[:, 0], ref.accelerations[:, 0]
    pre = Preprocessor().fit(ref.positions[:, 0], qd, qdd, np.ones(qd.size))
    v = pre.transform(ref.positions[:, 0], qd, qdd)
    types = network_types(v["v22"], v["v33"], v["viable"], ref.fs)
    assert set(np.unique(types)) == {0, 1, 2, 3, 4}
    growing = (np.abs(qdd) > 0.2) & (np.sign(qdd) == np.sign(qd))
    falling = (np.abs(qdd) > 0.2) & (np.sign(qdd) == -np.sign(qd))
    assert np.all(types[growing & (qd > 0)] == 1) and np.all(types[falling & (qd > 0)] == 2)
    assert np.all(types[falling & (qd < 0)] == 3) and np.all(types[growing & (qd < 0)] == 4)
    cruise = (np.abs(qd) > 0.49) & (np.abs(qdd) < 1e-9)
    assert cruise.sum() > 1000 and np.mean(types[cruise] == 0) > 0.9  # velocity constant for long: no network
    assert np.all(types[~v["viable"]] == 0)


def test_predictor_learns_an_error_that_is_a_function_of_the_reference():
    """A made-up error e = f(velocity, acceleration) of 2-axis references: predicted on new
    references where one of Table 3's networks is active (not at long constant velocity: the paper
    predicts zero there), and zero where the reference rests."""
    from lcgym.systems.ix.references import reference_set

    train, new = reference_set("train", 0, 6, 20.0, 1000.0), reference_set("validation", 0, 1, 20.0, 1000.0)

    def error(r):
        return np.tanh(3 * r.velocities) * 0.5 + 0.05 * r.accelerations

    paper = RBFExpertConfig(lowpass_hz=50.0, cruise_and_rest=False)
    pred = RBFExpertPredictor(np.eye(2), (0, 1), paper).fit(train, [error(r) for r in train])
    r = new[0]
    e, e_hat = error(r), pred.predict(r)
    for a in range(2):
        active = pred.inputs(r, a)[1] > 0
        rel = np.sqrt(np.mean((e - e_hat)[active, a] ** 2) / np.mean(e[active, a] ** 2))
        assert active.mean() > 0.1 and rel < 0.15, (a, rel)
    still = np.all(np.abs(r.velocities) < 1e-9, axis=1) & np.all(np.abs(r.accelerations) < 1e-9, axis=1)
    assert np.abs(pred.predict(r, filtered=False)[still]).max() == 0.0
    assert all(0 <= s < 0.2 for s in pred.outside_share_.values())


def test_the_cruise_and_rest_experts_predict_where_table_3_does_not():
    """Beyond the paper: a made-up tracking error that lasts at constant velocity (a friction) and
    at rest (a spring over the position, the direction of the last move) is predicted there too, on
    references it was not learned on; Table 3's four experts predict zero there."""
    from lcgym.methods.rbf_expert.expert import CRUISE, REST
    from lcgym.physics.kinematics import relay
    from lcgym.systems.ix.references import reference_set

    train, new = reference_set("train", 0, 6, 20.0, 1000.0), reference_set("validation", 0, 1, 20.0, 1000.0)

    def error(r):  # a friction and a spring: at rest, over the position and the last move's direction
        return np.tanh(3 * r.velocities) * 0.5 + 0.05 * r.accelerations + 0.2 * r.positions + 0.05 * relay(r.velocities)

    config = RBFExpertConfig(lowpass_hz=50.0)
    assert config.cruise_and_rest  # the rbf-expert method's default
    pred = RBFExpertPredictor(np.eye(2), (0, 1), config).fit(train, [error(r) for r in train])
    paper = RBFExpertPredictor(np.eye(2), (0, 1), RBFExpertConfig(lowpass_hz=50.0, cruise_and_rest=False))
    paper.fit(train, [error(r) for r in train])
    r = new[0]
    e, e_hat, e_paper = error(r), pred.predict(r, filtered=False), paper.predict(r, filtered=False)
    for a in range(2):
        types = pred.inputs(r, a)[1]
        for t in (CRUISE, REST):
            sel = types == t
            rel = np.sqrt(np.mean((e - e_hat)[sel, a] ** 2) / np.mean(e[sel, a] ** 2))
            # at rest the six training references rest at a few dozen places: the new one's are between them
            assert sel.mean() > 0.1 and rel < (0.35 if t == CRUISE else 0.6), (a, t, rel)
            assert np.abs(e_paper[sel, a]).max() == 0.0  # the paper's experts: nothing there
    assert pred.types == (1, 2, 3, 4, CRUISE, REST) and paper.types == (1, 2, 3, 4)


@pytest.mark.bad_input
def test_bad_configuration_is_refused():
    with pytest.raises(ValueError, match="dims"):
        RBFExpertConfig(dims=4)
    with pytest.raises(ValueError, match="method"):
        RBFExpertConfig(method="adam")
    with pytest.raises(RuntimeError, match="fit"):
        RBFExpertPredictor(np.eye(2), (0, 1)).predict(reference_set_one())


def reference_set_one():
    from lcgym.systems.ix.references import reference_set

    return reference_set("validation", 0, 1, 5.0, 1000.0)[0]


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def test_rbf_expert_method_on_the_ix_predicts_its_training_error_away():
    """On the IX, trained on three references with the physical model's feedforward, then used on one
    of them (inside the training data): the predicted correction lowers the tracking error."""
    from lcgym.methods.physical import PhysicalFeedforward
    from lcgym.methods.rbf_expert.method import RBFExpertFeedforward
    from lcgym.systems.ix.plant import IXPlant
    from lcgym.systems.ix.references import reference_set

    plant = IXPlant()
    refs = reference_set("train", 0, 3, 15.0, plant.fs)
    trials = plant.run(refs)
    method = RBFExpertFeedforward(system="ix").fit(trials)
    method.safeguard = False  # the prediction alone; the safeguard below
    method.learn(plant, refs[0])
    assert method.cost_.plant_trials == 3 and set(method.predictor_.joints) == {0, 1}
    physical = PhysicalFeedforward(system="ix").fit(trials)
    before = plant.run([refs[1]], [physical.feedforward(refs[1])])[0].error
    after = plant.run([refs[1]], [method.feedforward(refs[1])])[0].error
    assert method.reference_offset(refs[1]) is None
    for a in range(2):
        assert _rms(after[:, a]) < 0.9 * _rms(before[:, a]), (a, _rms(after[:, a]), _rms(before[:, a]))
    # the safeguard (on the tracking error): inside its training data the correction helps on both
    # axes; 3 training runs, then the base and the corrected feedforward on each
    guarded = RBFExpertFeedforward(system="ix").fit(trials).learn(plant, refs[0])
    assert guarded.kept_.all() and guarded.cost_.plant_trials == 3 + 2 * 3 and guarded.note_ == ""
    np.testing.assert_array_equal(guarded.feedforward(refs[1]), method.feedforward(refs[1]))


def test_rbf_expert_method_on_the_arm_lowers_the_model_following_error():
    """On the FlexArm (eq. 17 from Basic: paper 002's protocol, ``paper002-nnp``), trained on two
    lines, used on one of them: the joints' model-following error (true load acceleration) falls in
    the moving periods."""
    from lcgym.methods.rbf_expert.method import PaperNNP
    from lcgym.systems.flexarm.nominal import BasicFeedforward
    from lcgym.systems.flexarm.plant import FlexArmPlant

    plant = FlexArmPlant()
    refs = arm_reference_set("train", 0, 2)
    method = PaperNNP(system="flexarm").fit([plant.run(r) for r in refs]).learn(plant, refs[0])
    assert method.predictor_.joints == MOVING and method.cost_.plant_trials == 2  # no safeguard runs
    r = refs[0]
    basic = BasicFeedforward().compute(r.positions, r.fs)
    np.testing.assert_allclose(method.reference_offset(r), basic["reference_offset"])
    moving = np.any(np.abs(r.velocities) > 1e-6, axis=1)
    e = {}
    for label, update in (("basic", None), ("nnp", method.feedforward(r) - basic["tau_ff"])):
        tr = BasicFeedforward().run(plant, r, update)
        e[label] = np.column_stack([tr.extra[f"e_pl_true_{a}"] for a in tr.axes])[moving][:, list(MOVING)]
    assert _rms(e["nnp"]) < 0.8 * _rms(e["basic"]), (_rms(e["nnp"]), _rms(e["basic"]))
    assert set(method.outside_[r.name]) == set(MOVING)
