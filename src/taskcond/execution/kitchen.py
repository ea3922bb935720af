"""The executor's :class:`~taskcond.execution.world.World` over the PyBullet kitchen suite, and the
recording of oracle demonstrations into skills (``taskcond learn``, paper Fig. 2 and §III-D).

This is the only module of :mod:`taskcond.execution` that knows the simulator.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from taskcond.conditions import Collision
from taskcond.execution.skills import Demonstration, SkillLibrary, learn_skill, target_object
from taskcond.execution.sources import condition_from_environment
from taskcond.execution.world import Observation, Touch
from taskcond.sim.perception import EnvironmentInfo, Perception, PerceptionConfig
from taskcond.sim.recording import VideoRecorder
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.env import KitchenEnv
from taskcond.tasks.registry import get_task, list_tasks, make

REACH = 0.855
"""Panda reach (m) from the first joint's axis; farther goals are refused."""
SHOULDER = np.array([0.0, 0.0, 0.333])
"""Position (m, world frame) of the Panda's shoulder (joint 2) with the base at the origin."""
VIDEO_EVERY = 2
"""Record every n-th control step."""


def _observation(info: EnvironmentInfo) -> Observation:
    return Observation(
        predicates=info.predicates,
        centers={name: box.center for name, box in info.boxes.items()},
        touches=tuple(Touch(c.a, c.b, c.position) for c in info.contacts),
    )


class KitchenWorld:
    """A :class:`KitchenEnv` seen through the environment-information layer (§III-A.2).

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
        self._contacts = Perception(description, PerceptionConfig(check_visibility=False))
        self._rng = np.random.default_rng(seed)
        self._objects = tuple(b.name for b in description.bodies if b.kind != "robot")

    @property
    def time(self) -> float:
        return self.env.steps * self.env.dt

    @property
    def objects(self) -> tuple[str, ...]:
        return self._objects

    def observe(self) -> Observation:
        return _observation(self.perception.observe(self._rng))

    def touches(self) -> tuple[Touch, ...]:
        return _observation(self._contacts.observe()).touches

    def locate(self, name: str, observation: Observation) -> np.ndarray | None:
        if name == "position":
            target = self.env.target
            return None if not np.any(target) else np.asarray(target, float).copy()
        return observation.centers.get(name)

    def affords(self, primitive: str, objects: tuple[str, ...]) -> str | None:
        scene = self.env.scene
        unknown = [o for o in objects if o not in self._objects]
        if unknown:
            return f"{', '.join(map(repr, unknown))} not in the scene (objects: {', '.join(self._objects)})"
        free = scene.free_objects
        if primitive in ("open", "close") and objects[0] not in scene.joints:
            return f"{objects[0]!r} has no lid, door or drawer (containers: {', '.join(scene.joints)})"
        carried = ("grasp", "release", "tilt", "move", "move_on_top", "move_into", "move_in_front")
        if primitive in carried and objects[0] not in free:
            return f"{objects[0]!r} cannot be picked up (movable objects: {', '.join(free)})"
        if primitive == "move_into" and objects[1] not in scene.interiors:
            return f"{objects[1]!r} is not a container (containers: {', '.join(scene.interiors)})"
        if primitive == "fold":
            return "folding needs the cloth and two arms, which this scene does not have"
        return None

    def reach_error(self, position: np.ndarray) -> str | None:
        distance = float(np.linalg.norm(np.asarray(position, float) - SHOULDER))
        if distance > REACH:
            return f"{distance:.2f} m from the shoulder, the arm reaches {REACH} m"
        if position[2] < -0.05:
            return f"{position[2]:.2f} m is below the table"
        return None

    def ee_pose(self) -> tuple[np.ndarray, np.ndarray]:
        ee = self.env.robot.ee_pose()
        return ee.position, ee.orientation

    def step(self, position: np.ndarray, orientation: np.ndarray, gripper: float) -> str | None:
        _, _, terminated, _, info = self.env.step(np.concatenate([position, orientation, [gripper]]))
        if self.recorder is not None and self.env.steps % VIDEO_EVERY == 0:
            self.recorder.add(self.env.render())
        return info["failure"] if terminated else None


# ----------------------------------------------------------------------------------- demonstrations
def record_demonstration(task_id: str, seed: int = 0) -> tuple[Demonstration, bool]:
    """Run the oracle of a primitive suite task once and record it with the environment information
    before, during (contacts) and after it; returns the demonstration and whether the oracle succeeded.

    Raises:
        ValueError: ``task_id`` is not a primitive task of the registry.
    """
    task = get_task(task_id)
    if not isinstance(task, PrimitiveTask):
        raise ValueError(f"{task_id!r} is not a primitive task; demonstrations are of primitive tasks")
    env = make(task_id)
    try:
        env.reset(seed=seed)
        world = KitchenWorld(env)
        before = world.observe()
        name = task.info.task_name
        target = target_object(name)
        center = world.locate(target, before) if target is not None else None
        touched: set[Collision] = set()
        contact = -1
        rows: list[np.ndarray] = []
        for trajectory in task.plans(env):
            for i in range(len(trajectory)):
                action = trajectory.action(i)
                rows.append(action)
                env.step(action)
                for touch in world.touches():
                    touched.add(touch.collision)
                    if contact < 0 and target is not None and {touch.a, touch.b} == {"gripper", target}:
                        contact = len(rows) - 1
        for _ in range(5):
            env.step(rows[-1])
        after = world.observe()
        success = bool(task.success(env))
    finally:
        env.close()
    actions = np.array(rows)
    demo = Demonstration(
        task_name=name,
        task_id=task_id,
        times=np.arange(len(actions)) * env.dt,
        positions=actions[:, :3],
        orientations=actions[:, 3:7],
        gripper=actions[:, 7],
        target=target,
        target_center=np.zeros(3) if center is None else center,
        target_contact=contact,
        condition=condition_from_environment(name, before.predicates, after.predicates, touched),
    )
    return demo, success


def primitive_task_ids() -> list[str]:
    """Suite ids of every primitive task the Franka can demonstrate."""
    return [t.id for t in list_tasks() if t.kind == "primitive" and t.primitive != "fold"]


def learn_library(
    directory: str | Path | None = None,
    task_ids: Iterable[str] | None = None,
    seed: int = 0,
    tries: int = 5,
    progress: Callable[[str, bool], None] | None = None,
) -> SkillLibrary:
    """Record one successful oracle demonstration per primitive task and learn its skill (§III-D).

    Args:
        directory: where to save the library (plain files); not saved if None.
        task_ids: suite ids to learn, default all primitive tasks.
        seed: seed of the first try; a failed demonstration is recorded again with the next seed, up to
            ``tries`` times, and the last one is kept if none succeeded.
        progress: called with each task id and whether its demonstration succeeded.
    """
    library = SkillLibrary()
    for task_id in primitive_task_ids() if task_ids is None else task_ids:
        for k in range(tries):
            demo, ok = record_demonstration(task_id, seed + k)
            if ok:
                break
        library.add(learn_skill(demo))
        if progress is not None:
            progress(task_id, ok)
    if directory is not None:
        library.save(directory)
    return library


__all__ = ["KitchenWorld", "learn_library", "primitive_task_ids", "record_demonstration"]
