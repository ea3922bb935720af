"""Record and compare whole episodes of the executor: a check that a restructuring kept its behaviour.

``record`` runs seeded episodes (``run_episode``, as ``taskcond eval`` does) and writes one JSON line per
episode: the result and every event of its trace, without the wall-clock fields. ``compare`` reports how
many episodes of two recordings are identical and names the fields of those that are not. Record once at
the commit before the change (e.g. from ``git worktree add``) and once after, with the same skill library
and LLM response cache (``TASKCOND_CACHE_DIR``), so that both runs see the same conditions.

Run::

    .venv/bin/python benchmarks/trace_episodes.py record before.jsonl --task LHT1:llm,none --episodes 3
    .venv/bin/python benchmarks/trace_episodes.py record after.jsonl --task LHT1:llm,none --episodes 3
    .venv/bin/python benchmarks/trace_episodes.py compare before.jsonl after.jsonl

Exit code 1 when the recordings differ.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from dataclasses import asdict
from pathlib import Path

from taskcond.application.condition_sources import make_source
from taskcond.application.episode import DEFAULT_NOISE, run_episode
from taskcond.application.library import load_library
from taskcond.application.plans import plan_run

WALL_CLOCK = ("wall_seconds", "env_seconds")
"""Fields of an episode that measure the machine, not the behaviour."""


def record(out: Path, specs: list[str], episodes: int, noise: float, seed: int) -> None:
    """Episodes ``seed`` ... ``seed + episodes - 1`` of every ``task:method,method`` in ``specs``."""
    library = load_library()
    sources = {}
    with out.open("w", encoding="utf-8") as fh:
        for spec in specs:
            task, _, methods = spec.partition(":")
            for method in (methods or "llm,env,none").split(","):
                if method not in sources:
                    sources[method] = make_source(method, library)  # type: ignore[arg-type]
                for k in range(episodes):
                    result = run_episode(plan_run(task), method, seed + k, library, sources[method], noise)  # type: ignore[arg-type]
                    fields = {f: v for f, v in asdict(result).items() if f not in WALL_CLOCK}
                    fh.write(json.dumps(fields, sort_keys=True) + "\n")
                    fh.flush()
                    print(task, method, seed + k, result.success, len(result.events), "events", flush=True)


def compare(a: Path, b: Path) -> bool:
    """Print how many episodes of the recordings ``a`` and ``b`` are identical; True if all are."""
    first = [json.loads(line) for line in a.read_text(encoding="utf-8").splitlines()]
    second = [json.loads(line) for line in b.read_text(encoding="utf-8").splitlines()]
    same = sum(x == y for x, y in zip(first, second, strict=False))
    kinds = Counter(e["kind"] for x in first[: len(second)] for e in x["events"])
    print(
        f"{len(first)} / {len(second)} episodes, {same} identical; "
        f"{sum(kinds.values())} events in the compared ones: {dict(sorted(kinds.items()))}"
    )
    for x, y in zip(first, second, strict=False):
        if x != y:
            diff = sorted(k for k in x.keys() | y.keys() if x.get(k) != y.get(k))
            print(f"differs: {x['task']} {x['method']} seed {x['seed']}: {', '.join(diff)}")
    return len(first) == len(second) == same


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="Record seeded episodes with their traces.")
    rec.add_argument("out", type=Path)
    rec.add_argument("--task", action="append", required=True, help="TASK[:method,method] (repeatable).")
    rec.add_argument("--episodes", type=int, default=3)
    rec.add_argument("--noise", type=float, default=DEFAULT_NOISE)
    rec.add_argument("--seed", type=int, default=1000)
    cmp = sub.add_parser("compare", help="Compare two recordings.")
    cmp.add_argument("a", type=Path)
    cmp.add_argument("b", type=Path)
    args = parser.parse_args()
    if args.command == "record":
        record(args.out, args.task, args.episodes, args.noise, args.seed)
    elif not compare(args.a, args.b):
        sys.exit(1)


if __name__ == "__main__":
    main()
