"""The suite's task kinds for free instructions and random starts: :class:`FreeTask` (an instruction's episode
in a scene), :class:`RandomStart` (a suite task from a random start state, :func:`random_start`), and
:func:`final_predicates`, what holds at an episode's end by the ground truth, and :func:`fallen_objects`, what
lies there fallen over.
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np
import pybullet as p

from taskcond.conditions import (
    KINOVA_GRIPPER,
    ContainerState,
    GripperState,
    Predicate,
    Relation,
    SpatialRelation,
)
from taskcond.envs.kitchen import KitchenEnv
from taskcond.primitives import parse_task
from taskcond.sim.scene import TABLE, SceneConfig, dual_arm_config
from taskcond.tasks.base import Task, TaskInfo
from taskcond.tasks.close import DOOR_START
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.move import free_goal

SCENES = ("kitchen", "dual-arm")
"""Scenes of a free instruction: the default kitchen (the Franka, containers closed) or the dual-arm
kitchen of the cloth tasks (:func:`taskcond.sim.scene.dual_arm_config`: the Kinova and the cloth, without
the free objects that lie near the cloth)."""


class StartMode(StrEnum):
    """Where an episode starts (``--start``)."""

    TASK = "task"
    """The task's own start (a free instruction: the scene's reset, free objects near their nominal spots,
    containers closed, arms home)."""
    RANDOM = "random"
    """:func:`random_start` (a suite task: :class:`RandomStart`)."""


STARTS: tuple[StartMode, ...] = tuple(StartMode)
"""Every start mode."""

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
        moved = [parse_task(s).objects[0] for s in self.info.primitive if parse_task(s).primitive.to_position]
        if moved and moved[0] in env.scene.free_objects:
            env.target = free_goal(env, moved[0], rng)

    def success(self, env: KitchenEnv, truth: GroundTruth | None = None) -> bool:
        return False


def fallen_objects(env: KitchenEnv) -> list[str]:
    """The free objects that lie at the end of an episode (fell over, :meth:`~taskcond.sim.scene.
    KitchenScene.lying`) and that no gripper holds (a tilted bottle in the hand did not fall), sorted: what
    an episode's ``fallen`` reports."""
    grippers = ["gripper", *((KINOVA_GRIPPER,) if env.kinova is not None else ())]
    held = {o for o in env.scene.lying() for g in grippers if env.truth.holds(GripperState(o, g))}
    return sorted(set(env.scene.lying()) - held)


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
