"""The executor's :class:`~taskcond.execution.world.World` over the PyBullet kitchen suite, and the
recording of oracle demonstrations into skills (``taskcond learn``, paper Fig. 2 and §III-D).

This is the only module of :mod:`taskcond.execution` that knows the simulator.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from functools import cache
from pathlib import Path

import numpy as np
import pybullet as p

from taskcond.conditions import (
    KINOVA_GRIPPER,
    Collision,
    ContainerState,
    GripperState,
    Predicate,
    Relation,
    SpatialRelation,
)
from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.decompose import mentions
from taskcond.execution.demofile import RecordedTrajectory
from taskcond.execution.skills import Demonstration, SkillLibrary, learn_skill, target_object
from taskcond.execution.sources import condition_from_environment
from taskcond.execution.world import Observation, Touch
from taskcond.grounding import DemoEvidence
from taskcond.primitives import get_primitive, parse_task
from taskcond.sim.assets import BottleSpec, VesselSpec
from taskcond.sim.perception import EnvironmentInfo, Perception, PerceptionConfig
from taskcond.sim.recording import VideoRecorder
from taskcond.sim.scene import TABLE, SceneConfig, dual_arm_config
from taskcond.tasks.base import PrimitiveTask, Task, TaskInfo
from taskcond.tasks.close import DOOR_START
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.move import free_goal
from taskcond.tasks.registry import get_task, list_tasks, make

REACH = 0.95
"""Reach (m) of the Panda's end effector (between the fingertips) from its shoulder: 0.855 m to the
flange plus the hand; farther goals are refused."""
SHOULDER = np.array([0.0, 0.0, 0.333])
"""Position (m, world frame) of the Panda's shoulder (joint 2) with the base at the origin."""
VIDEO_EVERY = 2
"""Record every n-th control step."""
KINOVA_STILL = 1e-4
"""A demonstration step whose Kinova commands vary less than this (m, quaternion units, gripper) is a
Franka-only demonstration: the Kinova held still."""


LYING = math.cos(math.radians(45.0))
"""A free object whose upright axis has a world-z component below this (tilted more than 45°) lies."""


def _observation(info: EnvironmentInfo, round_: frozenset[str], lying: frozenset[str]) -> Observation:
    return Observation(
        predicates=info.predicates,
        centers={name: box.center for name, box in info.boxes.items()},
        touches=tuple(Touch(c.a, c.b, c.position) for c in info.contacts),
        boxes={name: (box.lower, box.upper) for name, box in info.boxes.items()},
        round=round_,
        lying=lying,
    )


SWEEP_WITHIN = 0.05
"""Distance (m) up to which :meth:`KitchenWorld.sweep` measures the arm's clearance."""

FLAT = 0.02
"""Perceived height (m) under which a soft body lies flat on the table. Its centre's height is then the
height at which it rests (:attr:`~taskcond.sim.cloth.ClothSpec.collision_margin` above the table top), not
the perceived one: for a layer a few millimetres thick the perceived height is the perception noise
(σ = 5 mm by default) and the bumps of what lies on it, and LHT4's fold grips the cloth within a 16 mm
window of fingertip heights."""


