"""Write a demonstration file of ``push cube in front of bowl`` (the primitive of ``push.toml``): a scripted
push in the default kitchen, standing in for a teleoperated or kinesthetic recording.

    python examples/push_demo.py push_demo.json
    taskcond learn --primitives examples/push.toml --demo push_demo.json
    taskcond run --primitives examples/push.toml --method llm+demo "push cube in front of bowl"

The hand comes down beside the cube with its fingers closed, slides the cube along the table until it
stands between the robot and the bowl, and rises again.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from taskcond.envs.kitchen import KitchenEnv
from taskcond.execution.demofile import RecordedTrajectory
from taskcond.primitives import load_primitives
from taskcond.sim.franka import top_down
from taskcond.tasks.free import FreeTask
from taskcond.tasks.motion_plan import Waypoint
from taskcond.tasks.motions import CLOSED, plan

TASK = "push cube in front of bowl"
HEIGHT = 0.025
"""End-effector height (m) above the table while pushing (the fingertips just clear the table)."""
BEHIND = 0.055
"""Distance (m) from the cube's centre to the end effector when the push starts."""


def push_demonstration(seed: int = 0) -> RecordedTrajectory:
    """The scripted push in the default kitchen reset with ``seed`` (declares the primitive of push.toml)."""
    load_primitives(Path(__file__).with_name("push.toml"))
    env = KitchenEnv(FreeTask(TASK))
    try:
        env.reset(seed=seed)
        cube, _ = env.scene.pose("cube")
        bowl, _ = env.scene.pose("bowl")
        down = np.array(top_down(0.0))
        start = np.array([cube[0], cube[1] + BEHIND, HEIGHT])
        end = np.array([cube[0], bowl[1] + BEHIND, HEIGHT])
        trajectory = plan(
            env,
            [
                Waypoint(start + np.array([0.0, 0.0, 0.15]), down, CLOSED),
                Waypoint(start, down, CLOSED, 1.0),
                Waypoint(end, down, CLOSED, 2.0),
                Waypoint(end + np.array([0.0, 0.03, 0.15]), down, CLOSED, 1.0),
            ],
        )
    finally:
        env.close()
    return RecordedTrajectory(
        TASK, None, seed, trajectory.times, trajectory.positions, trajectory.orientations, trajectory.gripper
    )


if __name__ == "__main__":
    path = push_demonstration().save(sys.argv[1] if len(sys.argv) > 1 else "push_demo.json")
    print(f"wrote {path}")
