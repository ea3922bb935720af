"""robosuite (real MuJoCo) as a second world: each supported task's scripted oracle judged by robosuite's
own ``_check_success``, the environment information, a condition-guided episode from a skill learned from
one demonstration, and the command line's ``--world``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from taskcond.application.condition_sources import make_source
from taskcond.application.robosuite import run_episode
from taskcond.cli import app
from taskcond.conditions import ContainerState, GripperState, Relation, SpatialRelation
from taskcond.execution.skills import SkillLibrary, learn_skill
from taskcond.reproduce import build_cells, robosuite_table
from taskcond.worlds.robosuite.demos import record_demonstrations
from taskcond.worlds.robosuite.scene import CLOSING, make_env, reset
from taskcond.worlds.robosuite.tasks import TASKS, across, closing_axis, down, oracle
from taskcond.worlds.robosuite.world import HAND_POINTS, RobosuiteWorld

pytestmark = pytest.mark.sim

ORACLE_SEEDS = {"PickPlace": 0}
"""Seed of each oracle episode (default 0)."""


@pytest.mark.parametrize("task_id", list(TASKS))
def test_oracle_succeeds_by_robosuites_check(task_id: str) -> None:
    env = make_env(task_id)
    try:
        scene = reset(env, ORACLE_SEEDS.get(task_id, 0))
        world = RobosuiteWorld(scene)
        assert not scene.success()
        quat = down(scene)
        for step in TASKS[task_id].steps:
            for position, orientation, gripper in oracle(scene, step, quat):
                assert world.step(position, orientation, gripper) is None
        assert scene.success()
    finally:
        env.close()


def test_environment_information_in_the_vocabulary() -> None:
    env = make_env("PickPlaceCan")
    try:
        world = RobosuiteWorld(reset(env, 3), noise_sigma=0.005, seed=3)
        obs = world.observe()
        assert obs.grasped() is None
        assert SpatialRelation("can", Relation.INSIDE, "start bin") in obs.predicates
        assert SpatialRelation("can", Relation.INSIDE, "can bin") not in obs.predicates
        assert obs.round == frozenset({"can"})
        assert obs.yaws == {}  # a round object has no heading to turn a grasp by
        assert world.observe() is obs  # the same noise draw until the next step
        assert world.affords("move_into", ("can", "milk")) is not None  # not a container
        assert world.affords("grasp", ("can bin",)) is not None  # a bin cannot be picked up
        assert world.affords("move_into", ("can", "can bin")) is None
        quat = down(world.scene)
        with pytest.raises(ValueError, match="no robosuite oracle for 'open can'"):
            oracle(world.scene, "open can", quat)  # chosen by what a primitive achieves: no state here
        for position, orientation, gripper in oracle(world.scene, "grasp can", quat):
            world.step(position, orientation, gripper)
        assert GripperState("can", "gripper") in world.observe().predicates
    finally:
        env.close()


def test_door_opened_by_its_oracle_then_by_the_skill_learned_from_it() -> None:
    """The door closed, then open, in the vocabulary (its hinge angle); the oracle's demonstration teaches
    ``open door``, which opens another draw of the door with conditions from that demonstration."""
    env = make_env("Door")
    try:
        world = RobosuiteWorld(reset(env, 1))
        obs = world.observe()
        assert np.allclose(obs.centers["door"], world.scene.pose("door")[0])  # the panel's, not its box's
        assert obs.yaws["door"] == pytest.approx(world.scene.yaw("door"))  # an open is turned by its change
        assert world.affords("open", ("door",)) is None
        assert world.affords("open", ("door frame",)) is not None  # only the door opens
        assert world.affords("grasp", ("door",)) is not None  # nor is it picked up
    finally:
        env.close()
    demos, ok = record_demonstrations("Door", seed=1)
    assert ok and len(demos) == 1 and demos[0].target_yaw is not None
    evidence = demos[0].evidence
    assert evidence is not None
    assert ContainerState("door", False) in evidence.start and ContainerState("door", True) in evidence.end
    assert GripperState(None, "gripper") in evidence.end  # the hand let go of the lever
    library = SkillLibrary()
    library.add(learn_skill(demos[0]))
    result = run_episode(TASKS["Door"], "env", 1000, library, make_source("env", library), noise=0.005)
    assert result.success, result.reason
    assert "door open" in result.final_predicates


def test_fingers_close_along_the_closing_axis_across_the_cereals_narrow_side() -> None:
    """The hand's closing axis is MuJoCo's (the pads lie along it, :data:`HAND_POINTS`' fingertips at
    them), and a grasp turns it across the cereal's 3 cm side, which lies along the box geom's x but the
    body's y (the object's own axes are its geom's, in which its box's sides are read)."""
    env = make_env("PickPlaceCereal")
    try:
        scene = reset(env, 1)
        position, quat = scene.ee_pose()
        site = Rotation.from_quat(quat)
        pads = [
            scene.sim.data.geom_xpos[scene.model.geom_name2id(name)]
            for group in ("left_fingerpad", "right_fingerpad")
            for name in scene.gripper_model.important_geoms[group]
        ]
        gap = site.inv().apply(np.array(pads[-1]) - np.array(pads[0]))
        assert abs(gap @ CLOSING) == pytest.approx(np.linalg.norm(gap), abs=1e-3)
        tips = site.inv().apply(np.array(pads) - position)
        assert (
            np.abs(np.sort(tips @ CLOSING)[[0, -1]] - HAND_POINTS[[1, 3]] @ CLOSING).max() < 0.005
        )  # the pads
        axes, half = scene.axes("cereal"), scene.half_size("cereal")
        lower, upper = scene.box("cereal")
        assert np.allclose(np.abs(axes) @ half, (upper - lower) / 2, atol=1e-4)  # its sides, in its frame
        body_x = Rotation.from_quat(scene.pose("cereal")[1]).apply([1.0, 0.0, 0.0])
        assert abs(axes[:, 0] @ body_x) < 0.1  # the geom's frame is not the body's
        narrow = axes[:, int(np.argmin(half[:2]))]
        assert abs(closing_axis(across(scene, "cereal", down(scene))) @ narrow) == pytest.approx(
            1.0, abs=1e-6
        )
    finally:
        env.close()


def test_square_nut_perceived_by_its_ring() -> None:
    """The nut's centre and heading are its ring's: the handle puts its box's centre off the ring's."""
    env = make_env("NutAssemblySquare")
    try:
        world = RobosuiteWorld(reset(env, 0))
        obs = world.observe()
        ring = world.scene.pose("square nut")[0]
        lower, upper = obs.boxes["square nut"]
        assert np.allclose(obs.centers["square nut"], ring)
        assert np.linalg.norm((lower + upper) / 2 - ring) > 0.01
        assert obs.yaw_periods["square nut"] == pytest.approx(np.pi)
        assert obs.yaws["square nut"] == pytest.approx(world.scene.yaw("square nut"))
        assert world.affords("move_on_top", ("square nut", "square peg")) is None
    finally:
        env.close()


def test_condition_guided_lift_from_one_demonstration(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """An episode from the learned skill, then the same cell through ``taskcond reproduce robosuite``."""
    demos, ok = record_demonstrations("Lift", seed=0)
    assert ok and len(demos) == 1
    library = SkillLibrary()
    library.add(learn_skill(demos[0]))
    result = run_episode(TASKS["Lift"], "env", 1000, library, make_source("env", library), noise=0.005)
    assert result.success, result.reason
    assert "gripper grasping cube" in result.conditions["grasp cube"]["post_conditions"]
    assert "gripper grasping cube" in result.final_predicates
    library.save(tmp_path / "skills")
    assert SkillLibrary.load(tmp_path / "skills").skills["Lift"].target_yaw == demos[0].target_yaw
    assert demos[0].target_yaw is None  # a cube's square section has no heading to turn a grasp by
    args = ["reproduce", "robosuite", "--out", str(tmp_path / "out"), "--skills", str(tmp_path / "skills")]
    runner = CliRunner()
    bad = runner.invoke(app, [*args, "--row", "Wipe"])
    assert bad.exit_code == 2 and "robosuite has no row Wipe; valid:" in bad.output
    done = runner.invoke(app, [*args, "--row", "Lift", "--column", "env", "--episodes", "1"])
    assert done.exit_code == 0, done.output
    table = json.loads((tmp_path / "out" / "robosuite.json").read_text())
    cells = table["blocks"][0]["rows"][0]["cells"]
    assert (cells["env"]["successes"], cells["env"]["trials"]) == (1, 1)  # seed 1000, as the episode above
    assert cells["llm"]["status"] == "not run" and cells["robomimic"]["paper"] == 100
    assert table["config"]["world"].startswith("robosuite ")


def test_robomimics_published_figures_stand_beside_the_tasks_robomimic_has() -> None:
    """robomimic's Lift, Can and Square are robosuite's Lift, PickPlaceCan and NutAssemblySquare: the
    robomimic column of ``taskcond reproduce robosuite`` shows robomimic's figure on those rows only."""
    spec = robosuite_table()
    cells = build_cells(spec, [], 1)
    shown = {r.key: cells[("robosuite", r.key, "robomimic")].paper for r in spec.blocks[0].rows}
    published = {key: value for key, value in shown.items() if value is not None}
    assert published == {"Lift": 100, "PickPlaceCan": 100, "NutAssemblySquare": 84}


