"""Benchmark of grasps, carries and releases that leave objects standing (issue 31, part 2): the
combination benchmark's grasp and move-into cells (every graspable object; every object that fits the
box or the top drawer, :func:`taskcond.combinations.generate`) from random starts, each as its primitive
plan (``grasp A`` / ``grasp A, move A into B, release A``; no LLM decomposition), judged by the
template's goal predicates, with the objects that fell over.

Run: ``.venv/bin/python benchmarks/bench_grasps.py [--episodes N] [--seed S] [--cells grasp,move_into]``;
``--targets box,top drawer,mug``: other move-into targets; ``--cells move_on_top,move_in_front``: the
moves on top of and in front of every target, as ``grasp A``,
the move, ``release A``, judged by the combination's goal.
Conditions from the demonstrations (method env), the default skill library, perception noise σ = 5 mm.
Prints one markdown row per cell (successes, fallen, failures) and the totals.
"""

from __future__ import annotations

import argparse
from collections import Counter

from taskcond.application.condition_sources import make_source
from taskcond.application.episode import run_episode
from taskcond.application.library import load_library
from taskcond.application.plans import RunPlan
from taskcond.combinations import generate
from taskcond.conditions import parse_predicate
from taskcond.sim.roles import scene_roles

TARGETS = ("box", "top drawer")
"""The move-into targets measured by default (the slice of the issue's measurement; ``--targets``)."""
PLACES = ("move_on_top", "move_in_front")
"""The other placing primitives, measured on every target the generator allows (``--cells``)."""


def _cells(
    kinds: set[str], targets: tuple[str, ...] = TARGETS
) -> list[tuple[str, tuple[str, ...], tuple[str, ...]]]:
    """(cell label, plan steps, goal predicates) of each measured single-step combination."""
    cells = []
    for combo in generate(scene_roles()).combinations:
        if len(combo.steps) != 1:
            continue
        (step,) = combo.steps
        a = step.subject
        if step.primitive == "grasp" and "grasp" in kinds:
            cells.append((f"grasp {a}", (f"grasp {a}",), (f"gripper grasping {a}",)))
        elif step.primitive == "move_into" and step.target in targets and "move_into" in kinds:
            steps = (f"grasp {a}", step.name, f"release {a}")
            cells.append((step.name, steps, (f"{a} inside {step.target}", "gripper not grasping")))
        elif step.primitive in PLACES and step.primitive in kinds:
            cells.append((step.name, (f"grasp {a}", step.name, f"release {a}"), tuple(map(str, combo.goal))))
    return cells


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--cells", default="grasp,move_into")
    parser.add_argument("--match", default="", help="only the cells whose label contains this")
    parser.add_argument("--targets", default=",".join(TARGETS), help="the move-into targets, comma-separated")
    args = parser.parse_args()
    library = load_library()
    source = make_source("env", library)
    total = fallen = ok_all = 0
    print("| cell | success | fallen | failures |\n|---|---|---|---|")
    for label, steps, goal in _cells(set(args.cells.split(",")), tuple(args.targets.split(","))):
        if args.match not in label:
            continue
        plan = RunPlan(label, None, steps)
        goal_predicates = tuple(parse_predicate(g) for g in goal)
        results = [
            run_episode(plan, "env", seed, library, source, start_state="random", goal=goal_predicates)
            for seed in range(args.seed, args.seed + args.episodes)
        ]
        ok = sum(bool(r.success) for r in results)
        fell = sum(bool(r.fallen) or r.failure == "fallen" for r in results)
        failures = Counter(str(r.failure) for r in results if not r.success)
        print(f"| {label} | {ok}/{len(results)} | {fell} | {dict(failures) or '-'} |", flush=True)
        total, fallen, ok_all = total + len(results), fallen + fell, ok_all + ok
    print(f"\nall: {ok_all}/{total} ({ok_all / max(total, 1):.0%}), fallen {fallen}/{total}")


if __name__ == "__main__":
    main()
