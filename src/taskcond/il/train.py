"""Training the baseline's policy (:mod:`taskcond.il.policy`) by behaviour cloning, its checkpoints, and the
trained policy that acts (``taskcond learn --method image-il``).

Training: AdamW with a cosine-decayed learning rate on mini-batches drawn uniformly from every sample,
each image shifted by up to :attr:`TrainSpec.shift` pixels at random (edge-padded random crops, as in
Kostrikov et al. 2020, "Image augmentation is all you need", a standard regularizer of image-based
behaviour cloning on few demonstrations).

A checkpoint directory holds ``model.eqx`` (the network's weights, :func:`equinox.tree_serialise_leaves`),
``policy.json`` (task names, normalization, demonstration lengths, arms per task, both specs) and
``history.json`` (the loss every :data:`LOG_EVERY` steps, the training time).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from taskcond.il.config import NetSpec, TrainSpec
from taskcond.il.dataset import ACTION_DIM, CHUNK, STATE_DIM, DataSpec, Samples
from taskcond.il.policy import Normalizer, Policy, decode, loss_terms, normalize_targets, to_input

LOG_EVERY = 50
"""Training steps per point of the loss history."""


class PolicyError(RuntimeError):
    """A checkpoint that cannot be read, or a task the policy was not trained on."""


STATE_STD_FLOOR = 0.02
"""Smallest standard deviation a state dimension is normalized by (m, quaternion units): a dimension that
barely varies in the demonstrations (the top-down quaternion's small components) would otherwise turn a
millimetre off the demonstrations into a huge input."""
POSITION_STD_FLOOR = 0.005
"""Smallest standard deviation (m) a position target is normalized by."""


def normalizer(samples: Samples, absolute: bool) -> Normalizer:
    """Means and standard deviations of the samples' state and position targets (world positions when
    ``absolute``, else offsets; the Kinova's from the two-arm samples only), the deviations no smaller than
    :data:`STATE_STD_FLOOR` and :data:`POSITION_STD_FLOOR`."""

    def stats(x: np.ndarray, floor: float) -> tuple[np.ndarray, np.ndarray]:
        if len(x) == 0:
            return np.zeros(x.shape[1], np.float32), np.ones(x.shape[1], np.float32)
        return x.mean(0).astype(np.float32), np.maximum(x.std(0), floor).astype(np.float32)

    s_mean, s_std = stats(samples.state, STATE_STD_FLOOR)
    plain = Normalizer(s_mean, s_std, np.zeros(6), np.ones(6), absolute)
    position = plain.targets(samples.actions, samples.state)  # (n, K, 2, 3)
    franka = stats(position[..., 0, :].reshape(-1, 3), POSITION_STD_FLOOR)
    kinova = stats(position[samples.arms == 2][..., 1, :].reshape(-1, 3), POSITION_STD_FLOOR)
    mean, std = np.concatenate([franka[0], kinova[0]]), np.concatenate([franka[1], kinova[1]])
    return Normalizer(s_mean, s_std, mean, std, absolute)


def _shift(images: jax.Array, key: jax.Array, pad: int) -> jax.Array:
    """Random crops (B, C, H, W) of the edge-padded images: shifts of up to ``pad`` pixels."""
    b, c, h, w = images.shape
    padded = jnp.pad(images, ((0, 0), (0, 0), (pad, pad), (pad, pad)), mode="edge")
    offsets = jax.random.randint(key, (b, 2), 0, 2 * pad + 1)

    def crop(img: jax.Array, off: jax.Array) -> jax.Array:
        return jax.lax.dynamic_slice(img, (0, off[0], off[1]), (c, h, w))

    return jax.vmap(crop)(padded, offsets)


def train(
    samples: Samples,
    spec: TrainSpec,
    progress: Callable[[int, float], None] | None = None,
    log_every: int = LOG_EVERY,
) -> tuple[TrainedPolicy, dict[str, Any]]:
    """Fit a :class:`~taskcond.il.policy.Policy` to ``samples``; ``progress`` is told the step and the mean
    loss of the last ``log_every`` steps. Returns the trained policy and the history (loss terms every
    ``log_every`` steps, seconds)."""
    norm = normalizer(samples, spec.absolute)
    key = jax.random.PRNGKey(spec.seed)
    key, init = jax.random.split(key)
    model = Policy(spec.net, len(samples.names), STATE_DIM, CHUNK, ACTION_DIM, init)
    schedule = optax.warmup_cosine_decay_schedule(
        0.0, spec.learning_rate, min(100, spec.steps // 10), spec.steps, 0.01 * spec.learning_rate
    )
    optimizer = optax.adamw(schedule, weight_decay=spec.weight_decay)
    opt_state = optimizer.init(eqx.filter(model, eqx.is_array))
    states = (samples.state - norm.state_mean) / norm.state_std
    targets = normalize_targets(samples.actions, samples.state, norm)

    @eqx.filter_jit
    def step(model, opt_state, images, state, progress_, task, target, arms, key):
        def loss(model):
            shift, noise = jax.random.split(key)
            x = _shift(to_input(images), shift, spec.shift) if spec.shift else to_input(images)
            noisy = state + spec.state_noise * jax.random.normal(noise, state.shape)
            out = jax.vmap(model)(x, noisy, progress_, task)
            return loss_terms(out, target, arms)

        (value, terms), grads = eqx.filter_value_and_grad(loss, has_aux=True)(model)
        updates, opt_state = optimizer.update(grads, opt_state, eqx.filter(model, eqx.is_array))
        return eqx.apply_updates(model, updates), opt_state, value, terms

    rng = np.random.default_rng(spec.seed)
    history: dict[str, list[float]] = {
        "step": [],
        "loss": [],
        "position": [],
        "quaternion": [],
        "gripper": [],
    }
    window: list[tuple[float, dict[str, float]]] = []
    start = time.perf_counter()
    for k in range(1, spec.steps + 1):
        idx = rng.integers(0, len(samples), spec.batch)
        key, sub = jax.random.split(key)
        model, opt_state, value, terms = step(
            model,
            opt_state,
            samples.image[idx],
            states[idx],
            samples.progress[idx],
            samples.task[idx],
            targets[idx],
            samples.arms[idx],
            sub,
        )
        window.append((value, terms))
        if k % log_every == 0 or k == spec.steps:
            values = jax.device_get(window)
            history["step"].append(k)
            history["loss"].append(float(np.mean([v for v, _ in values])))
            for name in ("position", "quaternion", "gripper"):
                history[name].append(float(np.mean([t[name] for _, t in values])))
            window = []
            if progress is not None:
                progress(k, history["loss"][-1])
    seconds = time.perf_counter() - start
    lengths = {n: samples.lengths.get(n, []) for n in samples.names}
    arms = {n: int(samples.arms[samples.task == i].max()) for i, n in enumerate(samples.names)}
    policy = TrainedPolicy(model, norm, samples.names, lengths, arms, {"train": _spec_dict(spec)})
    return policy, {**history, "seconds": seconds, "samples": len(samples)}


def _spec_dict(spec: Any) -> dict[str, Any]:
    return json.loads(json.dumps(asdict(spec)))


@dataclass
class TrainedPolicy:
    """A trained policy that acts.

    Attributes:
        model: the network.
        norm: the normalization of its inputs and outputs.
        names: primitive task names, in the order of the network's task embedding.
        lengths: control steps of each name's training demonstrations.
        arms: 1 or 2 per name (2: the demonstrations moved the Kinova too).
        meta: the specs it was made with.
    """

    model: Policy
    norm: Normalizer
    names: list[str]
    lengths: dict[str, list[int]]
    arms: dict[str, int]
    meta: dict[str, Any]
    _forward: Any = field(default=None, repr=False)

    def nominal_steps(self, name: str) -> int:
        """Median control steps of ``name``'s demonstrations (the denominator of the progress input)."""
        return int(np.median(self.lengths[name]))

    def budget(self, name: str) -> int:
        """Control steps the policy runs ``name`` for: 1.25 times its longest demonstration, whole chunks."""
        return CHUNK * int(np.ceil(1.25 * max(self.lengths[name]) / CHUNK))

    def act(self, image: np.ndarray, state: np.ndarray, progress: float, name: str) -> np.ndarray:
        """Absolute actions (K, 16) for one observation: ``image`` (H, W, 4) uint8 and ``state``
        (:data:`~taskcond.il.dataset.STATE_DIM`,) as :mod:`taskcond.il.dataset` makes them, at ``progress``
        of task ``name``.

        Raises:
            PolicyError: the policy was not trained on ``name``.
        """
        if name not in self.names:
            raise PolicyError(
                f"the image-il policy was not trained on {name!r}; it knows: {', '.join(self.names)}"
            )
        if self._forward is None:
            self._forward = eqx.filter_jit(lambda m, *a: m(*a))
        x = to_input(image)
        s = jnp.asarray((state - self.norm.state_mean) / self.norm.state_std, jnp.float32)
        out = self._forward(self.model, x, s, jnp.float32(progress), jnp.int32(self.names.index(name)))
        return decode(np.asarray(out), state, self.norm)

    def save(self, directory: Path, history: dict[str, Any] | None = None) -> None:
        directory.mkdir(parents=True, exist_ok=True)
        eqx.tree_serialise_leaves(directory / "model.eqx", self.model)
        meta = {
            "names": self.names,
            "norm": self.norm.to_dict(),
            "lengths": self.lengths,
            "arms": self.arms,
            **self.meta,
        }
        (directory / "policy.json").write_text(json.dumps(meta, indent=1), encoding="utf-8")
        if history is not None:
            (directory / "history.json").write_text(json.dumps(history), encoding="utf-8")

    @classmethod
    def load(cls, directory: Path) -> TrainedPolicy:
        """The policy saved in ``directory``.

        Raises:
            PolicyError: no readable checkpoint there.
        """
        try:
            meta = json.loads((directory / "policy.json").read_text(encoding="utf-8"))
            net = NetSpec(
                **{k: tuple(v) if isinstance(v, list) else v for k, v in meta["train"]["net"].items()}
            )
            skeleton = Policy(net, len(meta["names"]), STATE_DIM, CHUNK, ACTION_DIM, jax.random.PRNGKey(0))
            model = eqx.tree_deserialise_leaves(directory / "model.eqx", skeleton)
        except (OSError, KeyError, ValueError, TypeError) as exc:
            raise PolicyError(
                f"no image-il checkpoint in {directory} ({exc}); run `taskcond learn --method image-il`"
            ) from None
        rest = {k: v for k, v in meta.items() if k not in ("names", "norm", "lengths", "arms")}
        return cls(
            model, Normalizer.from_dict(meta["norm"]), meta["names"], meta["lengths"], meta["arms"], rest
        )


def learn_policy(
    directory: Path,
    samples: Samples,
    data: DataSpec,
    spec: TrainSpec,
    progress: Callable[[int, float], None] | None = None,
) -> tuple[TrainedPolicy, dict[str, Any]]:
    """Train on ``samples`` (demonstrated as ``data`` says) and save the checkpoint in ``directory``."""
    policy, history = train(samples, spec, progress)
    policy.meta["data"] = _spec_dict(data)
    policy.save(directory, history)
    return policy, history


__all__ = ["LOG_EVERY", "PolicyError", "TrainedPolicy", "learn_policy", "normalizer", "train"]
