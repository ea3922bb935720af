"""The cloth tasks of the suite (paper §IV, Table I): PT6 Fold (dual-arm), grasp the cloth (PT1 on a soft
object) and the cloth step of LHT4, "move spatula on top of cloth".

Scene: :func:`taskcond.sim.scene.dual_arm_config`: the Kinova Gen3 on the Franka's left (+y), the cloth
(:mod:`taskcond.sim.cloth`) flat between them with its edges along x and y. The cloth's local ``-x`` edge
faces the robots; its ``-y`` end is the Franka's side, its ``+y`` end the Kinova's.

Fold oracle (scripted, dual-arm): the Franka takes the near edge's ``-y`` corner and the Kinova its ``+y``
corner, both top-down with the fingers closing across the edge; both lift the edge, carry it over the fold
line on a half-ellipse and lay it onto the far (``+x``) edge, then let go and rise. Timing is shared, so
the edge stays straight. With an object lying on the cloth (LHT4's spatula), the edge is laid beyond the
far edge by :data:`OVERSHOOT` times the object's height, as the top layer draped over it springs back.

Fold success, measured on the simulation mesh (:func:`taskcond.sim.cloth.fold_measure`): at least
:data:`MIN_DOUBLE_FRACTION` of half the cloth's area is covered by two layers, the moved edge lies on the
far edge (mean node distance at most :data:`MAX_EDGE_DISTANCE`), and neither gripper holds the cloth.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
from scipy.spatial.transform import Rotation

from taskcond.conditions import KINOVA_GRIPPER, GripperState, Predicate, Relation, SpatialRelation
from taskcond.envs.kitchen import KitchenEnv
from taskcond.sim.cloth import ClothSpec, FoldMeasure, fold_measure
from taskcond.sim.franka import top_down
from taskcond.sim.scene import SceneConfig, dual_arm_config
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.dual_arm import DualArmMotionPlan
from taskcond.tasks.groundtruth import GroundTruth
from taskcond.tasks.motion_plan import MotionPlan, Waypoint
from taskcond.tasks.motions import CLOSED, GRIP_TIME, OPEN, bottom_to_com, carry, nearest_grip, plan

MIN_DOUBLE_FRACTION = 0.75
"""Fold success: fraction of half the cloth's area that must lie under two layers."""
MAX_EDGE_DISTANCE = 0.03
"""Fold success: largest mean distance (m) between the moved edge's nodes and the far edge's."""
MOVED_EDGE, ONTO_EDGE = "-x", "+x"
"""The fold lays the cloth's near edge (facing the robots) onto its far edge."""
FINGERTIP_CLEARANCE = 0.009
"""Height (m) of the fingertips above the table when a gripper closes on the cloth: the middle of the heights
from which the grasp anchors the cloth (0-16 mm with :attr:`ClothSpec.pad_margin` 20 mm, measured on
fold-cloth seed 0), so that an executor's goal moved by the perceived cloth's height (noise σ = 5 mm)
neither puts the fingertips on the table (as 2 mm did when the cloth was perceived low, an unallowed
collision) nor grasps above the cloth."""
FRANKA_GRASP_Z = 0.011 + FINGERTIP_CLEARANCE
"""Franka end-effector height (m) grasping the cloth on the table: fingertips
:data:`FINGERTIP_CLEARANCE` above it."""
KINOVA_GRASP_Z = 0.020 + FINGERTIP_CLEARANCE
"""Kinova tool-centre-point height (m) grasping the cloth: fingertips :data:`FINGERTIP_CLEARANCE` above the
table."""
INSET = 0.012
"""Metres the grasp point lies inside the cloth from the corner, along both edges."""
ARC_HEIGHT = 0.8
"""Height of the fold's half-ellipse as a fraction of its half-width (half the cloth's length). Below 1,
the ellipse stays inside the circle about the fold line the grasped edge could reach with the cloth taut,
so the lower half is never dragged."""
ARC_POINTS = 8
ARC_TIME = 2.4
"""Seconds of the fold's arc."""
PLACE_Z = 0.012
"""Height (m) above the grasp height where the moved edge is let go (on top of the lower layer)."""
OVERSHOOT = 0.5
"""The fold lays the moved edge this many times the height of the tallest object lying on the cloth
(:func:`height_on_cloth`) beyond the far edge: the top layer draped over the object springs back once let
go (the measurements that chose 0.5 are in BENCHMARKS.md, "Values chosen by measurement")."""
CLOTH_LIFT = 0.05
"""Grasp cloth success: the highest cloth node is at least this high (m) above the table."""


def _up(z: float) -> np.ndarray:
    """Vertical offset (3,) of ``z`` m."""
    return np.array([0.0, 0.0, z])


def _require_cloth(env: KitchenEnv, task: str) -> ClothSpec:
    if env.scene.cloth is None or env.scene.config.cloth is None:
        raise ValueError(
            f"{task} needs a cloth in the scene, and this scene has none (SceneConfig.cloth is None)"
        )
    return env.scene.config.cloth


