"""The Gymnasium-style environment of the task suite (paper §IV).

Action (8,) float: end-effector target position xyz (m, world frame), orientation quaternion xyzw, gripper
command (< 0.5 open, ≥ 0.5 closed); a (7,) action gives the orientation as roll-pitch-yaw (rad) instead.
Each step converts the target to joint positions with PyBullet IK (§III-E) and runs
:attr:`KitchenEnv.substeps` physics steps of 1/240 s under position control.

Observation (dict of float arrays): ``ee_position`` (3,), ``ee_orientation`` (4,), ``gripper_width``
(1,) m, ``joint_positions`` (7,) rad, ``object_poses`` (n, 7) position + xyzw of the free objects in the
order of :attr:`KitchenEnv.object_names`, ``container_open`` (4,) open fractions of
:data:`taskcond.sim.scene.ARTICULATED`, ``target`` (3,) goal position of ``move`` tasks (zeros otherwise).

``info``: ``success`` (bool), ``failure`` (reason string or ``None``), ``steps``. A simulation blow-up (NaN,
an object leaving the workspace, deep interpenetration) terminates the episode with its reason.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pybullet as p
from gymnasium import spaces

from taskcond.sim.franka import HOME, top_down
from taskcond.sim.scene import ARTICULATED, PHYSICS_HZ, KitchenScene, SceneConfig
from taskcond.tasks.base import Task
from taskcond.tasks.groundtruth import GroundTruth

WORKSPACE = (np.array([-0.4, -1.0, -0.2]), np.array([1.1, 1.0, 1.5]))
"""Bounds (min, max) in metres of where free objects may be; leaving them ends the episode."""
PENETRATION = 0.03
"""Contact depth (m) counted as a simulation blow-up."""
RENDER_SIZE = (320, 240)


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
        self.scene = KitchenScene(config, gui=gui)
        self.truth = GroundTruth(self.scene)
        self.robot = self.scene.robot
        self.substeps = PHYSICS_HZ // control_hz
        self.dt = self.substeps / PHYSICS_HZ
        self.object_names = self.scene.free_objects
        self.target = np.zeros(3)
        self.steps = 0
        self.failure: str | None = None
        self._q = np.array(HOME)
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
        self.action_space = box(
            np.array([-1, -1, -0.2, -1, -1, -1, -1, 0.0]),
            np.array([1.2, 1, 1.2, 1, 1, 1, 1, 1.0]),
            dtype=np.float64,
        )

    # ------------------------------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Randomize the free objects' poses (seeded), close every container, put the arm home, then
        apply the task's initial state."""
        if seed is None and self._seed is not None:
            seed, self._seed = self._seed, None
        super().reset(seed=seed)
        rng = self.np_random
        cfg = self.scene.config
        for name, (_, place) in cfg.free_objects.items():
            xy = np.array(place.xy) + rng.uniform(-cfg.position_noise, cfg.position_noise, 2)
            self.scene.place(name, xy, place.yaw + rng.uniform(-cfg.yaw_noise, cfg.yaw_noise))
        for name in ARTICULATED:
            self.scene.set_joint(name, 0.0)
        self.robot.reset(HOME)
        self._q = np.array(HOME)
        self.target = np.zeros(3)
        self.steps = 0
        self.failure = None
        self.task.setup(self, rng)
        self.settle(0.1)
        return self._obs(), self._info()

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        action = np.asarray(action, dtype=float)
        if action.shape == (7,):
            orn = np.array(p.getQuaternionFromEuler(action[3:6]))
            action = np.concatenate([action[:3], orn, action[6:]])
        if action.shape != (8,):
            raise ValueError(f"action must have shape (8,) or (7,), got {action.shape}")
        orn = action[3:7] / (np.linalg.norm(action[3:7]) or 1.0)
        if self.failure is None:
            self._q = self.robot.ik(action[:3], orn, seed=self._q)
            self.robot.command(self._q, closed=bool(action[7] >= 0.5))
            for _ in range(self.substeps):
                p.stepSimulation(physicsClientId=self.scene.client)
            self.failure = self._check_blowup()
        self.steps += 1
        success = self.failure is None and self.task.success(self)
        terminated = self.failure is not None
        truncated = self.steps >= self.task.max_steps
        return self._obs(), float(success), terminated, truncated, self._info(success)

    def render(self) -> np.ndarray:
        """RGB image (240, 320, 3) uint8 from a fixed camera behind and above the robot (CPU renderer)."""
        w, h = RENDER_SIZE
        view = p.computeViewMatrix((-0.45, 0.0, 0.85), (0.5, 0.0, 0.05), (0, 0, 1))
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
        self._q = q
        self.settle(0.3)

    def home_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """End-effector pose of the home joint configuration."""
        return self.robot.fk(np.array(HOME)).position, np.array(top_down())

    def _obs(self) -> dict[str, np.ndarray]:
        ee = self.robot.ee_pose()
        poses = np.array([np.concatenate(self.scene.pose(n)) for n in self.object_names])
        return {
            "ee_position": ee.position,
            "ee_orientation": ee.orientation,
            "gripper_width": np.array([self.robot.finger_width()]),
            "joint_positions": self.robot.joint_positions(),
            "object_poses": poses,
            "container_open": np.array([self.scene.open_fraction(c) for c in ARTICULATED]),
            "target": self.target.copy(),
        }

    def _info(self, success: bool = False) -> dict[str, Any]:
        return {"success": success, "failure": self.failure, "steps": self.steps}

    def _check_blowup(self) -> str | None:
        client = self.scene.client
        if not np.all(np.isfinite(self.robot.joint_positions())):
            return "nan_state"
        for name in self.object_names:
            pos = np.array(
                p.getBasePositionAndOrientation(self.scene.bodies[name], physicsClientId=client)[0]
            )
            if not np.all(np.isfinite(pos)):
                return "nan_state"
            if np.any(pos < WORKSPACE[0]) or np.any(pos > WORKSPACE[1]):
                return f"{name}_left_workspace"
        for pt in p.getContactPoints(physicsClientId=client):
            if pt[8] < -PENETRATION:
                return "deep_penetration"
        return None
