"""Observers of one episode in the suite, and the world wrapper that tells them what happens.

An :class:`EpisodeObserver` is told, in order: :meth:`~EpisodeObserver.start` (the environment, reset, and
the world it is seen through), the planner's repair and goal, every event of the trace, every movement the
executor starts or re-plans (:class:`~taskcond.execution.observer.ExecutionObserver`), every observation
the executor makes and every control step, and at last the episode's result.
:func:`taskcond.application.episode.run_episode` wraps its world in an :class:`ObservedWorld` when it has
observers; the executor sees a
:class:`~taskcond.execution.world.World` as before and knows nothing of them. An observer must not change
the episode: it never calls :meth:`KitchenWorld.observe` (that draws perception noise) and reads the
simulator without stepping it.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from taskcond.conditions import Predicate
from taskcond.execution.collisions import CollisionMonitor
from taskcond.execution.events import Event
from taskcond.execution.world import Observation, Touch
from taskcond.worlds.kitchen import KitchenWorld

if TYPE_CHECKING:
    from taskcond.application.episode import EpisodeResult
    from taskcond.envs.kitchen import KitchenEnv
    from taskcond.execution.planner import PlanRepair


@dataclass(frozen=True)
class EpisodeInfo:
    """What an episode runs, as observers label it.

    Attributes:
        label: the suite task id or the instruction.
        method: the execution method.
        seed: the reset seed.
        steps: the primitive task names as planned (before the planner's repair).
    """

    label: str
    method: str
    seed: int
    steps: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class ControlStep:
    """One control step as the executor commanded it.

    Attributes:
        index: control steps since the reset, this one included.
        time: world time after it, s.
        position: (3k,) commanded end-effector positions of the arms it moves, m, world frame.
        orientation: (4k,) commanded orientations, xyzw.
        gripper: the gripper command (0 open, 1 closed).
    """

    index: int
    time: float
    position: np.ndarray
    orientation: np.ndarray
    gripper: float


class EpisodeObserver:
    """Watches one episode (module doc); every method does nothing here."""

    def start(self, env: KitchenEnv, world: ObservedWorld, info: EpisodeInfo) -> None:
        """The environment is reset; ``world`` is what the executor acts through."""

    def on_plan(self, repair: PlanRepair | None, goal: tuple[Predicate, ...]) -> None:
        """The planner's repair (None: none was made) and the episode's goal, before anything moves."""

    def on_event(self, event: Event) -> None:
        """An event of the trace, as it happens."""

    def moving(
        self, path: np.ndarray, goal: np.ndarray, monitor: CollisionMonitor | None, closed: bool
    ) -> None:
        """A movement starts or is re-planned
        (:meth:`~taskcond.execution.observer.ExecutionObserver.moving`)."""

    def observed(self, observation: Observation) -> None:
        """The executor read the environment information (perceived boxes and predicates)."""

    def stepped(self, step: ControlStep) -> None:
        """A control step ended."""

    def ended(self, success: bool) -> None:
        """Nothing moves any more; the environment is still open (its final state). ``success``: the
        episode reached its goal (the task's success check, or the goal predicates and no failure)."""

    def finish(self, result: EpisodeResult) -> None:
        """The episode ended with ``result`` (the environment is closed)."""

    def close(self) -> None:
        """Release files; called once, also when the episode raised."""


class Observers(EpisodeObserver):
    """Several observers told everything in turn (the executor's
    :class:`~taskcond.execution.observer.ExecutionObserver` too). An observer that raises is not told
    anything more but :meth:`close`, with a warning: watching an episode never stops it."""

    def __init__(self, observers: Sequence[EpisodeObserver]) -> None:
        self.observers = list(observers)

    def _each(self, method: str, *args: Any) -> None:
        for observer in list(self.observers):
            try:
                getattr(observer, method)(*args)
            except Exception as exc:
                if method == "close":
                    raise
                warnings.warn(
                    f"{type(observer).__name__} stopped watching the episode: {type(exc).__name__}: {exc}",
                    RuntimeWarning,
                    stacklevel=2,
                )
                self.observers.remove(observer)
                observer.close()

    def start(self, env: KitchenEnv, world: ObservedWorld, info: EpisodeInfo) -> None:
        self._each("start", env, world, info)

    def on_plan(self, repair: PlanRepair | None, goal: tuple[Predicate, ...]) -> None:
        self._each("on_plan", repair, goal)

    def on_event(self, event: Event) -> None:
        self._each("on_event", event)

    def moving(
        self, path: np.ndarray, goal: np.ndarray, monitor: CollisionMonitor | None, closed: bool
    ) -> None:
        self._each("moving", path, goal, monitor, closed)

    def observed(self, observation: Observation) -> None:
        self._each("observed", observation)

    def stepped(self, step: ControlStep) -> None:
        self._each("stepped", step)

    def ended(self, success: bool) -> None:
        self._each("ended", success)

    def finish(self, result: EpisodeResult) -> None:
        self._each("finish", result)

    def close(self) -> None:
        self._each("close")

    def chain(self, callback: Callable[..., None] | None, method: str) -> Callable[..., None]:
        """A callback that calls ``callback`` (if any) and then this fan-out's ``method``."""
        own = getattr(self, method)

        def both(*args: Any) -> None:
            if callback is not None:
                callback(*args)
            own(*args)

        return both


class ObservedWorld:
    """A :class:`KitchenWorld` whose control steps and observations are told to ``observers``; everything
    else is the world's. Contacts are read once per control step, for the executor and the observers alike.
    """

    def __init__(self, world: KitchenWorld, observers: EpisodeObserver) -> None:
        self.world = world
        self.observers = observers
        self._touches: tuple[int, tuple[Touch, ...]] | None = None
        self._told: Observation | None = None

    def __getattr__(self, name: str) -> Any:
        return getattr(self.world, name)

    @property
    def time(self) -> float:
        return self.world.time

    def observe(self) -> Observation:
        observation = self.world.observe()
        if observation is not self._told:  # the world repeats its observation until a step
            self._told = observation
            self.observers.observed(observation)
        return observation

    def touches(self) -> tuple[Touch, ...]:
        steps = self.world.env.steps
        if self._touches is None or self._touches[0] != steps:
            self._touches = (steps, self.world.touches())
        return self._touches[1]

    def step(self, position: np.ndarray, orientation: np.ndarray, gripper: float) -> str | None:
        reason = self.world.step(position, orientation, gripper)
        env = self.world.env
        self.observers.stepped(
            ControlStep(env.steps, self.world.time, np.asarray(position), np.asarray(orientation), gripper)
        )
        return reason

    def unwind(self, gripper: float) -> str | None:
        """The world's unwind (:meth:`KitchenWorld.unwind`), each control step told with the hand's pose
        after it as the command."""

        def stepped() -> None:
            position, orientation = self.world.ee_pose()
            env = self.world.env
            self.observers.stepped(ControlStep(env.steps, self.world.time, position, orientation, gripper))

        return self.world.unwind(gripper, stepped)


__all__ = ["ControlStep", "EpisodeInfo", "EpisodeObserver", "ObservedWorld", "Observers"]
