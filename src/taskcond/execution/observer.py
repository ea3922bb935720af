"""What an observer of the executor (a recording, a captioned video) learns beyond the trace's events.

The :class:`~taskcond.execution.executor.Executor` tells an :class:`ExecutionObserver`, when it has one,
each movement it starts or re-plans: the planned end-effector path (the DMP rollout of Alg. 2 line 5 from
where the arm is, or the straight lines of a transit, a back-off or a set-down), its goal, and the
collision monitor (Alg. 2 lines 8–9) that judges the contacts on the way. Nothing here knows the simulator
or a viewer; without an observer the executor computes none of it.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from taskcond.dmp import DMPRollout
from taskcond.execution.collisions import CollisionMonitor


class ExecutionObserver(Protocol):
    """Told every movement the executor starts or re-plans (module doc)."""

    def moving(
        self, path: np.ndarray, goal: np.ndarray, monitor: CollisionMonitor | None, closed: bool
    ) -> None:
        """A movement starts, or Alg. 2 re-planned it after moving its goal.

        Args:
            path: (n, 3k) planned end-effector positions of the k arms that move, m, world frame, from now to
                the end of the movement.
            goal: (3k,) its goal, m, world frame.
            monitor: the collision monitor of the primitive (None: contacts are not checked, DMP only or a
                movement outside Alg. 2).
            closed: the gripper command of the movement is closed (held objects move with the arm).
        """
        ...


PLANNED_POINTS = 60
"""Most points of a planned DMP path told to an observer (:func:`planned_path`)."""


def planned_path(rollout: DMPRollout, dt: float) -> np.ndarray:
    """The positions (n, d) the rollout will pass from its current state to the end of its duration τ,
    m, in at most :data:`PLANNED_POINTS` equal steps of at least ``dt`` s, integrated with sub-steps ten
    times as long as the rollout's; the rollout itself is not changed (a copy is integrated)."""
    coarse = rollout.tau / 50  # a drawing: sub-steps ten times the rollout's own
    copy = DMPRollout(
        rollout.params, rollout.y0, rollout.goal, tau=rollout.tau, max_substep=coarse, history=0
    )
    copy.restore(rollout.state())
    remaining = max(rollout.tau - rollout.time, 0.0)
    n = max(1, min(PLANNED_POINTS, math.ceil(remaining / dt - 1e-9)))
    step = max(remaining / n, 1e-6)
    return np.array([copy.position] + [copy.step(step)[0] for _ in range(n)])


__all__ = ["PLANNED_POINTS", "ExecutionObserver", "planned_path"]
