"""Tests of the DMP trajectory-learning module (paper §III-D Eq. 1–3, §III-E Alg. 2)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from taskcond.dmp import (
    BACKUP_POINTS,
    DMPParameters,
    DMPRollout,
    GripperEvent,
    Trajectory,
    extract_gripper_events,
    gripper_command_at,
    gripper_schedule,
    learn_dmp,
    load_parameters,
    rollout,
    save_parameters,
)

DURATION = 2.0
N_SAMPLES = 201


def _demo(n_dims: int = 3, z_returns: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """A reach with a lift: minimum-jerk from y0 to g plus a bump in z (and a wiggle in x), at rest at
    both ends. Dimensions 3–5 (if asked) are Euler angles in rad. With ``z_returns`` z ends where it
    started (g == y0 in that dimension)."""
    t = np.linspace(0.0, DURATION, N_SAMPLES)
    s = t / DURATION
    min_jerk = 10 * s**3 - 15 * s**4 + 6 * s**5
    y0 = np.array([0.4, -0.1, 0.3, 0.0, np.pi, 0.2])[:n_dims]
    goal = np.array([0.6, 0.2, 0.3 if z_returns else 0.1, 0.3, np.pi - 0.4, -0.5])[:n_dims]
    positions = y0 + (goal - y0) * min_jerk[:, None]
    positions[:, 2] += 0.15 * np.sin(np.pi * s) ** 4
    positions[:, 0] += 0.03 * np.sin(2 * np.pi * s) * np.sin(np.pi * s) ** 4
    return t, positions


def _step_through(runner: DMPRollout, dt: float, n_steps: int) -> np.ndarray:
    return np.array([runner.step(dt)[0] for _ in range(n_steps)])


@pytest.fixture(scope="module")
def demo() -> tuple[np.ndarray, np.ndarray]:
    return _demo()


@pytest.fixture(scope="module")
def params(demo: tuple[np.ndarray, np.ndarray]) -> DMPParameters:
    return learn_dmp(*demo)


def test_learned_parameters_follow_the_paper(params: DMPParameters) -> None:
    assert params.weights.shape == (3, 100)
    assert (params.alpha_y, params.beta_y, params.alpha_x, params.x0) == (60.0, 15.0, 1.0, 1.0)
    assert params.tau == pytest.approx(DURATION)
    assert params.centres[0] == 1.0
    assert params.centres[-1] == pytest.approx(np.exp(-1.0))
    assert_array_equal(params.goal_scaled, [True, True, True])
    assert np.all(np.isfinite(params.weights))


@pytest.mark.parametrize("n_dims", [3, 6])
def test_reproduces_the_demonstration(n_dims: int) -> None:
    t, positions = _demo(n_dims)
    params = learn_dmp(t, positions)
    runner = DMPRollout(params, positions[0], positions[-1])
    reproduced = np.vstack([positions[:1], _step_through(runner, t[1] - t[0], N_SAMPLES - 1)])
    assert_allclose(reproduced, positions, atol=3e-4)


def test_rollout_function_matches_stepping(
    params: DMPParameters, demo: tuple[np.ndarray, np.ndarray]
) -> None:
    _, positions = demo
    trajectory = rollout(params, positions[0], positions[-1], n_steps=200)
    assert isinstance(trajectory, Trajectory)
    assert trajectory.positions.shape == (201, 3)
    assert_allclose(trajectory.times[-1], DURATION)
    stepped = _step_through(DMPRollout(params, positions[0], positions[-1]), DURATION / 200, 200)
    assert_allclose(trajectory.positions[1:], stepped, rtol=0, atol=1e-15)
    assert_allclose(trajectory.positions, positions, atol=3e-4)


def test_converges_to_a_new_goal(params: DMPParameters) -> None:
    y0, goal = np.array([0.1, 0.3, 0.2]), np.array([-0.2, 0.5, 0.45])
    trajectory = rollout(params, y0, goal, duration=4 * DURATION, n_steps=800)
    assert_allclose(trajectory.positions[0], y0)
    assert_allclose(trajectory.positions[-1], goal, atol=1e-4)
    assert_allclose(trajectory.velocities[-1], 0.0, atol=1e-3)


def test_shape_scales_with_the_goal_offset(
    params: DMPParameters, demo: tuple[np.ndarray, np.ndarray]
) -> None:
    """Eq. 2 scales f by (g − y0): per dimension, the rollout's displacement from its start scales
    with g − y0 (including a flip of sign), and moving start and goal together translates it."""
    _, positions = demo
    y0, goal = positions[0], positions[-1]
    reference = rollout(params, y0, goal, n_steps=300).positions
    factor = np.array([2.0, -0.5, 0.3])
    scaled = rollout(params, y0, y0 + factor * (goal - y0), n_steps=300).positions
    assert_allclose(scaled - y0, factor * (reference - y0), rtol=1e-9, atol=1e-12)
    shift = np.array([0.1, -0.2, 0.05])
    shifted = rollout(params, y0 + shift, goal + shift, n_steps=300).positions
    assert_allclose(shifted, reference + shift, rtol=0, atol=1e-12)


def test_displaced_goal_repeats_the_demonstrated_displacement(
    params: DMPParameters, demo: tuple[np.ndarray, np.ndarray]
) -> None:
    _, positions = demo
    start = np.array([0.0, 0.5, 0.2])
    assert_allclose(params.displaced_goal(start), start + positions[-1] - positions[0], atol=1e-15)


def test_goal_change_mid_rollout_converges_to_the_new_goal(
    params: DMPParameters, demo: tuple[np.ndarray, np.ndarray]
) -> None:
    _, positions = demo
    runner = DMPRollout(params, positions[0], positions[-1])
    dt = 0.01
    before = _step_through(runner, dt, 100)
    new_goal = positions[-1] + np.array([0.05, -0.1, 0.08])
    runner.set_goal(new_goal)
    assert_array_equal(runner.goal, new_goal)
    after = _step_through(runner, dt, 700)
    assert np.max(np.abs(after[0] - before[-1])) < 0.02
    assert_allclose(after[-1], new_goal, atol=1e-4)
    assert runner.time == pytest.approx(8.0)


def test_restore_reproduces_the_continuation_exactly(params: DMPParameters) -> None:
    y0, goal = np.array([0.0, 0.0, 0.0]), np.array([0.3, -0.2, 0.1])
    runner = DMPRollout(params, y0, goal)
    _step_through(runner, 0.01, 30)
    saved = runner.state()
    first = _step_through(runner, 0.01, 40)
    runner.set_goal(goal + 1.0)
    _step_through(runner, 0.01, 5)
    runner.restore(saved)
    assert runner.time == saved.time
    assert_array_equal(runner.goal, goal)
    assert_array_equal(_step_through(runner, 0.01, 40), first)


def test_back_up_then_replan_as_in_algorithm_2(params: DMPParameters) -> None:
    """Alg. 2: on a collision go back 10 trajectory points, move the goal, continue."""
    y0, goal = np.array([0.0, 0.0, 0.0]), np.array([0.3, -0.2, 0.1])
    runner = DMPRollout(params, y0, goal)
    path = _step_through(runner, 0.01, 50)
    state = runner.back_up()
    assert state.time == pytest.approx(0.40)
    assert_array_equal(runner.position, path[50 - BACKUP_POINTS - 1])
    assert_array_equal(_step_through(runner, 0.01, BACKUP_POINTS), path[-BACKUP_POINTS:])
    runner.back_up(BACKUP_POINTS)
    new_goal = goal + np.array([0.0, 0.1, 0.2])
    runner.set_goal(new_goal)
    _step_through(runner, 0.01, 800)
    assert_allclose(runner.position, new_goal, atol=1e-4)
    with pytest.raises(ValueError, match=r"cannot back up 11 points, 10 are kept"):
        runner.back_up(11)


def test_demonstration_with_goal_equal_to_start_in_one_dimension() -> None:
    """z returns to its start: that dimension falls back to the unscaled forcing term."""
    t, positions = _demo(z_returns=True)
    params = learn_dmp(t, positions)
    assert_array_equal(params.goal_scaled, [True, True, False])
    assert np.all(np.isfinite(params.weights))
    reproduced = rollout(params, positions[0], positions[-1], n_steps=200).positions
    assert_allclose(reproduced, positions, atol=3e-4)
    assert reproduced[:, 2].max() == pytest.approx(positions[:, 2].max(), abs=3e-4)
    shift = np.array([0.1, 0.1, -0.1])
    shifted = rollout(params, positions[0] + shift, positions[-1] + shift, n_steps=200).positions
    assert_allclose(shifted, reproduced + shift, atol=1e-12)
    new_goal = positions[-1] + np.array([0.0, 0.0, 0.1])
    raised = rollout(params, positions[0], new_goal, duration=4 * DURATION, n_steps=800).positions
    assert raised[:, 2].max() > positions[:, 2].max()
    assert_allclose(raised[-1], new_goal, atol=1e-4)


def test_rollout_with_goal_equal_to_start_stays_put(params: DMPParameters) -> None:
    """In a scaled dimension g == y0 zeroes the forcing term of Eq. 2: that dimension does not move."""
    y0 = np.array([0.2, 0.1, 0.3])
    goal = np.array([0.5, 0.1, 0.3])
    trajectory = rollout(params, y0, goal, n_steps=200)
    assert_array_equal(trajectory.positions[:, 1:], np.broadcast_to(y0[1:], (201, 2)))
    assert np.ptp(trajectory.positions[:, 0]) > 0.2


def test_save_load_round_trip_is_exact(params: DMPParameters, tmp_path) -> None:
    json_path, npz_path = save_parameters(params, tmp_path / "skills" / "pick")
    assert json_path.name == "pick.json" and npz_path.name == "pick.npz"
    meta = json.loads(json_path.read_text())
    assert meta["format_version"] == 1 and meta["kind"] == "taskcond.dmp"
    loaded = load_parameters(tmp_path / "skills" / "pick.json")
    for name in ("weights", "centres", "widths", "y0", "goal", "goal_scaled"):
        assert_array_equal(getattr(loaded, name), getattr(params, name))
        assert getattr(loaded, name).dtype == getattr(params, name).dtype
    for name in ("alpha_y", "beta_y", "alpha_x", "x0", "tau"):
        assert getattr(loaded, name) == getattr(params, name)
    y0, goal = np.array([0.1, 0.2, 0.3]), np.array([0.3, 0.0, 0.5])
    assert_array_equal(rollout(loaded, y0, goal).positions, rollout(params, y0, goal).positions)


def test_load_rejects_unknown_versions_and_missing_fields(params: DMPParameters, tmp_path) -> None:
    json_path, _ = save_parameters(params, tmp_path / "pick")
    meta = json.loads(json_path.read_text())
    meta["format_version"] = 99
    json_path.write_text(json.dumps(meta))
    with pytest.raises(ValueError, match=r"format version 99, expected 1"):
        load_parameters(json_path)
    del meta["tau"]
    meta["format_version"] = 1
    json_path.write_text(json.dumps(meta))
    with pytest.raises(ValueError, match=r"pick.json lacks the field\(s\) tau"):
        load_parameters(json_path)


_T = np.linspace(0.0, 1.0, 20)
_Y = np.zeros((20, 3))


@pytest.mark.parametrize(
    ("times", "positions", "message"),
    [
        (
            _T,
            np.zeros((19, 3)),
            r"positions must have shape \(n, d\) with n = len\(times\) = 20, got \(19, 3\)",
        ),
        (_T, np.zeros(20), r"positions must be 2-D, got shape \(20,\)"),
        (_T.reshape(4, 5), _Y, r"times must be 1-D"),
        (np.r_[_T[:5], _T[4], _T[6:]], _Y, r"times must be strictly increasing, times\[5\]"),
        (_T[::-1], _Y, r"times must be strictly increasing"),
        (np.r_[_T[:-1], np.nan], _Y, r"times contains NaN or inf"),
        (_T, np.where(np.arange(20)[:, None] == 7, np.nan, _Y), r"positions contains NaN or inf"),
        (_T[:2], _Y[:2], r"times must have at least 3 samples, got 2"),
        (_T, [["a"] * 3] * 20, r"positions must be a numeric array"),
    ],
)
def test_learn_rejects_bad_input(times, positions, message: str) -> None:
    with pytest.raises(ValueError, match=message) as info:
        learn_dmp(times, positions)
    assert "\n" not in str(info.value)


def test_rollout_rejects_bad_input(params: DMPParameters) -> None:
    with pytest.raises(ValueError, match=r"y0 must have shape \(3,\), got \(2,\)"):
        DMPRollout(params, np.zeros(2), np.ones(3))
    runner = DMPRollout(params, np.zeros(3), np.ones(3))
    with pytest.raises(ValueError, match=r"goal contains NaN or inf"):
        runner.set_goal([0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match=r"dt must be a finite number > 0, got 0"):
        runner.step(0.0)
    with pytest.raises(ValueError, match=r"dt must be a finite number > 0, got nan"):
        runner.step(float("nan"))
    with pytest.raises(ValueError, match=r"n_steps must be >= 1, got 0"):
        rollout(params, np.zeros(3), np.ones(3), n_steps=0)
    with pytest.raises(ValueError, match=r"cannot back up 1 points, 0 are kept"):
        runner.back_up(1)


def test_trajectory_validates_its_arrays() -> None:
    with pytest.raises(ValueError, match=r"velocities must have shape \(20, 3\), got \(20, 2\)"):
        Trajectory(_T, _Y, np.zeros((20, 2)))
    trajectory = Trajectory(_T, _Y)
    assert trajectory.duration == 1.0
    assert not trajectory.positions.flags.writeable


def test_gripper_events_are_extracted_and_mapped_to_a_rollout() -> None:
    times = np.linspace(10.0, 17.0, 8)
    commands = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0])
    events = extract_gripper_events(times, commands)
    assert events == (GripperEvent(0.0, 0.0), GripperEvent(3 / 7, 1.0), GripperEvent(6 / 7, 0.0))
    assert gripper_schedule(events, duration=3.5, start_time=1.0) == [(1.0, 0.0), (2.5, 1.0), (4.0, 0.0)]
    assert gripper_command_at(events, 0.2) == 0.0
    assert gripper_command_at(events, 0.5) == 1.0
    assert gripper_command_at(events, 1.3) == 0.0
    assert extract_gripper_events(times, np.full(8, 0.04)) == (GripperEvent(0.0, 0.04),)
    with pytest.raises(ValueError, match=r"commands must have shape \(8,\) like times, got \(7,\)"):
        extract_gripper_events(times, commands[:-1])


def test_gripper_events_follow_rollout_progress(params: DMPParameters) -> None:
    events = (GripperEvent(0.0, 0.0), GripperEvent(0.5, 1.0))
    runner = DMPRollout(params, np.zeros(3), np.ones(3), tau=4.0)
    _step_through(runner, 0.01, 150)
    assert gripper_command_at(events, runner.progress) == 0.0
    _step_through(runner, 0.01, 55)
    assert gripper_command_at(events, runner.progress) == 1.0
    runner.back_up()
    assert gripper_command_at(events, runner.progress) == 0.0


def test_unscaled_keeps_the_learned_forcing_and_stops_rescaling() -> None:
    t = np.linspace(0.0, 1.0, 201)
    demo = np.stack([0.05 * t + 0.2 * np.sin(np.pi * t), 0.2 * t], axis=1)  # up and back
    params = learn_dmp(t, demo)
    plain = params.unscaled(np.array([True, False]))
    assert_array_equal(plain.goal_scaled, [False, True])
    x = params.phase(t)
    assert_allclose(plain.forcing(x, params.y0, params.goal), params.forcing(x, params.y0, params.goal))
    # a goal on the other side: the scaled form mirrors the bump, the unscaled one keeps it upwards
    goal = params.y0 + np.array([-0.05, 0.2])
    mirrored = rollout(params, params.y0, goal, n_steps=200).positions[:, 0]
    kept = rollout(plain, params.y0, goal, n_steps=200).positions[:, 0]
    assert mirrored.min() < -0.15
    assert kept.max() > 0.1
    assert_allclose(kept[-1], goal[0], atol=0.02)