class KitchenWorld:
    """A :class:`KitchenEnv` seen through the environment-information layer (§III-A.2).

    Arms: the Franka (``gripper``) and, in the dual-arm scene, the Kinova Gen3 (``kinova gripper``); a
    command for the Franka alone leaves the Kinova holding its last command.

    Args:
        env: the environment, already reset.
        noise_sigma: Gaussian noise (m) on every perceived centre and box coordinate (the paper's method).
        seed: seed of the perception noise.
        recorder: video of every :data:`VIDEO_EVERY`-th control step, if given.
    """

    def __init__(
        self,
        env: KitchenEnv,
        noise_sigma: float = 0.0,
        seed: int | None = None,
        recorder: VideoRecorder | None = None,
    ) -> None:
        self.env = env
        self.dt = env.dt
        self.recorder = recorder
        description = env.scene.description()
        self.perception = Perception(
            description, PerceptionConfig(noise_sigma=noise_sigma, check_visibility=False)
        )
        self._owner = self.perception.owners
        self._contact_distance = self.perception.config.contact_distance
        """Contact points farther apart (m) are not contacts: the perceiver's rule."""
        self._rng = np.random.default_rng(seed)
        self._objects = tuple(b.name for b in description.bodies if b.kind != "robot")
        self._free = (
            *env.scene.free_objects,
            *(("cloth",) if getattr(env.scene, "cloth", None) is not None else ()),
        )
        self._arms = ("gripper",) if env.kinova is None else ("gripper", KINOVA_GRIPPER)
        self._bodies = (env.robot.body,) if env.kinova is None else (env.robot.body, env.kinova.body_id)
        self._kinova_command: np.ndarray | None = None
        cloth = env.scene.config.cloth if getattr(env.scene, "cloth", None) is not None else None
        self._rest = {} if cloth is None else {"cloth": cloth.collision_margin}
        """Soft body → the height (m) of its centre lying flat on the table (:data:`FLAT`)."""
        self._joints = tuple(env.scene.joints)
        self._interiors = tuple(env.scene.interiors)
        self._round = frozenset(
            name
            for name, (spec, _) in env.scene.config.free_objects.items()
            if isinstance(spec, BottleSpec | VesselSpec)
        )
        """Free objects of a turned-about-their-axis shape: cylinders (bottle, can) and vessels (bowl, mug:
        held by the wall, which the mug's handle leaves free on most sides)."""
        self.env_seconds = 0.0
        self._observed: tuple[int, Observation] | None = None
        """Wall-clock seconds spent inside the environment's step (IK and physics)."""

    @property
    def time(self) -> float:
        return self.env.steps * self.env.dt

    @property
    def objects(self) -> tuple[str, ...]:
        return self._objects

    @property
    def arms(self) -> tuple[str, ...]:
        return self._arms

    @property
    def ground(self) -> tuple[str, ...]:
        return (TABLE,)

    def observe(self) -> Observation:
        """Environment information now; repeated calls without a control step in between return the same
        observation (same noise draw), as a real robot's perception would until something moves."""
        if self._observed is None or self._observed[0] != self.env.steps:
            info = self.perception.observe(self._rng)
            self._observed = (self.env.steps, _observation(info, self._round, self._lying()))
        return self._observed[1]

    def _lying(self) -> frozenset[str]:
        """The free objects tilted more than 45° from upright (:data:`LYING`), from their poses."""
        lying = []
        for name in self.env.scene.free_objects:
            _, orn = self.env.scene.pose(name)
            up = p.getMatrixFromQuaternion(orn)[8]  # world z of the object's own z axis
            if up < LYING:
                lying.append(name)
        return frozenset(lying)

    def touches(self) -> tuple[Touch, ...]:
        """Contacts of the arms (all of an arm's links are its gripper) and of whatever they touch with
        the bodies around, from PyBullet's contact points of the last step: only what Alg. 2 checks."""
        robots = set(self._bodies)
        client = self.env.scene.client
        points = [pt for r in self._bodies for pt in p.getContactPoints(bodyA=r, physicsClientId=client)]
        touched = {pt[2] for pt in points} - robots
        for body in touched:  # its other contacts; those with an arm are already in ``points``
            points += [
                pt for pt in p.getContactPoints(bodyA=body, physicsClientId=client) if pt[2] not in robots
            ]
        merged: dict[frozenset[str], list[np.ndarray]] = {}
        names: dict[frozenset[str], tuple[str, str]] = {}
        for pt in points:
            a, b = self._owner.get((pt[1], pt[3])), self._owner.get((pt[2], pt[4]))
            if a is None or b is None or a == b or pt[8] > self._contact_distance:
                continue
            key = frozenset((a, b))
            names.setdefault(key, (min(a, b), max(a, b)))
            merged.setdefault(key, []).append((np.array(pt[5]) + np.array(pt[6])) / 2.0)
        return tuple(Touch(*names[k], np.mean(v, axis=0)) for k, v in merged.items())

    def locate(self, name: str, observation: Observation) -> np.ndarray | None:
        """The perceived centre; a soft body perceived flatter than :data:`FLAT` at its resting height."""
        if name == "position":
            target = self.env.target
            return None if not np.any(target) else np.asarray(target, float).copy()
        centre = observation.centers.get(name)
        rest = self._rest.get(name)
        if centre is None or rest is None:
            return centre
        lower, upper = observation.boxes[name]
        if upper[2] - lower[2] >= FLAT:
            return centre
        return np.array([centre[0], centre[1], rest])

    def affords(self, primitive: str, objects: tuple[str, ...]) -> str | None:
        unknown = [o for o in objects if o not in self._objects]
        if unknown:
            return f"{', '.join(map(repr, unknown))} not in the scene (objects: {', '.join(self._objects)})"
        free, joints, interiors = self._free, self._joints, self._interiors
        if primitive in ("open", "close") and objects[0] not in joints:
            return f"{objects[0]!r} has no lid, door or drawer (containers: {', '.join(joints)})"
        fixed = [objects[k] for k in get_primitive(primitive).movable if objects[k] not in free]
        if fixed:
            return f"{fixed[0]!r} cannot be moved (movable objects: {', '.join(free)})"
        if primitive == "move_into" and objects[1] not in interiors:
            return f"{objects[1]!r} is not a container (containers: {', '.join(interiors)})"
        if primitive == "fold" and ("cloth" not in self._objects or len(self._arms) < 2):
            return "folding needs the cloth and two arms, which this scene does not have"
        return None

    def reach_error(self, position: np.ndarray) -> str | None:
        position = np.asarray(position, float)
        for arm in range(len(position) // 3):
            point = position[3 * arm : 3 * arm + 3]
            if arm == 0:
                shoulder, reach = SHOULDER, REACH
            else:
                assert self.env.kinova is not None
                shoulder, reach = self.env.kinova.shoulder, self.env.kinova.reach
            distance = float(np.linalg.norm(point - shoulder))
            if distance > reach:
                return f"{distance:.2f} m from the {self._arms[arm]}'s shoulder, it reaches {reach:.2f} m"
            if point[2] < -0.05:
                return f"{point[2]:.2f} m is below the table"
        return None

    def sweep(self, positions: np.ndarray, orientations: np.ndarray, ignore: tuple[str, ...]) -> float:
        """The arm's IK for each pose in turn, each seeded by the last (the current joints first), checked
        against the scene's collision shapes of the named bodies but ``ignore`` and the table (:attr:`ground`)
        (:meth:`Franka.clearance`)."""
        robot = self.env.robot
        bodies = [
            (b.body_id, b.link_index)
            for b in self.env.scene.description().bodies
            if b.kind != "robot" and b.name not in (*ignore, *self.ground)
        ]
        seed = robot.joint_positions()
        qs = []
        for position, orientation in zip(positions, orientations, strict=True):
            seed = robot.ik(position, orientation, seed)
            qs.append(seed)
        return robot.clearance(qs, bodies, SWEEP_WITHIN)

    def ee_pose(self, arms: int = 1) -> tuple[np.ndarray, np.ndarray]:
        ee = self.env.robot.ee_pose()
        if arms < 2:
            return ee.position, ee.orientation
        assert self.env.kinova is not None
        position, orientation = self.env.kinova.ee_pose()
        return np.concatenate([ee.position, position]), np.concatenate([ee.orientation, orientation])

    def step(self, position: np.ndarray, orientation: np.ndarray, gripper: float) -> str | None:
        start = time.perf_counter()
        action = np.concatenate([position[:3], orientation[:4], [gripper]])
        if len(position) >= 6:
            self._kinova_command = np.concatenate([position[3:6], orientation[4:8], [gripper]])
        if self._kinova_command is not None:  # once moved, the Kinova holds its last command
            action = np.concatenate([action, self._kinova_command])
        _, _, terminated, _, info = self.env.step(action)
        self.env_seconds += time.perf_counter() - start
        if self.recorder is not None and self.env.steps % VIDEO_EVERY == 0:
            self.recorder.add(self.env.render())
        return info["failure"] if terminated else None


SCENES = ("kitchen", "dual-arm")
"""Scenes of a free instruction: the default kitchen (the Franka, containers closed) or the dual-arm
kitchen of the cloth tasks (:func:`taskcond.sim.scene.dual_arm_config`: the Kinova and the cloth, without
the free objects that lie near the cloth)."""

DUAL_ARM_WORDS = ("cloth", "fold", "kinova", "second arm", "other arm", "both arms", "two arms", "both hands")
"""Words of an instruction that name what only the dual-arm kitchen has."""


def instruction_scene(instruction: str) -> str:
    """The scene an instruction needs (:data:`SCENES`): ``dual-arm`` when it names the cloth or a second
    arm (:data:`DUAL_ARM_WORDS`), else ``kitchen``."""
    return "dual-arm" if mentions(instruction, DUAL_ARM_WORDS) else "kitchen"


STARTS = ("task", "random")
"""Start states of an episode: ``task``, the task's own (a free instruction: the scene's reset, free objects
near their nominal spots, containers closed, arms home); ``random``, :func:`random_start` (a suite task:
:class:`RandomStart`)."""

RANDOM_AREA = ((0.22, 0.55), (-0.45, 0.35))
"""World x and y ranges (m) of the table area where :func:`random_start` places free objects: in front of
the Franka (base at the origin), within about 0.7 m of it, where its demonstrations reach."""
RANDOM_MIN_RADIUS = 0.28
"""Least horizontal distance (m) of a randomly placed object's centre from the Franka's base axis (the
origin): nearer, the hand cannot reach down to the table top (the elbow at its limit; the oracles' grasps
of the bottle and the toothpaste fail at 0.24 m in front of the base and succeed from 0.27 m)."""
RANDOM_CLEARANCE = 0.03
"""Least gap (m) between the footprints of a randomly placed object and anything else on the table."""
RANDOM_TRIES = 200


def random_start(env: KitchenEnv, rng: np.random.Generator, fixed: dict[str, float] | None = None) -> None:
    """A random start state: each articulated container (drawers, box, microwave) open or closed with
    probability 1/2 (open: drawers and the box fully, the microwave's door at the suite's
    :data:`~taskcond.tasks.close.DOOR_START`, where its close is demonstrated; a container of ``fixed``
    at its given open fraction instead; the draw is made all the same, so that the rest of the scene does
    not depend on ``fixed``); then each free object, in the
    scene's order, upright with a uniform yaw at a uniform spot of :data:`RANDOM_AREA` at least
    :data:`RANDOM_MIN_RADIUS` from the Franka's base whose footprint
    (its bounding rectangle at that yaw) keeps :data:`RANDOM_CLEARANCE` from the bounding boxes of the
    containers both open and closed (an object in front of a closed drawer would keep it from opening, and
    no primitive moves an object out of the way), of the cloth and of the objects placed before it:
    rejection sampling,
    :data:`RANDOM_TRIES` draws per object, the whole placement drawn again (up to 20 times) when an object
    finds no spot. ``rng`` decides everything: the same seed gives the same scene.

    Raises:
        RuntimeError: no placement found.
    """
    scene = env.scene
    fixed = fixed or {}
    standing = [n for n in scene.bodies if n not in scene.free_objects and n not in (TABLE, "cloth")]
    boxes = []
    for fraction in (1.0, 0.0):  # what every container covers open (its drawer out, lid up) and closed
        for name in scene.joints:
            scene.set_joint(name, fraction)
        boxes += [(lo[:2], hi[:2]) for lo, hi in map(scene.aabb, standing)]
        for joint in scene.joints.values():  # the moving part itself: a lid, a door
            lo, hi = p.getAABB(joint.body_id, joint.joint_index, physicsClientId=scene.client)
            boxes.append((np.array(lo[:2]), np.array(hi[:2])))
    for name, joint in scene.joints.items():
        opened = DOOR_START / joint.open_position if name == "microwave" else 1.0
        drawn = opened if rng.random() < 0.5 else 0.0
        scene.set_joint(name, fixed.get(name, drawn))
    if scene.cloth is not None:
        nodes = scene.cloth_nodes()
        boxes.append((nodes.min(axis=0)[:2], nodes.max(axis=0)[:2]))
    half = {}
    for name in scene.free_objects:  # half extents (m) of the footprint at yaw 0
        scene.place(name, (0.0, -2.0 - len(half)), 0.0)
        lo, hi = scene.aabb(name)
        half[name] = (hi[:2] - lo[:2]) / 2
    (x0, x1), (y0, y1) = RANDOM_AREA
    for _ in range(20):
        placed = list(boxes)
        spots = {}
        for name, (hx, hy) in half.items():
            for _ in range(RANDOM_TRIES):
                xy = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])
                yaw = rng.uniform(-np.pi, np.pi)
                cos, sin = abs(np.cos(yaw)), abs(np.sin(yaw))
                extent = np.array([cos * hx + sin * hy, sin * hx + cos * hy]) + RANDOM_CLEARANCE
                if np.hypot(*xy) < RANDOM_MIN_RADIUS:
                    continue
                if all(np.any(xy + extent <= lo) or np.any(xy - extent >= hi) for lo, hi in placed):
                    break
            else:
                break
            placed.append((xy - extent + RANDOM_CLEARANCE, xy + extent - RANDOM_CLEARANCE))
            spots[name] = (xy, yaw)
        if len(spots) == len(half):
            for name, (xy, yaw) in spots.items():
                scene.place(name, xy, yaw)
            return
    raise RuntimeError("random start: no collision-free placement of the free objects found")