def measure(env: KitchenEnv) -> FoldMeasure:
    """The fold measure of the current cloth (see :func:`taskcond.sim.cloth.fold_measure`).

    Raises:
        ValueError: the scene has no cloth.
    """
    spec = _require_cloth(env, "the fold measure")
    return fold_measure(env.scene.cloth_nodes(), spec, MOVED_EDGE, ONTO_EDGE)


def folded(env: KitchenEnv, horizontal: bool = False) -> bool:
    """Whether the cloth is folded in half (:data:`MIN_DOUBLE_FRACTION`, :data:`MAX_EDGE_DISTANCE`);
    ``False`` without a cloth.

    Args:
        horizontal: measure the moved edge's miss in the xy-plane (:attr:`FoldMeasure.edge_offset`), for a
            fold over an object that holds the top layer up (LHT4's spatula: 39 mm tall on the cloth).
    """
    if env.scene.cloth is None:
        return False
    m = measure(env)
    miss = m.edge_offset if horizontal else m.edge_distance
    return m.double_fraction >= MIN_DOUBLE_FRACTION and miss <= MAX_EDGE_DISTANCE


def height_on_cloth(env: KitchenEnv) -> float:
    """Height (m) above the table of the top of the tallest free object lying on the cloth: its centre over
    the xy bounding box of the cloth's nodes and its bottom less than 2 cm above the cloth's highest node;
    0 without one."""
    nodes = env.scene.cloth_nodes()
    lo_cloth, hi_cloth = nodes[:, :2].min(axis=0), nodes[:, :2].max(axis=0)
    top = 0.0
    for name in env.scene.free_objects:
        lo, hi = env.scene.aabb(name)
        centre = (lo[:2] + hi[:2]) / 2
        on = np.all(centre >= lo_cloth) and np.all(centre <= hi_cloth) and lo[2] < nodes[:, 2].max() + 0.02
        if on:
            top = max(top, float(hi[2]))
    return top


