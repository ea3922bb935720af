"""Example task conditions, one per primitive: the demo data shown to the LLM (paper Fig. 2, §III-B).

They live in ``taskcond/data/examples.txt`` in the paper's Listing 1 format, written for concrete objects
(``move bottle into box``). :func:`letter_example` turns one into its letter form for a prompt
(``move A into B``, §III-B), and :func:`reference_condition` instantiates a primitive's example for other
objects: the reference an LLM answer is scored against in ``taskcond eval conditions``.
"""

from __future__ import annotations

from functools import cache
from importlib import resources

from taskcond.conditions import TaskCondition, parse_examples
from taskcond.primitives import PRIMITIVES, ParsedTask, parse_task


@cache
def example_conditions() -> dict[str, TaskCondition]:
    """Primitive id → example condition, read once from the package data, in the registry's order: one for
    each of the paper's ten primitives, none for a declared one (its conditions are always generalized)."""
    text = resources.files("taskcond").joinpath("data/examples.txt").read_text(encoding="utf-8")
    by_id: dict[str, TaskCondition] = {}
    for cond in parse_examples(text):
        by_id[parse_task(cond.task_name).primitive.id] = cond
    missing = {pid for pid, p in PRIMITIVES.items() if not p.declared} - set(by_id)
    if missing:
        raise RuntimeError(f"data/examples.txt lacks examples for {sorted(missing)}")
    return {pid: by_id[pid] for pid in PRIMITIVES if pid in by_id}


def letter_example(pid: str) -> TaskCondition:
    """A primitive's example with its objects replaced by letters, as shown in prompts."""
    cond = example_conditions()[pid]
    task = parse_task(cond.task_name)
    return cond.rename(task.letters(), task_name=task.letter_name)


def reference_condition(task: ParsedTask) -> TaskCondition:
    """The example condition of ``task``'s primitive, instantiated for ``task``'s objects."""
    cond = example_conditions()[task.primitive.id]
    example_task = parse_task(cond.task_name)
    mapping = dict(zip(example_task.objects, task.objects, strict=True))
    return cond.rename(mapping, task_name=task.name)
