"""The URDF plant's compiled rigid body (``systems/rigid_body.py``) against pinocchio, an independent
implementation of the same equation by another algorithm (the articulated-body algorithm against
ours, Newton-Euler and composite rigid bodies): forward dynamics with armature and gravity torques
on the shipped machines, the 7-joint Panda, and a chain of every joint kind with tilted axes,
offset frames and full inertia tensors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from lcgym import systems
from lcgym.systems import rigid_body
from lcgym.systems.urdf import from_urdf, urdf_robot

PANDA = Path(__file__).parent / "data" / "panda" / "panda.urdf"

EVERY_KIND = """<?xml version="1.0"?>
<robot name="every_kind">
  <link name="base"/>
  <link name="carriage"><inertial><origin xyz="0.05 -0.02 0.1"/><mass value="4.0"/>
    <inertia ixx="0.05" ixy="0.004" ixz="-0.002" iyy="0.06" iyz="0.003" izz="0.04"/></inertial></link>
  <link name="turret"><inertial><origin xyz="0.01 0.03 0.2" rpy="0.1 0.2 0.3"/><mass value="2.5"/>
    <inertia ixx="0.03" ixy="0.001" ixz="0.002" iyy="0.02" iyz="-0.001" izz="0.025"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0.3 0.0 0.02"/><mass value="1.2"/>
    <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.04" iyz="0" izz="0.041"/></inertial></link>
  <link name="wrist"><inertial><origin xyz="0.0 0.04 0.0"/><mass value="0.4"/>
    <inertia ixx="0.001" ixy="0.0001" ixz="0" iyy="0.0012" iyz="0" izz="0.0009"/></inertial></link>
  <joint name="rail" type="prismatic"><parent link="base"/><child link="carriage"/>
    <origin xyz="0.1 0.2 0.3" rpy="0.0 0.3 0.0"/><axis xyz="1 0 0"/>
    <limit lower="-0.5" upper="0.5" effort="200" velocity="0.5"/></joint>
  <joint name="spin" type="continuous"><parent link="carriage"/><child link="turret"/>
    <origin xyz="0 0 0.15" rpy="0.2 0 0.1"/><axis xyz="0.3 0.5 0.8"/>
    <limit effort="50" velocity="2"/></joint>
  <joint name="lift" type="revolute"><parent link="turret"/><child link="arm"/>
    <origin xyz="0.02 0 0.3" rpy="0 0 0.4"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="40" velocity="2"/></joint>
  <joint name="slide" type="prismatic"><parent link="arm"/><child link="wrist"/>
    <origin xyz="0.5 0 0" rpy="0.3 -0.2 0.1"/><axis xyz="0.6 0 0.8"/>
    <limit lower="-0.1" upper="0.1" effort="50" velocity="0.2"/></joint>
</robot>
"""


def machines(tmp_path):
    path = tmp_path / "every_kind.urdf"
    path.write_text(EVERY_KIND)
    return {"two_link": systems.get("two_link"), "emps_sim": systems.get("emps_sim"), "cobot6": systems.get("cobot6"),
            "panda": from_urdf(PANDA, joints=[f"panda_joint{i}" for i in range(1, 8)]), "every_kind": from_urdf(path)}


def pinocchio_configuration(model, q):
    """Pinocchio's configuration of joint angles and positions q (joint order): cos and sin for an
    unbounded joint."""
    out = np.zeros(model.nq)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nq == 2:
            out[joint.idx_q], out[joint.idx_q + 1] = np.cos(q[j - 1]), np.sin(q[j - 1])
        else:
            out[joint.idx_q] = q[j - 1]
    return out


def test_every_kind_of_joint_is_read():
    model = pin.buildModelFromXML(EVERY_KIND)
    kinds, axes = zip(*(rigid_body._joint_kind(model, i) for i in range(1, model.njoints)), strict=True)
    assert kinds == (rigid_body.PRISMATIC, rigid_body.REVOLUTE, rigid_body.REVOLUTE, rigid_body.PRISMATIC)
    np.testing.assert_allclose(axes[1], np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8]))
    np.testing.assert_allclose(axes[3], [0.6, 0.0, 0.8])


@pytest.mark.parametrize("name", ["two_link", "emps_sim", "cobot6", "panda", "every_kind"])
def test_forward_dynamics_and_gravity_equal_pinocchio(name, tmp_path):
    model = urdf_robot(machines(tmp_path)[name]).model.copy()
    rng = np.random.default_rng(0)
    model.armature = rng.uniform(0.0, 0.05, model.nv)  # rotor inertias: on M's diagonal
    data = model.createData()
    body = rigid_body.RigidBody.from_model(model)
    work = rigid_body.scratch(body.n)
    for _ in range(50):
        q, qd, tau = rng.uniform(-1.5, 1.5, body.n), rng.uniform(-3, 3, body.n), rng.uniform(-20, 20, body.n)
        config = pinocchio_configuration(model, q)
        qdd, g = np.zeros(body.n), np.zeros(body.n)
        rigid_body.accelerations(q, qd, tau, *body.packed(), *work, qdd)
        rigid_body.gravity_torque(q, *body.packed(), *work, g)
        expected = pin.aba(model, data, config, qd, tau)
        np.testing.assert_allclose(qdd, expected, rtol=1e-10, atol=1e-10 * (1 + np.abs(expected).max()))
        expected = pin.computeGeneralizedGravity(model, data, config)
        np.testing.assert_allclose(g, expected, rtol=1e-10, atol=1e-10 * (1 + np.abs(expected).max()))


def test_a_joint_it_cannot_integrate_is_refused():
    model = pin.Model()
    model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    with pytest.raises(ValueError, match="1-DOF joints"):
        rigid_body.RigidBody.from_model(model)
