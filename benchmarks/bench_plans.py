"""Benchmark of the combination benchmark's decompositions alone (issue 31, item 5): for every generated
task and each of the wordings its first ``--episodes`` seeds say (seed 1000 + k says wording k, as
``taskcond eval combinations`` does), the configured LLM's plan (answers cached like any other) and whether
the goal that plan derives (:func:`taskcond.execution.planner.goal_of`) includes the template's goal: a
plan that says something else ("grasp can, release can" for "grasp the can", "move bowl into box" for
"stack the bowl on the box") cannot meet the goal an episode is judged by, whatever the skills do.
The plan is judged as the LLM gave it, before the planner's repair: ``tilt X`` alone (the grasp left to
the planner, which inserts it in an episode) misses ``gripper grasping X`` here.
Run: ``.venv/bin/python benchmarks/bench_plans.py [--episodes 3]``; prints the wrong plans and the totals
per primitive (a sequence's row is its length), and how many plans were read from the words after every
answer of the LLM contradicted them (:func:`taskcond.decompose.decompose`).
"""

from __future__ import annotations

import argparse
from collections import Counter

from taskcond.application.plans import instruction_plan, llm_decomposer
from taskcond.combinations import generate
from taskcond.decompose import DecompositionError
from taskcond.execution.planner import goal_of
from taskcond.sim.roles import scene_roles


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1000)
    args = parser.parse_args()
    told: list[str] = []
    decomposer = llm_decomposer(None, tell=told.append)
    right: Counter[str] = Counter()
    total: Counter[str] = Counter()
    for c in generate(scene_roles()).combinations:
        row = c.cell[0].split()[0] if len(c.steps) == 1 else c.cell[0]
        for seed in range(args.seed, args.seed + args.episodes):
            text = c.instruction().text_for(seed)
            try:
                plan = instruction_plan(text, decomposer).steps
                missing = set(c.goal) - set(goal_of(plan))
            except DecompositionError as exc:
                plan, missing = (f"no plan: {str(exc)[:90]}",), set(c.goal)
            total[row] += 1
            right[row] += not missing
            if missing:
                print(f"- {text!r}: {'; '.join(plan)} (misses {', '.join(map(str, missing))})")
    print("\n| primitive | plans that say the task |\n|---|---|")
    for row in sorted(total):
        print(f"| {row} | {right[row]}/{total[row]} |")
    print(f"| all | {sum(right.values())}/{sum(total.values())} |")
    print(f"\n{len(told)} plans read from the words after the LLM's answers contradicted them")


if __name__ == "__main__":
    main()
