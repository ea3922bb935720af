"""Oracle demonstrations of the suite as behaviour-cloning samples (the image-based baseline, paper §V).

A demonstration runs a suite task's scripted oracle (:mod:`taskcond.tasks.oracle`) from a seeded reset and
records, every :data:`CHUNK` control steps, one :class:`Sample`: the camera image, the low-dimensional
state and the oracle's next :data:`CHUNK` actions. A long-horizon task's oracle is split at its primitive
steps, each labelled with that step's primitive task name, so that a policy learns "grasp bottle" from the
state a preceding primitive leaves too (as the skill library does with
:data:`taskcond.application.demonstrations.CONTEXTS`). Each step's demonstration ends with
:data:`HOLD_STEPS` steps holding its last action (the policy learns to stay once done).

Frames and units: positions in metres in the world frame (z up), quaternions xyzw, gripper command 0 (open)
or 1 (closed), images from :data:`CAMERA` (pixel row 0 at the top).

Sample layout (one row of each array of :class:`Samples`):

- ``image`` (H, W, 4) uint8: RGB and the depth quantized over [:data:`DEPTH_NEAR`, :data:`DEPTH_FAR`] m;
- ``state`` (:data:`STATE_DIM`,) float32: per arm (Franka, then the Kinova, zeros without it) end-effector
  position (3), orientation (4, sign fixed by :func:`canonical`) and gripper opening (1, m), then the goal
  of a ``move`` task relative to the Franka's end effector (3; zeros for other tasks);
- ``progress`` float32: control steps since the primitive task started over the median length of its
  demonstrations;
- ``actions`` (:data:`CHUNK`, 16) float32: the oracle's next actions, per arm the target position relative
  to that arm's end-effector position at the sample (3), the target quaternion in the hemisphere of the
  current one (4), the gripper command (1); past the demonstration's end the last action repeats;
- ``arms`` int8: 1 (the Franka acts; the Kinova holds) or 2 (both arms act).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from taskcond.envs.kitchen import RENDER_EYE, RENDER_TARGET, KitchenEnv
from taskcond.sim.camera import CameraSpec, render
from taskcond.tasks.base import PrimitiveTask
from taskcond.tasks.dual_arm import DualArmMotionPlan
from taskcond.tasks.registry import get_task, make

IMAGE_SIZE = 64
"""Image side in pixels. The CPU renderer costs about 48 ms per image at 64×64 as at 96×96 (BENCHMARKS.md)."""
CAMERA = CameraSpec(eye=RENDER_EYE, target=RENDER_TARGET, width=IMAGE_SIZE, height=IMAGE_SIZE, fov_deg=42.0)
"""The fixed camera of the baseline: the suite's render camera (in front of the table on the robot's right,
seeing both arms and every object), square."""
DEPTH_NEAR, DEPTH_FAR = 0.5, 2.5
"""Metres mapped to depth values 0 and 255."""
CHUNK = 4
"""Actions predicted from one image and executed open loop: one image per 4 control steps (133 ms) keeps
the renderer's cost to a quarter."""
HOLD_STEPS = 2 * CHUNK
"""Control steps recorded after each primitive's demonstration holding its last action."""
ARM_STATE = 8
STATE_DIM = 2 * ARM_STATE + 3
ACTION_DIM = 16
"""Per step of a chunk: (8,) per arm, Franka then Kinova."""
_REFERENCE = np.array([1.0, 0.0, 0.0, 0.0])
"""Quaternion (xyzw) whose hemisphere :func:`canonical` picks: the Franka's top-down grasp."""


def canonical(q: np.ndarray) -> np.ndarray:
    """The quaternion (4,) xyzw of the same rotation whose dot product with :data:`_REFERENCE` (or, at 0, the
    first non-zero component) is positive."""
    d = float(q @ _REFERENCE)
    if abs(d) < 1e-9:
        d = float(q[np.flatnonzero(np.abs(q) > 1e-9)[0]])
    return q if d >= 0 else -q


def observe_image(env: KitchenEnv) -> np.ndarray:
    """The camera image (:data:`IMAGE_SIZE`, :data:`IMAGE_SIZE`, 4) uint8: RGB and quantized depth."""
    frame = render(env.scene.client, CAMERA)
    depth = (np.clip(frame.depth, DEPTH_NEAR, DEPTH_FAR) - DEPTH_NEAR) / (DEPTH_FAR - DEPTH_NEAR)
    return np.concatenate([frame.rgb, np.round(255 * depth).astype(np.uint8)[..., None]], axis=-1)


