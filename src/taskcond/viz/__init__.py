"""Seeing why an episode failed: observers of an episode in the suite.

- :mod:`taskcond.viz.episode`: the :class:`~taskcond.viz.episode.EpisodeObserver` interface, the world
  wrapper that tells observers every control step and observation, and a fan-out to several observers;
- :mod:`taskcond.viz.rerun_recording`: a Rerun recording (``.rrd``) of an episode on one timeline (needs the
  ``[viz]`` extra, ``rerun-sdk``);
- :mod:`taskcond.viz.captions`: videos captioned with the current step, its condition's status, Alg. 1/2
  events and the failure reason;
- :mod:`taskcond.application.replay`: re-running one stored episode of a results file from its recorded
  configuration and seed (``taskcond replay``).

:func:`require_rerun` says in one line how to install the extra when it is missing.
"""

from __future__ import annotations


class RerunUnavailableError(RuntimeError):
    """The ``[viz]`` extra (rerun-sdk) is not installed."""


def require_rerun() -> None:
    """Raise :class:`RerunUnavailableError` with the install command when rerun-sdk is missing."""
    try:
        import rerun  # noqa: F401
    except ImportError:
        raise RerunUnavailableError(
            "--rerun needs the [viz] extra (rerun-sdk missing): pip install 'taskcond[viz]'"
        ) from None


__all__ = ["RerunUnavailableError", "require_rerun"]