class RandomStart(Task):
    """A suite task from a random start (``--start random``): :func:`random_start` keeping the containers
    the task's start needs (:meth:`~taskcond.tasks.base.Task.fixed_joints`), then the task's own set-up
    from there (:meth:`~taskcond.tasks.base.Task.setup_after_random`: an object the task starts holding is
    grasped where it now stands; a long-horizon task opens nothing). Everything else (scene, success,
    oracle) is the task's.

    Which tasks keep what (:meth:`fixed_joints` of each family): ``open C`` keeps C closed; ``close C``
    opens C; ``move A into B`` opens B and, for a drawer, closes the other drawer (an open top drawer covers
    the bottom one); ``move A on top of B`` and ``move A in front of B`` keep B closed (the cabinet: both
    drawers); grasp, release, tilt, move, the cloth tasks and the long-horizon tasks keep nothing (a
    long-horizon task's own steps, repaired by the planner, must deal with the containers it meets).
    """

    def __init__(self, task: Task) -> None:
        self.task = task
        self.info = task.info
        self.max_steps = task.max_steps

    def scene_config(self, config: SceneConfig | None) -> SceneConfig | None:
        return self.task.scene_config(config)

    def ground_truth(self, scene):  # type: ignore[no-untyped-def]
        return self.task.ground_truth(scene)

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        random_start(env, rng, self.task.fixed_joints(env))
        self.task.setup_after_random(env, rng)

    def post_conditions(self) -> tuple[Predicate, ...]:
        return self.task.post_conditions()

    def extra_success(self, env: KitchenEnv) -> bool:
        return self.task.extra_success(env)

    def success(self, env: KitchenEnv, truth: GroundTruth | None = None) -> bool:
        return self.task.success(env, truth)

    def plans(self, env: KitchenEnv):  # type: ignore[no-untyped-def]
        return self.task.plans(env)


