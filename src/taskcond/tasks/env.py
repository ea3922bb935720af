"""The Gymnasium-style environment of the task suite (paper §IV).

Action (8,) float: end-effector target position xyz (m, world frame), orientation quaternion xyzw, gripper
command (< 0.5 open, ≥ 0.5 closed); a (7,) action gives the orientation as roll-pitch-yaw (rad) instead.
Each step converts the target to joint positions with PyBullet IK (§III-E; a target equal to the previous
step's keeps its solution) and runs
:attr:`KitchenEnv.substeps` physics steps of 1/240 s under position control.

Observation (dict of float arrays): ``ee_position`` (3,), ``ee_orientation`` (4,), ``gripper_width``
(1,) m, ``joint_positions`` (7,) rad, ``object_poses`` (n, 7) position + xyzw of the free objects in the
order of :attr:`KitchenEnv.object_names`, ``container_open`` (4,) open fractions of
:data:`taskcond.sim.scene.ARTICULATED`, ``target`` (3,) goal position of ``move`` tasks (zeros otherwise).

``info``: ``success`` (bool), ``failure`` (reason string or ``None``), ``failure_detail`` (one line or
``None``), ``steps``. A simulation blow-up (NaN, an object leaving the workspace, deep interpenetration)
terminates the episode with its reason.

Episodes are independent: ``reset(seed=s)`` followed by the same actions gives the same trajectory, bit for
bit, in a fresh environment and in one that has run other episodes. Bullet keeps state across a reset that
no pose or velocity shows: persistent contact points (whose impulses warm-start the solver), the order of
overlapping pairs, and sleeping (a free object asleep at the end of one episode stayed asleep, hovering
where :meth:`~taskcond.sim.scene.KitchenScene.place` put it 0.5 mm above the counter). The client therefore
orders pairs deterministically (``deterministicOverlappingPairs``), and every reset first parks the free
objects far apart and out of reach with sleeping disabled and runs one physics step
(:meth:`KitchenEnv._forget_contacts`), which drops their contacts and wakes them.

Dual-arm tasks (the task's :meth:`~taskcond.tasks.base.Task.scene_config` adds the Kinova and the cloth):
the action may be (16,): the Franka's (8,) action followed by the Kinova's (8,) in the same layout (tool
centre point target, quaternion, gripper command); an (8,) or (7,) action moves the Franka only and the
Kinova holds its last command. The Kinova's target is converted by its own IK
(:meth:`taskcond.sim.kinova.KinovaArm.solve_ik`); a target beyond its reach or without a joint solution
ends the episode with failure ``kinova_unreachable`` and the IK's one-line message in ``failure_detail``.
The observation gains ``kinova_ee_position`` (3,), ``kinova_ee_orientation`` (4,), ``kinova_gripper_width``
(1,), ``kinova_joint_positions`` (7,) and, with the cloth, ``cloth_nodes`` (n*n, 3) world node positions.
After every control step the soft-body anchors of the grippers on the cloth are updated
(:class:`taskcond.sim.cloth.ClothGrips`).
"""

from __future__ import annotations

import math
from itertools import compress, repeat
from operator import itemgetter, ne, or_
from typing import Any, ClassVar, NamedTuple

import gymnasium as gym
import numpy as np
import pybullet as p
from gymnasium import spaces

from taskcond.sim.franka import ARM_JOINTS, FINGER_JOINTS, HOME, top_down
from taskcond.sim.kinova import GEN3_HOME
from taskcond.sim.scene import ARTICULATED, PHYSICS_HZ, FramePose, KitchenScene, SceneConfig
from taskcond.tasks.base import Task
from taskcond.tasks.groundtruth import GroundTruth, KnownState

