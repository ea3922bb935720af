"""The single registry of the task suite (paper §IV, Table I): every primitive task with each object it
applies to (ids ``<primitive>-<object>[-<object>]`` with spaces as ``_``, e.g. ``open-top_drawer``,
``move_into-bottle-box``) and the long-horizon tasks ``LHT1``, ``LHT2``, ``LHT3``, ``LHT1*``, ``LHT2*``.

The primitive ids are those of :data:`taskcond.primitives.PRIMITIVES`. The cloth tasks ``grasp-cloth`` and
``fold-cloth`` (PT6, dual-arm) and ``LHT4`` run in the dual-arm scene with the Kinova and the cloth
(:func:`taskcond.sim.scene.dual_arm_config`); every other task in the single-arm kitchen.
"""

from __future__ import annotations

from collections.abc import Callable

from taskcond.envs.kitchen import KitchenEnv
from taskcond.primitives import PRIMITIVES
from taskcond.sim.scene import SceneConfig
from taskcond.tasks import (
    close,
    fold,
    grasp,
    move,
    move_in_front,
    move_into,
    move_on_top,
    open,
    release,
    tilt,
)
from taskcond.tasks.base import PrimitiveTask, Task, TaskInfo
from taskcond.tasks.long_horizon import long_horizon_tasks


class UnknownTaskError(ValueError):
    """A task id, primitive or object name the registry does not know; the message lists the valid ones."""


_FAMILIES: dict[str, tuple[type[PrimitiveTask], tuple[tuple[str, ...], ...]]] = {
    "grasp": (grasp.Grasp, tuple((o,) for o in grasp.OBJECTS)),
    "release": (release.Release, tuple((o,) for o in release.OBJECTS)),
    "open": (open.Open, tuple((o,) for o in open.OBJECTS)),
    "close": (close.Close, tuple((o,) for o in close.OBJECTS)),
    "tilt": (tilt.Tilt, tuple((o,) for o in tilt.OBJECTS)),
    "move": (move.Move, tuple((o,) for o in move.OBJECTS)),
    "move_on_top": (move_on_top.MoveOnTop, move_on_top.PAIRS),
    "move_into": (move_into.MoveInto, move_into.PAIRS),
    "move_in_front": (move_in_front.MoveInFront, move_in_front.PAIRS),
}
assert set(_FAMILIES) <= set(PRIMITIVES)
_CLOTH_TASKS: dict[str, Callable[[], Task]] = {"grasp-cloth": fold.GraspCloth, "fold-cloth": fold.Fold}
"""Primitive tasks on the cloth (dual-arm scene), registered after the rigid-object families."""


def _factories() -> dict[str, Callable[[], Task]]:
    out: dict[str, Callable[[], Task]] = {}
    for cls, combos in _FAMILIES.values():
        for objects in combos:
            task = cls(*objects)
            out[task.info.id] = lambda cls=cls, objects=objects: cls(*objects)
    out.update(_CLOTH_TASKS)
    for lht in long_horizon_tasks():
        out[lht.info.id] = lambda tid=lht.info.id: next(t for t in long_horizon_tasks() if t.info.id == tid)
    return out


_TASKS = _factories()


def task_ids() -> list[str]:
    """Every registry id, primitive tasks first (Table I order), then the long-horizon tasks."""
    return list(_TASKS)


def get_task(task_id: str) -> Task:
    """A fresh task object for ``task_id``; raises :class:`UnknownTaskError` with the valid ids/objects."""
    if task_id in _TASKS:
        return _TASKS[task_id]()
    prim, _, rest = task_id.partition("-")
    cloth = [t.partition("-")[2] for t in _CLOTH_TASKS if t.partition("-")[0] == prim]
    if (prim in _FAMILIES or cloth) and rest:
        combos = _FAMILIES[prim][1] if prim in _FAMILIES else ()
        valid = ", ".join([*("-".join(o.replace(" ", "_") for o in objs) for objs in combos), *cloth])
        raise UnknownTaskError(f"unknown object(s) {rest!r} for primitive {prim!r}; valid: {valid}")
    raise UnknownTaskError(f"unknown task {task_id!r}; valid: {', '.join(_TASKS)}")


def list_tasks() -> list[TaskInfo]:
    """The registry entries: id, kind, primitive id (or the LHT's primitive task names), objects."""
    return [_TASKS[t]().info for t in _TASKS]


def make(
    task_id: str,
    seed: int | None = None,
    render_mode: str | None = None,
    gui: bool = False,
    config: SceneConfig | None = None,
) -> KitchenEnv:
    """A :class:`KitchenEnv` for ``task_id`` (see :func:`task_ids`); ``seed`` seeds its first reset."""
    return KitchenEnv(get_task(task_id), seed=seed, render_mode=render_mode, gui=gui, config=config)


def primitive_task_ids() -> list[str]:
    """Suite ids of every primitive task (the fold with both arms)."""
    return [t.id for t in list_tasks() if t.kind == "primitive"]
