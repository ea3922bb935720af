"""Seeing why an episode failed (taskcond.viz): a Rerun recording read back with Rerun's own reader agrees
with the trace; recording changes nothing; captioned videos; eval recordings of failed episodes; a stored
episode's replay reproduces it. Real PyBullet, a one-skill library, a few seconds of simulation each."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("pybullet")
pytest.importorskip("rerun")

from taskcond.application.demonstrations import learn_library
from taskcond.application.episode import run_episode
from taskcond.application.evaluate import evaluate, execution_config
from taskcond.application.plans import plan_run
from taskcond.application.replay import find_episode, replay
from taskcond.cli import app
from taskcond.conditions import GripperState, TaskCondition
from taskcond.execution.skills import SkillLibrary
from taskcond.execution.sources import EnvConditions
from taskcond.results import Job, ResultsFile
from taskcond.viz.captions import FPS, HOLD_SECONDS, outcome_lines
from taskcond.viz.rerun_recording import ALLOWED, UNALLOWED, RerunRecording, read_recording

pytestmark = pytest.mark.sim

NOISE = 0.005


@pytest.fixture(scope="module")
def library_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("skills")
    learn_library(directory, ["grasp-bottle"])
    return directory


@pytest.fixture(scope="module")
def library(library_dir):
    return SkillLibrary.load(library_dir)


class Strict:
    """A condition source whose grasp allows no collision with the bottle: Alg. 2 moves the goal."""

    name = "strict"

    def condition(self, task_name: str) -> TaskCondition:
        return TaskCondition("grasp bottle", post_conditions=(GripperState("bottle"),))


@pytest.fixture(scope="module")
def recorded(library, tmp_path_factory):
    """The same grasp with collisions, run without and with a recording; the recording read back."""
    path = tmp_path_factory.mktemp("rrd") / "grasp.rrd"
    plain = run_episode(plan_run("grasp-bottle"), "llm", 1000, library, Strict(), NOISE)
    watched = run_episode(
        plan_run("grasp-bottle"), "llm", 1000, library, Strict(), NOISE, observers=[RerunRecording(path)]
    )
    return plain, watched, read_recording(path)


def _texts(rows) -> list[str]:
    return [r.values["TextLog:text"][0] for r in rows]


def test_recording_changes_nothing_in_the_episode(recorded) -> None:
    plain, watched, _ = recorded
    assert watched.events == plain.events
    assert (watched.success, watched.sim_seconds, watched.adjustments) == (
        plain.success,
        plain.sim_seconds,
        plain.adjustments,
    )


def test_an_observer_that_raises_stops_watching_and_the_episode_goes_on(library, recorded) -> None:
    from taskcond.viz.episode import EpisodeObserver

    class Broken(EpisodeObserver):
        closed = False

        def stepped(self, step) -> None:  # type: ignore[no-untyped-def]
            raise KeyError("gripper")

        def close(self) -> None:
            Broken.closed = True

    plain, _, _ = recorded
    with pytest.warns(RuntimeWarning, match="Broken stopped watching the episode: KeyError"):
        result = run_episode(
            plan_run("grasp-bottle"), "llm", 1000, library, Strict(), NOISE, observers=[Broken()]
        )
    assert result.events == plain.events and Broken.closed


def test_every_event_of_the_trace_is_a_log_line_at_its_time(recorded) -> None:
    _, result, data = recorded
    logged = sorted(
        (entity.removeprefix("/events/"), round(row.time, 3), text)
        for entity, rows in data.items()
        if entity.startswith("/events/")
        and entity not in ("/events/plan", "/events/outcome", "/events/goal_check")
        for row, text in zip(rows, _texts(rows), strict=True)
    )
    trace = sorted((e["kind"], e["time"], e["message"]) for e in result.events)
    assert logged == trace
    assert any(kind == "collision" for kind, _, _ in trace)
    outcome = _texts(data["/events/outcome"])[0]
    assert ("SUCCEEDED" in outcome) == bool(result.success)


def test_the_outcome_names_what_lies_knocked_over_success_or_not(recorded) -> None:
    """The last frame and the recording's outcome say which objects lie knocked over at the end, also
    when the goal holds."""
    _, result, _ = recorded
    assert not any("knocked over" in line.text for line in outcome_lines(result))
    for success in (True, False):
        fallen = dataclasses.replace(result, success=success, fallen=["bottle", "can"])
        assert outcome_lines(fallen)[-1].text == "knocked over: bottle, can"


def test_goals_alg2_moved_and_the_contacts_agree_with_the_trace(recorded) -> None:
    _, result, data = recorded
    hits = [e for e in result.events if e["kind"] == "collision"]
    arrows = data["/world/plan/moved_goals"][-1].values
    tips = np.array(arrows["Arrows3D:origins"]) + np.array(arrows["Arrows3D:vectors"])
    assert np.allclose(tips, [h["goal"][:3] for h in hits], atol=2e-4)  # the trace rounds to 0.1 mm
    assert all(
        {"gripper", "bottle"} <= set(label.split(":")[0].split(" / ")) for label in arrows["Arrows3D:labels"]
    )
    colours = {c for row in data["/world/contacts"] for c in row.values["Points3D:colors"]}
    packed = {(r << 24) | (g << 16) | (b << 8) | 255 for r, g, b in (UNALLOWED, ALLOWED)}
    assert packed & colours  # contacts judged by Alg. 2's monitor
    first = round(hits[0]["time"] / (1 / 30))
    at = [row for row in data["/world/contacts"] if row.step == first]
    assert at and any(c == packed_of(UNALLOWED) for c in at[0].values["Points3D:colors"])


def packed_of(rgb: tuple[int, int, int]) -> int:
    r, g, b = rgb
    return (r << 24) | (g << 16) | (b << 8) | 255


def test_boxes_show_the_noise_and_paths_follow_the_plan(recorded) -> None:
    _, result, data = recorded
    labels = data["/world/boxes/true"][0].values["Boxes3D:labels"]  # static: the same bodies every time
    true = data["/world/boxes/true"][1].values
    perceived = data["/world/boxes/perceived"][0].values
    assert "bottle" in labels and "bottle" in perceived["Boxes3D:labels"]
    t = np.array(true["Boxes3D:centers"][labels.index("bottle")])
    q = np.array(perceived["Boxes3D:centers"][perceived["Boxes3D:labels"].index("bottle")])
    assert 0 < np.linalg.norm(t - q) < 6 * NOISE  # the noise shows, within reason
    ee = [row.values["Points3D:positions"][0] for row in data["/world/arms/gripper/ee"]]
    assert len(ee) == round(result.sim_seconds * 30)  # one point per control step
    target = data["/world/plan/target"][0].values["Points3D:positions"][0]
    primitive = next(e for e in result.events if e["kind"] == "primitive")
    assert np.allclose(target, primitive["target_center"], atol=2e-4)
    plan = data["/world/plan/path"][-1].values["LineStrips3D:strips"][0]
    assert np.linalg.norm(np.array(ee[-1]) - np.array(plan[-1])) < 0.03  # the hand ends where planned
    assert result.success and "/world/camera/rgb" not in data  # a success's end takes no camera image
    assert data["/state/perceived"] and data["/state/true"]


def test_captioned_video_holds_the_outcome_at_its_end(library, tmp_path) -> None:
    import imageio.v2 as imageio

    path = tmp_path / "grasp.mp4"
    result = run_episode(
        plan_run("grasp-bottle"),
        "env",
        1000,
        library,
        EnvConditions(library),
        video=path,
        video_size=(320, 240),
    )
    reader = imageio.get_reader(path)
    n, held = reader.count_frames(), round(HOLD_SECONDS * FPS)
    first, last, held_from = reader.get_data(0), reader.get_data(n - 1), reader.get_data(n - held)
    reader.close()
    assert first.shape == (240, 320, 3)
    assert n == round(result.sim_seconds * 30) // 2 + held
    assert np.abs(last.astype(int) - held_from).mean() < 2  # the last frame, held (up to the codec)
    assert first[:40].mean() < first[100:140].mean()  # the caption's darkened band


def test_eval_keeps_the_recording_of_a_failed_episode_and_replay_reproduces(library_dir, tmp_path) -> None:
    """``open-box`` has no demonstration in this library: a real failure (no condition from the
    demonstrations); ``grasp-bottle`` succeeds, so its recording is dropped."""
    out, rerun = tmp_path / "eval.jsonl", tmp_path / "rrd"
    results = ResultsFile(out, execution_config(library_dir, NOISE))
    jobs = [Job("grasp-bottle", "env", 1000), Job("open-box", "env", 1000)]
    records = evaluate(jobs, results, library_dir, noise=NOISE, rerun=rerun)
    by_task = {r["task"]: r for r in records}
    assert by_task["grasp-bottle"]["success"] and "rerun" not in by_task["grasp-bottle"]
    assert by_task["open-box"]["success"] is False
    assert sorted(p.name for p in rerun.iterdir()) == ["open-box-env-1000.rrd"]
    failed = read_recording(by_task["open-box"]["rerun"])
    assert _texts(failed["/events/failure"]) == [f"stopped: {by_task['open-box']['reason']}"]
    assert failed["/world/camera/rgb"] and failed["/world/camera/depth"]  # the scene as it failed
    for episode in ("grasp-bottle:env:1000", "open-box:1000"):
        done = replay(find_episode(out, episode), library_dir)
        assert done.reproduced, done.differences
    cli = CliRunner().invoke(
        app,
        [
            "replay",
            str(out),
            "--episode",
            "grasp-bottle:env:1000",
            "--skills",
            str(library_dir),
            "--rerun",
            str(tmp_path / "r.rrd"),
        ],
    )
    assert cli.exit_code == 0, cli.output
    assert "reproduces" in cli.output and (tmp_path / "r.rrd").stat().st_size > 0
    bad = CliRunner().invoke(app, ["replay", str(out), "--episode", "LHT9:llm:1"])
    assert bad.exit_code == 2 and "open-box:env:1000 (failed ones)" in bad.output


def test_a_replay_that_differs_says_what_differs(library_dir, tmp_path) -> None:
    out = tmp_path / "eval.jsonl"
    results = ResultsFile(out, execution_config(library_dir, NOISE))
    evaluate([Job("grasp-bottle", "env", 1000)], results, library_dir, noise=NOISE)
    lines = out.read_text().splitlines()
    record = json.loads(lines[1])
    record["sim_seconds"] += 1.0  # a stored outcome the code does not give
    out.write_text("\n".join([lines[0], json.dumps(record)]) + "\n")
    done = replay(find_episode(out, "1"), library_dir)
    assert not done.reproduced and done.differences[0].startswith("sim_seconds: stored")


def test_the_caption_says_the_step_the_condition_and_an_alg1_event() -> None:
    from taskcond.conditions import ContainerState
    from taskcond.execution.events import Event
    from taskcond.viz.captions import Narrator
    from taskcond.viz.episode import EpisodeInfo

    narrator = Narrator(EpisodeInfo("LHT1", "llm", 3, ("move bottle into box", "close box")))
    cond = TaskCondition(
        "open box", ("box",), (ContainerState("box", False),), (ContainerState("box", True),)
    )
    narrator.on_event(Event(0.0, "step", "move bottle into box", 0, "step: move bottle into box"))
    narrator.on_event(Event(0.5, "condition", "open box", 1, "condition ...", {"condition": cond.to_dict()}))
    narrator.on_event(
        Event(0.5, "raise", "open box", 1, "pre-condition 'box open' unmet: raising 'open box'", {"for": "x"})
    )
    narrator.on_event(Event(0.6, "primitive", "open box", 1, "open box: skill open-box"))
    narrator.predicates = frozenset({ContainerState("box", False)})
    text = [line.text for line in narrator.lines(1.0)]
    assert text[1] == "step 1/2: move bottle into box"
    assert "'open box', raised by Alg. 1" in text[2]
    assert "pre 1/1 hold, post 0/1 hold" in text[3]
    assert text[4].startswith("Alg. 1: pre-condition 'box open' unmet")
    assert len(narrator.lines(0.5 + 2.5)) == 4  # the event's line is gone after a while
    narrator.predicates = frozenset()
    assert narrator.status() == "pre 0/1 hold, post 0/1 hold (unmet: box closed)"
    narrator.predicates = frozenset({ContainerState("box", True)})  # opened: its pre-condition is undone
    assert narrator.status() == "pre 0/1 hold, post 1/1 hold (done)"


def test_without_the_extra_a_recording_is_refused_in_one_line(monkeypatch, tmp_path) -> None:
    import sys

    from taskcond.viz import RerunUnavailableError

    monkeypatch.setitem(sys.modules, "rerun", None)
    with pytest.raises(RerunUnavailableError, match=r"pip install 'taskcond\[viz\]'"):
        RerunRecording(tmp_path / "x.rrd")
    result = CliRunner().invoke(app, ["run", "grasp-bottle", "--rerun", str(tmp_path / "x.rrd")])
    assert result.exit_code == 2 and "[viz] extra" in result.output