class FreeTask(Task):
    """A free instruction's episode: the default scene (containers closed, arm home), or the dual-arm
    kitchen with ``scene="dual-arm"``; with ``start="random"`` the start state of :func:`random_start`.
    A plan that moves an object to a position gets a target (the observation ``target``) as the suite's
    move task draws it (:func:`taskcond.tasks.move.free_goal`, from where the object stands). Its success
    is judged by the runner against the instruction's goal predicates, not by the task."""

    max_steps = 10**9

    def __init__(
        self, label: str, steps: tuple[str, ...] = (), scene: str = "kitchen", start: str = "task"
    ) -> None:
        if scene not in SCENES:
            raise ValueError(f"unknown scene {scene!r}; valid: {', '.join(SCENES)}")
        if start not in STARTS:
            raise ValueError(f"unknown start {start!r}; valid: {', '.join(STARTS)}")
        self.info = TaskInfo("instruction", "long-horizon", steps, (), label)
        self.scene = scene
        self.start = start

    def scene_config(self, config: SceneConfig | None) -> SceneConfig | None:
        return dual_arm_config(config) if self.scene == "dual-arm" else config

    def setup(self, env: KitchenEnv, rng: np.random.Generator) -> None:
        if self.start == "random":
            random_start(env, rng)
        moved = [
            parse_task(s).objects[0] for s in self.info.primitive if parse_task(s).primitive.id == "move"
        ]
        if moved and moved[0] in env.scene.free_objects:
            env.target = free_goal(env, moved[0], rng)

    def success(self, env: KitchenEnv, truth: GroundTruth | None = None) -> bool:
        return False


