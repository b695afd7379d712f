"""Third-order setpoints and reference sets (lcgym/references.py, lcgym/systems/ix/references.py).

The jerk-limited move is checked from outside: evaluated on a fine time grid it must end at the
target at rest, respect |v| <= vmax, |a| <= amax, |jerk| <= jmax (jerk by finite differences of
the evaluated acceleration), reach the limits on long moves, and be continuous in position,
velocity and acceleration across phase boundaries. Reference sets must be seeded, disjoint
between set names and seeds, and inside the IX range and setpoint limits.
"""

import math

import numpy as np
import pytest

from lcgym.references import AxisProfile, third_order_phases
from lcgym.systems.ix.references import AXES, DEG, IX_LIMITS, reference_set

REL = 1e-9  # limit tolerance for exactly evaluated quantities


def _random_cases(n: int, seed: int):
    """(start, distance, v, a, j): distances log-uniform 1e-7..10 rad with random sign; limits
    spread so that all regimes (v reached or not, a reached or not) occur."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        d = 10 ** rng.uniform(-7, 1) * rng.choice([-1.0, 1.0])
        v = 10 ** rng.uniform(-1.5, 0.5)
        a = 10 ** rng.uniform(-1, 1)
        j = 10 ** rng.uniform(-0.5, 2.5)
        out.append((rng.uniform(-1, 1), d, v, a, j))
    return out


CASES = _random_cases(300, seed=11)


def _integrate(durations, jerks, x0=0.0):
    """Exact (x, v, a) at each phase boundary, starting at rest at x0."""
    x, v, a = x0, 0.0, 0.0
    states = [(x, v, a)]
    for dur, jk in zip(durations, jerks, strict=True):
        x, v, a = (
            x + v * dur + a * dur**2 / 2 + jk * dur**3 / 6,
            v + a * dur + jk * dur**2 / 2,
            a + jk * dur,
        )
        states.append((x, v, a))
    return np.array(states)


def _fine(profile: AxisProfile, n: int = 4001, t_end: float | None = None):
    t_end = profile.end_time if t_end is None else t_end
    t = np.linspace(0.0, t_end, n)
    return (t, *profile.evaluate(t))


def _regime(d, v, a, j):
    """Which limits the move reaches: (v_reached, a_reached), computed independently."""
    d = abs(d)
    if a * a / j <= v:  # a reachable before v: reach distance v (v/a + a/j)
        v_reached = d >= v * (v / a + a / j)
        a_reached = v_reached or d >= 2 * a**3 / j**2
    else:  # v reached with triangular acceleration, peak sqrt(v j) < a
        v_reached = d >= 2 * v * math.sqrt(v / j)
        a_reached = False
    return v_reached, a_reached


# ---------------------------------------------------------------------------------------------
# third_order_phases
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", range(0, len(CASES), 3))
def test_phases_end_at_target_at_rest(case):
    _, d, v, a, j = CASES[case]
    durations, jerks = third_order_phases(d, v, a, j)
    assert len(durations) == len(jerks) == 7
    # >= 0 up to round-off (see test_phase_durations_never_negative for exact zero)
    assert all(dur >= -1e-12 * sum(durations) for dur in durations)
    s = math.copysign(1.0, d)
    assert jerks == pytest.approx([s * j, 0, -s * j, 0, -s * j, 0, s * j])
    st = _integrate(durations, jerks)
    assert st[-1, 0] == pytest.approx(d, rel=1e-10, abs=1e-15)
    assert abs(st[-1, 1]) <= 1e-10 * v
    assert abs(st[-1, 2]) <= 1e-10 * a
    # v and a peak at phase boundaries (a is piecewise linear; v is extremal where a = 0)
    assert np.max(np.abs(st[:, 1])) <= v * (1 + REL)
    assert np.max(np.abs(st[:, 2])) <= a * (1 + REL)
    # the move never turns back: velocity has the sign of d throughout
    assert np.all(s * st[:, 1] >= -1e-12 * v)


def test_phases_zero_distance():
    assert third_order_phases(0.0, 1.0, 1.0, 1.0) == ([], [])
    p = AxisProfile(0.3).move(0.3, 1.0, 1.0, 1.0)
    assert p.end_time == 0.0
    x, vel, acc = p.evaluate(np.array([0.0, 1.0]))
    assert np.all(x == 0.3) and np.all(vel == 0) and np.all(acc == 0)


def test_phase_durations_never_negative():
    durations, _ = third_order_phases(10.0, 0.5, 100.0, 1.0)  # a^2/j > v: triangular acceleration
    assert min(durations) >= 0.0


def test_phases_long_move_duration_and_shape():
    """A long move reaching both limits: T = d/v + v/a + a/j, jerk phases a/j, plateau v/a - a/j."""
    d, v, a, j = 2.0, 0.3, 0.6, 4.0  # a^2/j = 0.09 < v
    durations, _ = third_order_phases(d, v, a, j)
    assert sum(durations) == pytest.approx(d / v + v / a + a / j, rel=1e-12)
    assert durations[0] == pytest.approx(a / j, rel=1e-12)
    assert durations[1] == pytest.approx(v / a - a / j, rel=1e-12)
    assert durations[3] == pytest.approx(d / v - (v / a + a / j), rel=1e-12)
    assert durations == pytest.approx(list(reversed(durations)), rel=1e-12)  # symmetric


@pytest.mark.parametrize(
    ("d", "v", "a", "j", "v_reached", "a_reached"),
    [
        (1e-6, 15 * DEG, 30 * DEG, 200 * DEG, False, False),  # tiny
        (-3e-4, 15 * DEG, 30 * DEG, 200 * DEG, False, False),  # tiny, negative
        (0.02, 15 * DEG, 30 * DEG, 200 * DEG, False, False),  # just short of reaching a (0.0235 rad)
        (0.05, 15 * DEG, 30 * DEG, 200 * DEG, False, True),  # a reached, v not
        (-0.05, 15 * DEG, 30 * DEG, 200 * DEG, False, True),
        (1.0, 15 * DEG, 30 * DEG, 200 * DEG, True, True),  # both
        (-1.5, 20 * DEG, 40 * DEG, 300 * DEG, True, True),
        (0.5, 0.1, 2.0, 1.0, True, False),  # a unreachable: a^2/j > v
        (0.05, 0.1, 2.0, 1.0, False, False),  # v reached from 0.0632 rad on
    ],
)
def test_regimes(d, v, a, j, v_reached, a_reached):
    assert _regime(d, v, a, j) == (v_reached, a_reached)  # the cases are what they claim
    durations, _ = third_order_phases(d, v, a, j)
    assert (durations[3] > 0) == v_reached  # constant-velocity phase only when v is reached
    assert (durations[1] > 0) == (a_reached and a * a / j < v)
    p = AxisProfile(0.0).move(d, v, a, j)
    t, x, vel, acc = _fine(p, n=20001)
    assert x[-1] == d
    peak_v, peak_a = np.max(np.abs(vel)), np.max(np.abs(acc))
    if v_reached:
        assert peak_v == pytest.approx(v, rel=REL)
    else:
        assert peak_v < v * (1 - 1e-6)
    if a_reached:
        assert peak_a == pytest.approx(a, rel=REL)
    else:
        assert peak_a < a * (1 - 1e-6)


@pytest.mark.parametrize(("v", "a", "j"), [(15 * DEG, 30 * DEG, 200 * DEG), (0.4, 1.0, 2.0), (0.1, 2.0, 1.0)])
def test_limits_hold_across_regime_boundaries(v, a, j):
    """Distances just below, at and just above the distance where a (2 a^3 / j^2) or v becomes
    reachable: limits hold, and the peaks grow continuously and monotonically with the distance."""
    d_a = 2 * a**3 / j**2
    d_v = v * (v / a + a / j) if a * a / j <= v else 2 * v * math.sqrt(v / j)
    factors = np.concatenate([1 + np.linspace(-0.03, 0.03, 61), [1 - 1e-9, 1 + 1e-9]])
    for d_edge in (d_a, d_v):
        ds = np.sort(d_edge * factors)
        peaks = []
        for d in ds:
            durations, jerks = third_order_phases(d, v, a, j)
            st = _integrate(durations, jerks)
            assert st[-1, 0] == pytest.approx(d, rel=1e-10)
            peaks.append((np.max(np.abs(st[:, 1])), np.max(np.abs(st[:, 2]))))
        peaks = np.array(peaks)
        assert np.all(peaks[:, 0] <= v * (1 + REL)) and np.all(peaks[:, 1] <= a * (1 + REL))
        assert np.all(np.diff(peaks, axis=0) >= -1e-12)  # longer moves never have lower peaks
        assert np.max(np.abs(np.diff(peaks[:, 0]))) <= 0.02 * v  # no jump in peak velocity
        assert np.max(np.abs(np.diff(peaks[:, 1]))) <= 0.02 * a  # nor in peak acceleration


# ---------------------------------------------------------------------------------------------
# AxisProfile.move evaluated on a fine grid
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", range(len(CASES)))
def test_move_respects_limits_and_ends_at_target(case):
    x0, d, v, a, j = CASES[case]
    target = x0 + d
    p = AxisProfile(x0).move(target, v, a, j)
    assert p.x == target
    t, x, vel, acc = _fine(p)
    # end exactly at the target, at rest; just before the end, continuously so
    xe, ve, ae = p.evaluate(np.array([p.end_time, p.end_time + 1.0]))
    assert np.all(xe == target) and np.all(ve == 0.0) and np.all(ae == 0.0)
    delta = 1e-9 * p.end_time
    xb, vb, ab = p.evaluate(np.array([p.end_time - delta]))
    assert abs(xb[0] - target) <= v * delta + 1e-10 * abs(d) + 1e-15
    assert abs(vb[0]) <= a * delta + 1e-10 * v
    assert abs(ab[0]) <= j * delta * 1.01 + 1e-10 * a
    # limits
    assert np.max(np.abs(vel)) <= v * (1 + REL)
    assert np.max(np.abs(acc)) <= a * (1 + REL)
    jerk = np.diff(acc) / np.diff(t)
    assert np.max(np.abs(jerk)) <= j * 1.02
    # x, v, a consistent with each other: trapezoid rule on the fine grid, whose error is at most
    # h^3 j / 12 for x (v'' = jerk) and h^2 j / 2 for v (a has kinks where the jerk switches)
    h = t[1] - t[0]
    roundoff = 1e-14 * (abs(x0) + abs(d))
    np.testing.assert_allclose(np.diff(x), h * (vel[1:] + vel[:-1]) / 2, rtol=0, atol=h**3 * j / 12 * 1.01 + roundoff)
    np.testing.assert_allclose(np.diff(vel), h * (acc[1:] + acc[:-1]) / 2, rtol=0, atol=h**2 * j / 2 * 1.01 + 1e-14 * v)
    # monotone between start and target: no overshoot
    assert np.all((x - x0) * math.copysign(1, d) >= -roundoff)
    assert np.all((target - x) * math.copysign(1, d) >= -roundoff)
    # limits reached exactly on long moves
    v_reached, a_reached = _regime(d, v, a, j)
    if v_reached:
        assert np.max(np.abs(vel)) == pytest.approx(v, rel=REL)
    if a_reached and a * a / j < v:
        assert np.max(np.abs(acc)) == pytest.approx(a, rel=REL)


def test_random_cases_cover_all_regimes():
    regimes = {_regime(d, v, a, j) for _, d, v, a, j in CASES}
    assert regimes == {(False, False), (False, True), (True, True), (True, False)}
    assert any(d < 0 for _, d, *_ in CASES) and any(abs(d) < 1e-5 for _, d, *_ in CASES)


def test_peak_jerk_reached():
    v, a, j = 15 * DEG, 30 * DEG, 200 * DEG
    p = AxisProfile(0.0).move(1.0, v, a, j)
    t, _, _, acc = _fine(p, n=40001)
    jerk = np.diff(acc) / np.diff(t)
    assert np.max(jerk) == pytest.approx(j, rel=1e-3)
    assert np.min(jerk) == pytest.approx(-j, rel=1e-3)


def test_continuity_across_phase_boundaries():
    v, a, j = 20 * DEG, 40 * DEG, 300 * DEG
    p = AxisProfile(-0.5).move(1.2, v, a, j).dwell(0.4).move(1.19, v, a, j).move(-1.0, 0.5 * v, a, 0.7 * j)
    p.dwell(0.3).move(0.2, v, 0.5 * a, j)
    boundaries = np.array(p.t0[1:] + [p.end_time])
    assert len(boundaries) > 20
    delta = 1e-9
    xl, vl, al = p.evaluate(boundaries - delta)
    xr, vr, ar = p.evaluate(boundaries + delta)
    x0, v0, a0 = p.evaluate(boundaries)
    for left, mid, right, bound in ((xl, x0, xr, v), (vl, v0, vr, a), (al, a0, ar, j)):
        assert np.max(np.abs(right - left)) <= 2 * delta * bound * 1.01 + 1e-12
        assert np.max(np.abs(mid - left)) <= delta * bound * 1.01 + 1e-12


def test_profile_evaluate_before_any_move_and_after_end():
    p = AxisProfile(0.7)
    x, vel, acc = p.evaluate(np.linspace(0, 3, 7))
    assert np.all(x == 0.7) and not vel.any() and not acc.any()
    p.dwell(1.0).move(-0.2, 1.0, 2.0, 10.0)
    x, vel, acc = p.evaluate(np.array([0.0, 0.5, 1.0, p.end_time + 5.0]))
    assert x[:3] == pytest.approx([0.7, 0.7, 0.7], abs=1e-15)
    assert x[3] == -0.2 and vel[3] == 0 and acc[3] == 0


# ---------------------------------------------------------------------------------------------
# Reference sets
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def sets():
    return {name: reference_set(name, seed=0) for name in ("train", "validation", "test", "calibration")}


def _refs_equal(r1, r2) -> bool:
    return r1.positions.shape == r2.positions.shape and np.array_equal(r1.positions, r2.positions)


def test_set_sizes(sets):
    assert [len(sets[n]) for n in ("train", "validation", "test")] == [8, 4, 4]
    assert len(reference_set("train", seed=5, n_references=2, duration=5.0)) == 2
    for r in sets["train"]:
        assert r.fs == 500.0
        assert r.n_samples / r.fs >= 40.0
        assert r.axes == AXES
        assert r.positions.shape == r.velocities.shape == r.accelerations.shape == (r.n_samples, 2)
        np.testing.assert_allclose(r.t[1] - r.t[0], 1 / 500.0)


def test_set_reproducible(sets):
    again = reference_set("train", seed=0)
    assert all(_refs_equal(a, b) for a, b in zip(sets["train"], again, strict=True))
    for a, b in zip(sets["train"], again, strict=True):
        assert np.array_equal(a.velocities, b.velocities) and np.array_equal(a.accelerations, b.accelerations)
    cal = reference_set("calibration", seed=0)
    assert all(_refs_equal(a, b) for a, b in zip(sets["calibration"], cal, strict=True))


def test_set_differs_between_seeds(sets):
    other = reference_set("train", seed=1)
    assert not any(_refs_equal(a, b) for a in sets["train"] for b in other)
    cal = reference_set("calibration", seed=1)
    assert not all(_refs_equal(a, b) for a, b in zip(sets["calibration"], cal, strict=True))


def test_set_differs_between_names(sets):
    names = ("train", "validation", "test")
    for i, n1 in enumerate(names):
        for n2 in names[i + 1:]:
            assert not any(_refs_equal(a, b) for a in sets[n1] for b in sets[n2]), (n1, n2)
            # not merely distinct arrays: the very first start positions differ
            assert sets[n1][0].positions[0, 0] != sets[n2][0].positions[0, 0]
    # the references within a set differ from each other too
    tr = sets["train"]
    assert not any(_refs_equal(tr[i], tr[k]) for i in range(len(tr)) for k in range(i + 1, len(tr)))


@pytest.mark.parametrize("name", ["train", "validation", "test", "calibration"])
def test_set_within_range_and_limits(sets, name):
    for r in sets[name]:
        for k, lim in enumerate(IX_LIMITS):
            pos, vel, acc = r.positions[:, k], r.velocities[:, k], r.accelerations[:, k]
            assert np.all(np.isfinite(pos))
            assert pos.min() >= lim.low and pos.max() <= lim.high, (r.name, AXES[k])
            assert np.max(np.abs(vel)) <= lim.v * (1 + REL), (r.name, AXES[k])
            assert np.max(np.abs(acc)) <= lim.a * (1 + REL), (r.name, AXES[k])
            assert np.max(np.abs(np.diff(acc))) * r.fs <= lim.j * 1.02, (r.name, AXES[k])
            # velocity and acceleration belong to the positions (trapezoid rule at fs)
            np.testing.assert_allclose(np.diff(pos), (vel[1:] + vel[:-1]) / (2 * r.fs), atol=1e-6)
            np.testing.assert_allclose(np.diff(vel), (acc[1:] + acc[:-1]) / (2 * r.fs), atol=1e-5)
            # starts and ends at rest
            assert vel[0] == 0 and acc[0] == 0 and vel[-1] == 0 and acc[-1] == 0


def test_random_sets_move_both_axes(sets):
    for r in sets["train"] + sets["test"]:
        for k, lim in enumerate(IX_LIMITS):
            assert np.ptp(r.positions[:, k]) > 0.2 * (lim.high - lim.low), (r.name, AXES[k])
            assert np.max(np.abs(r.velocities[:, k])) > 0.3 * lim.v


def test_calibration_set(sets):
    cal = sets["calibration"]
    assert len(cal) == 14
    total = sum(r.n_samples for r in cal)
    assert 0.9e6 <= total <= 1.2e6
    swept_axes = []
    for r in cal:
        constant = [k for k in range(2) if np.ptp(r.positions[:, k]) == 0.0]
        assert len(constant) == 1, r.name
        parked = constant[0]
        assert not r.velocities[:, parked].any() and not r.accelerations[:, parked].any()
        swept = 1 - parked
        swept_axes.append(swept)
        lim = IX_LIMITS[swept]
        # swept over (nearly) the whole range, at full speed at least once
        assert np.ptp(r.positions[:, swept]) >= 0.9 * (lim.high - lim.low), r.name
        assert np.max(np.abs(r.velocities[:, swept])) == pytest.approx(lim.v, rel=REL)
        # and back: it returns to where it started
        assert r.positions[-1, swept] == pytest.approx(r.positions[0, swept], abs=1e-12)
    assert sorted(swept_axes) == [0] * 7 + [1] * 7
    # the parked positions spread across the parked axis' range
    for axis in range(2):
        parks = sorted(r.positions[0, 1 - axis] for r, s in zip(cal, swept_axes, strict=True) if s == axis)
        lim = IX_LIMITS[1 - axis]
        assert parks[-1] - parks[0] > 0.7 * (lim.high - lim.low)


# ---------------------------------------------------------------------------------------------
# Bad input
# ---------------------------------------------------------------------------------------------


@pytest.mark.bad_input
@pytest.mark.parametrize("name", ["train", "calibration"])
def test_negative_seed(name):
    with pytest.raises(ValueError, match="seed"):
        reference_set(name, seed=-1)


@pytest.mark.bad_input
@pytest.mark.parametrize("name", ["training", "Test", "", "val"])
def test_unknown_set_name(name):
    with pytest.raises(ValueError, match="reference set"):
        reference_set(name)


@pytest.mark.bad_input
def test_non_positive_reference_count():
    with pytest.raises(ValueError):
        reference_set("train", n_references=0)


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("v", "a", "j"),
    [(0.0, 1.0, 1.0), (1.0, 0.0, 1.0), (1.0, 1.0, 0.0), (-1.0, 1.0, 1.0), (1.0, -2.0, 1.0), (1.0, 1.0, -5.0)],
)
def test_non_positive_limits(v, a, j):
    with pytest.raises(ValueError, match="positive"):
        third_order_phases(0.5, v, a, j)
    with pytest.raises(ValueError, match="positive"):
        AxisProfile(0.0).move(0.5, v, a, j)
    with pytest.raises(ValueError, match="positive"):
        third_order_phases(0.0, v, a, j)  # even for a zero move