def _cloth_axes(env: KitchenEnv, spec: ClothSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Current corners of the moved edge (2, 3) (``-y`` end first), of the far edge (2, 3), and the unit
    horizontal direction (3,) from the moved edge to the far edge."""
    nodes = env.scene.cloth_nodes()
    moved, onto = spec.edge(MOVED_EDGE), spec.edge(ONTO_EDGE)
    near = nodes[[moved[0], moved[-1]]]
    far = nodes[[onto[0], onto[-1]]]
    direction = (far - near).mean(axis=0)
    direction[2] = 0.0
    return near, far, direction / np.linalg.norm(direction)


class Fold(PrimitiveTask):
    """PT6 Fold the cloth in half with both arms (see the module docstring)."""

    primitive_id = "fold"
    max_steps = 360

    def __init__(self, obj: str = "cloth") -> None:
        super().__init__(obj)

    def scene_config(self, config: SceneConfig | None) -> SceneConfig | None:
        return dual_arm_config(config)

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (GripperState(None), GripperState(None, KINOVA_GRIPPER))

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        return folded(env)

    def plans(self, env: KitchenEnv) -> Iterator[DualArmMotionPlan]:  # type: ignore[override]
        yield fold_trajectory(env)


def fold_trajectory(env: KitchenEnv) -> DualArmMotionPlan:
    """The dual-arm fold oracle, planned from the current cloth (see the module docstring).

    Raises:
        ValueError: the scene has no cloth or no Kinova.
    """
    spec = _require_cloth(env, "fold")
    if env.kinova is None:
        raise ValueError("fold needs the Kinova in the scene (SceneConfig.kinova)")
    near, far, ahead = _cloth_axes(env, spec)
    along = (near[1] - near[0]) / np.linalg.norm(near[1] - near[0])
    yaw = math.atan2(ahead[1], ahead[0]) + math.pi / 2  # fingers close along the edge
    overshoot = OVERSHOOT * height_on_cloth(env)
    orientation = np.array(top_down(yaw))
    arms: list[list[Waypoint]] = []
    for k, grasp_z in ((0, FRANKA_GRASP_Z), (1, KINOVA_GRASP_Z)):
        inward = ahead * INSET + along * (INSET if k == 0 else -INSET)
        start = near[k] + inward
        start[2] = grasp_z
        goal = far[k] + ahead * (overshoot - INSET) + along * (INSET if k == 0 else -INSET)
        goal[2] = grasp_z + PLACE_Z
        half = float((goal - start) @ ahead) / 2
        mid = start + ahead * half
        wps = [
            Waypoint(start + _up(0.08), orientation, OPEN),
            Waypoint(start, orientation, OPEN),
            Waypoint(start, orientation, CLOSED),
        ]
        for theta in np.linspace(0, math.pi, ARC_POINTS + 1)[1:]:
            point = mid - ahead * half * math.cos(theta)
            point[2] = grasp_z + ARC_HEIGHT * half * math.sin(theta)
            wps.append(Waypoint(point, orientation, CLOSED))
        wps += [
            Waypoint(goal, orientation, CLOSED),
            Waypoint(goal, orientation, OPEN),
            Waypoint(goal + _up(0.08), orientation, OPEN),
        ]
        arms.append(wps)
    durations = [1.6, 0.8, GRIP_TIME, *([ARC_TIME / ARC_POINTS] * ARC_POINTS), 0.6, GRIP_TIME, 0.6]
    return DualArmMotionPlan.from_waypoints(env, arms[0], arms[1], durations)


class GraspCloth(PrimitiveTask):
    """PT1 Grasp on the cloth: the Franka takes the near ``-y`` corner from above and lifts it.

    Success: ``gripper grasping cloth`` (the anchors of a closed grip) and the cloth's highest node at
    least :data:`CLOTH_LIFT` m above the table.
    """

    primitive_id = "grasp"
    max_steps = 200

    def __init__(self) -> None:
        super().__init__("cloth")

    def scene_config(self, config: SceneConfig | None) -> SceneConfig | None:
        return dual_arm_config(config)

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (GripperState("cloth"),)

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        return env.scene.cloth is not None and float(env.scene.cloth_nodes()[:, 2].max()) >= CLOTH_LIFT

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        spec = _require_cloth(env, "grasp cloth")
        near, _, ahead = _cloth_axes(env, spec)
        along = (near[1] - near[0]) / np.linalg.norm(near[1] - near[0])
        orientation = np.array(top_down(math.atan2(ahead[1], ahead[0])))
        start = near[0] + (ahead + along) * INSET
        start[2] = FRANKA_GRASP_Z
        return [
            Waypoint(start + _up(0.08), orientation, OPEN),
            Waypoint(start, orientation, OPEN, 0.8),
            Waypoint(start, orientation, CLOSED, GRIP_TIME),
            Waypoint(start + _up(0.12), orientation, CLOSED, 1.0),
            Waypoint(start + _up(0.12), orientation, CLOSED, 0.3),
        ]


SPATULA_ON_CLOTH = 0.3
"""Where LHT4 puts the spatula: this fraction of the cloth's length beyond its centre, towards the far
edge (the half the fold covers), turned along the fold line. Resting on the cloth, the spatula holds the
top layer up: at 0.35 the moved edge came to lie on its blade; at 0.1 the fold tipped it over."""
DROP = 0.012
"""Height (m) of the spatula's lowest point above the cloth's top where the oracle lets go."""


class MoveOntoCloth(PrimitiveTask):
    """PT8 Move A on top of the cloth, the step of LHT4: carry the held A over the half of the cloth the fold
    will cover, turned parallel to the fold line, and lower it onto the cloth.

    Success: ``A above cloth`` with A's lowest point at most 3 cm above the cloth's top.
    """

    primitive_id = "move_on_top"
    max_steps = 300

    def __init__(self, obj: str = "spatula") -> None:
        super().__init__(obj, "cloth")

    def scene_config(self, config: SceneConfig | None) -> SceneConfig | None:
        return dual_arm_config(config)

    def post_conditions(self) -> tuple[Predicate, ...]:
        return (SpatialRelation(self.objects[0], Relation.ABOVE, "cloth"),)

    def extra_success(self, env: KitchenEnv, judge: GroundTruth) -> bool:
        return judge.height_over(self.objects[0], "cloth") <= 0.03

    def waypoints(self, env: KitchenEnv) -> list[Waypoint]:
        spec = _require_cloth(env, "move onto cloth")
        obj = self.objects[0]
        near, far, ahead = _cloth_axes(env, spec)
        centre = (near.sum(axis=0) + far.sum(axis=0)) / 4
        _, hi = env.scene.aabb("cloth")
        goal = centre + ahead * spec.size * SPATULA_ON_CLOTH
        goal[2] = hi[2] + DROP + bottom_to_com(env, obj)
        hand = env.robot.ee_pose().orientation
        # the object's long axis (hand yaw + grasp offset 0) turned to lie along the fold line
        turned = (Rotation.from_euler("z", math.pi / 2) * Rotation.from_quat(hand)).as_quat()
        turned = nearest_grip(turned, hand)
        return carry(env, obj, goal, clearance=hi[2] + 0.05, orientation=turned)


def held_by_kinova(env: KitchenEnv, trajectory: MotionPlan) -> DualArmMotionPlan:
    """A single-arm (Franka) trajectory as a dual-arm one, the Kinova holding still."""
    return DualArmMotionPlan.hold(env, trajectory)


__all__ = [
    "MAX_EDGE_DISTANCE",
    "MIN_DOUBLE_FRACTION",
    "Fold",
    "GraspCloth",
    "MoveOntoCloth",
    "fold_trajectory",
    "folded",
    "measure",
    "plan",
]