def observe_state(obs: dict[str, np.ndarray], target: np.ndarray) -> np.ndarray:
    """The low-dimensional state (:data:`STATE_DIM`,) from an environment observation and the goal of a
    ``move`` task (zeros for other tasks)."""
    state = np.zeros(STATE_DIM, np.float32)
    for k, prefix in enumerate(("", "kinova_")):
        if f"{prefix}ee_position" in obs:
            state[k * ARM_STATE : (k + 1) * ARM_STATE] = np.concatenate(
                [
                    obs[f"{prefix}ee_position"],
                    canonical(np.asarray(obs[f"{prefix}ee_orientation"], float)),
                    obs[f"{prefix}gripper_width"],
                ]
            )
    if np.any(target):
        state[2 * ARM_STATE :] = target - obs["ee_position"]
    return state


def relative_actions(actions: np.ndarray, state: np.ndarray) -> np.ndarray:
    """Absolute actions (k, 8) or (k, 16) as targets relative to the arms' poses in ``state``
    (k, :data:`ACTION_DIM`); the Kinova's columns stay zero for an (8,) action."""
    out = np.zeros((len(actions), ACTION_DIM), np.float32)
    for arm in range(actions.shape[1] // 8):
        a, s = actions[:, 8 * arm : 8 * arm + 8], state[ARM_STATE * arm : ARM_STATE * arm + 8]
        q = s[3:7]
        quats = np.where((a[:, 3:7] @ q)[:, None] < 0, -a[:, 3:7], a[:, 3:7])
        out[:, 8 * arm : 8 * arm + 8] = np.concatenate([a[:, :3] - s[:3], quats, a[:, 7:8]], axis=1)
    return out


@dataclass
class Samples:
    """Behaviour-cloning samples (layout in the module docstring); ``names[task[i]]`` is sample i's primitive
    task name, ``lengths[name]`` the control steps of each of its demonstrations."""

    image: np.ndarray
    state: np.ndarray
    progress: np.ndarray
    actions: np.ndarray
    arms: np.ndarray
    task: np.ndarray
    names: list[str]
    lengths: dict[str, list[int]] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.task)

    def save(self, path: Path) -> None:
        arrays = {k: getattr(self, k) for k in ("image", "state", "progress", "actions", "arms", "task")}
        lengths = np.array([self.lengths.get(n, []) for n in self.names], dtype=object)
        np.savez_compressed(path, names=np.array(self.names), lengths=lengths, **arrays)

    @classmethod
    def load(cls, path: Path) -> Samples:
        with np.load(path, allow_pickle=True) as data:
            names = [str(n) for n in data["names"]]
            lengths = {n: [int(v) for v in ls] for n, ls in zip(names, data["lengths"], strict=True)}
            return cls(
                data["image"],
                data["state"],
                data["progress"],
                data["actions"],
                data["arms"],
                data["task"],
                names,
                lengths,
            )

    @classmethod
    def merge(cls, parts: list[Samples]) -> Samples:
        """One set of samples over the sorted union of the parts' task names."""
        names = sorted({n for part in parts for n in part.names})
        index = {n: i for i, n in enumerate(names)}
        lengths: dict[str, list[int]] = {n: [] for n in names}
        for part in parts:
            for n, ls in part.lengths.items():
                lengths[n] += ls
        return cls(
            *(
                np.concatenate([getattr(p, k) for p in parts])
                for k in ("image", "state", "progress", "actions")
            ),
            np.concatenate([p.arms for p in parts]),
            np.concatenate([np.array([index[p.names[t]] for t in p.task], np.int32) for p in parts]),
            names,
            lengths,
        )


@dataclass
class _Step:
    """One primitive step of an oracle run: its task name, actions (T, 8|16), and for every :data:`CHUNK`-th
    step the image and state before it."""

    name: str
    actions: list[np.ndarray] = field(default_factory=list)
    images: list[np.ndarray] = field(default_factory=list)
    states: list[np.ndarray] = field(default_factory=list)


def _oracle_steps(task_id: str, env: KitchenEnv) -> Iterator[tuple[str, Iterator[np.ndarray]]]:
    """(primitive task name, its oracle's actions) per primitive step of ``task_id``, each planned when its
    turn comes (the state the previous one left)."""
    task = get_task(task_id)
    steps = [env.task] if isinstance(task, PrimitiveTask) else list(env.task.steps)  # type: ignore[attr-defined]

    def actions(step: PrimitiveTask) -> Iterator[np.ndarray]:
        for plan in step.plans(env):
            if env.kinova is not None and not isinstance(plan, DualArmMotionPlan):
                plan = DualArmMotionPlan.hold(env, plan)
            for i in range(len(plan)):
                yield plan.action(i)

    for step in steps:
        yield step.info.task_name, actions(step)


