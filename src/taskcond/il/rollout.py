"""The baseline acting in the suite: a trained policy (:class:`~taskcond.il.train.TrainedPolicy`) drives a
:class:`~taskcond.envs.kitchen.KitchenEnv` along a sequence of primitive task names.

A primitive task runs for the policy's :meth:`~taskcond.il.train.TrainedPolicy.budget` of control steps:
every :data:`~taskcond.il.dataset.CHUNK` steps one image and state are taken and the predicted chunk of
actions is executed open loop. A long-horizon task chains the names of its steps (paper §V: the baseline
runs the primitive tasks of the LHT in turn; the paper does not say how it switches, we switch when a
step's budget is spent, without looking at the task's success). A name the policy acts with one arm sends
(8,) actions (the Kinova holds). Success is the task's own check at the end, as for the other methods.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from taskcond.envs.kitchen import KitchenEnv
from taskcond.il.dataset import CHUNK, observe_image, observe_state
from taskcond.il.train import PolicyError, TrainedPolicy
from taskcond.sim.recording import VideoRecorder

VIDEO_EVERY = 2
"""Record every n-th control step."""


@dataclass
class PolicyRun:
    """Outcome of :func:`run_policy`.

    Attributes:
        steps: the primitive task names run (all of them unless the episode ended early).
        failure: the environment's failure (a blow-up, an unreachable Kinova target) or None.
        detail: its one-line detail.
        control_steps: control steps taken.
        env_seconds: wall-clock seconds in the environment's step (IK and physics).
        policy_seconds: wall-clock seconds rendering and in the network.
    """

    steps: list[str]
    failure: str | None
    detail: str | None
    control_steps: int
    env_seconds: float
    policy_seconds: float


def run_policy(
    env: KitchenEnv,
    obs: dict[str, np.ndarray],
    policy: TrainedPolicy,
    names: tuple[str, ...],
    recorder: VideoRecorder | None = None,
) -> PolicyRun:
    """Run ``names`` in turn with ``policy`` in ``env``, reset with observation ``obs``.

    Raises:
        PolicyError: a name the policy was not trained on (before anything moves).
    """
    unknown = [n for n in names if n not in policy.names]
    if unknown:
        raise PolicyError(
            f"the image-il policy was not trained on {unknown[0]!r}; it knows: {', '.join(policy.names)}"
        )
    done: list[str] = []
    steps = 0
    env_seconds = policy_seconds = 0.0
    for name in names:
        done.append(name)
        nominal, arms = policy.nominal_steps(name), policy.arms[name]
        for t in range(0, policy.budget(name), CHUNK):
            start = time.perf_counter()
            state = observe_state(obs, env.target)
            chunk = policy.act(observe_image(env), state, t / nominal, name)
            policy_seconds += time.perf_counter() - start
            for action in chunk:
                start = time.perf_counter()
                obs, _, terminated, _, info = env.step(action if arms == 2 else action[:8])
                env_seconds += time.perf_counter() - start
                steps += 1
                if recorder is not None and steps % VIDEO_EVERY == 0:
                    recorder.add(env.render())
                if terminated:
                    return PolicyRun(
                        done, info["failure"], info["failure_detail"], steps, env_seconds, policy_seconds
                    )
    return PolicyRun(done, None, None, steps, env_seconds, policy_seconds)


__all__ = ["PolicyRun", "run_policy"]
