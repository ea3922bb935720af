"""What an episode runs: a suite task's steps, a primitive task name, or a free instruction's steps from the
LLM's decomposition (:class:`RunPlan`, :func:`plan_run`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any

from taskcond.decompose import mentions, said_tasks
from taskcond.llm.base import ChatBackend
from taskcond.primitives import TaskNameError, parse_task
from taskcond.sim.roles import part_aliases, scene_roles
from taskcond.sim.scene import scene_aliases
from taskcond.tasks.registry import UnknownTaskError, get_task, list_tasks
from taskcond.worlds.kitchen import scene_objects

DUAL_ARM_WORDS = ("cloth", "fold", "kinova", "second arm", "other arm", "both arms", "two arms", "both hands")
"""Words of an instruction that name what only the dual-arm kitchen has."""


def instruction_scene(instruction: str) -> str:
    """The scene an instruction needs (:data:`SCENES`): ``dual-arm`` when it names the cloth or a second
    arm (:data:`DUAL_ARM_WORDS`), else ``kitchen``."""
    return "dual-arm" if mentions(instruction, DUAL_ARM_WORDS) else "kitchen"


# --------------------------------------------------------------------------------------------- plans
@dataclass(frozen=True)
class RunPlan:
    """What an episode runs.

    Attributes:
        label: what was asked (a suite id or an instruction).
        task_id: the suite task whose initial state and success check apply; None for a free instruction
            (judged by its goal predicates).
        steps: primitive task names in order.
        decomposed: the steps come from the LLM's decomposition of a free instruction.
        scene: a free instruction's scene (:data:`taskcond.tasks.free.SCENES`); a suite task has
            its own.
    """

    label: str
    task_id: str | None
    steps: tuple[str, ...]
    decomposed: bool = False
    scene: str = "kitchen"


def plan_run(spec: str, decomposer: Callable[[str, str], list[str]] | None = None) -> RunPlan:
    """Resolve ``spec``: a suite id (``LHT1``, ``grasp-bottle``), a primitive task name of the suite
    (``"grasp bottle"``), another primitive task name on objects of its scene (a declared primitive, or
    objects no suite task has: one step in the scene :func:`~taskcond.application.plans.instruction_scene`
    picks), else a free instruction that ``decomposer`` turns into primitive task names (called with the
    instruction and its scene). A primitive task name on an object its scene lacks (``put the botle into
    the box``) goes to ``decomposer`` when there is one: the LLM reads a misspelling as the object meant.

    Raises:
        ValueError: an empty or blank ``spec``; a free instruction without a decomposer.
    """
    if not spec.strip():
        raise ValueError(
            "empty instruction; give a suite task id (see `taskcond tasks`), a primitive task such as "
            "'open box', or an instruction such as 'put the bottle into the box'"
        )
    try:
        info = get_task(spec.strip()).info
    except UnknownTaskError:
        pass
    else:
        steps = info.primitive if info.kind == "long-horizon" else (info.task_name,)
        return RunPlan(spec.strip(), info.id, tuple(steps))
    try:
        name = parse_task(spec).name
    except TaskNameError:
        name = None
    for info in list_tasks():
        if info.kind == "primitive" and info.task_name == name:
            return RunPlan(spec, info.id, (info.task_name,))
    scene = instruction_scene(spec)
    if name is not None and (
        decomposer is None or set(parse_task(name).objects) <= set(scene_objects(scene)[0])
    ):
        return RunPlan(spec, None, (name,), scene=scene)  # a primitive task the suite does not have
    if decomposer is None:
        raise ValueError(f"{spec!r} is neither a suite task id nor a primitive task of the suite")
    return RunPlan(spec, None, tuple(decomposer(spec, scene)), decomposed=True, scene=scene)


def llm_decomposer(
    llm: str | None = None,
    announce: Callable[[str], None] | None = None,
    threads: int | None = None,
    backend: ChatBackend | None = None,
    tell: Callable[[str], None] | None = None,
) -> Callable[[str, str], list[str]]:
    """The ``decomposer`` of :func:`plan_run` with the LLM of ``llm`` (the ``--llm`` spec; answers cached;
    an embedded model on ``threads`` CPU threads, None: every core), or with ``backend`` when given (a
    backend the caller built, e.g. its own LLM client or a model already loaded):
    an instruction that reads as one primitive task the scene cannot do is refused first
    (:func:`refused_task`); ``announce`` is told the scene before the LLM is asked, ``tell`` when the plan
    is read from the instruction's words instead of the LLM's answers
    (:func:`~taskcond.decompose.decompose`). The LLM reads the objects' other names
    (:func:`~taskcond.sim.scene.scene_aliases`) and their parts ("the door": the microwave,
    :func:`~taskcond.sim.roles.part_aliases`) as the objects' names.

    The decomposer raises DecompositionError (no valid plan, or refused) and LLMError."""
    from taskcond.decompose import DecompositionError, decompose, said_text
    from taskcond.llm.config import LLMConfig, make_backend

    backends: list[Any] = [] if backend is None else [backend]
    names: dict[tuple[str, ...], dict[str, str]] = {}  # the aliases of each scene's objects, read once

    def decomposer(instruction: str, scene: str) -> list[str]:
        objects, affords = scene_objects(scene)
        if tuple(objects) not in names:
            parts = part_aliases(o for o in scene_roles().values() if o.name in objects)
            names[tuple(objects)] = scene_aliases() | parts
        aliases = names[tuple(objects)]
        refused = refused_task(said_text(instruction, objects, aliases), objects, affords)
        if refused is not None:
            raise DecompositionError(f"{refused}; nothing was run")
        if announce is not None:
            announce(scene)
        if not backends:
            backends.append(make_backend(replace(LLMConfig.load(llm), threads=threads)))
        return decompose(instruction, backends[0], objects, affords, aliases=aliases, tell=tell)

    return decomposer


def instruction_plan(text: str, decomposer: Callable[[str, str], list[str]]) -> RunPlan:
    """A benchmark instruction's plan: ``decomposer``'s (the LLM's) steps for it, even where its words name
    one primitive task (``taskcond run`` runs "put the bottle into the box" as that suite task, which ends
    holding the bottle; the benchmark asks the LLM, which writes the release a user means), run as a free
    instruction in its scene and judged by its goal.

    Raises:
        ValueError: an empty instruction.
    """
    if not text.strip():
        raise ValueError("empty instruction")
    scene = instruction_scene(text)
    return RunPlan(text, None, tuple(decomposer(text, scene)), decomposed=True, scene=scene)


def refused_task(
    instruction: str, objects: Iterable[str], affords: Callable[[str, tuple[str, ...]], str | None]
) -> str | None:
    """Why an instruction that reads as one primitive task on objects of the scene, or has a clause that
    does (:func:`~taskcond.decompose.said_tasks`, "it" read as the previous clause's object), cannot be
    done there (``put the box into the bottle``: the box cannot be picked up; "pick up the mug and put it in
    the microwave": the hand cannot enter the microwave), or None. Asked before the LLM decomposes it,
    which would otherwise answer a different task (the bottle into the box; told that the mug cannot go into
    the microwave, the mug on the table, and the run would meet the goal of that plan). An instruction
    naming an object the scene lacks is left to the LLM (it may be a misspelling)."""
    for task in filter(None, said_tasks(instruction, list(objects))):
        parsed = parse_task(task)
        reason = affords(parsed.primitive.id, parsed.objects)
        if reason is not None:
            return f"cannot {parsed.name!r}: {reason}"
    return None
