"""A Rerun recording (``.rrd``) of one episode in the suite: open it with ``rerun FILE.rrd`` (the viewer
ships with the ``[viz]`` extra's ``rerun-sdk``).

Everything lies on two timelines, ``sim_time`` (simulated seconds) and ``step`` (control steps since the
reset). Entities, world frame, metres:

- ``world/boxes/perceived``: each object's box as the executor perceived it (noise included), labelled,
  logged at every observation; ``world/boxes/perceived_centres``: the perceived centres the executor aims
  at; ``world/boxes/true``: the noise-free boxes (PyBullet's) of what can move (free objects, containers
  with a joint, grippers) every :data:`TRUE_EVERY` control steps, ``world/boxes/true_fixed`` the others;
- ``world/arms/<arm>/ee`` and ``.../path``: each arm's end effector and the path it took;
  ``world/arms/<arm>/gripper``: the gripper command (0 open, 1 closed) and ``.../opening``: the Franka's
  finger opening (m), as series;
- ``world/plan/path`` and ``world/plan/goal``: the planned path of the running movement (the DMP rollout of
  Alg. 2 line 5, re-planned after each goal change, or a straight transit) and its goal, labelled with the
  primitive; ``world/plan/target``: the target's centre (Alg. 2 line 4);
  ``world/plan/moved_goals``: every goal Alg. 2 moved (lines 10–13), an arrow from the old goal to the
  new, labelled with the colliding pair;
- ``world/contacts``: the contacts after each control step as points, coloured by Alg. 2's judgement:
  :data:`UNALLOWED` red, :data:`ALLOWED` green, :data:`SEEN` orange (not allowed, but there at the start or
  its pair already moved the goal once), contacts of nothing that moves (or DMP only, no condition) grey;
  labelled with the pair;
- ``world/camera``: the render camera's pose and intrinsics; ``world/camera/rgb`` and
  ``world/camera/depth`` (m) at a failure and at the end of an episode that did not reach its goal
  (:data:`CAMERA_EVENTS`; every :data:`CAMERA_EVERY` simulated seconds too if set). A success's final
  state is in its boxes: an image would cost about 6% of a short episode's wall time (BENCHMARKS.md);
- ``events/<kind>``: every event of the trace as a log line at its time (kinds of
  :class:`~taskcond.execution.events.Event`; ``failure`` as an error), ``events/plan`` the planner's
  repair, ``events/outcome`` and ``events/goal_check`` at the end;
- ``state/perceived`` and ``state/true``: the relations and states that start (``+``) or stop (``-``)
  holding: every one as perceived at each observation; by the ground truth, those of the goal, of the
  conditions used so far and each gripper's grasp, every :data:`TRUE_EVERY` control steps, at each
  top-level step, a failure and the end; ``status``: what the robot is doing
  (:class:`~taskcond.viz.captions.Narrator`); ``episode``, ``goal`` and ``outcome``: documents.

The file carries a default layout for the viewer (:func:`_layout`): the 3D scene, the trace's log, the
relations' changes, the status, the camera and the gripper series side by side.
:func:`read_recording` reads a recording back with Rerun's own reader (:class:`rerun.chunk.RrdReader`).
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from taskcond.envs.kitchen import RENDER_EYE, RENDER_TARGET
from taskcond.execution.collisions import CollisionMonitor
from taskcond.execution.events import Event
from taskcond.execution.world import Observation, Touch
from taskcond.sim.camera import CameraSpec, render
from taskcond.viz import require_rerun
from taskcond.viz.captions import Narrator, outcome_lines
from taskcond.viz.episode import ControlStep, EpisodeInfo, EpisodeObserver, ObservedWorld

if TYPE_CHECKING:
    from taskcond.application.episode import EpisodeResult
    from taskcond.envs.kitchen import KitchenEnv

APPLICATION_ID = "taskcond"
CAMERA_EVERY: float | None = None
"""Simulated seconds between two periodic camera images (RGB and depth); None: only at
:data:`CAMERA_EVENTS` and at the end of a failed episode. The CPU renderer costs 30–100 ms an image
whatever its size (BENCHMARKS.md), about 10 control steps of an episode: periodic images would break the
recording's budget of 15% of an episode's wall time."""
CAMERA_EVENTS = frozenset({"failure"})
"""Event kinds that take a camera image (besides the end), unless one was taken less than
:data:`CAMERA_GAP` before."""
CAMERA_GAP = 0.5
"""Least simulated seconds between two camera images."""
CAMERA_SIZE = (320, 240)
"""Camera image size, (width, height) pixels."""
TRUE_EVERY = 60
"""Control steps between two logs of the noise-free boxes of what can move and two checks of the ground
truth's relations and states (:meth:`RerunRecording._watched`)."""
FLUSH_EVERY = 90
"""Control steps whose end-effector poses, gripper commands and contacts are sent in one batch."""
PATH_STRIDE = 3
"""Every how many control steps a point of an arm's path is kept in ``world/arms/<arm>/path``."""

