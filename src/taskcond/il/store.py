"""Where the baseline's demonstrations and checkpoints are cached, keyed by everything that shapes them, so
that nothing is reused across configurations (like the skill library's
:func:`~taskcond.execution.runner.default_library_dir`).

- demonstrations: ``<cache dir>/il/data-v<DATA_FORMAT>-oracles<revision>-<digest of the DataSpec, camera,
  chunk>/<task id>.npz``;
- checkpoints: ``<cache dir>/il/policy-v<POLICY_FORMAT>-<digest of the data key and the TrainSpec>/``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

from taskcond.il.dataset import CAMERA, CHUNK, DEPTH_FAR, DEPTH_NEAR, HOLD_STEPS, DataSpec
from taskcond.llm.models import cache_dir

DATA_FORMAT = 1
"""Raised whenever the samples' layout or recording changes."""
POLICY_FORMAT = 1
"""Raised whenever the network, its inputs or the training loop change."""


def _digest(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:12]


def data_key(spec: DataSpec) -> str:
    """``data-v<format>-oracles<revision>-<digest>`` of the demonstrations ``spec`` asks for."""
    from taskcond.execution.runner import ORACLE_REVISION

    camera = {k: getattr(CAMERA, k) for k in ("eye", "target", "up", "fov_deg", "width", "height")}
    recording = {"camera": camera, "chunk": CHUNK, "hold": HOLD_STEPS, "depth": [DEPTH_NEAR, DEPTH_FAR]}
    return f"data-v{DATA_FORMAT}-oracles{ORACLE_REVISION}-{_digest([asdict(spec), recording])}"


def data_dir(spec: DataSpec, root: Path | None = None) -> Path:
    return (root or cache_dir() / "il") / data_key(spec)


def policy_dir(data: DataSpec, train: Any, root: Path | None = None) -> Path:
    """The checkpoint directory of a policy trained as ``train`` (a :class:`~taskcond.il.train.TrainSpec`)
    on the demonstrations of ``data``."""
    key = _digest([data_key(data), asdict(train)])
    return (root or cache_dir() / "il") / f"policy-v{POLICY_FORMAT}-{key}"


__all__ = ["DATA_FORMAT", "POLICY_FORMAT", "data_dir", "data_key", "policy_dir"]
