"""Static bodies made of PyBullet primitive shapes, for hand-placed scenes (perception tests and benchmarks).

Positions are metres in the world frame; half extents in metres.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pybullet as p

RGBA = tuple[float, float, float, float]


def add_box(
    client: int,
    half: Sequence[float],
    pos: Sequence[float],
    mass: float = 0.0,
    orn: Sequence[float] = (0, 0, 0, 1),
    rgba: RGBA = (0.7, 0.4, 0.3, 1.0),
) -> int:
    """A box of half extents ``half`` (3,) centred at ``pos``; ``mass=0`` makes it static."""
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client)
    vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=rgba, physicsClientId=client)
    return p.createMultiBody(mass, col, vis, basePosition=pos, baseOrientation=orn, physicsClientId=client)


def add_cylinder(
    client: int, radius: float, height: float, pos: Sequence[float], rgba: RGBA = (0.3, 0.6, 0.4, 1.0)
) -> int:
    """A static upright cylinder centred at ``pos``."""
    col = p.createCollisionShape(p.GEOM_CYLINDER, radius=radius, height=height, physicsClientId=client)
    vis = p.createVisualShape(
        p.GEOM_CYLINDER, radius=radius, length=height, rgbaColor=rgba, physicsClientId=client
    )
    return p.createMultiBody(0.0, col, vis, basePosition=pos, physicsClientId=client)


def add_tray(client: int, half: float, wall: float, pos: Sequence[float], upside_down: bool = False) -> int:
    """A static open square box: 1 cm floor of half width ``half`` and walls ``wall`` m high; ``pos`` is the
    centre of the floor's bottom. ``upside_down`` turns it over (a cover that hides what is under it)."""
    t = 0.005
    halves = [
        (half, half, t),
        (t, half, wall / 2),
        (t, half, wall / 2),
        (half, t, wall / 2),
        (half, t, wall / 2),
    ]
    z = wall / 2
    frames = [(0, 0, t), (half - t, 0, z), (t - half, 0, z), (0, half - t, z), (0, t - half, z)]
    col = p.createCollisionShapeArray(
        [p.GEOM_BOX] * 5, halfExtents=halves, collisionFramePositions=frames, physicsClientId=client
    )
    vis = p.createVisualShapeArray(
        [p.GEOM_BOX] * 5, halfExtents=halves, visualFramePositions=frames, physicsClientId=client
    )
    orn = p.getQuaternionFromEuler((np.pi, 0, 0)) if upside_down else (0, 0, 0, 1)
    return p.createMultiBody(0.0, col, vis, basePosition=pos, baseOrientation=orn, physicsClientId=client)
