"""Demonstration files: a recorded end-effector trajectory a user provides to teach a primitive its skill
(``taskcond learn --demo FILE``), or that ``taskcond record`` writes from a suite oracle.

The file is JSON (format ``taskcond-demonstration/1``)::

    {
      "format": "taskcond-demonstration/1",
      "task_name": "push toothpaste in front of bottle",   # a task name of a registered primitive
      "objects": {"A": "toothpaste", "B": "bottle"},       # optional: the objects bound to the roles;
                                                           #   must agree with task_name when given
      "scene": null,        # the suite task whose initial state it starts from (`taskcond tasks`),
                            #   null: the default kitchen (containers closed, arm at home)
      "seed": 0,            # the scene's reset seed
      "dt": 0.01,           # sample period in s; or "times": [t0, t1, ...] (s, increasing)
      "positions": [[x, y, z], ...],        # (n, 3) end-effector positions, metres, world frame;
                                            #   (n, 6) for two arms (Franka first, then the Kinova)
      "orientations": [[x, y, z, w], ...],  # (n, 4) quaternions xyzw, world frame; (n, 8) for two arms
      "gripper": [0.0, ...]                 # (n,) gripper command, 0 open, 1 closed
    }

The world frame is the kitchen's: the Franka's base at the origin facing +x, z up. Samples at another rate
than the environment's control period are resampled to it (positions linearly, orientations by slerp, the
gripper command held). Learning replays the trajectory in its scene, one command per control step, and
reads the environment information at its start and end (the demonstration's evidence, for FromEnv
conditions and grounding) exactly as for the suite's oracle demonstrations.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from taskcond.primitives import LETTERS, TaskNameError, parse_task

FORMAT = "taskcond-demonstration/1"


class DemoFileError(ValueError):
    """A demonstration file that cannot be read; the message names the file and what is wrong."""


@dataclass(frozen=True, eq=False)
class RecordedTrajectory:
    """The content of a demonstration file.

    Attributes:
        task_name: canonical task name.
        scene: suite task id whose initial state the recording starts from, or None (default kitchen).
        seed: reset seed of the scene.
        times: (n,) s, increasing, from 0.
        positions: (n, 3k) metres, world frame, k arms.
        orientations: (n, 4k) quaternions xyzw.
        gripper: (n,) 0 open, 1 closed.
    """

    task_name: str
    scene: str | None
    seed: int
    times: np.ndarray
    positions: np.ndarray
    orientations: np.ndarray
    gripper: np.ndarray

    @property
    def arms(self) -> int:
        return self.positions.shape[1] // 3

    def actions(self, dt: float) -> np.ndarray:
        """Environment actions (m, 8k) at the control period ``dt``: per arm position, quaternion and the
        gripper command, resampled from :attr:`times`."""
        n = max(2, round(self.times[-1] / dt) + 1)
        t = np.minimum(np.arange(n) * dt, self.times[-1])
        held = np.searchsorted(self.times, t, side="right") - 1
        columns = []
        for arm in range(self.arms):
            pos = self.positions[:, 3 * arm : 3 * arm + 3]
            quats = self.orientations[:, 4 * arm : 4 * arm + 4]
            columns.append(np.stack([np.interp(t, self.times, pos[:, i]) for i in range(3)], axis=1))
            columns.append(Slerp(self.times, Rotation.from_quat(quats))(t).as_quat())
            columns.append(self.gripper[held][:, None])
        return np.concatenate(columns, axis=1)

    def to_dict(self) -> dict[str, Any]:
        task = parse_task(self.task_name)
        return {
            "format": FORMAT,
            "task_name": self.task_name,
            "objects": dict(zip(LETTERS, task.objects, strict=False)),
            "scene": self.scene,
            "seed": self.seed,
            "times": np.round(self.times, 6).tolist(),
            "positions": np.round(self.positions, 6).tolist(),
            "orientations": np.round(self.orientations, 6).tolist(),
            "gripper": np.round(self.gripper, 6).tolist(),
        }

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict()), encoding="utf-8")
        return path


def _array(data: dict[str, Any], key: str, columns: tuple[int, ...], path: Path) -> np.ndarray:
    try:
        arr = np.asarray(data[key], dtype=float)
    except KeyError:
        raise DemoFileError(f"{path}: missing {key!r}") from None
    except (TypeError, ValueError):
        raise DemoFileError(f"{path}: {key!r} must be a list of numbers or of lists of numbers") from None
    ok = arr.ndim == 1 if not columns else arr.ndim == 2 and arr.shape[1] in columns
    if not ok or not np.all(np.isfinite(arr)):
        shape = "(n,)" if not columns else " or ".join(f"(n, {c})" for c in columns)
        raise DemoFileError(f"{path}: {key!r} must be finite numbers of shape {shape}, got {arr.shape}")
    return arr


def load_trajectory(path: str | Path) -> RecordedTrajectory:
    """Read and check a demonstration file (module doc).

    Raises:
        DemoFileError: unreadable, another format, an unknown task name, objects that disagree with it,
            inconsistent array shapes, fewer than 3 samples, or times that do not increase.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise DemoFileError(f"cannot read demonstration {path}: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        found = data.get("format") if isinstance(data, dict) else None
        raise DemoFileError(f'{path}: format {found!r}; a demonstration file has "format": "{FORMAT}"')
    try:
        task = parse_task(str(data.get("task_name", "")))
    except TaskNameError as exc:
        raise DemoFileError(f"{path}: {exc}") from None
    objects = data.get("objects")
    if objects is not None and dict(objects) != dict(zip(LETTERS, task.objects, strict=False)):
        raise DemoFileError(f"{path}: objects {objects} disagree with the task name {task.name!r}")
    positions = _array(data, "positions", (3, 6), path)
    orientations = _array(data, "orientations", (4, 8), path)
    gripper = _array(data, "gripper", (), path)
    n = len(positions)
    if len(orientations) != n or len(gripper) != n or orientations.shape[1] // 4 != positions.shape[1] // 3:
        raise DemoFileError(f"{path}: positions, orientations and gripper must have one row per sample each")
    if n < 3:
        raise DemoFileError(f"{path}: {n} samples; at least 3 are needed")
    if "times" in data:
        times = _array(data, "times", (), path)
        if len(times) != n or np.any(np.diff(times) <= 0):
            raise DemoFileError(f"{path}: 'times' must have one increasing entry per sample")
        times = times - times[0]
    else:
        dt = data.get("dt")
        if not isinstance(dt, int | float) or dt <= 0:
            raise DemoFileError(f"{path}: give 'dt' (s, > 0) or 'times'")
        times = np.arange(n) * float(dt)
    scene = data.get("scene")
    seed = data.get("seed", 0)
    if (scene is not None and not isinstance(scene, str)) or not isinstance(seed, int):
        raise DemoFileError(f"{path}: 'scene' must be a suite task id or null and 'seed' an integer")
    return RecordedTrajectory(task.name, scene, seed, times, positions, orientations, gripper)


__all__ = ["FORMAT", "DemoFileError", "RecordedTrajectory", "load_trajectory"]
