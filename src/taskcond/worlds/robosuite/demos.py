"""Demonstrations of robosuite tasks by their scripted oracles, and the skills learned from them
(``taskcond learn --world robosuite``, paper Fig. 2 and §III-D): one demonstration per primitive step of
each task, recorded as the kitchen records its own
(:func:`~taskcond.application.demonstrations.record_demonstrations`: the commanded end-effector trajectory,
the environment information before and after, the contacts during) and learned by the same
:func:`~taskcond.execution.skills.learn_skill`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from taskcond.conditions import Collision
from taskcond.execution.skills import Demonstration, SkillLibrary, learn_skill, target_object
from taskcond.execution.sources import condition_from_environment
from taskcond.grounding import DemoEvidence
from taskcond.llm.models import cache_dir
from taskcond.primitives import parse_task
from taskcond.worlds.robosuite.scene import make_env, reset
from taskcond.worlds.robosuite.tasks import Command, down, get_task, oracle
from taskcond.worlds.robosuite.world import RobosuiteWorld

ORACLE_REVISION = 13
"""Revision of the robosuite oracles the default library is learned from; raised whenever their
demonstrations change, so that an older library is not picked up by default."""
SETTLE = 5
"""Control steps the last command of a demonstration is held before its end is observed."""
DEMONSTRATED = (
    "Lift",
    "Stack",
    "PickPlaceMilk",
    "PickPlaceBread",
    "PickPlaceCereal",
    "PickPlaceCan",
    "Door",
    "NutAssemblySquare",
)
"""Tasks demonstrated by default: one demonstration of each of their primitive steps (the four-object
PickPlace reuses the single-object skills: the same primitive task names)."""


def default_library_dir() -> Path:
    """``<cache dir>/skills/robosuite-oracles<revision>`` (:data:`ORACLE_REVISION`)."""
    return cache_dir() / "skills" / f"robosuite-oracles{ORACLE_REVISION}"


def record(world: RobosuiteWorld, name: str, task_id: str, commands: Iterable[Command]) -> Demonstration:
    """Command ``commands`` one control step each from the current state and record the demonstration of
    the primitive task ``name``."""
    before = world.observe()
    target = target_object(name)
    center = world.locate(target, before) if target is not None else None
    touched: set[Collision] = set()
    contact = -1
    rows: list[np.ndarray] = []
    for position, orientation, gripper in commands:
        rows.append(np.concatenate([position, orientation, [gripper]]))
        world.step(position, orientation, gripper)
        for touch in world.touches():
            touched.add(touch.collision)
            if contact < 0 and target is not None and {touch.a, touch.b} == {"gripper", target}:
                contact = len(rows) - 1
    for _ in range(SETTLE):
        world.step(rows[-1][:3], rows[-1][3:7], rows[-1][7])
    after = world.observe()
    actions = np.array(rows)
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
        times=np.arange(len(actions)) * world.dt,
        positions=actions[:, :3],
        orientations=actions[:, 3:7],
        gripper=actions[:, 7],
        target=target,
        target_center=np.zeros(3) if center is None else center,
        target_contact=contact,
        condition=condition_from_environment(name, before.predicates, after.predicates, touched),
        evidence=evidence.restricted(evidence.objects),
        target_yaw=before.yaws.get(target) if target is not None else None,
    )


def record_demonstrations(task_id: str, seed: int = 0) -> tuple[list[Demonstration], bool]:
    """Run the oracle of a robosuite task once from robosuite's start for ``seed`` and record one
    demonstration per primitive step; returns them and robosuite's success check."""
    task = get_task(task_id)
    env = make_env(task_id)
    try:
        scene = reset(env, seed)
        world = RobosuiteWorld(scene)
        quat = down(scene)
        ids = [f"{task_id}.{k}" if len(task.steps) > 1 else task_id for k in range(1, len(task.steps) + 1)]
        demos = [
            record(world, step, i, oracle(scene, step, quat)) for i, step in zip(ids, task.steps, strict=True)
        ]
        return demos, scene.success()
    finally:
        env.close()


def learn_library(
    directory: str | Path | None = None,
    task_ids: Iterable[str] | None = None,
    seed: int = 0,
    tries: int = 5,
    progress: Callable[[str, bool], None] | None = None,
) -> SkillLibrary:
    """Record oracle demonstrations of robosuite tasks (default :data:`DEMONSTRATED`) and learn a skill
    from each; a failed oracle run is recorded again with the next seed, up to ``tries`` times (the last
    kept if none succeeded). Saved to ``directory`` if given."""
    library = SkillLibrary()
    for task_id in DEMONSTRATED if task_ids is None else task_ids:
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
    "DEMONSTRATED",
    "ORACLE_REVISION",
    "default_library_dir",
    "learn_library",
    "record",
    "record_demonstrations",
]
