"""What the simulator tells the perception layer about a built scene: which PyBullet bodies and links carry
which condition-vocabulary names, which joints make a container open or closed, and where the grippers are.

The scene builder fills a :class:`SceneDescription`; the environment-information layer (§III-A.2) reads it.
Neither side knows about tasks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

BodyKind = Literal["object", "container", "furniture", "gripper", "robot"]


@dataclass(frozen=True)
class NamedBody:
    """A body (or one link of it) under the name conditions use, e.g. ``"bottle"`` or ``"top drawer"``.

    Attributes:
        name: canonical object name (lower case, single spaces), as in :mod:`taskcond.conditions`.
        body_id: PyBullet unique body id.
        link_index: link of the body that *is* the object; ``-1`` for the base (the whole body for rigid
            objects), e.g. the drawer link of a cabinet body.
        kind: role in the scene; ``container`` bodies also have a :class:`ContainerJoint` unless they are
            open vessels (bowl, mug) that are always open.
    """

    name: str
    body_id: int
    link_index: int = -1
    kind: BodyKind = "object"


@dataclass(frozen=True)
class ContainerJoint:
    """The joint whose position makes a container open or closed (drawer slide, lid or door hinge).

    Attributes:
        name: the container's object name (``"box"``, ``"top drawer"``, ``"microwave"``).
        body_id, joint_index: the PyBullet joint.
        closed_position, open_position: joint positions (metres for prismatic, radians for revolute) of the
            fully closed and fully open container.
        open_fraction: the container counts as open once it has moved this fraction of the way from
            closed to open.
        closed_fraction: it counts as closed within this fraction of its range from closed (the suite's
            judge's rule, :data:`taskcond.tasks.groundtruth.CLOSED_FRACTION`); in between it is neither,
            so that a drawer pushed half shut is not taken for closed.
    """

    name: str
    body_id: int
    joint_index: int
    closed_position: float
    open_position: float
    open_fraction: float = 0.5
    closed_fraction: float = 0.08


@dataclass(frozen=True)
class GripperSpec:
    """A parallel gripper: its name in conditions, the arm body, finger links and end-effector link.

    Naming with two arms: the Franka's gripper keeps the single-arm name ``"gripper"``, the Kinova's is
    ``"kinova gripper"``; any name ending in ``gripper`` denotes a gripper in conditions."""

    body_id: int
    finger_links: tuple[int, int]
    ee_link: int
    name: str = "gripper"


@dataclass
class SceneDescription:
    """Everything the perception layer needs to read a scene, in one place."""

    client: int
    bodies: list[NamedBody] = field(default_factory=list)
    containers: list[ContainerJoint] = field(default_factory=list)
    grippers: list[GripperSpec] = field(default_factory=list)
    soft_bodies: list[int] = field(default_factory=list)
    """Body ids of soft bodies (the cloth): their box comes from their simulation mesh, and a gripper
    grasps one when its closed fingers hold mesh nodes between them."""

    def body(self, name: str) -> NamedBody:
        """Look up a named body; raises ``KeyError`` listing the valid names."""
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(
            f"no body named {name!r} in the scene; valid: {', '.join(b.name for b in self.bodies)}"
        )
