"""The executor's :class:`~taskcond.execution.world.World` over the PyBullet kitchen suite: the world adapter.

The executor core (:mod:`taskcond.execution`) knows the simulator only through this module.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from functools import cache

import numpy as np
import pybullet as p

from taskcond.conditions import KINOVA_GRIPPER, Relation, SpatialRelation
from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.world import REACHED, Observation, Touch
from taskcond.primitives import get_primitive
from taskcond.sim.assets import ROUND_CLASSES, shape_class
from taskcond.sim.franka import HOME
from taskcond.sim.perception import EnvironmentInfo, Perception, PerceptionConfig
from taskcond.sim.recording import VideoRecorder
from taskcond.sim.roles import SceneObject, fits_into, hand_enters, scene_roles
from taskcond.sim.scene import DECLARED, TABLE
from taskcond.tasks.free import FreeTask

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


def _observation(
    info: EnvironmentInfo,
    round_: frozenset[str],
    lying: frozenset[str],
    shapes: dict[str, str],
    yaws: dict[str, float],
    openings: dict[str, np.ndarray],
) -> Observation:
    return Observation(
        predicates=info.predicates,
        centers={name: box.center for name, box in info.boxes.items()},
        touches=tuple(Touch(c.a, c.b, c.position) for c in info.contacts),
        boxes={name: (box.lower, box.upper) for name, box in info.boxes.items()},
        round=round_,
        lying=lying,
        shapes=shapes,
        yaws=yaws,
        openings=openings,
    )


HEADED = frozenset({"flat"})
"""Shape classes (:func:`~taskcond.sim.assets.shape_class`) whose heading about the vertical the kitchen
world perceives (:attr:`~taskcond.execution.world.Observation.yaws`, from the pose, like the robosuite
world's elongated objects): a flat object (the spatula) is held across its length, so a grasp demonstrated
at one heading is turned with it (issue 31: from random starts the spatula was grasped along or aslant its
handle, pivoted in the fingers and fell out of them)."""

WOUND_EVERY = 10
"""Every how many poses of a way :meth:`KitchenWorld.wound` solves from home."""
UNWIND_SPEED = 1.0
"""rad/s: the fastest joint's speed on :meth:`KitchenWorld.unwind`'s joint-space way home."""
UNWIND_SETTLE = 30
"""Most control steps :meth:`KitchenWorld.unwind` holds the home joints for the arm to arrive."""
UNWOUND = 0.02
"""rad: the largest joint's distance from home at which :meth:`KitchenWorld.unwind`'s arm has arrived."""

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
        self._shapes = {name: shape_class(spec) for name, (spec, _) in env.scene.config.free_objects.items()}
        """Free object → its shape class (:func:`~taskcond.sim.assets.shape_class`)."""
        self._round = frozenset(name for name, shape in self._shapes.items() if shape in ROUND_CLASSES)
        """Free objects of a turned-about-their-axis shape: cylinders (bottle, can), spheres and vessels
        (bowl, mug: held by the wall, which the mug's handle leaves free on most sides)."""
        self._roles: dict[str, SceneObject] | None = None
        """Every object's roles (:func:`~taskcond.sim.roles.scene_roles`), read when a move into is asked."""
        self._headed = tuple(name for name, shape in self._shapes.items() if shape in HEADED)
        """Free objects whose heading is perceived (:data:`HEADED`)."""
        self._vessels = tuple(name for name, shape in self._shapes.items() if shape == "vessel")
        """Free vessels, whose openings are perceived (:meth:`_opening`)."""
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
            lying = self._lying()
            yaws = {name: self.env.scene.yaw(name) for name in self._headed if name not in lying}
            openings = {name: self._opening(name) for name in self._vessels if name not in lying}
            observation = _observation(info, self._round, lying, self._shapes, yaws, openings)
            self._observed = (self.env.steps, observation)
        return self._observed[1]

    def _opening(self, vessel: str) -> np.ndarray:
        """:attr:`~taskcond.execution.world.Observation.openings`: the centre of ``vessel``'s interior
        (:meth:`~taskcond.sim.scene.KitchenScene.interior`, from its pose) raised to the interior's top."""
        inside = self.env.scene.interior(vessel)
        return inside.center + inside.rotation @ np.array([0.0, 0.0, inside.half_extents[2]])

    def _lying(self) -> frozenset[str]:
        """The free objects that fell over (:meth:`~taskcond.sim.scene.KitchenScene.lying`)."""
        return frozenset(self.env.scene.lying())

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
        prim = get_primitive(primitive)
        if prim.sets_container and objects[0] not in joints:
            return f"{objects[0]!r} has no lid, door or drawer (containers: {', '.join(joints)})"
        fixed = [objects[k] for k in prim.movable if objects[k] not in free]
        if fixed:
            return f"{fixed[0]!r} cannot be moved (movable objects: {', '.join(free)})"
        into = prim.effect(*objects) if prim.places is Relation.INSIDE else None
        if isinstance(into, SpatialRelation) and into.reference not in interiors:
            return f"{into.reference!r} is not a container (containers: {', '.join(interiors)})"
        if isinstance(into, SpatialRelation):
            return self._put_into(into.subject, into.reference)
        if primitive == "fold" and ("cloth" not in self._objects or len(self._arms) < 2):
            return "folding needs the cloth and two arms, which this scene does not have"
        return None

    def _put_into(self, a: str, c: str) -> str | None:
        """Why ``a`` cannot be put into the container ``c`` by their sizes and by this hand (the combination
        benchmark's rules, :func:`~taskcond.sim.roles.fits_into` and
        :func:`~taskcond.sim.roles.hand_enters`: "put the mug in the microwave" is refused at once with
        the reason it is not in the benchmark), or None; a container or object the roles do not know (the
        dual-arm scene's) is left to the run."""
        if self._roles is None:
            self._roles = scene_roles(self.env.scene.config)
        roles = self._roles
        if a not in roles or c not in roles or roles[c].interior is None:
            return None
        return fits_into(roles[a], roles[c]) or hand_enters(roles[a], roles[c])

    def reach_error(self, position: np.ndarray, orientation: np.ndarray | None = None) -> str | None:
        """:meth:`World.reach_error`: the Franka's pose is solved from :data:`~taskcond.sim.franka.HOME` and
        from its joints now; it misses only if both answers do."""
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
        if orientation is not None:
            robot = self.env.robot
            seeds = (np.array(HOME), robot.joint_positions())
            miss = min(robot.solve_ik(position[:3], orientation, seed).errors[0] for seed in seeds)
            if miss > REACHED:
                return f"the {self._arms[0]}'s hand misses that pose by {miss * 100:.0f} cm"
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
            seed = robot.solve_ik(position, orientation, seed).q
            qs.append(seed)
        return robot.clearance(qs, bodies, SWEEP_WITHIN)

    def wound(self, positions: np.ndarray, orientations: np.ndarray) -> bool:
        """The Franka's IK for each pose in turn, each seeded by the last (the current joints first), as
        :meth:`~taskcond.envs.kitchen.KitchenEnv.step` solves its commands, misses one by more than
        :data:`REACHED` (clipped at a joint limit, an arm wound far from home cannot turn on towards its
        target by small steps), where each pose from that one on, solved alone from
        :data:`~taskcond.sim.franka.HOME` (every :data:`WOUND_EVERY`-th and the last), is reached: they
        are not beyond the arm's reach. The joint-space way home (:meth:`unwind`) is not checked against
        the scene. Nothing moves."""
        robot = self.env.robot
        first = self._first_missed(positions, orientations)
        if first is None:
            return False
        home = np.array(HOME)
        picked = [*range(first, len(positions), WOUND_EVERY), len(positions) - 1]
        return all(robot.solve_ik(positions[k], orientations[k], home).errors[0] <= REACHED for k in picked)

    def follows(self, positions: np.ndarray, orientations: np.ndarray) -> bool:
        """:meth:`World.follows`: the Franka's IK for each pose in turn, each seeded by the last (the current
        joints first), as :meth:`~taskcond.envs.kitchen.KitchenEnv.step` solves its commands."""
        return self._first_missed(positions, orientations) is None

    def _first_missed(self, positions: np.ndarray, orientations: np.ndarray) -> int | None:
        """The index of the first pose ((m, 3) m, (m, 4) xyzw) the Franka's IK, each answer seeding the
        next from the current joints, misses by more than :data:`REACHED`, or None."""
        robot = self.env.robot
        seed = robot.joint_positions()
        for k, (position, orientation) in enumerate(zip(positions, orientations, strict=True)):
            result = robot.solve_ik(position, orientation, seed)
            if result.errors[0] > REACHED:
                return k
            seed = result.q
        return None

    def unwind(self, gripper: float, stepped: Callable[[], None] | None = None) -> str | None:
        """The Franka's joints moved back to :data:`~taskcond.sim.franka.HOME` along the straight line in
        joint space, its fastest joint at :data:`UNWIND_SPEED`, one control step at a time (no joint jumps),
        then held there until every joint is within :data:`UNWOUND` of home (at most :data:`UNWIND_SETTLE`
        steps), the gripper command ``gripper`` held; the next end-effector command's IK starts from home.
        ``stepped`` is called after each control step (an episode's observers). Returns a failure reason
        (a simulation blow-up) or None."""
        env = self.env
        start, home = env.robot.joint_positions(), np.array(HOME)
        n = max(1, math.ceil(float(np.abs(home - start).max()) / (UNWIND_SPEED * self.dt)))
        way = [start + (home - start) * (k / n) for k in range(1, n + 1)]
        settle = [home] * UNWIND_SETTLE
        for k, q in enumerate([*way, *settle]):
            if k >= n and float(np.abs(env.robot.joint_positions() - home).max()) < UNWOUND:
                break
            begun = time.perf_counter()
            outcome = env.step_joints(q, gripper)
            self.env_seconds += time.perf_counter() - begun
            reason = self._record(*outcome)
            if stepped is not None:
                stepped()
            if reason is not None:
                return reason
        return None

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
        outcome = self.env.step(action)
        self.env_seconds += time.perf_counter() - start
        return self._record(*outcome)

    def _record(
        self, obs: object, reward: float, terminated: bool, truncated: bool, info: dict[str, object]
    ) -> str | None:
        """After a control step (the environment's step answer): its video frame, and the failure reason
        it ended the episode with, if any."""
        if self.recorder is not None and self.env.steps % VIDEO_EVERY == 0:
            self.recorder.add(self.env.render())
        return str(info["failure"]) if terminated else None


def scene_objects(
    scene: str = "kitchen",
) -> tuple[tuple[str, ...], Callable[[str, tuple[str, ...]], str | None]]:
    """The object names of a scene (:data:`SCENES`) and what each primitive affords there (for
    decomposition); built once per scene and set of declared objects (:data:`~taskcond.sim.scene.DECLARED`)
    in a process, so that an object declared later is among them."""
    return _scene_objects(scene, tuple(DECLARED.values()))


@cache
def _scene_objects(
    scene: str, declared: tuple[object, ...]
) -> tuple[tuple[str, ...], Callable[[str, tuple[str, ...]], str | None]]:
    env = KitchenEnv(FreeTask("", scene=scene))
    try:
        world = KitchenWorld(env)
        return world.objects, world.affords
    finally:
        env.close()