def test_milk_turned_a_quarter_turn_held_by_the_pads_below_its_gable_roof() -> None:
    """The milk stands turned -83° (seed 1013): the fingers close across its carton's gable roof. The
    grasp learned from one demonstration holds still at its grip before closing, so the lagging arm
    closes there, below the roof, and both pads hold it (robosuite's ``_check_grasp``); without the
    standstill it closed 1.3 cm below the top, lifted the milk by the fingers' rims and timed out."""
    demos, ok = record_demonstrations("PickPlaceMilk", seed=0)
    assert ok and len(demos) == 3
    library = SkillLibrary()
    for demo in demos:
        library.add(learn_skill(demo))
    grasp = library.skills["PickPlaceMilk.1"].segments  # touched while standing still, one approach:
    assert [s.gripper for s in grasp] == [0.0, 1.0]  # the straight descent (``_descends``) kept
    env = make_env("PickPlaceMilk")
    try:
        assert abs(abs(np.degrees(reset(env, 1013).yaw("milk"))) - 90.0) < 10.0  # a quarter turn
    finally:
        env.close()
    task = TASKS["PickPlaceMilk"]
    result = run_episode(task, "env", 1013, library, make_source("env", library), noise=0.005)
    assert result.success, result.reason
    assert not [e for e in result.events if e["kind"] == "post_missing"]  # the grasp held the first time


def test_cli_world_option() -> None:
    runner = CliRunner()
    listed = runner.invoke(app, ["tasks", "--world", "robosuite", "--json"])
    assert listed.exit_code == 0, listed.output
    assert {row["id"] for row in json.loads(listed.output)} == set(TASKS)
    bad = runner.invoke(app, ["tasks", "--world", "mars"])
    assert bad.exit_code == 2 and "use one of kitchen, robosuite" in bad.output
    unknown = runner.invoke(app, ["oracle", "--world", "robosuite", "Wipe", "--episodes", "1"])
    assert unknown.exit_code == 2 and "unknown robosuite task 'Wipe'" in unknown.output
    done = runner.invoke(app, ["oracle", "--world", "robosuite", "Lift", "--episodes", "1", "--json"])
    assert done.exit_code == 0 and json.loads(done.output)["successes"] == 1
