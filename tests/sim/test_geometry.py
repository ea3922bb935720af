"""Geometry from one place: the specs' accessors (hinges, handles, drawer links, wall radius) are where the
URDF they build puts things, and the oracles follow a changed spec."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("pybullet")

import pybullet as p

from taskcond.sim.assets import BoxSpec, MicrowaveSpec
from taskcond.sim.scene import KitchenScene, SceneConfig
from taskcond.tasks.motions import drawer_handle, grasp_of
from taskcond.tasks.oracle import run_episode
from taskcond.tasks.registry import make

pytestmark = pytest.mark.sim

MARGIN = 1.5e-3
"""PyBullet grows a link's AABB by its 1 mm collision margin."""


@pytest.fixture(scope="module")
def scene():
    s = KitchenScene()
    yield s
    s.close()


def link_frame(scene: KitchenScene, body: str, link: int) -> np.ndarray:
    state = p.getLinkState(
        scene.bodies[body], link, computeForwardKinematics=True, physicsClientId=scene.client
    )
    return np.array(state[4])


def test_hinges_are_where_the_urdf_puts_the_lid_and_the_door(scene: KitchenScene) -> None:
    for name in ("box", "microwave"):
        spec = scene.specs[name]
        assert isinstance(spec, BoxSpec | MicrowaveSpec)
        for fraction in (0.0, 0.7):
            scene.set_joint(name, fraction)
            point, axis = spec.hinge.axis_in_world(scene.pose(name))
            np.testing.assert_allclose(link_frame(scene, name, 0), point, atol=1e-6)  # float32
            info = p.getJointInfo(scene.bodies[name], 0, physicsClientId=scene.client)
            np.testing.assert_allclose(info[13], axis, atol=1e-6)
        scene.set_joint(name, 0.0)


def test_lip_fin_and_handles_are_on_the_loaded_links(scene: KitchenScene) -> None:
    box = scene.specs["box"]
    assert isinstance(box, BoxSpec)
    lid_lo, _ = p.getAABB(scene.bodies["box"], 0, physicsClientId=scene.client)
    lip = box.hinge.to_world(scene.pose("box"), 0.0, box.lip_center)
    assert lip[0] - box.lip[0] / 2 == pytest.approx(lid_lo[0], abs=MARGIN)  # the lip is the lid's front end
    microwave = scene.specs["microwave"]
    assert isinstance(microwave, MicrowaveSpec)
    _, door_hi = p.getAABB(scene.bodies["microwave"], 0, physicsClientId=scene.client)
    fin = microwave.hinge.to_world(scene.pose("microwave"), 0.0, microwave.fin_center)
    assert fin[2] + microwave.fin[2] / 2 == pytest.approx(door_hi[2], abs=MARGIN)  # the fin tops the door
    cabinet = scene.config.cabinet
    for index, (name, link) in enumerate(cabinet.drawer_links):
        assert scene.links[name] == index
        assert p.getJointInfo(scene.bodies[name], index, physicsClientId=scene.client)[12].decode() == link
        lo, hi = scene.aabb(name)
        handle = drawer_handle(scene, name)
        assert lo[0] == pytest.approx(handle[0] - 0.01, abs=MARGIN)  # the bar (2 cm thick) is the front end
        assert lo[2] < handle[2] < hi[2]


def test_a_vessel_grasp_closes_on_the_wall(scene: KitchenScene) -> None:
    for name in ("bowl", "mug"):
        spec = scene.config.free_objects[name][0]
        grasp = grasp_of(scene, name)
        assert -grasp.along == pytest.approx(spec.wall_radius, abs=1e-6)
        assert grasp.width == spec.wall


@pytest.mark.parametrize(
    ("task", "change"),
    [
        ("open-box", lambda c: replace(c, box=replace(c.box, size=(0.18, 0.22, 0.13), open_angle=1.75))),
        ("open-microwave", lambda c: replace(c, microwave=replace(c.microwave, width=0.27, height=0.22))),
        ("open-top_drawer", lambda c: replace(c, cabinet=replace(c.cabinet, handle_standoff=0.04))),
    ],
)
def test_the_oracle_follows_a_changed_spec(task, change) -> None:
    env = make(task, config=change(SceneConfig()))
    try:
        ok, reason, _, _ = run_episode(env, seed=2)
        assert ok, reason
    finally:
        env.close()


def test_a_lid_or_a_door_pushed_past_its_stop_comes_back_to_it() -> None:
    """PyBullet's limit constraint stops a joint at its limit but leaves one pushed past it there (a hand
    shoved the box's lid 0.3 rad past its stop in LHT1 from a random start); the scene drives it back."""
    env = make("close-box", seed=0)
    env.reset()
    scene = env.scene
    past = {"box": 1.98, "microwave": -0.2}
    for name, q in past.items():
        joint = scene.joints[name]
        p.resetJointState(joint.body_id, joint.joint_index, q, physicsClientId=scene.client)
    ee = scene.robot.ee_pose()
    for _ in range(60):  # 2 s at 30 Hz
        env.step(np.concatenate([ee.position, ee.orientation, [0.0]]))
    for name, stop in {"box": scene.joints["box"].open_position, "microwave": 0.0}.items():
        assert scene.joint_position(name) == pytest.approx(stop, abs=0.01), name
    env.close()
