"""The image-based imitation-learning baseline of the paper's Tables III and IV (§V): behaviour cloning of
the suite's oracles from camera images and proprioception.

- :mod:`taskcond.il.dataset`: oracle demonstrations rendered as (image, proprioception, action chunk)
  samples (needs the ``[sim]`` extra, not the deep-learning library);
- :mod:`taskcond.il.policy`: the network (Equinox on JAX; no simulator, no task wording);
- :mod:`taskcond.il.train`: training, checkpoints and their cache;
- :mod:`taskcond.il.rollout`: the policy driving a :class:`~taskcond.envs.kitchen.KitchenEnv` along a
  sequence of primitive task names.

The deep-learning library is the ``[il]`` extra (JAX, Equinox, Optax); :func:`require_il` says so in one line
when it is missing.
"""

from __future__ import annotations


class ILUnavailableError(RuntimeError):
    """The ``[il]`` extra (JAX, Equinox, Optax) is not installed."""


def require_il() -> None:
    """Raise :class:`ILUnavailableError` with the install command when JAX, Equinox or Optax is missing."""
    try:
        import equinox  # noqa: F401
        import jax  # noqa: F401
        import optax  # noqa: F401
    except ImportError as exc:
        raise ILUnavailableError(
            f"--method image-il needs the [il] extra ({exc.name} missing): pip install 'taskcond[il]'"
        ) from None


__all__ = ["ILUnavailableError", "require_il"]
