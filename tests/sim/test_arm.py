"""Both arms of the suite offer the one arm protocol (:class:`taskcond.sim.arm.Arm`) with the same semantics:
IK that reports its errors and leaves the arm as it was, joint targets that refuse the limits."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

pytest.importorskip("pybullet")

import pybullet as p

from taskcond.sim.arm import Arm
from taskcond.sim.franka import Franka, top_down
from taskcond.sim.kinova import KinovaArm

pytestmark = pytest.mark.sim


@pytest.fixture
def client() -> Iterator[int]:
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


@pytest.fixture(params=["franka", "kinova"])
def arm(request: pytest.FixtureRequest, client: int) -> Arm:
    return Franka(client) if request.param == "franka" else KinovaArm(client)


def test_both_arms_are_arms(arm: Arm) -> None:
    assert isinstance(arm, Arm)


def test_ik_reports_its_errors_and_leaves_the_arm_alone(arm: Arm) -> None:
    before = arm.joint_positions()
    hit = arm.solve_ik((0.45, 0.1, 0.25), top_down(0.3))
    assert hit.success and hit.within_limits
    assert hit.position_error < 1e-3 and hit.orientation_error < 1e-2
    # pointing down above the shoulder, higher than either hand gets that way: the best answer, reported
    miss = arm.solve_ik((0.0, 0.0, 1.25), top_down(0.3))
    assert not miss.success
    assert miss.position_error > 0.1
    np.testing.assert_array_equal(arm.joint_positions(), before)


def test_joint_targets_outside_the_limits_are_refused(arm: Arm) -> None:
    q = np.array(arm.joint_positions())
    joint = int(np.flatnonzero(np.isfinite(arm.upper))[0])
    q[joint] = arm.upper[joint] + 0.1
    with pytest.raises(ValueError, match=r"outside the .* joint limits"):
        arm.set_joint_targets(q)