WORKSPACE = (np.array([-0.4, -1.0, -0.2]), np.array([1.1, 1.0, 1.5]))
"""Bounds (min, max) in metres of where free objects may be; leaving them ends the episode."""
_WORKSPACE_BOUNDS = tuple(zip(WORKSPACE[0].tolist(), WORKSPACE[1].tolist(), strict=True))
"""(min, max) per world axis of :data:`WORKSPACE`, as floats for the per-step check."""
_ROBOT_JOINTS = (*ARM_JOINTS, *FINGER_JOINTS)
"""Franka joints read once per control step: the arm's seven, then the two fingers."""
_ARM_DOFS = len(ARM_JOINTS)
PENETRATION = 0.03
"""Contact depth (m) counted as a simulation blow-up."""
BODY_QUERIES = 3
"""Most contact queries per body (``p.getContactPoints(bodyA=...)``) the deep-penetration check makes
(:meth:`KitchenEnv._moved_bodies`); with more bodies to query it asks for every contact point at once."""
_DEEPER_THAN_PENETRATION = (-PENETRATION).__gt__
"""Whether a contact distance (m, negative inside) is below ``-PENETRATION``: ``False`` for NaN, as ``<``."""
_FIRST = itemgetter(0)
"""Item 0 of a ``p.getJointStates`` entry: the joint position (m or rad)."""
_CONTACT_DISTANCE = itemgetter(8)
"""Item 8 of a ``p.getContactPoints`` tuple: the contact distance (m, negative when penetrating)."""
RENDER_SIZE = (320, 240)
RENDER_EYE = (0.95, -0.95, 1.05)
"""Position (m, world) of the :meth:`KitchenEnv.render` camera: high in front of the table on the robot's
right (beyond the microwave), facing the robots, so that no arm hides the objects and both arms show."""
RENDER_TARGET = (0.32, 0.05, 0.05)
"""Point (m, world) the render camera looks at: the middle of the work area."""
KINOVA_IK_TOLERANCE = 0.005
"""Metres the Kinova's IK answer may miss an action's target before the episode fails."""
PARKING = (100.0, 0.0, 100.0)
"""World position (m) of the first free object parked at reset (:meth:`KitchenEnv._forget_contacts`); the
others follow :data:`PARKING_SPACING` apart along +x, far from each other and from every other body."""
PARKING_SPACING = 2.0
"""Metres between parked free objects (every object is smaller than 0.5 m)."""


class _Reading(NamedTuple):
    """The simulator state read once after a control step, shared by the blow-up check and the observation.

    Attributes:
        joints: positions of the Franka's :data:`~taskcond.sim.franka.ARM_JOINTS` (rad), then of its two
            :data:`~taskcond.sim.franka.FINGER_JOINTS` (m).
        bases: centre-of-mass pose (position m, quaternion xyzw, world) of each free object, in the order of
            :attr:`KitchenEnv.object_names`, as ``p.getBasePositionAndOrientation`` reports it.
        containers: container joint positions (m or rad) per articulated body
            (:meth:`~taskcond.sim.scene.KitchenScene.container_joint_positions`).
        open_fractions: open fraction of each container of :data:`~taskcond.sim.scene.ARTICULATED`, in that
            order, from ``containers`` (:meth:`~taskcond.sim.scene.KitchenScene.open_fractions`).
        cloth_nodes: (n*n, 3) world node positions (m) of the cloth, or ``None`` without one.
    """

    joints: list[float]
    bases: list[FramePose]
    containers: list[tuple[float, ...]]
    open_fractions: list[float]
    cloth_nodes: np.ndarray | None


