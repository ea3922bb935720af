"""Benchmark of the PyBullet kitchen task suite (paper §IV).

Measures, and prints as a markdown table:

* simulation throughput (physics steps/s) of the suite's scenes driven through ``KitchenEnv.step`` vs raw
  PyBullet stepping the same bodies in the same client with the same motor commands, side by side: medians
  and the spread of the env/raw ratio over ``--repeats`` repetitions (:func:`throughput`);
* reset time, camera time per 320×240 observation, resident memory per environment;
* oracle success rates over ``--episodes`` seeded episodes per task;
* with ``--ik`` instead of all that: time and accuracy of the Franka IK's settings on the targets of oracle
  episodes (:func:`ik_accuracy`).

Usage: ``python benchmarks/bench_sim.py [--episodes 100] [--tasks grasp-bottle LHT1 ...]``;
``--throughput-only`` prints the throughput table alone; ``--ik`` the IK table alone.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import time
from dataclasses import dataclass

import numpy as np
import pybullet as p

from taskcond.envs.kitchen import KitchenEnv
from taskcond.sim.arm import IKResult
from taskcond.sim.franka import IK_DAMPING, IK_MAX_ITERATIONS, PYBULLET_IK_DAMPING, Franka
from taskcond.tasks.oracle import run_episode, run_oracle
from taskcond.tasks.registry import make, task_ids


def _rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


THROUGHPUT_TASKS = ("move_into-bottle-box", "LHT1")
"""Scenes of the throughput measurement: the arm holding the bottle over the open box, and the arm at home
with the box open (LHT1's initial state)."""


@dataclass(frozen=True)
class Throughput:
    """Physics steps per CPU second of one scene, through ``KitchenEnv.step`` and raw, medians over the
    repetitions. CPU time is the benchmark thread's (``time.thread_time``; PyBullet's ``DIRECT`` client
    simulates in the calling thread), which leaves out the time this shared machine gives other processes;
    the wall-clock ratios are kept for comparison.

    Attributes:
        scene: what was stepped (task id and how).
        env: median physics steps per CPU second through the env (IK, motor commands, blow-up and success
            checks, observation).
        raw: median physics steps per CPU second of ``p.stepSimulation`` alone, same client, bodies and motor
            commands.
        ratios: env/raw of each repetition (its raw CPU time over its env CPU time), sorted.
        wall_ratios: the same from wall-clock time (``time.perf_counter``), sorted.
        overhead_us: median of each repetition's env time minus raw time per control step, µs CPU time.
    """

    scene: str
    env: float
    raw: float
    ratios: tuple[float, ...]
    wall_ratios: tuple[float, ...]
    overhead_us: float

    @property
    def median(self) -> float:
        return statistics.median(self.ratios)


class _PairedClock:
    """Times ``env.step`` and, right after it, ``env.substeps`` raw ``stepSimulation`` calls of the same
    client, so that both see the same load to the millisecond; sums CPU and wall time per repetition."""

    def __init__(self, env: KitchenEnv) -> None:
        self.env = env
        self.repetitions: list[tuple[int, float, float, float, float]] = []
        self._sums = [0, 0.0, 0.0, 0.0, 0.0]

    def step(self, action: np.ndarray) -> bool:
        """One timed env step and one timed raw control period; whether the episode terminated."""
        client, substeps = self.env.scene.client, self.env.substeps
        c0, w0 = time.thread_time(), time.perf_counter()
        terminated = self.env.step(action)[2]
        c1, w1 = time.thread_time(), time.perf_counter()
        for _ in range(substeps):
            p.stepSimulation(physicsClientId=client)
        c2, w2 = time.thread_time(), time.perf_counter()
        sums = self._sums
        sums[0] += 1
        sums[1] += c1 - c0
        sums[2] += c2 - c1
        sums[3] += w1 - w0
        sums[4] += w2 - w1
        return terminated

    def end_repetition(self) -> None:
        n, t_env, t_raw, w_env, w_raw = self._sums
        self.repetitions.append((int(n), t_env, t_raw, w_env, w_raw))
        self._sums = [0, 0.0, 0.0, 0.0, 0.0]

    def result(self, scene: str) -> Throughput:
        substeps = self.env.substeps
        reps = self.repetitions
        return Throughput(
            scene,
            statistics.median(n * substeps / t_env for n, t_env, *_ in reps),
            statistics.median(n * substeps / t_raw for n, _, t_raw, *_ in reps),
            tuple(sorted(t_raw / t_env for _, t_env, t_raw, *_ in reps)),
            tuple(sorted(w_raw / w_env for *_, w_env, w_raw in reps)),
            statistics.median(1e6 * (t_env - t_raw) / n for n, t_env, t_raw, *_ in reps),
        )


def throughput(task_id: str = "move_into-bottle-box", repeats: int = 21, steps: int = 60) -> Throughput:
    """Physics steps per CPU second through the env and raw ``stepSimulation``, same client and bodies, with
    the arm holding the pose ``reset`` left (gripper command unchanged).

    Each of ``repeats`` repetitions alternates ``steps`` times one timed ``env.step`` and one timed run of
    ``env.substeps`` raw ``stepSimulation`` calls; a repetition's ratio is its raw time over its env time.
    Ten untimed rounds of both come first."""
    env = make(task_id, seed=0)
    obs, _ = env.reset()
    action = np.concatenate([obs["ee_position"], obs["ee_orientation"], [float(env.robot.gripper_closed)]])
    clock = _PairedClock(env)
    for _ in range(10):
        clock.step(action)
    clock.end_repetition()
    clock.repetitions.clear()  # the warm-up
    for _ in range(repeats):
        for _ in range(steps):
            clock.step(action)
        clock.end_repetition()
    env.close()
    return clock.result(f"{task_id}, holding the reset pose")


def episode_throughput(task_id: str = "LHT1", episodes: int = 5) -> Throughput:
    """As :func:`throughput` along the oracle's episodes (seeds ``0 .. episodes - 1``, one repetition each):
    every ``env.step`` of the oracle's actions is followed by ``env.substeps`` timed raw steps with the motor
    commands it left. The raw steps add simulated time (the arm holds each target one more control period),
    so the episodes are not the plain oracle's; the env steps include the IK of a moving target."""
    env = make(task_id)
    clock = _PairedClock(env)
    for seed in range(episodes):
        env.reset(seed=seed)
        terminated = False
        for trajectory in env.task.plans(env):
            for i in range(len(trajectory)):
                terminated = clock.step(trajectory.action(i))
                if terminated:
                    break
            if terminated:
                break
        clock.end_repetition()
    env.close()
    return clock.result(f"{task_id}, oracle episodes")


def print_throughput(results: list[Throughput]) -> None:
    """Markdown table of throughput results (rates per CPU second; wall-clock ratios alongside)."""
    print(
        "| scene | env physics steps/s | raw physics steps/s | env/raw median | env/raw min-max "
        "| env/raw median, wall clock | env overhead per control step |"
    )
    print("|---|---|---|---|---|---|---|")
    for r in results:
        print(
            f"| {r.scene} | {r.env:.0f} | {r.raw:.0f} | {100 * r.median:.1f}% "
            f"| {100 * r.ratios[0]:.1f}-{100 * r.ratios[-1]:.1f}% ({len(r.ratios)} repetitions) "
            f"| {100 * statistics.median(r.wall_ratios):.1f}% "
            f"({100 * r.wall_ratios[0]:.1f}-{100 * r.wall_ratios[-1]:.1f}%) | {r.overhead_us:.0f} µs |",
            flush=True,
        )


IK_TASKS = (
    "grasp-bottle",
    "grasp-spatula",
    "open-top_drawer",
    "open-box",
    "close-microwave",
    "tilt-bottle",
    "move_into-bowl-top_drawer",
    "move_into-bowl-bottom_drawer",
    "move_into-toothpaste-mug",
    "move_on_top-spatula-box",
    "LHT1",
    "LHT2",
    "LHT3",
)
"""Tasks whose oracle episodes give the IK targets of :func:`ik_accuracy`."""
IK_SETTINGS = {
    f"PyBullet default damping {PYBULLET_IK_DAMPING[0]}, 100 iterations": (PYBULLET_IK_DAMPING, 100),
    f"damping {IK_DAMPING[0]:g}, {IK_MAX_ITERATIONS} iterations (used)": (IK_DAMPING, IK_MAX_ITERATIONS),
}
"""IK settings compared by :func:`ik_accuracy`: name → (damping per degree of freedom, iteration cap)."""


@dataclass(frozen=True)
class IkCall:
    """One call of ``Franka.solve_ik`` in an oracle episode: target ``position`` (3,) m and unit
    ``orientation`` (4,) xyzw (world frame), the ``seed`` joints (7,) rad, and whether the seed was the
    previous call's solution (``chained``; ``KitchenEnv.step`` seeds with the last solution)."""

    position: np.ndarray
    orientation: np.ndarray
    seed: np.ndarray
    chained: bool


class _IkRecorder:
    """Stands in for ``robot.solve_ik`` of one environment: solves with it and appends every call to
    ``calls``."""

    def __init__(self, env: KitchenEnv, calls: list[IkCall]) -> None:
        self.robot, self.solve, self.calls = env.robot, env.robot.solve_ik, calls
        self.last: np.ndarray | None = None

    def __call__(
        self, position: np.ndarray, orientation: np.ndarray, seed: np.ndarray | None = None
    ) -> IKResult:
        start = self.robot.joint_positions() if seed is None else np.asarray(seed, dtype=float)
        chained = self.last is not None and np.array_equal(start, self.last)
        orientation = np.asarray(orientation, dtype=float)
        orientation = orientation / np.linalg.norm(orientation)
        self.calls.append(IkCall(np.array(position, dtype=float), orientation, start.copy(), chained))
        result = self.solve(position, orientation, start)
        self.last = result.q
        return result


def record_ik_calls(tasks: tuple[str, ...] = IK_TASKS, episodes: int = 2) -> list[IkCall]:
    """Every ``Franka.solve_ik`` call of the oracle episodes (seeds ``0 .. episodes - 1``) of ``tasks``."""
    calls: list[IkCall] = []
    for task_id in tasks:
        env = make(task_id)
        env.robot.solve_ik = _IkRecorder(env, calls)  # type: ignore[method-assign]
        for seed in range(episodes):
            run_episode(env, seed)
        env.close()
    return calls


@dataclass(frozen=True)
class IkAccuracy:
    """Time and accuracy of one IK setting over recorded calls.

    Attributes:
        setting: name (see :data:`IK_SETTINGS`).
        us_per_call: median over repetitions of the CPU time per call, µs.
        position_mm: 50th, 99th percentile and maximum of the end-effector position error (m → mm) over the
            targets that no setting's solution has at a joint limit (some of them are beyond the arm's reach).
        orientation_deg: the same of the orientation error (rotation angle, degrees).
        met: of those targets, how many this setting's solution meets within :data:`IK_MET` (mm, °).
        at_limit: calls whose solution this setting clipped to a joint limit.
    """

    setting: str
    us_per_call: float
    position_mm: tuple[float, float, float]
    orientation_deg: tuple[float, float, float]
    met: int
    at_limit: int


IK_MET = (1.0, 0.1)
"""Position (mm) and orientation (°) error within which :class:`IkAccuracy` counts a target as met."""


def ik_accuracy(calls: list[IkCall], repeats: int = 3) -> tuple[list[IkAccuracy], int]:
    """Solve the recorded ``calls`` with every setting of :data:`IK_SETTINGS` in a fresh client, in order;
    a chained call is seeded with the setting's own previous solution, the others with the recorded seed.
    Returns the result per setting and the number of targets no setting's solution has at a joint limit."""
    client = p.connect(p.DIRECT)
    robot = Franka(client)
    solutions: dict[str, list[np.ndarray]] = {}
    times: dict[str, float] = {}
    for name, (damping, iterations) in IK_SETTINGS.items():
        cpu = []
        for _ in range(repeats):
            qs: list[np.ndarray] = []
            start = time.thread_time()
            for call in calls:
                seed = qs[-1] if call.chained and qs else call.seed
                qs.append(robot.solve_ik(call.position, call.orientation, seed, damping, iterations).q)
            cpu.append(time.thread_time() - start)
        solutions[name], times[name] = qs, 1e6 * statistics.median(cpu) / len(calls)
    at_limit = {
        name: np.array([np.any((q <= robot.lower) | (q >= robot.upper)) for q in qs])
        for name, qs in solutions.items()
    }
    inside = ~np.any(list(at_limit.values()), axis=0)
    results = []
    for name, qs in solutions.items():
        position, angle = [], []
        for call, q in zip(calls, qs, strict=True):
            pose = robot.fk(q)
            position.append(1000 * np.linalg.norm(pose.position - call.position))
            # PyBullet's link quaternions are unit to about 1e-8, which alone reads as 0.01°
            unit = pose.orientation / np.linalg.norm(pose.orientation)
            dot = min(1.0, abs(float(np.dot(unit, call.orientation))))
            angle.append(np.degrees(2 * np.arccos(dot)))
        pos, ang = np.array(position)[inside], np.array(angle)[inside]
        results.append(
            IkAccuracy(
                name,
                times[name],
                (float(np.median(pos)), float(np.percentile(pos, 99)), float(pos.max())),
                (float(np.median(ang)), float(np.percentile(ang, 99)), float(ang.max())),
                int(np.sum((pos <= IK_MET[0]) & (ang <= IK_MET[1]))),
                int(at_limit[name].sum()),
            )
        )
    p.disconnect(client)
    return results, int(inside.sum())


def print_ik(calls: list[IkCall], results: list[IkAccuracy], inside: int) -> None:
    """Markdown table of :func:`ik_accuracy`'s results."""
    print(
        f"{len(calls)} IK calls of oracle episodes (seeds 0-1) of {len(IK_TASKS)} tasks; errors over the "
        f"{inside} whose solution no setting has at a joint limit:\n"
    )
    print(
        "| IK setting | CPU time per call | position error p50 / p99 / max "
        f"| orientation error p50 / p99 / max | within {IK_MET[0]:g} mm and {IK_MET[1]:g}° "
        "| solutions at a joint limit |"
    )
    print("|---|---|---|---|---|---|")
    for r in results:
        pos, ang = r.position_mm, r.orientation_deg
        print(
            f"| {r.setting} | {r.us_per_call:.1f} µs | {pos[0]:.4f} / {pos[1]:.3f} / {pos[2]:.1f} mm "
            f"| {ang[0]:.5f} / {ang[1]:.4f} / {ang[2]:.2f}° | {r.met} ({100 * r.met / inside:.1f}%) "
            f"| {r.at_limit} |",
            flush=True,
        )


def timings(task_id: str = "grasp-bottle", n: int = 10) -> dict[str, float]:
    before = _rss_mb()
    env = make(task_id, seed=0, render_mode="rgb_array")
    env.reset()
    mem = _rss_mb() - before
    t0 = time.perf_counter()
    for k in range(n):
        env.reset(seed=k)
    reset = (time.perf_counter() - t0) / n
    t0 = time.perf_counter()
    for _ in range(n):
        env.render()
    cam = (time.perf_counter() - t0) / n
    env.close()
    return {"reset_s": reset, "camera_s": cam, "memory_mb": mem}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=100, help="oracle episodes per task of the success table")
    ap.add_argument("--tasks", nargs="*", default=None, help="registry ids (default: all)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--repeats", type=int, default=21, help="throughput repetitions per scene (median and spread)"
    )
    ap.add_argument(
        "--throughput-episodes",
        type=int,
        default=5,
        help="oracle episodes per scene of the episode throughput (one repetition each)",
    )
    ap.add_argument(
        "--throughput-only",
        action="store_true",
        help="print the throughput table only (no reset/camera/memory timings, no oracle episodes)",
    )
    ap.add_argument(
        "--ik",
        action="store_true",
        help="print the IK time/accuracy table only (targets of oracle episodes, seeds 0-1, of IK_TASKS)",
    )
    args = ap.parse_args()

    if args.ik:
        calls = record_ik_calls()
        print_ik(calls, *ik_accuracy(calls))
        return
    results = [throughput(t, repeats=args.repeats) for t in THROUGHPUT_TASKS]
    results += [episode_throughput(t, args.throughput_episodes) for t in THROUGHPUT_TASKS]
    print_throughput(results)
    if args.throughput_only:
        return
    tm = timings()
    print()
    print("| metric | value |\n|---|---|")
    print(f"| reset time | {1000 * tm['reset_s']:.1f} ms |")
    print(f"| camera 320x240 per observation | {1000 * tm['camera_s']:.1f} ms |")
    print(f"| memory per environment | {tm['memory_mb']:.1f} MB |")
    print()
    print("| task | episodes | success rate | control steps/s | failures |\n|---|---|---|---|---|")
    for task_id in args.tasks or task_ids():
        r = run_oracle(task_id, args.episodes, seed=args.seed)
        fails = ", ".join(f"{k}: {v}" for k, v in sorted(r.failures.items())) or "-"
        rate = f"{100 * r.success_rate:.0f}%"
        print(f"| {task_id} | {r.episodes} | {rate} | {r.steps_per_second:.0f} | {fails} |", flush=True)


if __name__ == "__main__":
    main()