UNALLOWED = (230, 40, 40)
ALLOWED = (40, 200, 60)
SEEN = (255, 160, 30)
"""A contact the condition does not allow that Alg. 2 lets pass: there when the primitive started, or its
pair already moved the goal once in this execution."""
UNCHECKED = (150, 150, 150)
PERCEIVED = (70, 140, 255)
TRUE = (235, 235, 235)
LEVELS = {"failure": "ERROR", "collision": "WARN", "post_missing": "WARN", "ignored": "WARN"}
"""Log level of an event kind in ``events/<kind>``; INFO otherwise."""


@dataclass
class _Batch:
    """Per-step data waiting to be sent (:data:`FLUSH_EVERY`)."""

    steps: list[int] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    ee: list[np.ndarray] = field(default_factory=list)
    gripper: list[float] = field(default_factory=list)
    opening: list[float] = field(default_factory=list)
    contacts: list[tuple[np.ndarray, list[tuple[int, int, int]], list[str]]] = field(default_factory=list)


class RerunRecording(EpisodeObserver):
    """Records an episode to the Rerun file ``path`` (module doc).

    Args:
        path: the ``.rrd`` file, written as the episode runs (its directory is made).
        camera: take camera images (at :data:`CAMERA_EVENTS` and the end).
        camera_every: simulated seconds between periodic camera images besides; None for none.
        camera_size: camera image size (width, height) pixels.

    Raises:
        RerunUnavailableError: rerun-sdk is not installed.
    """

    def __init__(
        self,
        path: str | Path,
        camera: bool = True,
        camera_every: float | None = CAMERA_EVERY,
        camera_size: tuple[int, int] = CAMERA_SIZE,
    ) -> None:
        require_rerun()
        self.path = Path(path)
        self.camera_on = camera
        self.camera_every = camera_every
        self.camera = CameraSpec(
            eye=RENDER_EYE, target=RENDER_TARGET, width=camera_size[0], height=camera_size[1], far=4.0
        )
        self.rec: Any = None
        self.narrator: Narrator | None = None
        self._env: KitchenEnv | None = None
        self._world: ObservedWorld | None = None
        self._monitor: CollisionMonitor | None = None
        self._closed_gripper = False
        self._batch = _Batch()
        self._paths: dict[str, list[np.ndarray]] = defaultdict(list)
        self._perceived: frozenset = frozenset()
        self._true: frozenset[str] = frozenset()
        self._moved: list[tuple[np.ndarray, np.ndarray, str]] = []
        self._next_camera = 0.0 if camera_every is not None else math.inf
        self._last_camera = -math.inf
        self._goal: frozenset = frozenset()
        self._labelled: set[str] = set()
        self._finished = False

    # ------------------------------------------------------------------------------------ observer
    def start(self, env: KitchenEnv, world: ObservedWorld, info: EpisodeInfo) -> None:
        import rerun as rr

        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.rec = rr.RecordingStream(APPLICATION_ID, recording_id=f"{info.label}-{info.method}-{info.seed}")
        self.rec.save(self.path, default_blueprint=_layout())
        self.rec.set_log_time_enabled(False)
        self._env, self._world, self.narrator = env, world, Narrator(info)
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.rec.log(
            "episode",
            rr.TextDocument(
                f"# {info.label}\n\nmethod {info.method}, seed {info.seed}\n\nsteps: "
                + "; ".join(info.steps),
                media_type="text/markdown",
            ),
            static=True,
        )
        self._log_camera_pose()
        self._at(env.steps, world.time)
        self._log_true_boxes(fixed=True)
        self._check_truth()

    def on_plan(self, repair, goal) -> None:  # type: ignore[no-untyped-def]
        import rerun as rr

        if self.rec is None:
            return
        if repair is None:
            text = "plan not checked by the planner"
        elif repair.impossible is not None:
            text = f"planner: cannot be done: {repair.impossible}"
        elif repair.changes:
            text = f"planner repaired the plan to {'; '.join(repair.steps)}: " + "; ".join(
                map(str, repair.changes)
            )
        else:
            text = "planner: plan checked, no change"
        self.rec.log("events/plan", rr.TextLog(text, level="INFO"))
        self.rec.log("goal", rr.TextDocument("goal: " + (", ".join(map(str, goal)) or "none")), static=True)
        self._goal = frozenset(goal)

    def on_event(self, event: Event) -> None:
        import rerun as rr

        if self.rec is None or self.narrator is None or self._world is None:
            return
        self.narrator.on_event(event)
        self._at(round(event.time / self._world.dt), event.time)
        self.rec.log(f"events/{event.kind}", rr.TextLog(event.message, level=LEVELS.get(event.kind, "INFO")))
        if event.kind == "primitive" and event.data.get("target_center") is not None:
            self.rec.log(
                "world/plan/target",
                rr.Points3D([event.data["target_center"]], labels=[event.data["target"]], radii=0.008),
            )
        elif event.kind == "collision":
            self._moved_goal(event)
        self._log_status(event.time)
        if event.kind in ("step", "failure"):
            self._check_truth()
        if event.kind in CAMERA_EVENTS and event.time >= self._last_camera + CAMERA_GAP - 1e-9:
            self._log_camera(event.time)

    def moving(
        self, path: np.ndarray, goal: np.ndarray, monitor: CollisionMonitor | None, closed: bool
    ) -> None:
        import rerun as rr

        if self.rec is None or self.narrator is None or self._world is None:
            return
        self._monitor, self._closed_gripper = monitor, closed
        self._at(self._world.env.steps, self._world.time)
        arms = len(goal) // 3
        task = self.narrator.task
        self.rec.log(
            "world/plan/path",
            rr.LineStrips3D([path[:, 3 * a : 3 * a + 3] for a in range(arms)], labels=[task] * arms),
        )
        self.rec.log(
            "world/plan/goal",
            rr.Points3D(np.reshape(goal, (arms, 3)), labels=[f"goal of {task}"] * arms, radii=0.01),
        )

    def observed(self, observation: Observation) -> None:
        import rerun as rr

        if self.rec is None or self.narrator is None or self._world is None:
            return
        self.narrator.observed(observation)
        self._at(self._world.env.steps, self._world.time)
        names = sorted(observation.boxes)
        lower = np.array([observation.boxes[n][0] for n in names])
        upper = np.array([observation.boxes[n][1] for n in names])
        self.rec.log(
            "world/boxes/perceived",
            rr.Boxes3D(
                centers=(lower + upper) / 2, half_sizes=(upper - lower) / 2, labels=names, colors=PERCEIVED
            ),
        )
        centred = sorted(observation.centers)
        self.rec.log(
            "world/boxes/perceived_centres",
            rr.Points3D(
                [observation.centers[n] for n in centred], labels=centred, colors=PERCEIVED, radii=0.005
            ),
        )
        self._log_changes("state/perceived", self._perceived, observation.predicates)
        self._perceived = observation.predicates

    def stepped(self, step: ControlStep) -> None:
        if self.rec is None or self._world is None or self._env is None:
            return
        world, env = self._world, self._env
        batch = self._batch
        batch.steps.append(step.index)
        batch.times.append(step.time)
        batch.ee.append(world.ee_pose(len(world.arms))[0])
        batch.gripper.append(step.gripper)
        batch.opening.append(env.robot.finger_width())
        batch.contacts.append(self._contacts(world.touches()))
        if step.index % TRUE_EVERY == 0:
            self._at(step.index, step.time)
            self._log_true_boxes()
            self._check_truth()
        if step.time >= self._next_camera - 1e-9:
            self._at(step.index, step.time)
            self._log_camera(step.time)
        if len(batch.steps) >= FLUSH_EVERY:
            self._flush()

    def ended(self, success: bool) -> None:
        if self.rec is None or self._world is None:
            return
        self._flush()
        self._at(self._world.env.steps, self._world.time)
        self._log_true_boxes()
        self._check_truth()
        if not success and self._last_camera < self._world.time:
            self._log_camera(self._world.time)

    def finish(self, result: EpisodeResult) -> None:
        import rerun as rr

        if self.rec is None or self._world is None or self._finished:
            return
        self._finished = True
        self._flush()
        steps = round(result.sim_seconds / self._world.dt)
        self._at(steps, result.sim_seconds)
        text = " ".join(line.text for line in outcome_lines(result))
        self.rec.log("events/outcome", rr.TextLog(text, level="INFO" if result.success else "ERROR"))
        missing = ", ".join(result.goal_missing)
        self.rec.log(
            "events/goal_check",
            rr.TextLog(
                f"goal {', '.join(result.goal) or 'none'}: " + (f"missing {missing}" if missing else "holds"),
                level="INFO" if not missing else "WARN",
            ),
        )
        self.rec.log("outcome", rr.TextDocument(text), static=True)

    def close(self) -> None:
        if self.rec is not None:
            self._flush()
            self.rec.flush()
            self.rec.disconnect()
            self.rec = None

    # --------------------------------------------------------------------------------------- parts
    def _at(self, step: int, time: float) -> None:
        self.rec.set_time("step", sequence=int(step))
        self.rec.set_time("sim_time", duration=float(time))

    def _contacts(
        self, touches: tuple[Touch, ...]
    ) -> tuple[np.ndarray, list[tuple[int, int, int]], list[str]]:
        """Positions (n, 3), colours and labels of ``touches`` as Alg. 2 judges them (module doc)."""
        monitor, colours = self._monitor, []
        for touch in touches:
            if monitor is None or not _moves(touch, monitor, self._closed_gripper):
                colours.append(UNCHECKED)
            elif monitor.unallowed([touch], self._closed_gripper) is touch:
                colours.append(UNALLOWED)
            elif touch.collision in monitor.seen and touch.collision not in monitor.allowed:
                colours.append(SEEN)
            else:
                colours.append(ALLOWED)
        positions = np.array([t.position for t in touches]).reshape(-1, 3)
        return positions, colours, [f"{t.a} / {t.b}" for t in touches]

    def _flush(self) -> None:
        """Send the batched per-step data (:class:`_Batch`) as columns, and the arms' paths so far."""
        import rerun as rr

        batch = self._batch
        if not batch.steps or self._world is None:
            return
        index = [
            rr.TimeColumn("step", sequence=batch.steps),
            rr.TimeColumn("sim_time", duration=batch.times),
        ]
        ee = np.array(batch.ee)
        for a, arm in enumerate(self._world.arms[: ee.shape[1] // 3]):
            where = f"world/arms/{_part(arm)}"
            points = ee[:, 3 * a : 3 * a + 3]
            self.rec.send_columns(f"{where}/ee", indexes=index, columns=rr.Points3D.columns(positions=points))
            self._paths[arm] += list(points[::PATH_STRIDE])
        self.rec.send_columns(
            "world/arms/gripper/gripper", indexes=index, columns=rr.Scalars.columns(scalars=batch.gripper)
        )
        self.rec.send_columns(
            "world/arms/gripper/opening", indexes=index, columns=rr.Scalars.columns(scalars=batch.opening)
        )
        counts = [len(c[1]) for c in batch.contacts]
        if sum(counts):
            positions = np.concatenate([c[0] for c in batch.contacts])
            colours = [col for c in batch.contacts for col in c[1]]
            labels = [lab for c in batch.contacts for lab in c[2]]
            self.rec.send_columns(
                "world/contacts",
                indexes=index,
                columns=rr.Points3D.columns(
                    positions=positions, colors=colours, labels=labels, radii=[0.006] * len(labels)
                ).partition(counts),
            )
        self._at(batch.steps[-1], batch.times[-1])
        for arm, points in self._paths.items():
            self.rec.log(f"world/arms/{_part(arm)}/path", rr.LineStrips3D([np.array(points)]))
        self._batch = _Batch()

    def _log_true_boxes(self, fixed: bool = False) -> None:
        """The noise-free boxes of what can move (``fixed``: of what cannot, once, and then the others)."""
        import rerun as rr

        if fixed:
            self._log_true_boxes()
        perception = self._world.perception  # type: ignore[union-attr]
        scene = self._env.scene  # type: ignore[union-attr]
        moving = {*scene.free_objects, *scene.joints, *(("cloth",) if scene.cloth is not None else ())}
        boxes = {n: perception.ground_truth_box(n) for n in perception._objects if (n in moving) != fixed}
        if not fixed:
            boxes |= {g.name: perception.gripper_box(g) for g in perception.scene.grippers}
        names = sorted(boxes)
        lower = np.array([boxes[n].lower for n in names]).reshape(-1, 3)
        upper = np.array([boxes[n].upper for n in names]).reshape(-1, 3)
        entity = "world/boxes/true_fixed" if fixed else "world/boxes/true"
        if entity not in self._labelled:  # the same bodies every time: their labels once
            self._labelled.add(entity)
            self.rec.log(entity, rr.Boxes3D.from_fields(labels=names, colors=TRUE), static=True)
        self.rec.log(
            entity, rr.Boxes3D.from_fields(centers=(lower + upper) / 2, half_sizes=(upper - lower) / 2)
        )

    def _log_camera_pose(self) -> None:
        import rerun as rr

        spec = self.camera
        eye, target = np.array(spec.eye), np.array(spec.target)
        forward = (target - eye) / np.linalg.norm(target - eye)
        right = np.cross(forward, spec.up)
        right /= np.linalg.norm(right)
        down = np.cross(forward, right)
        self.rec.log(
            "world/camera",
            rr.Transform3D(translation=eye, mat3x3=np.column_stack([right, down, forward])),
            static=True,
        )
        self.rec.log(
            "world/camera",
            rr.Pinhole(
                focal_length=float(spec.focal_length_px),
                width=spec.width,
                height=spec.height,
                camera_xyz=rr.ViewCoordinates.RDF,
            ),
            static=True,
        )

    def _log_camera(self, time: float) -> None:
        """A camera image now (unless there is none), the next periodic one :attr:`camera_every` later."""
        import rerun as rr

        if not self.camera_on:
            return
        self._last_camera = time
        self._next_camera = math.inf if self.camera_every is None else time + self.camera_every
        frame = render(self._env.scene.client, self.camera)  # type: ignore[union-attr]
        self.rec.log("world/camera/rgb", rr.Image(frame.rgb).compress(jpeg_quality=85))
        depth = np.minimum(frame.depth, 65.0)
        self.rec.log("world/camera/depth", rr.DepthImage((depth * 1000).astype(np.uint16), meter=1000.0))

    def _check_truth(self) -> None:
        truth = self._env.truth  # type: ignore[union-attr]

        def holds(pred: Any) -> bool:
            try:
                return bool(truth.holds(pred))
            except (KeyError, ValueError):  # a relation of the gripper itself: the judge has none
                return False

        now = frozenset(str(p) for p in self._watched() if holds(p))
        self._log_changes("state/true", self._true, now)
        self._true = now

    def _watched(self) -> set:
        """The predicates whose ground truth is followed: the goal's, those of every condition used so far
        and each gripper's grasp of each object that can move."""
        from taskcond.conditions import GripperState

        scene = self._env.scene  # type: ignore[union-attr]
        movable = [*scene.free_objects, *(("cloth",) if scene.cloth is not None else ())]
        watched = set(self._goal)
        for cond in self.narrator.conditions.values():  # type: ignore[union-attr]
            watched.update(cond.pre_conditions, cond.post_conditions)
        for arm in self._world.arms:  # type: ignore[union-attr]
            watched.update(GripperState(o, arm) for o in movable)
        return watched

    def _log_changes(self, entity: str, before: frozenset, now: frozenset) -> None:
        import rerun as rr

        started = sorted(map(str, now - before))
        stopped = sorted(map(str, before - now))
        if not started and not stopped:
            return
        lines = [f"+ {p}" for p in started] + [f"- {p}" for p in stopped]
        self.rec.log(entity, rr.TextLog("\n".join(lines), level="DEBUG"))
        self.rec.log(f"{entity}/now", rr.TextDocument("\n".join(sorted(map(str, now)))))

    def _log_status(self, time: float) -> None:
        import rerun as rr

        lines = self.narrator.lines(time)  # type: ignore[union-attr]
        self.rec.log("status", rr.TextDocument("\n".join(line.text for line in lines)))

    def _moved_goal(self, event: Event) -> None:
        """The goal Alg. 2 moved (lines 10–13): every one so far as arrows, the contact as a point."""
        import rerun as rr

        goal = np.array(event.data["goal"][:3])
        shift = np.array(event.data["shift"])
        a, b = event.data["collision"]
        self._moved.append(
            (goal - shift, shift, f"{a} / {b}: goal moved {np.linalg.norm(shift) * 100:.1f} cm")
        )
        self.rec.log(
            "world/plan/moved_goals",
            rr.Arrows3D(
                origins=[m[0] for m in self._moved],
                vectors=[m[1] for m in self._moved],
                labels=[m[2] for m in self._moved],
                colors=UNALLOWED,
            ),
        )
        self.rec.log(
            "world/plan/collision",
            rr.Points3D([event.data["position"]], labels=[f"{a} / {b}"], colors=UNALLOWED, radii=0.01),
        )


class EvalRecordings:
    """A Rerun recording of each episode of an evaluation in ``directory``, named by :func:`episode_name`;
    kept for a failed (or crashed) episode, for every episode with ``every``. A recording is written
    beside its final name (``.partial``) while its episode runs."""

    def __init__(self, directory: Path, every: bool = False) -> None:
        require_rerun()
        self.directory = directory
        self.every = every

    def recording(self, job: Any) -> RerunRecording:
        """The recording of ``job`` (a :class:`~taskcond.results.Job`)."""
        name = episode_name(job.task, job.method, job.seed)
        return RerunRecording(self.directory / f"{name}.rrd.partial")

    def keep(self, recording: RerunRecording, success: bool) -> dict[str, str]:
        """Close ``recording``; keep it under its final name unless its episode succeeded (and not
        :attr:`every`). Returns ``{"rerun": path}`` for a kept recording, else nothing."""
        recording.close()
        partial = recording.path
        if not partial.exists():  # the episode never started (no plan, or the baseline)
            return {}
        if success and not self.every:
            partial.unlink()
            return {}
        final = partial.with_suffix("")
        partial.replace(final)
        return {"rerun": str(final)}


def episode_name(task: str, method: str, seed: int) -> str:
    """A file name stem for an episode: ``<task>-<method>-<seed>``, the task's characters other than
    letters, digits, ``.``, ``_`` and ``-`` replaced by ``_``."""
    safe = "".join(c if c.isalnum() or c in "._-" else "_" for c in task)[:80]
    return f"{safe}-{method.replace('+', '_')}-{seed}"


def _layout() -> Any:
    """The viewer's layout: the 3D scene beside the trace's log, above the status, the camera, the gripper
    series and the relations as they change."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial3DView(origin="world", name="scene: boxes perceived/true, paths, plan, contacts"),
                rrb.Horizontal(
                    rrb.TextDocumentView(origin="status", name="what the robot is doing"),
                    rrb.Spatial2DView(origin="world/camera", name="camera"),
                    rrb.TimeSeriesView(origin="world/arms", name="gripper command and opening"),
                ),
                row_shares=[3, 1],
            ),
            rrb.Vertical(
                rrb.TextLogView(origin="events", name="trace"),
                rrb.TextLogView(origin="state", name="relations and states (+ start, - stop)"),
                row_shares=[2, 1],
            ),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline="sim_time"),
        collapse_panels=False,
    )


def _moves(touch: Touch, monitor: CollisionMonitor, closed: bool) -> bool:
    """``touch`` involves what Alg. 2 checks: a gripper, or while closed an object it holds."""
    from taskcond.conditions import is_gripper

    held = closed and (touch.a in monitor.held or touch.b in monitor.held)
    return is_gripper(touch.a) or is_gripper(touch.b) or held


def _part(name: str) -> str:
    """``name`` as one entity path part (``kinova gripper`` → ``kinova_gripper``)."""
    return name.replace(" ", "_")


# ------------------------------------------------------------------------------------------ reading
@dataclass(frozen=True)
class Row:
    """One logged row of an entity: its ``step`` and ``sim_time`` (s; None when static) and its
    components by name (``Points3D:positions``, ``TextLog:text``) as Python values."""

    step: int | None
    time: float | None
    values: dict[str, Any]


def read_recording(path: str | Path) -> dict[str, list[Row]]:
    """Every entity of the recording ``path`` (its first recording store) → its rows in step order, read
    with Rerun's own reader (:class:`rerun.chunk.RrdReader`).

    Raises:
        RerunUnavailableError: rerun-sdk is not installed.
        ValueError: not a Rerun file with a recording.
    """
    require_rerun()
    from rerun.chunk import RrdReader

    out: dict[str, list[Row]] = defaultdict(list)
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        columns = {name: batch.column(name) for name in batch.schema.names}
        steps = columns.pop("step", None)
        times = columns.pop("sim_time", None)
        columns.pop("rerun.controls.RowId", None)
        columns.pop("log_time", None)
        values = {name: column.to_pylist() for name, column in columns.items()}
        for k in range(batch.num_rows):
            out[chunk.entity_path].append(
                Row(
                    None if steps is None else steps[k].as_py(),
                    None if times is None else _seconds(times[k]),
                    {name: v[k] for name, v in values.items()},
                )
            )
    return {
        entity: sorted(rows, key=lambda r: (r.step is not None, r.step or 0)) for entity, rows in out.items()
    }


def _seconds(value: Any) -> float | None:
    """A ``sim_time`` cell (a duration) in seconds."""
    raw = value.cast("int64").as_py() if hasattr(value, "cast") else value.value
    return None if raw is None else raw / 1e9


__all__ = [
    "ALLOWED",
    "CAMERA_EVERY",
    "SEEN",
    "UNALLOWED",
    "UNCHECKED",
    "EvalRecordings",
    "RerunRecording",
    "Row",
    "episode_name",
    "read_recording",
]