@cache
def scene_objects(
    scene: str = "kitchen",
) -> tuple[tuple[str, ...], Callable[[str, tuple[str, ...]], str | None]]:
    """The object names of a scene (:data:`SCENES`) and what each primitive affords there (for
    decomposition); built once per scene and process."""
    env = KitchenEnv(FreeTask("", scene=scene))
    try:
        world = KitchenWorld(env)
        objects, affords = world.objects, world.affords
        return objects, affords
    finally:
        env.close()


def final_predicates(env: KitchenEnv) -> list[str]:
    """Every relation and state of the condition vocabulary that holds now by the ground-truth judge
    (:class:`taskcond.tasks.groundtruth.GroundTruth`), as sorted canonical strings: each gripper's grasp
    (or ``not grasping``), each container's ``open``/``closed``, and the four spatial relations between
    every ordered pair of the scene's named non-robot bodies."""
    scene, truth = env.scene, env.truth
    names = [b.name for b in scene.description().bodies if b.kind != "robot"]
    movable = [*scene.free_objects, *(("cloth",) if scene.cloth is not None else ())]
    grippers = ["gripper", *((KINOVA_GRIPPER,) if env.kinova is not None else ())]
    preds: list[Predicate] = [GripperState(None, g) for g in grippers]
    preds += [GripperState(o, g) for g in grippers for o in movable]
    preds += [ContainerState(c, is_open) for c in scene.interiors for is_open in (True, False)]
    preds += [SpatialRelation(a, r, b) for a in names for b in names if a != b for r in Relation]
    return sorted(str(q) for q in preds if truth.holds(q))


