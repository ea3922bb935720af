"""Videos that say what the robot is doing: every frame captioned with the current step, the primitive
running and its condition's status, and for a while after each one an Alg. 1 or Alg. 2 event (a raised
primitive, an unallowed collision and the goal moved, post-conditions not met); the last frame, held for
:data:`HOLD_SECONDS`, says how the episode ended and why.

:class:`Narrator` follows the trace and the observations and words the status; :class:`CaptionedVideo`
draws it over frames of the suite's render camera (:meth:`taskcond.envs.kitchen.KitchenEnv.render`).
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from taskcond.conditions import TaskCondition
from taskcond.execution.events import Event
from taskcond.execution.world import Observation
from taskcond.sim.recording import VideoRecorder
from taskcond.viz.episode import ControlStep, EpisodeInfo, EpisodeObserver, ObservedWorld
from taskcond.worlds.kitchen import VIDEO_EVERY

if TYPE_CHECKING:
    from taskcond.application.episode import EpisodeResult
    from taskcond.envs.kitchen import KitchenEnv

VIDEO_SIZE = (640, 480)
"""Default video size, (width, height) pixels."""
FPS = 15
"""Frames per second: the control rate (30 Hz) over :data:`~taskcond.execution.kitchen.VIDEO_EVERY`, so the
video plays in simulated time."""
FLASH_SECONDS = 2.0
"""Simulated seconds an Alg. 1/Alg. 2 event stays in the caption."""
HOLD_SECONDS = 3.0
"""Seconds of video the last frame, with the outcome, is held."""

WHITE, YELLOW, ORANGE, RED, GREEN, GREY = (
    (255, 255, 255),
    (255, 220, 80),
    (255, 150, 60),
    (255, 90, 90),
    (110, 230, 110),
    (190, 190, 190),
)
ALG1 = {"raise": "Alg. 1", "skip": "Alg. 1", "set_down": "Alg. 1", "put_back": "Alg. 1"}
"""Event kinds flashed as Alg. 1's (pre-condition satisfaction)."""
ALG2 = {
    "collision": "Alg. 2",
    "post_missing": "Alg. 2",
    "back_off": "retry",
    "regrip": "retry",
    "repair": "grounding",
}
"""Event kinds flashed as Alg. 2's (control with conditions, post-conditions) or a retry's."""


@dataclass(frozen=True)
class Line:
    """One caption line: ``text`` in ``color`` (RGB)."""

    text: str
    color: tuple[int, int, int] = WHITE


class Narrator:
    """What is happening now, from the events of the trace and the executor's observations.

    Attributes:
        info: the episode.
        step: the top-level step running (``step`` events), 1-based; 0 before the first.
        step_name: its primitive task.
        task: the primitive running now (the last ``primitive`` event), and its ``depth``.
        conditions: task name → its condition (``condition`` events).
        predicates: what the executor perceived last.
        flash: the last Alg. 1/Alg. 2 event, its line and the simulated time it is shown until.
        planned: the number of top-level steps (after the planner's repair, once known).
    """

    def __init__(self, info: EpisodeInfo) -> None:
        self.info = info
        self.step = 0
        self.step_name = ""
        self.planned = len(info.steps)
        self.task = ""
        self.depth = 0
        self.raised_for = ""
        self.conditions: dict[str, TaskCondition] = {}
        self.predicates: frozenset = frozenset()
        self.flash: tuple[Line, float] | None = None

    def on_event(self, event: Event) -> None:
        if event.kind == "step":
            self.step += 1
            self.step_name = self.task = event.task
            self.depth = 0
        elif event.kind == "condition":
            self.conditions[event.task] = TaskCondition.from_dict(event.data["condition"])
        elif event.kind == "raise":
            self.raised_for = event.data.get("for", "")
        elif event.kind == "primitive":
            self.task, self.depth = event.task, event.depth
        if event.kind in ALG1 or event.kind in ALG2:
            who = ALG1.get(event.kind) or ALG2[event.kind]
            color = YELLOW if event.kind in ALG1 else ORANGE
            self.flash = (Line(f"{who}: {event.message}", color), event.time + FLASH_SECONDS)

    def observed(self, observation: Observation) -> None:
        self.predicates = observation.predicates

    def status(self) -> str:
        """The running primitive's condition: how many pre- and post-conditions hold as last perceived, and
        the pre-conditions that do not; once every post-condition holds the primitive is done, and a
        pre-condition its own motion undid (a release's ``gripper grasping``) is no longer listed."""
        cond = self.conditions.get(self.task)
        if cond is None:
            return "no condition (DMP only)" if self.info.method == "none" else "condition not generated yet"
        pre = sum(p in self.predicates for p in cond.pre_conditions)
        post = sum(p in self.predicates for p in cond.post_conditions)
        text = f"pre {pre}/{len(cond.pre_conditions)} hold, post {post}/{len(cond.post_conditions)} hold"
        if post == len(cond.post_conditions):
            return text + " (done)"
        unmet = [str(p) for p in cond.pre_conditions if p not in self.predicates]
        return text + (f" (unmet: {', '.join(unmet)})" if unmet else "")

    def lines(self, time: float) -> list[Line]:
        """The caption at world time ``time`` (s)."""
        head = f"{time:5.1f} s   {self.info.label} ({self.info.method}, seed {self.info.seed})"
        if not self.step:
            return [Line(head), Line("planning", GREY)]
        lines = [Line(head), Line(f"step {self.step}/{max(self.planned, self.step)}: {self.step_name}")]
        if self.depth > 0:
            lines.append(Line(f"  running {self.task!r}, raised by Alg. 1 for {self.raised_for!r}", YELLOW))
        elif self.task != self.step_name:
            lines.append(Line(f"  running {self.task!r}"))
        lines.append(Line(f"  condition: {self.status()}", GREY))
        if self.flash is not None and time <= self.flash[1]:
            lines.append(self.flash[0])
        return lines


