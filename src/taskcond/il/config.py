"""The baseline's training configuration (:class:`NetSpec`, :class:`TrainSpec`; importable without JAX) and
where its demonstrations and checkpoints are cached, keyed by everything that shapes them, so
that nothing is reused across configurations (like the skill library's
:func:`~taskcond.application.library.default_library_dir`).

- demonstrations: ``<cache dir>/il/data-v<DATA_FORMAT>-oracles<revision>-<digest of the DataSpec, camera,
  chunk>/<task id>.npz``;
- checkpoints: ``<cache dir>/il/policy-v<POLICY_FORMAT>-<digest of the data key and the TrainSpec>/``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from taskcond.il.dataset import CAMERA, CHUNK, DEPTH_FAR, DEPTH_NEAR, HOLD_STEPS, DataSpec
from taskcond.llm.models import cache_dir


@dataclass(frozen=True)
class NetSpec:
    """Sizes of the network (:class:`taskcond.il.policy.Policy`): convolution channels, task embedding
    width, hidden width of the MLP."""

    channels: tuple[int, ...] = (16, 32, 32)
    embedding: int = 32
    hidden: int = 256


@dataclass(frozen=True)
class TrainSpec:
    """Training hyper-parameters (all of them are in the checkpoint's key).

    Attributes:
        steps: optimizer steps.
        batch: samples per step.
        learning_rate: peak learning rate (linear warm-up over a tenth of the steps, at most 100, then
            cosine decay to 1% of it).
        weight_decay: AdamW's decoupled weight decay.
        shift: maximal random image shift in pixels.
        state_noise: standard deviation of the Gaussian noise added to the normalized state input (keeps
            the policy from copying the demonstrations' proprioception alone).
        absolute: the network predicts world positions (True) or offsets from the end effector.
        seed: seed of the initialization, the batches and the shifts.
        net: the network's sizes.
    """

    steps: int = 8000
    batch: int = 32
    learning_rate: float = 1e-3
    weight_decay: float = 1e-4
    shift: int = 4
    state_noise: float = 0.1
    absolute: bool = True
    seed: int = 0
    net: NetSpec = field(default_factory=NetSpec)


DATA_FORMAT = 1
"""Raised whenever the samples' layout or recording changes."""
POLICY_FORMAT = 1
"""Raised whenever the network, its inputs or the training loop change."""


def _digest(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:12]


def data_key(spec: DataSpec) -> str:
    """``data-v<format>-oracles<revision>-<digest>`` of the demonstrations ``spec`` asks for."""
    from taskcond.tasks.oracle import ORACLE_REVISION

    camera = {k: getattr(CAMERA, k) for k in ("eye", "target", "up", "fov_deg", "width", "height")}
    recording = {"camera": camera, "chunk": CHUNK, "hold": HOLD_STEPS, "depth": [DEPTH_NEAR, DEPTH_FAR]}
    return f"data-v{DATA_FORMAT}-oracles{ORACLE_REVISION}-{_digest([asdict(spec), recording])}"


def data_dir(spec: DataSpec, root: Path | None = None) -> Path:
    return (root or cache_dir() / "il") / data_key(spec)


def policy_dir(
    data: DataSpec | None = None, train: TrainSpec | None = None, root: Path | None = None
) -> Path:
    """The checkpoint directory of a policy trained as ``train`` on the demonstrations of ``data`` (default
    specs when None): where ``taskcond learn --method image-il`` puts it and evaluations look for it."""
    data, train = data or DataSpec(), train or TrainSpec()
    key = _digest([data_key(data), asdict(train)])
    return (root or cache_dir() / "il") / f"policy-v{POLICY_FORMAT}-{key}"


__all__ = ["DATA_FORMAT", "POLICY_FORMAT", "NetSpec", "TrainSpec", "data_dir", "data_key", "policy_dir"]