# ----------------------------------------------------------------------------------- demonstrations
def _record_step(world: KitchenWorld, step: PrimitiveTask, task_id: str) -> Demonstration:
    """Execute one primitive oracle from the current state and record it."""
    actions = (trajectory.action(i) for trajectory in step.plans(world.env) for i in range(len(trajectory)))
    return _record(world, step.info.task_name, task_id, actions)


def _record(world: KitchenWorld, name: str, task_id: str, actions: Iterable[np.ndarray]) -> Demonstration:
    """Command ``actions`` (each (8,) or (16,): position, quaternion xyzw, gripper per arm) one control step
    each from the current state and record the demonstration of task ``name``: the commanded end-effector
    trajectory, the environment information before and after, the contacts during."""
    env = world.env
    before = world.observe()
    target = target_object(name)
    center = world.locate(target, before) if target is not None else None
    touched: set[Collision] = set()
    contact = -1
    rows: list[np.ndarray] = []
    for action in actions:
        rows.append(np.asarray(action, float))
        env.step(rows[-1])
        for touch in world.touches():
            touched.add(touch.collision)
            if contact < 0 and target is not None and {touch.a, touch.b} == {"gripper", target}:
                contact = len(rows) - 1
    for _ in range(5):
        env.step(rows[-1])
    after = world.observe()
    actions = np.array(rows)
    arms = [actions[:, :8]]
    if actions.shape[1] == 16 and np.ptp(actions[:, 8:], axis=0).max() > KINOVA_STILL:
        arms.append(actions[:, 8:])
    task = parse_task(name)
    evidence = DemoEvidence(
        task.name,
        frozenset((*task.objects, *world.arms)),
        before.predicates,
        after.predicates,
        frozenset(touched),
    )
    return Demonstration(
        task_name=task.name,
        task_id=task_id,
        times=np.arange(len(actions)) * env.dt,
        positions=np.concatenate([a[:, :3] for a in arms], axis=1),
        orientations=np.concatenate([a[:, 3:7] for a in arms], axis=1),
        gripper=actions[:, 7],
        target=target,
        target_center=np.zeros(3) if center is None else center,
        target_contact=contact,
        condition=condition_from_environment(name, before.predicates, after.predicates, touched),
        evidence=evidence.restricted(evidence.objects),
    )


