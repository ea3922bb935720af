"""The Gymnasium-style environment of the task suite (paper §IV): one task
(:class:`~taskcond.envs.protocol.Task`) in its own PyBullet kitchen
(:class:`~taskcond.sim.scene.KitchenScene`).

Action (8,) float: end-effector target position xyz (m, world frame), orientation quaternion xyzw, gripper
command (< 0.5 open, ≥ 0.5 closed); a (7,) action gives the orientation as roll-pitch-yaw (rad) instead.
Each step converts the target to joint positions with the arm's IK (:meth:`taskcond.sim.arm.Arm.solve_ik`,
PyBullet's; §III-E; a target equal to the previous step's keeps its solution) and runs
:attr:`KitchenEnv.substeps` physics steps of 1/240 s under position control.

Observation (dict of float arrays): ``ee_position`` (3,), ``ee_orientation`` (4,), ``gripper_width``
(1,) m, ``joint_positions`` (7,) rad, ``object_poses`` (n, 7) position + xyzw of the free objects in the
order of :attr:`KitchenEnv.object_names`, ``container_open`` (4,) open fractions of
:data:`taskcond.sim.scene.ARTICULATED`, ``target`` (3,) goal position of ``move`` tasks (zeros otherwise).

``info``: ``success`` (bool), ``failure`` (reason string or ``None``), ``failure_detail`` (one line or
``None``), ``steps``. A simulation blow-up (NaN, an object leaving the workspace, deep interpenetration)
terminates the episode with its reason (:class:`~taskcond.envs.reader.BlowupMonitor`).

After each control step the state is read once (:class:`~taskcond.envs.reader.StepReader`); the observation,
the blow-up check and the task's success judge (``env.truth.at(reading)``) all take that reading.

Episodes are independent: ``reset(seed=s)`` followed by the same actions gives the same trajectory, bit for
bit, in a fresh environment and in one that has run other episodes (:meth:`BlowupMonitor.reset
<taskcond.envs.reader.BlowupMonitor.reset>` forgets the previous episode's contacts and sleeping state).

Dual-arm tasks (the task's :meth:`~taskcond.envs.protocol.Task.scene_config` adds the Kinova and the cloth):
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
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pybullet as p
from gymnasium import spaces

from taskcond.envs.protocol import Task
from taskcond.envs.reader import ARM_DOFS, BlowupMonitor, Reading, StepReader
from taskcond.sim.arm import command_gripper
from taskcond.sim.franka import HOME, top_down
from taskcond.sim.kinova import GEN3_HOME
from taskcond.sim.scene import ARTICULATED, PHYSICS_HZ, KitchenScene, SceneConfig

RENDER_SIZE = (320, 240)
RENDER_EYE = (0.95, -0.95, 1.05)
"""Position (m, world) of the :meth:`KitchenEnv.render` camera: high in front of the table on the robot's
right (beyond the microwave), facing the robots, so that no arm hides the objects and both arms show."""
RENDER_TARGET = (0.32, 0.05, 0.05)
"""Point (m, world) the render camera looks at: the middle of the work area."""
KINOVA_IK_TOLERANCE = 0.005
"""Metres the Kinova's IK answer may miss an action's target before the episode fails."""


class KitchenEnv(gym.Env):
    """One task of the suite in its own PyBullet client.

    Args:
        task: the task, any :class:`~taskcond.envs.protocol.Task` (:func:`taskcond.tasks.registry.make`
            builds the suite's).
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
        self.truth = task.ground_truth(self.scene)
        """The task's judge of conditions on this scene (:class:`taskcond.tasks.groundtruth.GroundTruth`)."""
        self.robot = self.scene.robot
        self.kinova = self.scene.kinova
        """The Kinova Gen3 (:class:`taskcond.sim.kinova.KinovaArm`) of dual-arm tasks, else ``None``."""
        self.substeps = PHYSICS_HZ // control_hz
        self.dt = self.substeps / PHYSICS_HZ
        self.object_names = self.scene.free_objects
        self.reader = StepReader(self.scene)
        """Reads the state once per control step (observation, blow-up check, success judge)."""
        self.monitor = BlowupMonitor(self.scene)
        """The blow-up check after each control step and the contact reset of each episode."""
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
        """Forget the previous episode's contacts (:meth:`BlowupMonitor.reset
        <taskcond.envs.reader.BlowupMonitor.reset>`), randomize the free objects' poses (seeded), close every
        container, put the arm home, then apply the task's initial state."""
        if seed is None and self._seed is not None:
            seed, self._seed = self._seed, None
        super().reset(seed=seed)
        rng = self.np_random
        self.monitor.reset()
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
            # the products summed in the order of numpy's dot of the quaternion: the same bits
            norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw) or 1.0
            # an unchanged target keeps its solution: solving it again only jitters or creeps along the joint
            # limits (BENCHMARKS.md, "Simulation throughput")
            target = (x, y, z, qx / norm, qy / norm, qz / norm, qw / norm)
            if target != self._q_target:
                self._q = self.robot.solve_ik(target[:3], target[3:], seed=self._q).q
                self._q_target = target
            self.robot.set_joint_targets(self._q)
            command_gripper(self.robot, closed=gripper >= 0.5)
            self._simulate()
        return self._judge()

    def step_joints(
        self, q: np.ndarray, gripper: float
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """One control step of the Franka towards the arm joint positions ``q`` (7,) rad, with no IK: a
        joint-space move (:meth:`taskcond.worlds.kitchen.KitchenWorld.unwind`); the gripper command as in
        :meth:`step`, the Kinova holding its last command. The next end-effector action's IK starts from
        ``q``. Returns what :meth:`step` returns."""
        if self.failure is None:
            self._q, self._q_target = np.array(q, dtype=float), None
            self.robot.set_joint_targets(self._q)
            command_gripper(self.robot, closed=gripper >= 0.5)
            self._simulate()
        return self._judge()

    def _simulate(self) -> None:
        """The physics of one control step under the commands set, and the cloth's grips after it."""
        client = self.scene.client
        for _ in range(self.substeps):
            p.stepSimulation(client)
        if self.scene.grips is not None:
            self.scene.grips.update()

    def _judge(self) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """The end of a control step: the state read once, the containers' stops from it
        (:meth:`~taskcond.sim.scene.KitchenScene.keep_at_stops`), the blow-up check, the task's success
        judge."""
        reading = self.reader.read()
        self.scene.keep_at_stops(reading.containers)
        if self.failure is None:
            self.failure = self.monitor.check(reading)
        self.steps += 1
        # nothing moves until the step returns: the judge takes the state just read
        success = self.failure is None and self.task.success(self, self.truth.at(reading))
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
        command_gripper(self.kinova, closed=action[7] >= 0.5)

    def render(self, size: tuple[int, int] = RENDER_SIZE) -> np.ndarray:
        """RGB image (height, width, 3) uint8 of ``size`` (width, height) pixels from a fixed camera in front
        of the table on the robot's right, looking at the work area (:data:`RENDER_EYE`,
        :data:`RENDER_TARGET`; CPU renderer)."""
        w, h = size
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

    def hold(self, name: str, lift: float, grasp: Any) -> None:
        """Reset-time set-up of a held object: lift ``name`` by ``lift`` m where it stands, put the open
        hand around it at the grasp pose ``grasp`` (a :class:`taskcond.tasks.motions.GraspPose`), close the
        fingers and let the grasp settle."""
        pos, _ = self.scene.pose(name)
        yaw = self.scene.yaw(name)
        self.scene.place(name, pos[:2], yaw, z=lift)
        ee, orn = grasp.pose(self.scene, name)
        q = self.robot.solve_ik(ee, orn, seed=np.array(HOME)).q
        q = self.robot.solve_ik(ee, orn, seed=q).q
        self.robot.reset(q, finger=grasp.width / 2 + 0.002)
        self.robot.set_joint_targets(q)
        self.robot.close_gripper()
        self._q, self._q_target = q, None
        self.settle(0.3)

    def home_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """End-effector pose of the home joint configuration."""
        return self.robot.fk(np.array(HOME)).position, np.array(top_down())

    def _obs(self, reading: Reading | None = None) -> dict[str, np.ndarray]:
        """The observation (see the module docstring), from ``reading`` if given, else read now."""
        if reading is None:
            reading = self.reader.read()
        ee_position, ee_orientation = self.robot.ee_frame()
        joints = reading.joints
        obs = {
            "ee_position": np.array(ee_position),
            "ee_orientation": np.array(ee_orientation),
            "gripper_width": np.array([joints[ARM_DOFS] + joints[ARM_DOFS + 1]]),
            "joint_positions": np.array(joints[:ARM_DOFS]),
            "object_poses": self.reader.object_poses(reading.bases),
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

    def _info(self, success: bool = False) -> dict[str, Any]:
        return {
            "success": success,
            "failure": self.failure,
            "failure_detail": self.failure_detail,
            "steps": self.steps,
        }
