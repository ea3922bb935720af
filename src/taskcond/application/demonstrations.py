"""The recording of oracle demonstrations into skills (``taskcond learn``, paper Fig. 2 and §III-D), and of
a suite oracle's trajectory into a demonstration file (``taskcond record``).
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np

from taskcond.conditions import (
    Collision,
)
from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.demofile import RecordedTrajectory
from taskcond.execution.skills import (
    Demonstration,
    ObjectShape,
    SkillLibrary,
    learn_skill,
    target_object,
)
from taskcond.execution.sources import condition_from_environment
from taskcond.grounding import DemoEvidence
from taskcond.primitives import parse_task
from taskcond.sim.scene import suite_config
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.free import FreeTask
from taskcond.tasks.registry import UnknownTaskError, get_task, make, primitive_task_ids
from taskcond.worlds.kitchen import KINOVA_STILL, KitchenWorld


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
    hand = world.ee_pose()[0]
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
    held = before.grasped()
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
        shapes={
            o: ObjectShape(before.shapes.get(o, "fixed"), tuple(map(float, hi - lo)))  # type: ignore[arg-type]
            for o in task.objects
            if o in before.boxes
            for lo, hi in (before.boxes[o],)
        },
        hold_depth=None if held not in before.boxes else float(hand[2] - before.boxes[held][0][2]),
        target_yaw=before.yaws.get(target) if target is not None else None,
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
    env = make(task_id, config=suite_config())  # the suite's scene, whatever objects are declared
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
    workers: int = 1,
) -> SkillLibrary:
    """Record oracle demonstrations and learn a skill from each (§III-D).

    Args:
        directory: where to save the library (plain files); not saved if None.
        task_ids: suite ids to demonstrate, default every primitive task and :data:`CONTEXTS`.
        seed: seed of the first try; a failed oracle run is recorded again with the next seed, up to
            ``tries`` times, and the last one is kept if none succeeded.
        progress: called with each task id and whether its oracle succeeded, in the order of ``task_ids``.
        workers: processes recording demonstrations side by side. Each oracle run has its own simulation
            and seed, so the library is the same for any count. More than one starts new processes
            (``spawn``): a script that calls this needs the ``if __name__ == "__main__":`` guard.
    """
    ids = [*primitive_task_ids(), *CONTEXTS] if task_ids is None else list(task_ids)
    library = SkillLibrary()
    for task_id, (demos, ok) in zip(ids, _demonstrations(ids, seed, tries, workers), strict=True):
        for demo in demos:
            library.add(learn_skill(demo))
        if progress is not None:
            progress(task_id, ok)
    if directory is not None:
        library.save(directory)
    return library


def _demonstrations(
    ids: list[str], seed: int, tries: int, workers: int
) -> Iterator[tuple[list[Demonstration], bool]]:
    """:func:`_demonstrate` of each id, in order; in ``workers`` new processes when there are several,
    the longest first (:func:`_expected_cost`), so that no worker starts a long one when the others are
    done."""
    run = partial(_demonstrate, seed=seed, tries=tries)
    workers = min(workers, len(ids))
    if workers <= 1:
        yield from map(run, ids)
        return
    context = multiprocessing.get_context("spawn")  # no fork of a process that may hold an LLM's threads
    with ProcessPoolExecutor(workers, mp_context=context, initializer=_quiet_stdout) as pool:
        futures = {i: pool.submit(run, i) for i in sorted(set(ids), key=_expected_cost, reverse=True)}
        for task_id in ids:
            yield futures[task_id].result()


def _expected_cost(task_id: str) -> tuple[bool, int]:
    """What makes an oracle run long, to order them: a soft body in its scene (the cloth's, about 10 times
    the rigid ones' simulation time), then its primitive count. BENCHMARKS.md has the measured times."""
    try:
        task = get_task(task_id)
    except UnknownTaskError:
        return (False, 1)
    config, steps = task.scene_config(None), task.info.primitive
    return (config is not None and config.cloth is not None, len(steps) if isinstance(steps, tuple) else 1)


def _demonstrate(task_id: str, seed: int, tries: int) -> tuple[list[Demonstration], bool]:
    """The demonstrations of ``task_id``'s oracle from ``seed``, recorded again with the next seed after a
    failed run, up to ``tries`` runs (the last kept if none succeeded); and whether it succeeded."""
    for k in range(tries):
        demos, ok = record_demonstrations(task_id, seed + k)
        if ok:
            break
    return demos, ok


def _quiet_stdout() -> None:
    """A worker's standard output goes nowhere: PyBullet prints its build-time banner there at each
    connection (results come back through the pool, warnings on standard error)."""
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.close(null)