def record_episode(task_id: str, seed: int) -> tuple[list[_Step], bool]:
    """Run the oracle of ``task_id`` from ``reset(seed)``, recording each primitive step; returns the steps
    and whether the task succeeded. Raises ValueError for a task without primitive steps."""
    env = make(task_id)
    steps: list[_Step] = []
    try:
        obs, _ = env.reset(seed=seed)
        terminated = False
        for name, actions in _oracle_steps(task_id, env):
            step = _Step(name)
            steps.append(step)
            last = None
            for action in actions:
                if len(step.actions) % CHUNK == 0:
                    step.images.append(observe_image(env))
                    step.states.append(observe_state(obs, env.target))
                step.actions.append(np.asarray(action, float))
                last = action
                obs, _, terminated, _, _ = env.step(action)
                if terminated:
                    break
            if terminated or last is None:
                break
            for _ in range(HOLD_STEPS):
                if len(step.actions) % CHUNK == 0:
                    step.images.append(observe_image(env))
                    step.states.append(observe_state(obs, env.target))
                step.actions.append(np.asarray(last, float))
                obs, _, terminated, _, _ = env.step(last)
        success = not terminated and bool(env.task.success(env))
    finally:
        env.close()
    return steps, success


def _samples(steps: list[_Step]) -> Samples:
    names = sorted({s.name for s in steps})
    rows: dict[str, list] = {k: [] for k in ("image", "state", "progress", "actions", "arms", "task")}
    lengths: dict[str, list[int]] = {n: [] for n in names}
    for step in steps:
        acts = np.array(step.actions)
        length = len(acts) - HOLD_STEPS
        lengths[step.name].append(length)
        dual = acts.shape[1] == 16 and np.ptp(acts[:, 8:], axis=0).max() > 1e-4
        for k, (image, state) in enumerate(zip(step.images, step.states, strict=True)):
            t = k * CHUNK
            idx = np.minimum(np.arange(t, t + CHUNK), len(acts) - 1)
            chunk = acts[idx] if dual else acts[idx, :8]
            rows["image"].append(image)
            rows["state"].append(state)
            rows["progress"].append(t / max(length, 1))
            rows["actions"].append(relative_actions(chunk, state))
            rows["arms"].append(2 if dual else 1)
            rows["task"].append(names.index(step.name))
    return Samples(
        np.array(rows["image"], np.uint8),
        np.array(rows["state"], np.float32),
        np.array(rows["progress"], np.float32),
        np.array(rows["actions"], np.float32),
        np.array(rows["arms"], np.int8),
        np.array(rows["task"], np.int32),
        names,
        lengths,
    )


def demonstrate(
    task_id: str, episodes: int, seed: int = 0, tries: int = 3, progress: Callable[[], None] | None = None
) -> Samples:
    """Samples of ``episodes`` successful oracle demonstrations of ``task_id``, from seeds ``seed``,
    ``seed + 1``, ...; a failed demonstration is skipped (at most ``tries × episodes`` seeds are tried).

    Raises:
        RuntimeError: fewer than ``episodes`` demonstrations succeeded.
    """
    kept: list[_Step] = []
    good = 0
    for s in range(seed, seed + tries * episodes):
        steps, ok = record_episode(task_id, s)
        if ok:
            kept += steps
            good += 1
            if progress is not None:
                progress()
        if good == episodes:
            return _samples(kept)
    raise RuntimeError(f"the oracle of {task_id} succeeded {good} times in {tries * episodes} seeds")


@dataclass(frozen=True)
class DataSpec:
    """Which demonstrations the baseline learns from.

    Attributes:
        episodes: successful oracle demonstrations per task of the single-arm kitchen.
        dual_arm_episodes: per task of the dual-arm scene (the cloth's soft body costs 40-95 s of
            simulation per demonstration).
        seed: seed of each task's first demonstration (evaluations start at 1000).
    """

    episodes: int = 10
    dual_arm_episodes: int = 2
    seed: int = 0

    def episodes_of(self, task_id: str) -> int:
        return self.dual_arm_episodes if get_task(task_id).scene_config(None) is not None else self.episodes


def collect(
    directory: Path,
    task_ids: list[str],
    spec: DataSpec,
    progress: Callable[[str], None] | None = None,
) -> Samples:
    """The samples of every task in ``task_ids``, demonstrated as ``spec`` says; each task's samples are
    stored in ``directory/<task id>.npz`` as soon as they are recorded and read from there next time (an
    interrupted collection resumes). ``progress`` is told the task id after each demonstration."""
    directory.mkdir(parents=True, exist_ok=True)
    parts = []
    for task_id in task_ids:
        path = directory / f"{task_id}.npz"
        if not path.exists():
            samples = demonstrate(
                task_id,
                spec.episodes_of(task_id),
                spec.seed,
                progress=None if progress is None else lambda t=task_id: progress(t),
            )
            tmp = path.with_suffix(".tmp.npz")
            samples.save(tmp)
            tmp.replace(path)
        elif progress is not None:
            for _ in range(spec.episodes_of(task_id)):
                progress(task_id)
        parts.append(Samples.load(path))
    return Samples.merge(parts)


__all__ = [
    "ACTION_DIM",
    "CAMERA",
    "CHUNK",
    "IMAGE_SIZE",
    "STATE_DIM",
    "DataSpec",
    "Samples",
    "canonical",
    "collect",
    "demonstrate",
    "observe_image",
    "observe_state",
    "record_episode",
    "relative_actions",
]
