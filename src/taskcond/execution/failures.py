"""Why a run of the executor stops: :class:`ExecutionError` and its kinds."""

from __future__ import annotations


class ExecutionError(RuntimeError):
    """Execution cannot continue; the message is the one-line reason."""

    def __init__(self, reason: str, kind: str) -> None:
        super().__init__(reason)
        self.kind = kind
        """Short failure class for statistics: ``unsatisfiable``, ``cycle``, ``timeout``, ``unreachable``,
        ``no_skill``, ``not_perceived``, ``condition``, ``simulation``, ``bad_task``, ``fallen``."""
