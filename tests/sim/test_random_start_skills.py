"""Skills from start states no demonstration shows (issue 19), with real PyBullet: the random start's
reachable area, a grasp of a round object turned away from a neighbour, and a fallen object that stops the
run at once."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pybullet")

import pybullet
from scipy.spatial.transform import Rotation

from taskcond.application.demonstrations import learn_library
from taskcond.conditions import ContainerState, Relation, SpatialRelation
from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.approach import BACK_OFF_HEIGHT, GRIP_DEPTH
from taskcond.execution.config import ExecutionConfig
from taskcond.execution.executor import Executor
from taskcond.execution.sources import EnvConditions
from taskcond.sim.franka import FINGER_OPEN
from taskcond.tasks.free import RANDOM_MIN_RADIUS, FreeTask, random_start
from taskcond.worlds.kitchen import KitchenWorld

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def library():
    return learn_library(None, ["grasp-bowl", "grasp-bottle"])


def _scene(places: dict[str, tuple[float, ...]]) -> tuple[KitchenEnv, KitchenWorld]:
    """The default kitchen with ``places`` (name → x, y in m, and optionally a yaw in rad) and every other
    free object in a row at y = 0.3."""
    env = KitchenEnv(FreeTask("anything"))
    env.reset(seed=0)
    for k, name in enumerate(n for n in env.scene.free_objects if n not in places):
        env.scene.place(name, (0.30 + 0.06 * k, 0.30), 0.0)
    for name, (x, y, *yaw) in places.items():
        env.scene.place(name, (x, y), yaw[0] if yaw else 0.0)
    return env, KitchenWorld(env)


def test_random_starts_keep_objects_reachable_and_out_of_the_containers_way() -> None:
    """Every free object at least RANDOM_MIN_RADIUS from the base, and clear of each container opened: the
    drawers pulled out, the box's lid up, the microwave's door open."""
    env = KitchenEnv(FreeTask("anything"))
    env.reset(seed=0)
    try:
        scene = env.scene
        for seed in range(6):
            rng = np.random.default_rng(seed)
            random_start(env, rng)
            drawn = scene.open_fractions()
            for name in scene.joints:
                scene.set_joint(name, 1.0)
            standing = [n for n in scene.bodies if n not in scene.free_objects and n != "table"]
            for name in scene.free_objects:
                xy = scene.pose(name)[0][:2]
                assert math.hypot(*xy) >= RANDOM_MIN_RADIUS - 1e-9, (seed, name)
                lo, hi = scene.aabb(name)
                for other in standing:
                    olo, ohi = scene.aabb(other)
                    apart = np.any(hi[:2] <= olo[:2]) or np.any(lo[:2] >= ohi[:2])
                    assert apart, (seed, name, other, drawn)
    finally:
        env.close()


def test_a_grasp_of_a_round_object_comes_from_the_side_a_neighbour_leaves_free(library) -> None:
    """The bottle stands where the demonstrated bowl grasp puts the hand's housing (the bowl's -x side,
    fingers closing along x): the grasp is turned about the bowl and holds it without knocking the
    bottle over. Unturned (the demonstration's side), the hand lands on the bottle."""
    for turnable in (True, False):
        env, world = _scene({"bowl": (0.45, 0.10), "bottle": (0.36, 0.08)})
        try:
            executor = Executor(world, library, method="env", source=EnvConditions(library))
            if not turnable:
                executor._turn = lambda *args: 0.0  # the paper's approach: as demonstrated
            result = executor.run(["grasp bowl"])
            obs = world.observe()
            (aim,) = [e for e in result.events if e.kind == "primitive"][:1]
            if turnable:
                assert "turned" in aim.message and result.completed
                assert obs.grasped() == "bowl" and "bottle" not in obs.lying
            else:
                assert "turned" not in aim.message and obs.grasped() != "bowl"
        finally:
            env.close()


def test_a_fallen_object_stops_the_run_with_one_line_instead_of_regrasping(library) -> None:
    env, world = _scene({"bottle": (0.40, -0.10)})
    try:
        lying = pybullet.getQuaternionFromEuler((math.pi / 2, 0.0, 0.0))
        pybullet.resetBasePositionAndOrientation(
            env.scene.bodies["bottle"], (0.40, -0.10, 0.035), lying, physicsClientId=env.scene.client
        )
        ee = env.robot.ee_pose()
        for _ in range(30):  # let it come to rest
            env.step(np.concatenate([ee.position, ee.orientation, [0.0]]))
        assert "bottle" in world.observe().lying
        result = Executor(world, library, method="env", source=EnvConditions(library)).run(["grasp bottle"])
        assert result.failure_kind == "fallen" and "\n" not in result.failure
        assert "'bottle' fell over" in result.failure
        assert not [e for e in result.events if e.kind == "primitive"]  # not one grasp tried
    finally:
        env.close()


def test_a_place_on_top_demonstrated_with_another_object_holds_this_one_above_the_top() -> None:
    """The only demonstration of a move on top of the box carries the flat spatula low; the mug held by
    its wall would end inside the box's top, so the goal is raised by the difference (and the box
    stays closed: nothing pushes the mug into it)."""
    library = learn_library(None, ["grasp-mug", "move_on_top-spatula-box"])
    env, world = _scene({"mug": (0.40, 0.05)})
    try:
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        assert executor.run(["grasp mug"]).completed and world.observe().grasped() == "mug"
        aim = executor._aim("move mug on top of box", world.observe())
        assert aim.skill.task_id == "move_on_top-spatula-box"
        assert aim.aside[2] > 0.03 and not np.any(aim.aside[:2])
        Executor(world, library, method="none").run(["move mug on top of box"])  # no FromEnv artefacts
        obs = world.observe()
        lo = obs.boxes["mug"][0]
        assert lo[2] > obs.boxes["box"][1][2] - 0.005  # held above the lid, not pushed into it
    finally:
        env.close()


def test_a_grasp_far_from_every_demonstrated_start_goes_to_one_first() -> None:
    """The hand low beside the bowl, nearest to the start of the bowl grasp demonstrated from the bottom
    drawer's handle (LHT2) yet 0.18 m from it: without the approach that DMP runs from there (before issue
    31 it missed the bowl: its later pieces counted from wherever the hand had got to, now from the
    planned goal); with it the executor first carries the hand to the highest demonstrated start (the
    primitive task's, above the bowl) and the grasp holds."""
    library = learn_library(None, ["grasp-bowl", "LHT2"])
    for approach in (None, 0.15):
        env = KitchenEnv(FreeTask("anything"))
        env.reset(seed=0)
        try:
            for k, name in enumerate(n for n in env.scene.free_objects if n != "bowl"):
                env.scene.place(name, (0.62, -0.40 + 0.1 * k), 0.0)
            env.scene.place("bowl", (0.45, -0.10), 0.0)
            world = KitchenWorld(env)
            ee = env.robot.ee_pose()
            for k in range(60):  # the hand to (0.41, 0.25, 0.09), low beside the bowl
                position = ee.position + (np.array([0.41, 0.25, 0.09]) - ee.position) * min(1.0, k / 40)
                env.step(np.concatenate([position, ee.orientation, [0.0]]))
            config = ExecutionConfig(approach_distance=approach)
            executor = Executor(world, library, method="env", source=EnvConditions(library), config=config)
            result = executor.run(["grasp bowl"])
            (aim,) = [e for e in result.events if e.kind == "primitive"][:1]
            if approach is None:
                assert aim.data["skill"] == "LHT2.3-grasp-bowl" and "approach" not in aim.data
            else:
                assert aim.data["skill"] == "grasp-bowl" and "demonstrated start" in aim.message
                assert result.completed and world.observe().grasped() == "bowl"
        finally:
            env.close()


def test_the_arms_sweep_measures_clearance_without_moving_anything() -> None:
    """Down through the box the arm penetrates it; high above the table it keeps clear; the joints are
    where they were."""
    env, world = _scene({})
    try:
        before = env.robot.joint_positions()
        _, down = world.ee_pose()
        box = np.mean(world.observe().boxes["box"], axis=0)
        through = np.array([[box[0], box[1], z] for z in np.linspace(0.40, 0.05, 15)])
        assert world.sweep(through, np.tile(down, (15, 1)), ()) < -0.01
        high = np.array([[0.35, 0.0, z] for z in np.linspace(0.60, 0.50, 5)])
        assert world.sweep(high, np.tile(down, (5, 1)), ()) > 0.0
        assert np.allclose(env.robot.joint_positions(), before)
    finally:
        env.close()


def test_a_release_raised_to_free_the_hand_sets_the_object_down_first() -> None:
    """The bottle held 12 cm above the table when `open box` needs a free hand: Alg. 1 raises `release
    bottle`, which first lowers the bottle onto the table, so it stands where it was let go."""
    library = learn_library(None, ["grasp-bottle", "release-bottle", "open-box"])
    env, world = _scene({"bottle": (0.35, 0.15)})
    try:
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        assert executor.run(["grasp bottle"]).completed and world.observe().grasped() == "bottle"
        position, orientation = world.ee_pose()
        lift = np.array([0.0, 0.0, 0.12])
        for k in range(1, 41):
            env.step(np.concatenate([position + lift * min(1.0, k / 30), orientation, [1.0]]))
        assert world.observe().boxes["bottle"][0][2] > 0.08
        result = executor.run(["open box"])
        (down,) = [e for e in result.events if e.kind == "set_down"]
        assert down.task == "release bottle" and down.data["drop"] > 0.07
        obs = world.observe()
        assert obs.grasped() is None and "bottle" not in obs.lying
        assert obs.boxes["bottle"][0][2] < 0.01  # on the table, upright
    finally:
        env.close()


def test_a_release_raised_to_free_the_hand_puts_a_tilted_object_back_upright_where_it_was_picked_up() -> None:
    """The mug held 10 cm aside of where it was picked up and tilted 60° (as a tilt leaves it) when `open
    box` needs a free hand: Alg. 1 raises `release mug`, which first carries it back over its place,
    turned back upright, so it stands where it stood; without that it was let go on its side."""
    library = learn_library(None, ["grasp-mug", "release-mug", "open-box"])
    env, world = _scene({"mug": (0.35, 0.15)})
    try:
        stood = np.mean(world.observe().boxes["mug"], axis=0)
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        assert executor.run(["grasp mug"]).completed and world.observe().grasped() == "mug"
        position, orientation = world.ee_pose()
        for k in range(1, 141):  # aside, up and turned about world x, as a tilt leaves it
            f = min(1.0, k / 120)
            quat = Rotation.from_rotvec([math.radians(60.0) * f, 0.0, 0.0]) * Rotation.from_quat(orientation)
            env.step(np.concatenate([position + np.array([-0.10 * f, 0.0, 0.10 * f]), quat.as_quat(), [1.0]]))
        assert world.observe().grasped() == "mug"
        result = executor.run(["open box"])
        (back,) = [e for e in result.events if e.kind == "put_back"]
        assert back.task == "release mug" and back.data["turn_degrees"] > 40
        obs = world.observe()
        assert obs.grasped() is None and "mug" not in obs.lying
        assert np.linalg.norm(np.mean(obs.boxes["mug"], axis=0)[:2] - stood[:2]) < 0.02
    finally:
        env.close()


def test_a_grasp_tried_again_first_opens_the_hand_and_lifts_it() -> None:
    """Before a grasp is tried again the hand opens where it missed and rises straight up
    BACK_OFF_HEIGHT, without moving the object it stood beside."""
    library = learn_library(None, ["grasp-bowl"])
    env, world = _scene({"bowl": (0.45, -0.10)})
    try:
        ee = env.robot.ee_pose()
        low = np.array([0.45, -0.10 + 0.09, 0.10])
        for k in range(1, 61):
            position = ee.position + (low - ee.position) * min(1.0, k / 40)
            env.step(np.concatenate([position, ee.orientation, [1.0]]))
        here, _ = world.ee_pose()
        bowl = world.observe().centers["bowl"]
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        executor._back_off("grasp bowl", 0, "before trying again")
        for _ in range(20):
            env.step(np.concatenate([*executor._last[:2], [executor._last[2]]]))
        there, _ = world.ee_pose()
        assert there[2] - here[2] == pytest.approx(BACK_OFF_HEIGHT, abs=0.02)
        assert np.linalg.norm(there[:2] - here[:2]) < 0.01
        assert executor._last[2] == 0.0  # open
        assert np.linalg.norm(world.observe().centers["bowl"] - bowl) < 0.005
    finally:
        env.close()


def test_an_open_far_from_its_demonstrated_start_goes_there_first_and_opens() -> None:
    """The hand low at the table's side, 0.35 m from where the box's opening was demonstrated:
    the executor carries it to that start first, and the lid opens."""
    library = learn_library(None, ["open-box"])
    env, world = _scene({})
    try:
        ee = env.robot.ee_pose()
        away = np.array([0.40, -0.30, 0.20])
        for k in range(1, 61):
            position = ee.position + (away - ee.position) * min(1.0, k / 40)
            env.step(np.concatenate([position, ee.orientation, [0.0]]))
        result = Executor(world, library, method="env", source=EnvConditions(library)).run(["open box"])
        (aim,) = [e for e in result.events if e.kind == "primitive"][:1]
        assert "demonstrated start" in aim.message
        assert result.completed and world.observe().holds(ContainerState("box", True))
    finally:
        env.close()


def test_a_grasp_comes_straight_down_from_above_its_object_and_turns_a_narrow_one_from_a_neighbour() -> None:
    """Issue 31: the toothpaste with the bottle 10 cm on its -x side, where the demonstrated grasp's way
    (in sideways from 14 cm off) brings the hand's housing. The grasp goes to a pre-grasp pose straight
    above the grasp point, is turned about the narrow toothpaste (it fits the open hand both ways) so the
    housing lies clear of the bottle, comes straight down and holds it; nothing falls over, and the trace
    says which approach was used."""
    library = learn_library(None, ["grasp-toothpaste"])
    env, world = _scene(
        {"toothpaste": (0.50, 0.12), "bottle": (0.40, 0.15), "bowl": (0.30, -0.30), "mug": (0.45, -0.30)}
    )
    try:
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        result = executor.run(["grasp toothpaste"])
        obs = world.observe()
        (aim,) = [e for e in result.events if e.kind == "primitive"][:1]
        assert aim.data["approach_kind"] == "pre-grasp above" and "straight down" in aim.message
        above = np.array(aim.data["approach"])
        assert np.linalg.norm(above[:2] - obs.centers["toothpaste"][:2]) < 0.03  # over it, not beside it
        assert above[2] > obs.boxes["toothpaste"][1][2] + 0.04
        assert aim.data.get("turn_degrees") in (90, -90)
        assert result.completed and obs.grasped() == "toothpaste"
        assert not obs.lying, obs.lying
        assert not [e for e in result.events if e.kind == "collision"]  # nothing touched on the way
    finally:
        env.close()


def test_a_spatula_grasp_turns_with_the_perceived_heading_and_holds() -> None:
    """Issue 31: the kitchen perceives the heading of a flat object (the spatula), not of a round one, and
    the demonstration keeps it; from a random start, the spatula turned 70° from where it was
    demonstrated is grasped with the demonstration turned by the change (modulo half a turn) and held,
    and nothing falls."""
    library = learn_library(None, ["grasp-spatula"])
    (skill,) = library.skills.values()
    assert skill.target_yaw is not None
    env = KitchenEnv(FreeTask("anything"))
    env.reset(seed=0)
    try:
        random_start(env, np.random.default_rng(0))
        yaw = skill.target_yaw + math.radians(70.0)
        env.scene.place("spatula", env.scene.pose("spatula")[0][:2], yaw)
        world = KitchenWorld(env)
        obs = world.observe()
        assert set(obs.yaws) == {"spatula"} and obs.yaws["spatula"] == pytest.approx(yaw, abs=1e-3)
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        result = executor.run(["grasp spatula"])
        (aim,) = [e for e in result.events if e.kind == "primitive"][:1]
        assert aim.data["turn_degrees"] == 70
        assert result.completed and world.observe().grasped() == "spatula"
        assert not world.observe().lying
    finally:
        env.close()


def test_a_carry_goes_over_a_neighbour_and_sets_a_slender_object_down_from_above() -> None:
    """Issue 31: the toothpaste carried in front of the box with the bottle standing on the straight way
    between them. The grasp closes GRIP_DEPTH below the toothpaste's top (nearer its centre of mass than
    the demonstrated 1 cm), the carry goes over the bottle to a place above the spot and comes straight
    down, so nothing is touched on the way (the demonstrated way runs the toothpaste into the bottle), and
    both stand at the end; the trace says which way was taken and how high."""
    library = learn_library(None, ["grasp-toothpaste", "move_in_front-mug-box", "release-toothpaste"])
    env, world = _scene(
        {
            "toothpaste": (0.25, -0.45),
            "bottle": (0.30, -0.30),
            "bowl": (0.15, 0.45),
            "mug": (0.30, 0.45),
            "spatula": (0.25, 0.30),
            "cube": (0.45, 0.12),
            "can": (0.30, 0.15),
        }
    )
    try:
        bottle = world.observe().centers["bottle"]
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        result = executor.run(["grasp toothpaste"])
        hand, top = world.ee_pose()[0][2], world.observe().boxes["toothpaste"][1][2]
        assert result.completed and top - hand > GRIP_DEPTH - 0.01
        result = executor.run(["move toothpaste in front of box", "release toothpaste"])
        (carry,) = [e for e in result.events if e.kind == "primitive" and e.task.startswith("move")]
        assert carry.data["approach_kind"] == "place above"
        assert carry.data["carried_over"] > world.observe().boxes["bottle"][1][2]
        assert not [e for e in result.events if e.kind == "collision"]
        obs = world.observe()
        assert result.completed and not obs.lying, obs.lying
        assert np.linalg.norm(obs.centers["bottle"] - bottle) < 0.005
        assert obs.holds(SpatialRelation("toothpaste", Relation.IN_FRONT_OF, "box"))
    finally:
        env.close()


def test_a_slender_object_is_let_go_into_the_mug_with_the_fingertips_above_its_rim() -> None:
    """Issue 31: the toothpaste, held GRIP_DEPTH below its top, is carried into the mug. Its place is raised
    so that the fingertips end above the mug's rim (the fingers opened inside the mug pressed on its walls
    and held it, LHT3 seed 1000); the toothpaste drops in, the hand is empty and the mug stands where it
    stood."""
    library = learn_library(None, ["grasp-toothpaste", "move_into-toothpaste-mug", "release-toothpaste"])
    env, world = _scene({"toothpaste": (0.30, 0.12), "mug": (0.36, -0.22)})
    try:
        mug = world.observe().centers["mug"]
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        assert executor.run(["grasp toothpaste", "move toothpaste into mug"]).completed
        assert world.ee_pose()[0][2] > world.observe().boxes["mug"][1][2]
        result = executor.run(["release toothpaste"])
        obs = world.observe()
        assert result.completed and obs.grasped() is None and not {"mug", "toothpaste"} & obs.lying
        assert obs.holds(SpatialRelation("toothpaste", Relation.INSIDE, "mug"))
        assert np.linalg.norm(obs.centers["mug"][:2] - mug[:2]) < 0.01
    finally:
        env.close()


def test_an_open_goes_over_a_bystander_its_demonstrated_way_would_sweep_and_leaves_it_standing() -> None:
    """Issue 31: the can stands in front of the bottom drawer, where the demonstrated opening's arm sweeps
    low (the wrist behind the hand turned level to the handle, on the way in, on the pull, and the open
    hand backing off the handle). The executor sees it in the planned way (World.sweep), goes over it to
    the demonstrated last approach with the hand tilted, and the drawer opens with the can standing where
    it stood; the trace names the can and the tilt. Replayed as demonstrated, the arm knocks it over."""
    library = learn_library(None, ["open-bottom_drawer"])
    away = {"bottle": (0.30, -0.30), "bowl": (0.35, -0.15), "mug": (0.45, -0.40), "cube": (0.45, -0.10)}
    for detour in (True, False):
        env, world = _scene(
            {"can": (0.26, 0.37), "toothpaste": (0.30, -0.42), "spatula": (0.25, -0.45)} | away
        )
        try:
            can = world.observe().centers["can"]
            executor = Executor(world, library, method="env", source=EnvConditions(library))
            if not detour:
                executor._clear_way = lambda g, turn, way: way  # the demonstrated way
            result = executor.run(["open bottom drawer"])
            obs = world.observe()
            assert result.completed and obs.holds(ContainerState("bottom drawer", True))
            if detour:
                (aim,) = [e for e in result.events if e.kind == "primitive"]
                assert aim.data["approach_kind"] == "detour clear of bystanders" and aim.data["swept"] == [
                    "can"
                ]
                assert aim.data["tilt_degrees"] > 0
                assert "can" not in obs.lying and np.linalg.norm(obs.centers["can"][:2] - can[:2]) < 0.01
            else:
                assert "can" in obs.lying
        finally:
            env.close()


def test_a_carry_whose_spot_is_taken_sets_its_object_down_at_the_clearest_spot_beside_it() -> None:
    """Issue 31: the bottle stands on the demonstrated spot in front of the box and the toothpaste beside
    it, so that no spot in front of the box keeps the carried mug the clearance from both. The mug goes to
    the spot that keeps farthest from them (the trace's aside moves it), comes straight down beside the
    bottle and both stand at the end; set down on the demonstrated spot, it came down onto the bottle and
    knocked it over (start seed 1000 of the combination benchmark)."""
    library = learn_library(None, ["grasp-mug", "move_in_front-mug-box", "release-mug"])
    env, world = _scene(
        {
            "bottle": (0.316, -0.145, -1.125),
            "toothpaste": (0.345, 0.034, 1.474),
            "mug": (0.404, -0.448, -1.271),
            "bowl": (0.531, 0.112, -2.284),
            "spatula": (0.253, -0.397, 1.305),
            "cube": (0.30, 0.109, 2.423),
            "can": (0.544, -0.319, -1.544),
        }
    )
    try:
        bottle = world.observe().centers["bottle"]
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        result = executor.run(["grasp mug", "move mug in front of box", "release mug"])
        obs = world.observe()
        assert result.completed and not obs.lying, obs.lying
        assert np.linalg.norm(obs.centers["bottle"][:2] - bottle[:2]) < 0.01
        assert obs.holds(SpatialRelation("mug", Relation.IN_FRONT_OF, "box"))
        (carry,) = [e for e in result.events if e.kind == "primitive" and e.task.startswith("move")]
        assert np.linalg.norm(carry.data["aside"][:2]) > 0.05
    finally:
        env.close()


def test_a_release_touching_a_neighbour_backs_off_straight_up_and_leaves_its_object_standing() -> None:
    """Issue 31: the toothpaste set down with the bottle standing against the hand's open side. Opening,
    the finger touches the bottle (an unallowed contact of `release toothpaste`); Alg. 2's sideways goal
    (goalPos − collPos) would drag the open fingers through the toothpaste just let go and knock it over.
    A primitive that lets go moves its goal straight up instead: the toothpaste still stands."""
    library = learn_library(None, ["grasp-toothpaste", "release-toothpaste"])
    env, world = _scene(
        {
            "toothpaste": (0.40, -0.25),
            "bottle": (0.15, 0.45),
            "bowl": (0.30, 0.45),
            "mug": (0.45, 0.40),
            "spatula": (0.25, 0.30),
            "cube": (0.45, 0.20),
            "can": (0.30, 0.15),
        }
    )
    try:
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        assert executor.run(["grasp toothpaste"]).completed and world.observe().grasped() == "toothpaste"
        position, orientation = world.ee_pose()
        down = np.array([0.0, 0.0, world.observe().boxes["toothpaste"][0][2] - 0.002])
        for k in range(1, 41):
            env.step(np.concatenate([position - down * min(1.0, k / 30), orientation, [1.0]]))
        centre = world.observe().centers["toothpaste"]
        side = Rotation.from_quat(world.ee_pose()[1]).apply([0.0, 1.0, 0.0])  # the fingers open along it
        side = side[:2] / np.linalg.norm(side[:2])
        bottle = env.scene.specs["bottle"]
        env.scene.place("bottle", centre[:2] + side * (FINGER_OPEN + bottle.radius - 0.005), 0.0)
        assert not world.observe().lying
        result = executor.run(["release toothpaste"])
        shifts = [e.data["shift"] for e in result.events if e.kind == "collision"]
        assert shifts and all(abs(s[0]) + abs(s[1]) < 1e-9 and s[2] > 0 for s in shifts), shifts
        obs = world.observe()
        assert obs.grasped() is None and "toothpaste" not in obs.lying, obs.lying
    finally:
        env.close()


def test_a_grasp_after_an_open_of_the_bottom_drawer_unwinds_the_arm_and_leaves_the_toothpaste_standing() -> (
    None
):
    """Issue 31: from this random start (seed 1001) the open of the bottom drawer leaves the arm turned to
    the drawer; the grasp of the toothpaste, turned half round it, would wind the Panda's wrist to its limit
    on the transit, and its approach would then miss by 0.4 m: the hand closed beside the toothpaste and
    swept it over. The executor finds the way missed from the wound joints (World.wound), lifts the hand,
    moves the arm back through its home joints (the trace's ``unwind``) and grasps the toothpaste at the
    first try. Without the unwind the three tries miss."""
    library = learn_library(None, ["open-bottom_drawer", "grasp-toothpaste"])
    env = KitchenEnv(FreeTask("x", ("open bottom drawer", "grasp toothpaste"), start="random"))
    env.reset(seed=1001)
    try:
        world = KitchenWorld(env, noise_sigma=0.005, seed=1001)
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        result = executor.run(["open bottom drawer", "grasp toothpaste"])
        obs = world.observe()
        assert result.completed and obs.holds(ContainerState("bottom drawer", True))
        assert obs.grasped() == "toothpaste" and "toothpaste" not in obs.lying
        kinds = [(e.kind, e.task) for e in result.events if e.kind in ("unwind", "post_missing")]
        assert kinds == [("unwind", "grasp toothpaste")]
    finally:
        env.close()


def test_a_move_into_the_bottom_drawer_closes_the_top_drawer_open_over_it_first() -> None:
    """Issue 31: both drawers open, the top one over the bottom one's opening. The move into the bottom
    drawer adds ``top drawer closed`` to its pre-conditions (the trace's ``covered``), Alg. 1 sets the bowl
    down, closes the top drawer and grasps the bowl again, and the bowl ends in the bottom drawer; carried
    under the open top drawer, it ended outside it."""
    library = learn_library(
        None, ["grasp-bowl", "release-bowl", "move_into-bowl-bottom_drawer", "close-top_drawer"]
    )
    env, world = _scene(
        {
            "bowl": (0.35, 0.10),
            "bottle": (0.26, -0.30),
            "mug": (0.34, -0.30),
            "toothpaste": (0.42, -0.30),
            "spatula": (0.26, -0.38),
            "cube": (0.34, -0.38),
            "can": (0.42, -0.38),
        }
    )
    try:
        env.scene.set_joint("top drawer", 1.0)
        env.scene.set_joint("bottom drawer", 1.0)
        executor = Executor(world, library, method="env", source=EnvConditions(library))
        result = executor.run(["grasp bowl", "move bowl into bottom drawer", "release bowl"])
        assert result.completed, result.failure
        assert [e.data["covering"] for e in result.events if e.kind == "covered"][:1] == [
            ["top drawer closed"]
        ]
        assert env.truth.holds(SpatialRelation("bowl", Relation.INSIDE, "bottom drawer"))
        assert env.truth.holds(ContainerState("top drawer", False))
    finally:
        env.close()


def test_an_open_whose_approach_alg2_moved_into_the_drawer_still_pulls_it_the_demonstrated_length() -> None:
    """Issue 31 (start seed 1002 of the combination benchmark): on its way to the bottom drawer's handle the
    arm touches the top drawer, and Alg. 2 moves the goal 5 cm into the cabinet, where the closed drawer's
    front holds the hand back. The hand takes hold of the handle where it is and the pull counts from
    there: the drawer opens more than 80% of its travel; counted from the moved goal it opened 72%, and the
    carry into it ran into the top drawer's front."""
    library = learn_library(None, ["open-bottom_drawer"])
    env = KitchenEnv(FreeTask("open the bottom drawer", start="random"))
    env.reset(seed=1002)
    try:
        world = KitchenWorld(env, noise_sigma=0.005, seed=1002)
        result = Executor(world, library, method="env", source=EnvConditions(library)).run(
            ["open bottom drawer"]
        )
        assert result.completed, result.failure
        assert [e.data["shift"][0] for e in result.events if e.kind == "collision"][:1] == [
            pytest.approx(0.05, abs=0.005)
        ]
        assert env.scene.open_fraction("bottom drawer") > 0.8
    finally:
        env.close()


def test_a_place_on_the_cabinets_far_corner_is_pulled_within_the_hands_reach_and_the_toothpaste_stands() -> (
    None
):
    """Issue 31: from this random start (seed 1001) the demonstrated spot on the cabinet's top, scaled from
    the box's demonstration, lies at its far corner, 0.87 m from the shoulder: within the arm's nominal
    reach, but the hand pointing down sagged 10 cm short of it, the toothpaste touched the top tilted and
    lay down when let go. The place is searched like a taken one (the hand's pose checked by IK from
    home), pulled towards the robot on the top, and the toothpaste stands there after the release."""
    steps = ["grasp toothpaste", "move toothpaste on top of cabinet", "release toothpaste"]
    library = learn_library(None, ["grasp-toothpaste", "move_on_top-toothpaste-box", "release-toothpaste"])
    env = KitchenEnv(FreeTask("x", tuple(steps), start="random"))
    env.reset(seed=1001)
    try:
        world = KitchenWorld(env, noise_sigma=0.005, seed=1001)
        result = Executor(world, library, method="env", source=EnvConditions(library)).run(steps)
        obs = world.observe()
        assert result.completed and obs.grasped() is None
        assert obs.holds(SpatialRelation("toothpaste", Relation.ABOVE, "cabinet"))
        assert "toothpaste" not in obs.lying
    finally:
        env.close()


def test_the_opening_of_a_mug_is_perceived_on_its_axis_whatever_way_its_handle_points() -> None:
    """Issue 31: the mug's handle widens its box on one side, so the box's centre is off the opening's axis
    by a centimetre, on the side the handle points to. The kitchen perceives the opening itself, at the rim's
    height; a round vessel's is its box's centre."""
    for yaw in (0.0, math.pi / 2, 2.5):
        env, world = _scene({"mug": (0.40, -0.20, yaw), "bowl": (0.40, 0.10)})
        try:
            obs = world.observe()
            base = env.scene.pose("mug")[0]
            lo, hi = obs.boxes["mug"]
            opening = obs.openings["mug"]
            assert np.allclose(opening[:2], base[:2], atol=1e-3)
            assert np.linalg.norm((lo + hi)[:2] / 2 - opening[:2]) > 0.008  # the handle's side
            assert abs(opening[2] - hi[2]) < 0.015  # at the rim
            assert np.allclose(obs.openings["bowl"][:2], obs.centers["bowl"][:2], atol=0.005)
        finally:
            env.close()
