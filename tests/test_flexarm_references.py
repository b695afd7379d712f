"""FlexArm references: TCP lines along X with the tool down, only joints 2, 3, 5 moving."""

from __future__ import annotations

import numpy as np
import pytest

from lcgym.systems.flexarm import dynamics as arm
from lcgym.systems.flexarm.references import LENGTHS, TCP_HEIGHT, arm_reference_set

DH = arm.DH().table()


@pytest.fixture(scope="module")
def train():
    return arm_reference_set("train", seed=0, n_references=3)


def test_tcp_moves_on_a_straight_line_along_x_with_the_tool_down(train):
    for ref in train:
        q = ref.positions
        tcp, z6 = [], []
        for k in range(0, ref.n_samples, 50):
            Rw, pw = arm.forward_kinematics(DH, q[k])
            tcp.append(pw[5])
            z6.append(Rw[5][:, 2])
        tcp, z6 = np.array(tcp), np.array(z6)
        np.testing.assert_allclose(tcp[:, 1:], np.column_stack([np.zeros(len(tcp)), np.full(len(tcp), TCP_HEIGHT)]), atol=1e-9)
        np.testing.assert_allclose(z6, np.tile([0.0, 0.0, -1.0], (len(z6), 1)), atol=1e-9)
        length = np.ptp(tcp[:, 0])
        assert LENGTHS[0] - 1e-6 <= length <= LENGTHS[1] + 1e-6
        assert np.all(q[:, [0, 3, 5]] == 0.0)  # joints 1, 4, 6 stay put
        assert np.all(np.ptp(q[:, [1, 2, 4]], axis=0) > 0.05)  # joints 2, 3, 5 move


def test_joint_kinematics_are_smooth_and_the_sets_are_seeded(train):
    ref = train[0]
    assert ref.fs == 1000.0 and ref.axes == arm.AXES
    dq = np.diff(ref.positions, axis=0) * ref.fs
    np.testing.assert_allclose(ref.velocities[1:-1], 0.5 * (dq[1:] + dq[:-1]), atol=1e-9)
    assert np.abs(ref.accelerations).max() < 50.0  # rad/s^2: jerk-limited Cartesian setpoints
    again = arm_reference_set("train", seed=0, n_references=1)[0]
    np.testing.assert_array_equal(again.positions, ref.positions)
    other = arm_reference_set("validation", seed=0, n_references=1)[0]
    assert other.n_samples != ref.n_samples or not np.array_equal(other.positions, ref.positions)