def record_demonstrations(task_id: str, seed: int = 0) -> tuple[list[Demonstration], bool]:
    """Run the oracle of a suite task once and record a demonstration of each primitive it performs: one
    for a primitive task, one per step for a long-horizon task (each step planned from the state the
    previous one left). Returns the demonstrations and whether the oracle succeeded.

    Raises:
        ValueError: ``task_id`` has a step that is not a primitive task (it cannot be demonstrated).
    """
    task = get_task(task_id)
    steps = [task] if isinstance(task, PrimitiveTask) else list(getattr(task, "steps", ()))
    if not steps or not all(isinstance(s, PrimitiveTask) for s in steps):
        raise ValueError(f"{task_id!r} has no primitive steps to demonstrate")
    env = make(task_id)
    try:
        env.reset(seed=seed)
        world = KitchenWorld(env)
        demos = [
            _record_step(world, step, task_id if step is task else f"{task_id}.{k}-{step.info.id}")
            for k, step in enumerate(steps, start=1)
        ]
        success = bool(task.success(env))
    finally:
        env.close()
    return demos, success


def record_trajectory(task_id: str, seed: int = 0) -> tuple[RecordedTrajectory, bool]:
    """Run the oracle of a suite primitive task once and return its commanded trajectory as a
    demonstration file's content (``taskcond record``), with whether the oracle succeeded."""
    task = get_task(task_id)
    if not isinstance(task, PrimitiveTask):
        raise ValueError(
            f"{task_id!r} is not a primitive task; record one of: {', '.join(primitive_task_ids())}"
        )
    env = make(task_id)
    try:
        env.reset(seed=seed)
        rows = [trajectory.action(i) for trajectory in task.plans(env) for i in range(len(trajectory))]
        for row in rows:
            env.step(row)
        success = bool(task.success(env))
        dt = env.dt
    finally:
        env.close()
    actions = np.array(rows)
    recorded = RecordedTrajectory(
        task_name=task.info.task_name,
        scene=task_id,
        seed=seed,
        times=np.arange(len(actions)) * dt,
        positions=actions[:, :3],
        orientations=actions[:, 3:7],
        gripper=actions[:, 7],
    )
    return recorded, success


