"""The image-based imitation-learning baseline at small scale: real oracle demonstrations rendered by the
real camera, a few training steps whose loss falls, the checkpoint round trip, and rollouts through the
real environment (directly and through ``taskcond eval``). Skipped without the [il] extra."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("pybullet")
pytest.importorskip("jax", reason="needs the [il] extra")
pytest.importorskip("equinox", reason="needs the [il] extra")
pytest.importorskip("optax", reason="needs the [il] extra")

from taskcond.application.baseline import run_policy_episode
from taskcond.application.plans import plan_run
from taskcond.cli import app
from taskcond.il.config import NetSpec, TrainSpec, policy_dir
from taskcond.il.dataset import CHUNK, IMAGE_SIZE, STATE_DIM, demonstrate, record_episode
from taskcond.il.train import PolicyError, TrainedPolicy, train

pytestmark = pytest.mark.sim
TASK = "release-bottle"  # the shortest oracle: 42 control steps


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    samples = demonstrate(TASK, 2)
    spec = TrainSpec(
        steps=100, batch=16, learning_rate=3e-3, net=NetSpec(channels=(8, 8, 8), embedding=4, hidden=32)
    )
    policy, history = train(samples, spec, log_every=20)
    directory = tmp_path_factory.mktemp("il") / "policy"
    policy.save(directory, history)
    return samples, policy, history, directory


def test_demonstrations_are_rendered_samples_with_action_chunks(trained):
    samples, *_ = trained
    n = len(samples)
    assert samples.names == ["release bottle"] and len(samples.lengths["release bottle"]) == 2
    assert samples.image.shape == (n, IMAGE_SIZE, IMAGE_SIZE, 4) and samples.image.dtype == np.uint8
    assert samples.image[..., :3].std() > 10  # a scene, not a blank frame
    assert samples.state.shape == (n, STATE_DIM) and samples.actions.shape == (n, CHUNK, 16)
    assert set(samples.arms.tolist()) == {1} and not samples.actions[..., 8:].any()  # single-arm kitchen
    assert (
        set(np.unique(samples.actions[..., 7])) <= {0.0, 1.0} and samples.actions[-1, -1, 7] == 0.0
    )  # released
    assert np.all(np.diff(samples.progress[: n // 2]) > 0)


def test_the_loss_falls(trained):
    *_, history, _ = trained
    assert len(history["loss"]) == 5
    assert history["loss"][-1] < 0.6 * history["loss"][0], history["loss"]


def test_the_checkpoint_round_trip_acts_the_same(trained):
    samples, policy, _, directory = trained
    loaded = TrainedPolicy.load(directory)
    a = policy.act(samples.image[3], samples.state[3], 0.3, "release bottle")
    b = loaded.act(samples.image[3], samples.state[3], 0.3, "release bottle")
    assert a.shape == (CHUNK, 16) and np.array_equal(a, b)
    assert np.allclose(np.linalg.norm(a[:, 3:7], axis=1), 1.0) and set(a[:, 7]) <= {0.0, 1.0}
    with pytest.raises(PolicyError, match="not trained on 'grasp bottle'; it knows: release bottle"):
        loaded.act(samples.image[0], samples.state[0], 0.0, "grasp bottle")
    with pytest.raises(PolicyError, match="no image-il checkpoint in"):
        TrainedPolicy.load(directory.parent / "nothing")


@dataclass
class Replay:
    """A policy that acts a recorded oracle run of :data:`TASK` chunk by chunk (absolute (T, 8) actions),
    or, with ``hold``, keeps its first pose with the hand closed throughout (it never releases)."""

    actions: np.ndarray
    hold: bool = False
    t: int = 0
    names: tuple[str, ...] = ("release bottle",)
    arms: dict = dataclasses.field(default_factory=lambda: {"release bottle": 1})

    def nominal_steps(self, name: str) -> int:
        return len(self.actions)

    def budget(self, name: str) -> int:
        return CHUNK * int(np.ceil(len(self.actions) / CHUNK))

    def act(self, image: np.ndarray, state: np.ndarray, progress: float, name: str) -> np.ndarray:
        if self.hold:
            return np.tile(np.r_[self.actions[0, :7], 1.0], (CHUNK, 1))
        idx = np.minimum(self.t + np.arange(CHUNK), len(self.actions) - 1)
        self.t += CHUNK
        return self.actions[idx]


def test_a_rollout_is_judged_by_the_task_own_check(trained):
    """The oracle's own actions replayed from its seed succeed; the same start with the hand held closed
    fails on the release's post-condition; a trained policy's rollout is judged the same way."""
    steps, ok = record_episode(TASK, 1000)
    assert ok and [s.name for s in steps] == ["release bottle"]
    actions = np.array(steps[0].actions)
    done = run_policy_episode(plan_run(TASK), 1000, Replay(actions))
    assert done.success and done.failure is None and done.goal_missing == []
    assert done.goal == ["gripper not grasping"] and "gripper not grasping" in done.final_predicates
    held = run_policy_episode(plan_run(TASK), 1000, Replay(actions, hold=True))
    assert not held.success and held.goal_missing == ["gripper not grasping"], held.goal_missing
    assert held.failure is not None and "gripper not grasping" not in held.final_predicates
    _, policy, *_ = trained
    result = run_policy_episode(plan_run(TASK), 1000, policy)
    assert result.method == "image-il" and result.steps == ["release bottle"]
    assert result.sim_seconds == pytest.approx(policy.budget("release bottle") / 30, abs=1e-3)
    assert result.success is (not result.goal_missing and result.failure is None)
    with pytest.raises(PolicyError, match="not trained on 'grasp bottle'"):
        run_policy_episode(plan_run("LHT1"), 1000, policy)


def test_eval_records_the_checkpoint_in_its_configuration(trained, tmp_path, monkeypatch):
    *_, directory = trained
    monkeypatch.setenv("TASKCOND_CACHE_DIR", str(tmp_path / "cache"))
    target = policy_dir()
    target.parent.mkdir(parents=True)
    target.symlink_to(directory)
    out = tmp_path / "e.jsonl"
    args = ["eval", "primitives", "--task", TASK, "--method", "image-il", "--episodes", "1", "--workers", "1"]
    res = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert not (tmp_path / "cache" / "skills").exists()  # the baseline needs no skill library
    header, record = (json.loads(line) for line in Path(out).read_text().splitlines())
    assert header["config"]["il"].startswith(f"{target.name}@") and header["config"]["skills"] is None
    assert record["method"] == "image-il" and record["seed"] == 1000 and record["digest"] == header["digest"]