class KitchenEnv(gym.Env):
    """One task of the suite in its own PyBullet client.

    Args:
        task: the task (see :func:`taskcond.tasks.registry.make`).
        seed: seed of the first :meth:`reset`.
        render_mode: ``"rgb_array"`` or ``None``.
        gui: PyBullet GUI instead of headless.
        config: scene parameters (novel objects).
        control_hz: actions per simulated second.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(
        self,
        task: Task,
        seed: int | None = None,
        render_mode: str | None = None,
        gui: bool = False,
        config: SceneConfig | None = None,
        control_hz: int = 30,
    ) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"unknown render_mode {render_mode!r}; valid: 'rgb_array', None")
        self.task = task
        self.render_mode = render_mode
        self.scene = KitchenScene(task.scene_config(config), gui=gui)
        p.setPhysicsEngineParameter(deterministicOverlappingPairs=1, physicsClientId=self.scene.client)
        self.truth = GroundTruth(self.scene)
        self.robot = self.scene.robot
        self.kinova = self.scene.kinova
        """The Kinova Gen3 (:class:`taskcond.sim.kinova.KinovaArm`) of dual-arm tasks, else ``None``."""
        self.substeps = PHYSICS_HZ // control_hz
        self.dt = self.substeps / PHYSICS_HZ
        self.object_names = self.scene.free_objects
        self._free_ids = [self.scene.bodies[n] for n in self.object_names]
        self._com_to_base = [self.scene.com_to_base(body) for body in self._free_ids]
        """Per free object, its base-link frame in its centre-of-mass frame (the observation's poses)."""
        self._base_frames: list[tuple[FramePose, tuple[float, ...]] | None] = [None] * len(self._free_ids)
        """Per free object, the last centre-of-mass pose :meth:`_object_poses` transformed and its base-link
        frame (position m + quaternion xyzw, world)."""
        self._poses_of: tuple[list[FramePose] | None, np.ndarray] = (None, np.zeros((0, 7)))
        """The free objects' centre-of-mass poses of the last observation and their base-link poses (n, 7)
        (:meth:`_object_poses`), which the observation copies while the poses compare equal."""
        self._fractions_of: tuple[list[tuple[float, ...]] | None, list[float]] = (None, [])
        """The container joint positions of the last reading and their open fractions."""
        self._tracked: tuple[int, ...] | None = None
        """Bodies whose state :meth:`_moved_bodies` compares, in the order of :meth:`_body_states`: the
        Franka, the free objects, the articulated containers; ``None`` in a scene with the Kinova or the
        cloth, whose check asks for every contact point."""
        if self.kinova is None and self.scene.cloth is None:
            self._tracked = (self.robot.body, *self._free_ids, *self.scene.articulated_bodies)
        self._checked_states: list[Any] | None = None
        """:meth:`_body_states` at the last deep-penetration check, ``None`` before the episode's first."""
        self._moved_before: list[bool] = []
        """Per tracked body, whether it had moved at the last check."""
        self.target = np.zeros(3)
        self.steps = 0
        self.failure: str | None = None
        self.failure_detail: str | None = None
        self._q = np.array(HOME)
        self._q_target: tuple[float, ...] | None = None
        """End-effector target (position, unit quaternion) whose IK solution :attr:`_q` is, or ``None``."""
        self._kq = np.array(GEN3_HOME)
        self._k_target: np.ndarray | None = None
        self._seed = seed
        n = len(self.object_names)
        box = spaces.Box
        self.observation_space = spaces.Dict(
            {
                "ee_position": box(-2, 2, (3,), np.float64),
                "ee_orientation": box(-1, 1, (4,), np.float64),
                "gripper_width": box(0, 0.1, (1,), np.float64),
                "joint_positions": box(-4, 4, (7,), np.float64),
                "object_poses": box(-np.inf, np.inf, (n, 7), np.float64),
                "container_open": box(-1, 2, (len(ARTICULATED),), np.float64),
                "target": box(-2, 2, (3,), np.float64),
            }
        )
        low, high = np.array([-1, -1, -0.2, -1, -1, -1, -1, 0.0]), np.array([1.2, 1, 1.2, 1, 1, 1, 1, 1.0])
        if self.kinova is not None:
            low, high = np.tile(low, 2), np.tile(high, 2)
            self.observation_space.spaces.update(
                {
                    "kinova_ee_position": box(-2, 2, (3,), np.float64),
                    "kinova_ee_orientation": box(-1, 1, (4,), np.float64),
                    "kinova_gripper_width": box(0, 0.1, (1,), np.float64),
                    "kinova_joint_positions": box(-7, 7, (7,), np.float64),
                }
            )
        if self.scene.cloth is not None:
            nodes = self.scene.config.cloth.resolution**2  # type: ignore[union-attr]
            self.observation_space.spaces["cloth_nodes"] = box(-np.inf, np.inf, (nodes, 3), np.float64)
        self.action_space = box(low, high, dtype=np.float64)

    # ------------------------------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Forget the previous episode's contacts (:meth:`_forget_contacts`), randomize the free objects'
        poses (seeded), close every container, put the arm home, then apply the task's initial state."""
        if seed is None and self._seed is not None:
            seed, self._seed = self._seed, None
        super().reset(seed=seed)
        rng = self.np_random
        self._forget_contacts()
        cfg = self.scene.config
        for name, (_, place) in cfg.free_objects.items():
            xy = np.array(place.xy) + rng.uniform(-cfg.position_noise, cfg.position_noise, 2)
            self.scene.place(name, xy, place.yaw + rng.uniform(-cfg.yaw_noise, cfg.yaw_noise))
        for name in ARTICULATED:
            self.scene.set_joint(name, 0.0)
        self.robot.reset(HOME)
        self._q, self._q_target = np.array(HOME), None
        if self.kinova is not None:
            self.kinova.reset_home()
            self._kq, self._k_target = np.array(GEN3_HOME), None
        if self.scene.cloth is not None:
            xy = np.array(cfg.cloth_center) + rng.uniform(-cfg.position_noise, cfg.position_noise, 2)
            self.scene.place_cloth(xy)
        self.target = np.zeros(3)
        self.steps = 0
        self.failure = None
        self.failure_detail = None
        self._checked_states = None
        self.task.setup(self, rng)
        self.settle(0.1)
        return self._obs(), self._info()

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        action = np.asarray(action, dtype=float)
        if action.shape == (7,):
            orn = np.array(p.getQuaternionFromEuler(action[3:6]))
            action = np.concatenate([action[:3], orn, action[6:]])
        kinova_action = None
        if action.shape == (16,) and self.kinova is not None:
            action, kinova_action = action[:8], action[8:]
        if action.shape != (8,):
            valid = "(16,), (8,) or (7,)" if self.kinova is not None else "(8,) or (7,)"
            raise ValueError(f"action must have shape {valid}, got {action.shape}")
        if self.failure is None and kinova_action is not None:
            self._command_kinova(kinova_action)
        if self.failure is None:
            x, y, z, qx, qy, qz, qw, gripper = action.tolist()
            # numpy's dot of the quaternion sums the products in this order (OpenBLAS's loop for vectors
            # this short; the same bits on 10^6 random quaternions), so the target is unchanged
            norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw) or 1.0
            # Solving an unchanged target again from its solution moved the end effector by < 2 µm (99th
            # percentile of 7,100 reachable targets logged from oracle episodes); beyond the joint limits it
            # only crept along them (up to 5 mm per call), so the solution is kept.
            target = (x, y, z, qx / norm, qy / norm, qz / norm, qw / norm)
            if target != self._q_target:
                self._q = self.robot.ik(target[:3], target[3:], seed=self._q)
                self._q_target = target
            self.robot.command(self._q, closed=gripper >= 0.5)
            client = self.scene.client
            for _ in range(self.substeps):
                p.stepSimulation(client)
            if self.scene.grips is not None:
                self.scene.grips.update()
        reading = self._read()
        contacts: dict[int, Any] = {}
        if self.failure is None:
            self.failure = self._check_blowup(reading, contacts)
        self.steps += 1
        success = False
        if self.failure is None:
            # nothing moves until the step returns: the success check takes the state just read
            self.truth.known = KnownState(reading.bases, reading.open_fractions, contacts)
            try:
                success = self.task.success(self)
            finally:
                self.truth.known = None
        terminated = self.failure is not None
        truncated = self.steps >= self.task.max_steps
        return self._obs(reading), float(success), terminated, truncated, self._info(success)

    def _command_kinova(self, action: np.ndarray) -> None:
        """Kinova motor targets for an (8,) action; a target it cannot reach sets :attr:`failure`."""
        assert self.kinova is not None
        target = action[:7].copy()
        target[3:7] /= np.linalg.norm(target[3:7]) or 1.0
        if self._k_target is None or not np.allclose(target, self._k_target, atol=1e-7):
            try:
                result = self.kinova.solve_ik(target[:3], target[3:7], seed=self._kq)
            except ValueError as err:
                self.failure, self.failure_detail = "kinova_unreachable", str(err)
                return
            if result.position_error > KINOVA_IK_TOLERANCE or not result.within_limits:
                self.failure = "kinova_unreachable"
                self.failure_detail = (
                    f"no Kinova Gen3 joint solution for {np.round(target[:3], 3).tolist()}: IK is "
                    f"{result.position_error * 1000:.1f} mm off"
                    f"{'' if result.within_limits else ', outside the joint limits'}"
                )
                return
            self._kq, self._k_target = result.q, target
            self.kinova.set_joint_targets(result.q)
        if action[7] >= 0.5:
            self.kinova.close_gripper()
        else:
            self.kinova.open_gripper()

    def render(self) -> np.ndarray:
        """RGB image (240, 320, 3) uint8 from a fixed camera in front of the table on the robot's right,
        looking at the work area (:data:`RENDER_EYE`, :data:`RENDER_TARGET`; CPU renderer)."""
        w, h = RENDER_SIZE
        view = p.computeViewMatrix(RENDER_EYE, RENDER_TARGET, (0, 0, 1))
        proj = p.computeProjectionMatrixFOV(60, w / h, 0.05, 4.0)
        img = p.getCameraImage(
            w, h, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=self.scene.client
        )[2]
        return np.asarray(img, dtype=np.uint8).reshape(h, w, 4)[:, :, :3].copy()

    def close(self) -> None:
        self.scene.close()

    # -------------------------------------------------------------------------------------- helpers
    def settle(self, seconds: float) -> None:
        """Step the physics for ``seconds`` holding the current commands (reset time)."""
        for _ in range(round(seconds * PHYSICS_HZ)):
            p.stepSimulation(physicsClientId=self.scene.client)

    def _forget_contacts(self) -> None:
        """Drop the free objects' persistent contact points and sleeping state (reset time): park them
        :data:`PARKING_SPACING` apart from :data:`PARKING`, out of contact with anything, and run one physics
        step with sleeping disabled, which removes their contact pairs and zeroes their sleep timers; then
        allow sleeping again. Everything the step moves is put in place by :meth:`reset` afterwards."""
        client = self.scene.client
        for k, body in enumerate(self._free_ids):
            p.changeDynamics(
                body, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=client
            )
            position = (PARKING[0] + k * PARKING_SPACING, PARKING[1], PARKING[2])
            p.resetBasePositionAndOrientation(body, position, (0, 0, 0, 1), physicsClientId=client)
        p.stepSimulation(physicsClientId=client)
        for body in self._free_ids:
            p.changeDynamics(
                body, -1, activationState=p.ACTIVATION_STATE_ENABLE_SLEEPING, physicsClientId=client
            )

    def hold(self, name: str, lift: float, grasp: Any) -> None:
        """Reset-time set-up of a held object: lift ``name`` by ``lift`` m where it stands, put the open
        hand around it at the grasp pose ``grasp`` (a :class:`taskcond.tasks.skills.GraspPose`), close the
        fingers and let the grasp settle."""
        pos, _ = self.scene.pose(name)
        yaw = self.scene.yaw(name)
        self.scene.place(name, pos[:2], yaw, z=lift)
        ee, orn = grasp.pose(self.scene, name)
        q = self.robot.ik(ee, orn, seed=np.array(HOME))
        q = self.robot.ik(ee, orn, seed=q)
        self.robot.reset(q, finger=grasp.width / 2 + 0.002)
        self.robot.command(q, closed=True)
        self._q, self._q_target = q, None
        self.settle(0.3)

    def home_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """End-effector pose of the home joint configuration."""
        return self.robot.fk(np.array(HOME)).position, np.array(top_down())

    def _read(self) -> _Reading:
        """Read the Franka's joints, the free objects' poses, the container joints and the cloth's nodes
        (one query each, one per articulated body). While the container joints compare equal to the previous
        reading's, its open fractions are reused (they are a function of the joints alone)."""
        scene, client = self.scene, self.scene.client
        containers = scene.container_joint_positions()
        if containers != self._fractions_of[0]:
            self._fractions_of = (containers, scene.open_fractions(containers))
        return _Reading(
            list(map(_FIRST, p.getJointStates(self.robot.body, _ROBOT_JOINTS, client))),
            list(map(p.getBasePositionAndOrientation, self._free_ids, repeat(client))),
            containers,
            self._fractions_of[1],
            scene.cloth_nodes() if scene.cloth is not None else None,
        )

    def _obs(self, reading: _Reading | None = None) -> dict[str, np.ndarray]:
        """The observation (see the module docstring), from ``reading`` if given, else read now."""
        if reading is None:
            reading = self._read()
        ee_position, ee_orientation = self.robot.ee_frame()
        bases = reading.bases
        if bases != self._poses_of[0]:
            self._poses_of = (bases, np.array(self._object_poses(bases)).reshape(len(bases), 7))
        joints = reading.joints
        obs = {
            "ee_position": np.array(ee_position),
            "ee_orientation": np.array(ee_orientation),
            "gripper_width": np.array([joints[_ARM_DOFS] + joints[_ARM_DOFS + 1]]),
            "joint_positions": np.array(joints[:_ARM_DOFS]),
            "object_poses": self._poses_of[1].copy(),
            "container_open": np.array(reading.open_fractions),
            "target": self.target.copy(),
        }
        if self.kinova is not None:
            position, orientation = self.kinova.ee_pose()
            obs["kinova_ee_position"] = position
            obs["kinova_ee_orientation"] = orientation
            obs["kinova_gripper_width"] = np.array([self.kinova.gripper_opening()])
            obs["kinova_joint_positions"] = self.kinova.joint_positions()
        if reading.cloth_nodes is not None:
            obs["cloth_nodes"] = reading.cloth_nodes
        return obs

    def _object_poses(self, bases: list[FramePose]) -> list[float]:
        """Base-link pose (position m + quaternion xyzw, world) of each free object, concatenated, from the
        centre-of-mass poses ``bases``: :meth:`~taskcond.sim.scene.KitchenScene.base_frame` with each
        object's transform looked up once at construction. It is a function of the centre-of-mass pose
        alone, so an object that kept its pose keeps its frame."""
        flat: list[float] = []
        frames = self._base_frames
        for k, (pose, (offset, rotation)) in enumerate(zip(bases, self._com_to_base, strict=True)):
            cached = frames[k]
            if cached is None or cached[0] != pose:
                position, orientation = p.multiplyTransforms(pose[0], pose[1], offset, rotation)
                cached = frames[k] = (pose, position + orientation)
            flat += cached[1]
        return flat

    def _info(self, success: bool = False) -> dict[str, Any]:
        return {
            "success": success,
            "failure": self.failure,
            "failure_detail": self.failure_detail,
            "steps": self.steps,
        }

    def _body_states(self, reading: _Reading) -> list[Any]:
        """What places each body of :attr:`_tracked`, from ``reading``: the Franka's joint positions (its
        base is fixed), each free object's base pose, each articulated container's joint positions."""
        return [reading.joints, *reading.bases, *reading.containers]

    def _moved_bodies(self, reading: _Reading) -> list[int] | None:
        """The bodies whose contacts the deep-penetration check must read after this control step, or
        ``None`` for all contact points (the episode's first check, a scene with the Kinova or the cloth,
        more than :data:`BODY_QUERIES` bodies); records the states of ``reading`` for the next check.

        A body counts if its state (:meth:`_body_states`, compared bit for bit) changed since the last check
        or had changed at the one before. Bullet updates a pair's contact points only in a physics step; of
        a pair whose two bodies kept their state, the step recomputes the same points (the first step after
        a body stopped moves its points from where it was during its last step to where it stopped, hence
        the second check). The bodies not tracked (table, the containers' bases) are fixed. So every contact
        point not read has been read, with the same depth, at an earlier check of the episode, which found
        none too deep: over 10,438 control steps of oracle episodes of 13 tasks, the 152,648 contact points
        of unmoved pairs were those of the check before, bit for bit."""
        states = self._body_states(reading)
        before, self._checked_states = self._checked_states, states
        if self._tracked is None or before is None:
            self._moved_before = [True] * len(states)
            return None
        # the lists have one entry per tracked body (the scene's bodies are fixed at construction)
        moved = list(map(ne, states, before))
        bodies = list(compress(self._tracked, map(or_, moved, self._moved_before)))
        self._moved_before = moved
        return bodies if len(bodies) <= BODY_QUERIES else None

    def _check_blowup(self, reading: _Reading, contacts: dict[int, Any]) -> str | None:
        """The blow-up of the state in ``reading`` and the current contacts, or ``None``: ``nan_state`` (a
        non-finite Franka arm joint, free-object position, Kinova joint or cloth node),
        ``<object>_left_workspace`` (the first free object whose centre of mass is outside
        :data:`WORKSPACE`), ``cloth_left_workspace``, ``deep_penetration`` (a rigid contact deeper than
        :data:`PENETRATION`; the contacts of the bodies :meth:`_moved_bodies` names, all of them when it
        names none), checked in this order. The contact points read body by body are put in ``contacts``
        (body id → ``p.getContactPoints(bodyA=body)``) for the success check."""
        if not all(map(math.isfinite, reading.joints[:_ARM_DOFS])):
            return "nan_state"
        (x_lo, x_hi), (y_lo, y_hi), (z_lo, z_hi) = _WORKSPACE_BOUNDS
        for (x, y, z), _ in reading.bases:
            # NaN fails every comparison, so this passes exactly the finite positions inside
            if not (x_lo <= x <= x_hi and y_lo <= y <= y_hi and z_lo <= z <= z_hi):
                positions = np.array([com for com, _ in reading.bases])
                if not np.isfinite(positions).all():
                    return "nan_state"
                outside = ((positions < WORKSPACE[0]) | (positions > WORKSPACE[1])).any(axis=1)
                return f"{self.object_names[int(np.argmax(outside))]}_left_workspace"
        if self.kinova is not None and not np.all(np.isfinite(self.kinova.joint_positions())):
            return "nan_state"
        if reading.cloth_nodes is not None:
            nodes = reading.cloth_nodes
            if not np.all(np.isfinite(nodes)):
                return "nan_state"
            if np.any(nodes < WORKSPACE[0]) or np.any(nodes > WORKSPACE[1]):
                return "cloth_left_workspace"
        client = self.scene.client
        bodies = self._moved_bodies(reading)
        if bodies is not None:
            for body in bodies:
                points = contacts[body] = p.getContactPoints(bodyA=body, physicsClientId=client)
                if any(map(_DEEPER_THAN_PENETRATION, map(_CONTACT_DISTANCE, points))):
                    return "deep_penetration"
            return None
        points = p.getContactPoints(physicsClientId=client)
        if not any(map(_DEEPER_THAN_PENETRATION, map(_CONTACT_DISTANCE, points))):
            return None
        soft = self.scene.cloth  # soft contacts report no meaningful depth
        for pt in points:
            if _DEEPER_THAN_PENETRATION(pt[8]) and soft not in (pt[1], pt[2]):
                return "deep_penetration"
        return None
