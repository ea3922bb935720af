"""Constants of the executor (:class:`ExecutionConfig`) and the geometry of the robot's hand
(:class:`Hand`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ExecutionConfig:
    """Constants of Alg. 1 and Alg. 2.

    Attributes:
        budget: seconds of world time per top-level primitive, including what it raises (paper: 60 s).
        backup_points: trajectory points to go back after an unallowed collision (paper: 10).
        max_goal_shift: largest goal displacement per collision, metres.
        max_adjustments: collision adjustments per primitive attempt; later collisions are only reported.
        max_attempts: executions of a primitive while its post-conditions do not hold.
        max_depth: deepest recursion of raised primitives.
        settle_steps: control steps the last command is held after a primitive.
        speed_limit: largest planned approach speed, m/s; a longer approach than demonstrated is slowed
            to keep its average speed at or below the demonstration's and this.
        hand: half length and half width (m) of the hand's footprint seen from above, along the axis the
            fingers close on and across it (the Panda hand: a 0.20 × 0.06 m housing, the fingers inside
            it); what a grasp's approach keeps clear of the objects around
            (:meth:`~taskcond.execution.approach.Approach._turn`).
        clearance: depth (m) by which the hand's footprint at a grasp's goal may reach into the box of an
            object standing up beside it before the grasp of a round object is turned to another side;
            also the least gap (m) :meth:`~taskcond.execution.approach.Approach._aside` keeps around a
            placed object, and the height (m) above the end effector's height at a contact with the ground
            below the hand to which Alg. 2 moves the goal up
            (:meth:`~taskcond.execution.executor.Executor._lift`).
        approach_distance: a one-arm grasp whose hand is farther than this (m) from where every
            demonstration of it started, relative to the target, first goes to the highest such start
            (:meth:`~taskcond.execution.approach.Approach._far`,
            :meth:`~taskcond.execution.approach.Approach._transit`); None never does.
        track_target: the goal of a piece anchored on its target follows the mean of the target's
            perceived centres over every control step since the primitive was aimed (each observation
            draws its noise anew), instead of the one centre it was aimed at: a static object perceived
            n times is known to σ/√n. robosuite's square nut has 6.7 mm of clearance round its peg; the
            grasp aimed at the nut and the carry aimed at the peg, each from one observation at σ = 5 mm,
            missed it (issue 32). False (the kitchen's) aims once, as Alg. 2 line 4.
    """

    budget: float = 60.0
    backup_points: int = 10
    max_goal_shift: float = 0.05
    max_adjustments: int = 5
    max_attempts: int = 3
    max_depth: int = 4
    settle_steps: int = 5
    speed_limit: float = 0.25
    hand: tuple[float, float] = (0.105, 0.035)
    clearance: float = 0.01
    approach_distance: float | None = 0.25
    track_target: bool = False


@dataclass(frozen=True)
class Hand:
    """Geometry of the robot's hand that the approach (:mod:`taskcond.execution.approach`) keeps clear of
    what stands around its target; its footprint from above is :attr:`ExecutionConfig.hand`.

    Attributes:
        housing: height (m) of the hand's housing above its fingertips' end-effector point: on the way to a
            grasp, only what stands above the housing is in the footprint's way (the fingers are narrower).
        opening: widest gap (m) between the open fingers: a grasp of an object whose perceived box is
            narrower than this both ways may close across either side
            (:meth:`~taskcond.execution.approach.Approach._turn`).
        closing: the axis (3,) the fingers close along, in the end-effector frame: the long side of the
            hand's footprint (:attr:`ExecutionConfig.hand`); the kitchen's Panda closes along its y,
            robosuite's along its x.
        round_carry_holds: a carry of a round object keeps the hand's heading from where the carry starts
            (:attr:`~taskcond.execution.approach.Aim.hold`) instead of turning it back to the demonstrated
            one: the object is held alike from every side, and a grasp turned a quarter turn to a free
            side (:meth:`~taskcond.execution.approach.Approach._turn`) otherwise turns back by a quarter
            turn on the way, which either way is the nearer (the gripper's half-turn twin): robosuite's
            Panda turned its wrist the other way, its last joint met its limit (2.90 rad) and the arm
            lost the pose (PickPlace seed 1001). False keeps the kitchen's behaviour.
    """

    housing: float
    opening: float
    closing: tuple[float, float, float] = (0.0, 1.0, 0.0)
    round_carry_holds: bool = False


PANDA_HAND = Hand(housing=0.045, opening=0.08)
"""The Franka Panda's hand."""
