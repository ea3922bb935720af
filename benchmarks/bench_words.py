"""Benchmark of the scene's words before the LLM (issue 31, item 5): wordings of the combination benchmark
that name an object by its part ("the door", "the lid") or say "on" for on top of ("stack the X on the
box"), decomposed by the configured LLM with the scene's words (:func:`taskcond.decompose.with_on_top`,
:func:`taskcond.sim.roles.part_aliases`) and without them (the object aliases only, "on" as said).
A plan is correct when its steps other than grasp and release are exactly the template's task.
Run: ``.venv/bin/python benchmarks/bench_words.py`` (answers cached like any other LLM answer).
Prints one markdown row per wording and the totals.
"""

from __future__ import annotations

import taskcond.decompose as decomposition
from taskcond.application.plans import llm_decomposer
from taskcond.decompose import DecompositionError, decompose
from taskcond.llm.config import LLMConfig, make_backend
from taskcond.sim.scene import scene_aliases
from taskcond.worlds.kitchen import scene_objects

OBJECTS = ("bottle", "bowl", "mug", "toothpaste", "spatula", "cube", "can")


def cases() -> list[tuple[str, str]]:
    """(wording, the template's task) of each measured wording."""
    out = []
    for verb in ("open", "close"):
        said = verb.title()
        out += [(f"{said} the door.", f"{verb} microwave"), (f"{said} the lid.", f"{verb} box")]
    out += [
        ("Open the microwave's door.", "open microwave"),
        ("Open the box's lid.", "open box"),
        ("Shut the microwave's door.", "close microwave"),
        ("Shut the box's lid.", "close box"),
    ]
    for x in OBJECTS:
        out += [(f"Stack the {x} on the box.", f"move {x} on top of box")]
        out += [(f"Set the {x} on the cabinet.", f"move {x} on top of cabinet")]
    return out


def main() -> None:
    objects, affords = scene_objects("kitchen")
    backend = make_backend(LLMConfig.load(None))
    with_words = llm_decomposer(backend=backend)
    on_top = decomposition.with_on_top
    score = {"without": 0, "with": 0}
    print("| wording | without the scene's words | with them |\n|---|---|---|")
    for text, want in cases():
        row = []
        for side in score:
            decomposition.with_on_top = on_top if side == "with" else (lambda t: t)
            try:
                if side == "with":
                    plan = with_words(text, "kitchen")
                else:
                    plan = decompose(text, backend, objects, affords, aliases=scene_aliases())
            except DecompositionError as exc:
                plan = [f"no plan ({str(exc)[:60]})"]
            ok = [t for t in plan if not t.startswith(("grasp ", "release "))] == [want]
            score[side] += ok
            row.append(f"{'ok' if ok else '**wrong**'}: {'; '.join(plan)}")
        print(f"| {text} | {row[0]} | {row[1]} |", flush=True)
    print(f"\nwithout: {score['without']}/{len(cases())}, with: {score['with']}/{len(cases())}")


if __name__ == "__main__":
    main()