def demonstration_id(task_name: str) -> str:
    """Skill id of a demonstration from a file: ``<primitive>-<object>[-<object>]`` with spaces as ``_``,
    like the suite's ids (``push_in_front-toothpaste-bottle``)."""
    task = parse_task(task_name)
    return "-".join([task.primitive.id, *(o.replace(" ", "_") for o in task.objects)])


def replay_demonstration(recorded: RecordedTrajectory) -> Demonstration:
    """Replay a demonstration file's trajectory in its scene (a suite task's initial state, else the default
    kitchen) and record it like an oracle's: the environment information at its start and end, the contacts
    during it, the target's centre and first contact.

    Raises:
        ValueError: an unknown scene, or a task whose objects the scene does not have.
    """
    env = KitchenEnv(FreeTask(recorded.task_name)) if recorded.scene is None else make(recorded.scene)
    try:
        env.reset(seed=recorded.seed)
        world = KitchenWorld(env)
        task = parse_task(recorded.task_name)
        reason = world.affords(task.primitive.id, task.objects)
        if reason is not None:
            raise ValueError(f"cannot replay {task.name!r}: {reason}")
        if recorded.arms > len(world.arms):
            raise ValueError(f"the demonstration moves {recorded.arms} arms, the scene has {len(world.arms)}")
        return _record(world, task.name, demonstration_id(task.name), recorded.actions(env.dt))
    finally:
        env.close()


def primitive_task_ids() -> list[str]:
    """Suite ids of every primitive task (the fold with both arms)."""
    return [t.id for t in list_tasks() if t.kind == "primitive"]


CONTEXTS = ("LHT1", "LHT2", "LHT3", "LHT4")
"""Long-horizon oracles whose steps are demonstrated too by default: the same primitives started from the
states a preceding primitive leaves (the hand at a drawer handle, above a box), which demonstrations
started from the home pose do not show. The novel-object tasks LHT1* and LHT2* are left out."""


def learn_library(
    directory: str | Path | None = None,
    task_ids: Iterable[str] | None = None,
    seed: int = 0,
    tries: int = 5,
    progress: Callable[[str, bool], None] | None = None,
) -> SkillLibrary:
    """Record oracle demonstrations and learn a skill from each (§III-D).

    Args:
        directory: where to save the library (plain files); not saved if None.
        task_ids: suite ids to demonstrate, default every primitive task and :data:`CONTEXTS`.
        seed: seed of the first try; a failed oracle run is recorded again with the next seed, up to
            ``tries`` times, and the last one is kept if none succeeded.
        progress: called with each task id and whether its oracle succeeded.
    """
    library = SkillLibrary()
    for task_id in [*primitive_task_ids(), *CONTEXTS] if task_ids is None else task_ids:
        for k in range(tries):
            demos, ok = record_demonstrations(task_id, seed + k)
            if ok:
                break
        for demo in demos:
            library.add(learn_skill(demo))
        if progress is not None:
            progress(task_id, ok)
    if directory is not None:
        library.save(directory)
    return library


__all__ = [
    "CONTEXTS",
    "DUAL_ARM_WORDS",
    "RANDOM_AREA",
    "RANDOM_MIN_RADIUS",
    "SCENES",
    "STARTS",
    "FreeTask",
    "KitchenWorld",
    "RandomStart",
    "demonstration_id",
    "final_predicates",
    "instruction_scene",
    "learn_library",
    "primitive_task_ids",
    "random_start",
    "record_demonstrations",
    "record_trajectory",
    "replay_demonstration",
    "scene_objects",
]
