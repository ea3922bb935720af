"""Evaluation episodes as Ray tasks (``--backend ray``, extra ``[ray]``), for users who outgrow one machine.

Each episode is one task running :func:`~taskcond.application.workers.run_job`; a Ray worker process keeps its
skill library and condition sources between the episodes it runs, as a local worker process does. Where
Ray runs: ``address`` (``--ray-address``), else ``$RAY_ADDRESS``, else the Ray instance already running on
this machine, else a new local one with ``workers`` CPUs (shut down again at the end). The workers read
the skill library and the LLM response cache from the paths this process uses, so on a cluster those
must be on a shared file system (``$TASKCOND_CACHE_DIR`` is passed on to the workers).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

from taskcond.application.workers import WorkerArgs, run_job
from taskcond.results import Job


class RayUnavailableError(RuntimeError):
    """Ray is not installed, or the cluster cannot be reached."""


def _connect(workers: int, address: str | None):
    try:
        import ray
    except ImportError:
        raise RayUnavailableError(
            "--backend ray needs Ray: pip install 'taskcond[ray]' (or use --backend local)"
        ) from None
    if ray.is_initialized():
        return ray, False  # the caller's own Ray session: left as it is
    address = address or os.environ.get("RAY_ADDRESS") or None
    env = {k: os.environ[k] for k in ("TASKCOND_CACHE_DIR", "PYTHONPATH") if k in os.environ}
    common = {
        "include_dashboard": False,
        "log_to_driver": False,
        "logging_level": "ERROR",
        "runtime_env": {"env_vars": env} if env else None,
    }
    try:
        if address:
            ray.init(address=address, **common)
        else:
            try:
                ray.init(address="auto", **common)  # the Ray already running on this machine
            except ConnectionError:
                ray.init(num_cpus=workers, **common)  # else a new local one
    except (ConnectionError, RuntimeError, ValueError) as exc:
        raise RayUnavailableError(
            f"cannot start or reach Ray at {address or 'a local instance'}: {' '.join(str(exc).split())}"
        ) from None
    return ray, True


def run_on_ray(
    jobs: list[Job],
    init_args: WorkerArgs,
    workers: int,
    address: str | None = None,
    own_process: list[bool] | None = None,
) -> Iterator[dict[str, Any]]:
    """The records of ``jobs`` as their Ray tasks finish (one CPU each; a job whose ``own_process`` flag is
    set in a worker process that runs nothing else); a task whose worker died is a ``crashed`` record, like
    an episode that raised."""
    ray, connected = _connect(workers, address)
    try:
        remote = ray.remote(num_cpus=1, max_retries=0)(run_job)
        alone = ray.remote(num_cpus=1, max_retries=0, max_calls=1)(run_job)
        args = ray.put(init_args)
        own_process = own_process or [False] * len(jobs)
        submitted = {
            (alone if own else remote).remote(job, args): job
            for job, own in zip(jobs, own_process, strict=True)
        }
        pending = list(submitted)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            try:
                yield ray.get(ready[0])
            except ray.exceptions.RayError as exc:  # the worker died (a crash, retried on resume)
                job = submitted[ready[0]]
                error = f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"
                yield job.to_dict() | {"crashed": True, "error": error}
    finally:
        if connected:  # disconnect; a local instance we started stops with it
            ray.shutdown()


__all__ = ["RayUnavailableError", "run_on_ray"]
