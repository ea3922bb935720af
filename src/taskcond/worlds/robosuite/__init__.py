"""robosuite (MuJoCo) as a second world of the condition-guided executor (issue 32).

The layers are the kitchen's:

* simulator, :mod:`.scene`: robosuite's environments, the names of their bodies, boxes from geoms,
  contacts; knows no task;
* task suite, :mod:`.tasks`: each robosuite environment as primitive steps, a scripted oracle and
  robosuite's own ``_check_success``;
* execution: :mod:`.world` (the executor's :class:`~taskcond.execution.world.World`), :mod:`.demos`
  (demonstrations and skills); :mod:`taskcond.application.robosuite` (episodes and evaluations);
* interface, :mod:`taskcond.cli.robosuite`: ``taskcond ... --world robosuite``.

robosuite is an optional dependency (``pip install taskcond[robosuite]``); :func:`require_robosuite` says
how to get it.
"""

from __future__ import annotations

import importlib.metadata
import logging
import os


class RobosuiteUnavailableError(RuntimeError):
    """robosuite or MuJoCo is not installed; the message says how to install them."""


def require_robosuite() -> None:
    """Import robosuite once (headless: ``MUJOCO_GL=egl`` unless set; its log below errors silenced: at
    import it warns of optional parts nothing here uses), or raise a one-line error.

    Raises:
        RobosuiteUnavailableError: robosuite or mujoco is missing.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    log = logging.getLogger("robosuite_logs")
    if not log.filters:
        log.addFilter(lambda record: record.levelno >= logging.ERROR)
    try:
        import mujoco  # noqa: F401
        import robosuite  # noqa: F401
    except ImportError as exc:
        raise RobosuiteUnavailableError(
            f"--world robosuite needs robosuite and mujoco ({exc}); install them with "
            "`pip install 'taskcond[robosuite]'`"
        ) from None


def versions() -> dict[str, str]:
    """Installed versions of robosuite and mujoco (recorded in every result of this world)."""
    out = {}
    for name in ("robosuite", "mujoco"):
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "missing"
    return out


__all__ = ["RobosuiteUnavailableError", "require_robosuite", "versions"]
