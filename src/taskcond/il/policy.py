"""The baseline's network: one multi-task behaviour-cloning policy, conditioned on the index of the primitive
task name (an embedding), in Equinox on JAX. It knows arrays, not the simulator nor the tasks' wording.

Inputs of one sample (layout in :mod:`taskcond.il.dataset`): ``image`` (H, W, 4) uint8 RGB-D, ``state``
(S,) float32, ``progress`` float32, ``task`` int32. Output: an action chunk (K, 16): per arm the normalized
position target (3; world frame, or relative to the end effector, :attr:`Normalizer.absolute`), a
quaternion (4, xyzw, not normalized) and the gripper's logit (1).

Architecture: a convolutional encoder (5×5 stride 2, 3×3 stride 2, 3×3: 16, 32, 32 channels) whose last
feature maps give 32 spatial-softmax keypoints (expected image coordinates, as in Levine et al. 2016,
"End-to-end training of deep visuomotor policies") and their global average; with the normalized state,
the progress and a 32-dimensional task embedding, a 256-256 MLP predicts the chunk.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from taskcond.il.config import NetSpec


@dataclass(frozen=True)
class Normalizer:
    """Per-dimension mean and standard deviation (numpy arrays) of the state (S,) and of the chunk's
    position targets (6,: Franka xyz, Kinova xyz), from the training samples. ``absolute``: the targets
    are world positions (m); else offsets from the arm's end effector at the sample (m)."""

    state_mean: np.ndarray
    state_std: np.ndarray
    position_mean: np.ndarray
    position_std: np.ndarray
    absolute: bool = True

    def to_dict(self) -> dict[str, Any]:
        return {k: v if isinstance(v, bool) else np.asarray(v).tolist() for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Normalizer:
        return cls(**{k: v if isinstance(v, bool) else np.asarray(v, np.float32) for k, v in data.items()})

    def targets(self, actions: np.ndarray, state: np.ndarray) -> np.ndarray:
        """Position targets (..., K, 2, 3) of chunks (..., K, 16) laid out as :mod:`taskcond.il.dataset`
        does (offsets from the arms in ``state`` (..., S)), world positions when :attr:`absolute`."""
        rel = np.asarray(actions, np.float32).reshape(*actions.shape[:-1], 2, 8)[..., :3]
        if not self.absolute:
            return rel
        arms = np.stack([state[..., 0:3], state[..., 8:11]], axis=-2)  # (..., 2, 3)
        return rel + arms[..., None, :, :]


def spatial_softmax(features: jax.Array) -> jax.Array:
    """(C, H, W) feature maps → (2C,) expected (x, y) image coordinates in [-1, 1] of each channel's
    softmax over its pixels."""
    c, h, w = features.shape
    weights = jax.nn.softmax(features.reshape(c, h * w), axis=-1).reshape(c, h, w)
    xs, ys = jnp.linspace(-1.0, 1.0, w), jnp.linspace(-1.0, 1.0, h)
    return jnp.concatenate([(weights.sum(1) * xs).sum(-1), (weights.sum(2) * ys).sum(-1)])


class Policy(eqx.Module):
    """The network. Call it on one sample; :func:`jax.vmap` it for a batch."""

    convs: list[eqx.nn.Conv2d]
    embed: eqx.nn.Embedding
    mlp: eqx.nn.MLP
    chunk: int = eqx.field(static=True)
    action_dim: int = eqx.field(static=True)

    def __init__(
        self, spec: NetSpec, tasks: int, state_dim: int, chunk: int, action_dim: int, key: jax.Array
    ) -> None:
        keys = jax.random.split(key, len(spec.channels) + 2)
        sizes = [(5, 2), (3, 2), *[(3, 1)] * (len(spec.channels) - 2)]
        ins = (4, *spec.channels[:-1])
        self.convs = [
            eqx.nn.Conv2d(i, o, k, stride=s, padding=k // 2, key=kk)
            for i, o, (k, s), kk in zip(ins, spec.channels, sizes, keys, strict=False)
        ]
        self.embed = eqx.nn.Embedding(tasks, spec.embedding, key=keys[-2])
        features = 3 * spec.channels[-1] + state_dim + 1 + spec.embedding
        self.mlp = eqx.nn.MLP(features, chunk * action_dim, spec.hidden, 2, key=keys[-1])
        self.chunk, self.action_dim = chunk, action_dim

    def __call__(self, image: jax.Array, state: jax.Array, progress: jax.Array, task: jax.Array) -> jax.Array:
        """``image`` (4, H, W) float in [0, 1], ``state`` (S,) normalized, ``progress`` (), ``task`` () int →
        (K, A) raw outputs (normalized positions, quaternions, gripper logits)."""
        x = image
        for conv in self.convs:
            x = jax.nn.relu(conv(x))
        keypoints = spatial_softmax(x)
        pooled = x.mean(axis=(1, 2))
        z = jnp.concatenate([keypoints, pooled, state, progress[None], self.embed(task)])
        return self.mlp(z).reshape(self.chunk, self.action_dim)


def to_input(images: np.ndarray | jax.Array) -> jax.Array:
    """Images (..., H, W, 4) uint8 → (..., 4, H, W) float32 in [0, 1]."""
    return jnp.moveaxis(jnp.asarray(images, jnp.float32) / 255.0, -1, -3)


def normalize_targets(actions: np.ndarray, state: np.ndarray, norm: Normalizer) -> np.ndarray:
    """Target chunks (..., K, 16) of samples with states (..., S), their positions as ``norm`` makes
    them: what the network outputs for them."""
    out = np.array(actions, np.float32).reshape(*actions.shape[:-1], 2, 8)
    position = norm.targets(actions, state)
    out[..., :3] = (position - norm.position_mean.reshape(2, 3)) / norm.position_std.reshape(2, 3)
    return out.reshape(actions.shape)


def loss_terms(out: jax.Array, targets: jax.Array, arms: jax.Array) -> tuple[jax.Array, dict[str, jax.Array]]:
    """Loss of a batch: outputs (B, K, 16), targets (B, K, 16) from :func:`normalize_targets`, arms (B,) 1 or
    2 (the Kinova's columns count only for 2). Returns the total and its terms: mean squared error of the
    normalized positions, squared error of the quaternions (the target's sign in the hemisphere of
    the current orientation, as recorded) and the gripper's binary cross-entropy (weight 0.5)."""
    mask = jnp.stack([jnp.ones(arms.shape), (arms == 2).astype(jnp.float32)], 1)  # (B, 2)
    out, targets = out.reshape(*out.shape[:2], 2, 8), targets.reshape(*targets.shape[:2], 2, 8)
    position = ((out[..., :3] - targets[..., :3]) ** 2).mean(-1)
    quat = ((out[..., 3:7] - targets[..., 3:7]) ** 2).sum(-1)
    grip = optax.sigmoid_binary_cross_entropy(out[..., 7], targets[..., 7])
    weight = mask[:, None, :] / (mask.sum() * out.shape[1])
    terms = {
        "position": (position * weight).sum(),
        "quaternion": (quat * weight).sum(),
        "gripper": (grip * weight).sum(),
    }
    return terms["position"] + terms["quaternion"] + 0.5 * terms["gripper"], terms


def decode(out: np.ndarray, state: np.ndarray, norm: Normalizer) -> np.ndarray:
    """One sample's raw output (K, 16) → absolute actions (K, 16): per arm the end-effector target
    position (m, world; an offset is added to the arm's position in the un-normalized ``state``), the unit
    quaternion and the gripper command 0 or 1."""
    out = np.asarray(out, float).reshape(len(out), 2, 8)
    position = out[..., :3] * norm.position_std.reshape(2, 3) + norm.position_mean.reshape(2, 3)
    if not norm.absolute:
        position = position + np.stack([state[0:3], state[8:11]])
    quat = out[..., 3:7] / np.maximum(np.linalg.norm(out[..., 3:7], axis=-1, keepdims=True), 1e-6)
    grip = (out[..., 7:8] >= 0.0).astype(float)
    return np.concatenate([position, quat, grip], axis=-1).reshape(len(out), 16)


__all__ = [
    "Normalizer",
    "Policy",
    "decode",
    "loss_terms",
    "normalize_targets",
    "spatial_softmax",
    "to_input",
]
