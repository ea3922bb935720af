"""Benchmark of the Rerun recording of an episode (taskcond.viz.rerun_recording): its overhead on an
episode's wall time (target: at most 15%) and, with ``--code DIR``, the cost of the observer hooks when
recording is off against another checkout's code (target: none).

Run: ``.venv/bin/python benchmarks/bench_recording.py [--episodes N] [--tasks LHT1 LHT3] [--method env]
[--code /path/to/other/src]``. Each episode runs without and with a recording, one after the other (the
machine's load shifts alike on both), and with ``--code`` once more in a subprocess with the other
checkout's ``src`` first on the path. The wall time of an episode with a recording includes closing its
file. Prints a markdown table of medians and the median per-episode ratio.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from taskcond.application.condition_sources import make_source
from taskcond.application.episode import run_episode
from taskcond.application.library import load_library
from taskcond.application.plans import plan_run


def timed(
    task: str,
    method: str,
    seed: int,
    library,
    source,
    recording: Path | None,
    video: Path | None = None,
    size: tuple[int, int] | None = None,
) -> float:
    """Wall seconds of one episode (with the recording's or the video's file closed)."""
    observers = []
    if recording is not None:
        from taskcond.viz.rerun_recording import RerunRecording

        observers.append(RerunRecording(recording))
    start = time.perf_counter()
    run_episode(
        plan_run(task),
        method,  # type: ignore[arg-type]
        seed,
        library,
        source,
        video=video,
        video_size=size,
        observers=observers,
    )
    return time.perf_counter() - start


def other_code(src: str, task: str, method: str, seed: int) -> float:
    """Wall seconds of the episode without recording under the checkout ``src`` (a subprocess)."""
    code = (
        "import json, time; from taskcond.application.condition_sources import make_source; "
        "from taskcond.application.episode import run_episode; from taskcond.application.library import "
        "load_library; from taskcond.application.plans import plan_run; lib = load_library(); "
        f"s = make_source({method!r}, lib); run_episode(plan_run({task!r}), {method!r}, {seed}, lib, s); "
        f"t = time.perf_counter(); run_episode(plan_run({task!r}), {method!r}, {seed}, lib, s); "
        "print(json.dumps(time.perf_counter() - t))"
    )
    env = os.environ | {"PYTHONPATH": src}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return float(json.loads(out.stdout.strip().splitlines()[-1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--episodes", type=int, default=5, help="seeds per task")
    ap.add_argument("--tasks", nargs="+", default=["LHT1", "LHT3"], help="suite task ids")
    ap.add_argument("--method", default="env", help="execution method")
    ap.add_argument("--code", help="another checkout's src directory: its time with recording off")
    ap.add_argument(
        "--video-sizes", nargs="*", default=[], help="also time captioned videos of these sizes (WxH)"
    )
    args = ap.parse_args()
    if args.video_sizes:
        videos(args)
        return
    library = load_library()
    source = make_source(args.method, library)  # type: ignore[arg-type]
    import rerun  # noqa: F401  (imported once, as a long evaluation would)

    print("| task | episodes | off s (median) | on s (median) | on/off (median) | rrd MB (median) |", end="")
    print(" other code off s | off/other |" if args.code else "")
    print("|---|---|---|---|---|---|" + ("---|---|" if args.code else ""))
    with tempfile.TemporaryDirectory() as tmp:
        for task in args.tasks:
            timed(task, args.method, 999, library, source, Path(tmp) / "warm.rrd")  # warm caches
            off, on, ratios, sizes, other = [], [], [], [], []
            for k in range(args.episodes):
                seed = 1000 + k
                path = Path(tmp) / f"{task}-{seed}.rrd"
                off.append(timed(task, args.method, seed, library, source, None))
                on.append(timed(task, args.method, seed, library, source, path))
                ratios.append(on[-1] / off[-1])
                sizes.append(path.stat().st_size / 1e6)
                if args.code:
                    other.append(other_code(args.code, task, args.method, seed))
            row = (
                f"| {task} | {args.episodes} | {statistics.median(off):.2f} | {statistics.median(on):.2f} | "
                f"{statistics.median(ratios):.3f} | {statistics.median(sizes):.1f} |"
            )
            if args.code:
                theirs = statistics.median(other)
                row += f" {theirs:.2f} | {statistics.median(off) / theirs:.3f} |"
            print(row, flush=True)


def videos(args: argparse.Namespace) -> None:
    """Median wall time of episodes with a captioned video of each size, and its ratio to none."""
    library = load_library()
    source = make_source(args.method, library)  # type: ignore[arg-type]
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.video_sizes]
    print("| task | episodes | no video s | " + " | ".join(f"{w}x{h} s (ratio)" for w, h in sizes) + " |")
    print("|---|---|---|" + "---|" * len(sizes))
    with tempfile.TemporaryDirectory() as tmp:
        for task in args.tasks:
            timed(task, args.method, 999, library, source, None)
            off, on = [], {size: [] for size in sizes}
            for k in range(args.episodes):
                off.append(timed(task, args.method, 1000 + k, library, source, None))
                for size in sizes:
                    path = Path(tmp) / "v.mp4"
                    on[size].append(timed(task, args.method, 1000 + k, library, source, None, path, size))
            base = statistics.median(off)
            cells = [f"{statistics.median(v):.2f} ({statistics.median(v) / base:.2f})" for v in on.values()]
            print(f"| {task} | {args.episodes} | {base:.2f} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
