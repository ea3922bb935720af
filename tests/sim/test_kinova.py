"""The generated Kinova Gen3 arm in real PyBullet: kinematics against the DH table, limits, IK, grasping."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator

import numpy as np
import pytest
from numpy.testing import assert_allclose

pytest.importorskip("pybullet")

import pybullet as p
import pybullet_data
from scipy.spatial.transform import Rotation

from taskcond.sim.description import GripperSpec
from taskcond.sim.kinova import (
    GEN3_GRIPPER,
    GEN3_HOME,
    GEN3_JOINTS,
    GEN3_LINK_MASSES,
    GEN3_LINK_NAMES,
    KinovaArm,
    forward_kinematics,
    gen3_urdf,
    gen3_urdf_path,
)

pytestmark = pytest.mark.sim

DOWN = p.getQuaternionFromEuler([math.pi, 0.0, 0.0])
"""Tool z pointing straight down, fingers closing along world y."""


@pytest.fixture
def client() -> Iterator[int]:
    cid = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=cid)
    p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
    yield cid
    p.disconnect(cid)


def random_configurations(count: int, seed: int) -> np.ndarray:
    """Joint positions (count, 7) spread over the whole range, continuous joints over ±π."""
    rng = np.random.default_rng(seed)
    lower = np.array([-math.pi if s.lower is None else s.lower for s in GEN3_JOINTS])
    upper = np.array([math.pi if s.upper is None else s.upper for s in GEN3_JOINTS])
    return rng.uniform(lower, upper, size=(count, 7))


def test_dh_table_matches_kinova_published_home_height() -> None:
    """All joints at zero: the arm stands straight up; Kinova's frames put the tool frame at
    0.2848 + 0.4208 + 0.3143 + 0.1674 = 1.1873 m, offset 0.0246 m sideways by the elbow offsets."""
    pose = forward_kinematics(np.zeros(7))
    assert_allclose(pose[:3, 3], [0.0, -0.0246, 1.1873], atol=1e-9)
    assert_allclose(pose[:3, :3], np.eye(3), atol=1e-12)


def test_urdf_is_generated_into_the_asset_dir_whatever_the_working_directory(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("TASKCOND_ASSET_DIR", str(tmp_path / "cache" / "urdf"))
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    path = gen3_urdf_path()
    assert path.is_absolute() and path.parent == (tmp_path / "cache" / "urdf").resolve()
    assert path.read_text(encoding="utf-8") == gen3_urdf()
    assert gen3_urdf_path() == path
    root = ET.fromstring(gen3_urdf())
    assert not root.findall(".//mesh"), "primitives only"
    masses = {
        link.get("name"): float(link.find("inertial/mass").get("value")) for link in root.findall("link")
    }
    assert [masses[name] for name in GEN3_LINK_NAMES] == list(GEN3_LINK_MASSES)
    for link in root.findall("link"):
        inertia = link.find("inertial/inertia")
        tensor = np.array(
            [[float(inertia.get(f"i{a}{b}") or inertia.get(f"i{b}{a}")) for b in "xyz"] for a in "xyz"]
        )
        eigenvalues = np.linalg.eigvalsh(tensor)
        assert eigenvalues.min() > 0, link.get("name")
        assert eigenvalues.max() <= eigenvalues.sum() - eigenvalues.max() + 1e-12, "triangle inequality"


def test_pybullet_tcp_matches_dh_forward_kinematics(client: int) -> None:
    base_position = (0.3, -0.2, 0.1)
    base_orientation = p.getQuaternionFromEuler([0.0, 0.0, 0.7])
    arm = KinovaArm(client, base_position, base_orientation)
    base = np.eye(4)
    base[:3, :3] = Rotation.from_quat(base_orientation).as_matrix()
    base[:3, 3] = base_position
    for q in random_configurations(12, seed=7):
        for index, value in zip(arm.arm_joints, q, strict=True):
            p.resetJointState(arm.body_id, index, value, physicsClientId=client)
        expected = base @ forward_kinematics(q, GEN3_GRIPPER.tcp_offset)
        position, orientation = arm.ee_pose()
        assert_allclose(position, expected[:3, 3], atol=1e-3)
        angle = (Rotation.from_quat(orientation).inv() * Rotation.from_matrix(expected[:3, :3])).magnitude()
        assert angle < 1e-3
        tool = p.getLinkState(
            arm.body_id, arm.tool_link, computeForwardKinematics=True, physicsClientId=client
        )
        assert_allclose(tool[4], (base @ forward_kinematics(q))[:3, 3], atol=1e-3)


def test_joint_limits_equal_the_published_ones(client: int) -> None:
    arm = KinovaArm(client)
    for index, spec in zip(arm.arm_joints, GEN3_JOINTS, strict=True):
        info = p.getJointInfo(arm.body_id, index, physicsClientId=client)
        assert info[1].decode() == spec.name
        assert info[2] == p.JOINT_REVOLUTE
        assert (info[10], info[11]) == (pytest.approx(spec.effort), pytest.approx(spec.velocity))
        if spec.lower is None:
            assert info[8] > info[9], "continuous: PyBullet reports lower > upper"
        else:
            assert (info[8], info[9]) == (pytest.approx(spec.lower), pytest.approx(spec.upper))
    assert [(s.lower, s.upper) for s in GEN3_JOINTS if s.lower is not None] == [
        (-2.41, 2.41),
        (-2.66, 2.66),
        (-2.23, 2.23),
    ]
    assert arm.within_limits(GEN3_HOME)
    assert not arm.within_limits([0.0, 2.5, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert arm.within_limits([10.0, 0.0, -10.0, 0.0, 10.0, 0.0, -10.0])
    with pytest.raises(ValueError, match="outside the Kinova Gen3 joint limits"):
        arm.set_joint_targets([0.0, 0.0, 0.0, 2.7, 0.0, 0.0, 0.0])


@pytest.mark.parametrize(
    "target",
    [
        (0.4, 0.2, 0.3),
        (0.5, -0.2, 0.2),
        (0.3, 0.0, 0.5),
        (0.6, 0.1, 0.15),
        (0.45, 0.0, 0.05),
        (-0.3, 0.3, 0.3),
    ],
)
def test_ik_reaches_targets_within_2_mm(client: int, target: tuple[float, float, float]) -> None:
    arm = KinovaArm(client, base_position=(0.0, 0.0, 0.0))
    result = arm.solve_ik(target, DOWN)
    assert result.success, result
    assert result.position_error < 1e-3
    assert arm.move_joints(result.q)
    position, orientation = arm.ee_pose()
    assert np.linalg.norm(position - np.array(target)) < 2e-3
    assert (Rotation.from_quat(orientation).inv() * Rotation.from_quat(DOWN)).magnitude() < 1e-2


def test_out_of_reach_pose_is_a_clear_error(client: int) -> None:
    arm = KinovaArm(client)
    with pytest.raises(ValueError, match=r"^target .* beyond its reach of 1\.\d{3} m$"):
        arm.solve_ik((1.5, 0.0, 0.3), DOWN)
    with pytest.raises(ValueError, match=r"beyond its reach"):
        arm.move_to((0.0, 0.0, 2.0))
    assert not arm.reachable((1.5, 0.0, 0.3), DOWN)
    assert arm.reachable((0.5, 0.0, 0.3), DOWN)
    joints_before = arm.joint_positions()
    assert not arm.reachable((0.95, 0.0, 0.29), DOWN)  # within the sphere, but not pointing down
    assert_allclose(arm.joint_positions(), joints_before, atol=1e-12)


def test_gripper_closes_symmetrically_and_lifts_a_box_by_friction(client: int) -> None:
    p.loadURDF("plane.urdf", physicsClientId=client)
    arm = KinovaArm(client)
    assert arm.gripper_spec() == GripperSpec(arm.body_id, arm.finger_links, arm.ee_link)
    half = 0.02
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[half] * 3, physicsClientId=client)
    box = p.createMultiBody(0.1, shape, basePosition=[0.45, 0.0, half], physicsClientId=client)
    p.changeDynamics(box, -1, lateralFriction=1.0, physicsClientId=client)

    arm.move_to((0.45, 0.0, 0.15), DOWN)
    assert arm.gripper_opening() == pytest.approx(GEN3_GRIPPER.max_opening, abs=1e-3)
    arm.move_to((0.45, 0.0, half + 0.005), DOWN)
    arm.close_gripper()
    arm.step(240)
    left, right = (s[0] for s in p.getJointStates(arm.body_id, arm.finger_joints, physicsClientId=client))
    assert left == pytest.approx(right, abs=1e-3)
    assert arm.gripper_opening() == pytest.approx(2 * half, abs=2e-3)

    arm.move_to((0.45, 0.0, 0.30), DOWN)
    arm.step(120)
    box_position = np.array(p.getBasePositionAndOrientation(box, physicsClientId=client)[0])
    assert box_position[2] > 0.25
    assert np.linalg.norm(box_position - arm.ee_pose()[0]) < 0.01
    for finger in arm.finger_links:
        assert p.getContactPoints(arm.body_id, box, finger, -1, physicsClientId=client)
    assert p.getNumConstraints(physicsClientId=client) == 1, "only the finger gear; nothing glues the box"