def outcome_lines(result: EpisodeResult) -> list[Line]:
    """How the episode ended: success, or the failure kind and its reason, and the goal predicates that do
    not hold; either way the objects that lie knocked over at the end."""
    fallen = [Line(f"knocked over: {', '.join(result.fallen)}", RED)] if result.fallen else []
    if result.success:
        return [Line(f"SUCCEEDED in {result.sim_seconds:.1f} s", GREEN), *fallen]
    lines = [Line(f"FAILED ({result.failure}): {result.reason}", RED)]
    if result.goal_missing and result.failure != "not_succeeded":
        lines.append(Line(f"goal not reached: {', '.join(result.goal_missing)}", RED))
    return lines + fallen


@cache
def _font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    return ImageFont.load_default(size=size)


def caption(frame: np.ndarray, top: list[Line], bottom: list[Line] | None = None) -> np.ndarray:
    """``frame`` (H, W, 3) uint8 with ``top`` lines on a darkened band at its top and ``bottom`` lines at
    its bottom, each wrapped to the frame's width; a new array."""
    h, w = frame.shape[:2]
    size = max(10, h // 28)
    font = _font(size)
    chars = max(20, int(w / (0.55 * size)))
    out = frame.copy()

    def wrapped(lines: list[Line]) -> list[Line]:
        return [Line(t, line.color) for line in lines for t in textwrap.wrap(line.text, chars) or [""]]

    top, bottom = wrapped(top), wrapped(bottom or [])
    step = int(size * 1.25)
    pad = size // 3
    if top:
        out[: pad * 2 + step * len(top)] //= 3
    if bottom:
        out[h - pad * 2 - step * len(bottom) :] //= 3
    image = Image.fromarray(out)
    draw = ImageDraw.Draw(image)
    for k, line in enumerate(top):
        draw.text((pad * 2, pad + k * step), line.text, fill=line.color, font=font)
    for k, line in enumerate(bottom):
        draw.text((pad * 2, h - pad - step * (len(bottom) - k)), line.text, fill=line.color, font=font)
    return np.asarray(image)


class CaptionedVideo(EpisodeObserver):
    """A video (.mp4 or .gif) of the episode, every :data:`~taskcond.execution.kitchen.VIDEO_EVERY`-th
    control step, ``size`` (width, height) pixels, captioned by a :class:`Narrator`; the last frame says
    how the episode ended (:func:`outcome_lines`) and is held :data:`HOLD_SECONDS`."""

    def __init__(self, path: str | Path, size: tuple[int, int] = VIDEO_SIZE) -> None:
        self.path = Path(path)
        self.size = size
        self.writer = VideoRecorder(self.path, fps=FPS)
        self.narrator: Narrator | None = None
        self._env: KitchenEnv | None = None
        self._last: np.ndarray | None = None
        self._closed = False

    def start(self, env: KitchenEnv, world: ObservedWorld, info: EpisodeInfo) -> None:
        self._env = env
        self.narrator = Narrator(info)

    def on_plan(self, repair, goal) -> None:  # type: ignore[no-untyped-def]
        if self.narrator is not None and repair is not None and repair.impossible is None:
            self.narrator.planned = len(repair.steps)

    def on_event(self, event: Event) -> None:
        if self.narrator is not None:
            self.narrator.on_event(event)

    def observed(self, observation: Observation) -> None:
        if self.narrator is not None:
            self.narrator.observed(observation)

    def stepped(self, step: ControlStep) -> None:
        if step.index % VIDEO_EVERY or self._env is None or self.narrator is None:
            return
        self._last = self._env.render(self.size)
        self.writer.add(caption(self._last, self.narrator.lines(step.time)))

    def finish(self, result: EpisodeResult) -> None:
        if self.narrator is None:
            return
        frame = self._last if self._last is not None else np.zeros((self.size[1], self.size[0], 3), np.uint8)
        last = caption(frame, self.narrator.lines(result.sim_seconds), outcome_lines(result))
        for _ in range(round(HOLD_SECONDS * FPS)):
            self.writer.add(last)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.writer.close()


__all__ = ["FPS", "VIDEO_SIZE", "CaptionedVideo", "Line", "Narrator", "caption", "outcome_lines"]
