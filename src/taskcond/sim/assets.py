"""Procedural assets of the kitchen task suite (paper §IV, Fig. 4): URDFs built from boxes and cylinders.

Nothing is downloaded: every object is described by a small frozen dataclass (sizes in metres, masses in
kilograms, colours as RGBA in [0, 1]) and turned into URDF text by :func:`build_asset`, which writes it once
into a per-user cache directory keyed by the hash of the text. A "novel object" (paper §V, LHT1*/LHT2*) is
a parameter change of a spec.

Frames (all right-handed, z up):

* free objects (bottle, bowl, mug, toothpaste, spatula, blocks): origin at the centre of the bottom face;
* :class:`BoxSpec`: origin at the centre of the bottom face, lid hinge along y at the back top edge (+x);
  the lid joint angle is 0 when closed and positive when the front lifts;
* :class:`CabinetSpec`: origin at the centre of the front bottom edge, the carcass extends along +x; each
  drawer slides along -x (towards the robot), joint position 0 closed, positive open (metres);
* :class:`MicrowaveSpec`: origin at the centre of the front bottom edge, body along +x, door hinge along z
  at the front right corner (-y); the door angle is 0 closed and positive open (radians).

Each builder also returns the interior volumes (:class:`Interior`) used by the ground-truth ``inside``
check of the task suite, expressed in the frame of the link that carries them.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation

RGBA = tuple[float, float, float, float]
Vec3 = tuple[float, float, float]


# --------------------------------------------------------------------------------------- URDF building
@dataclass(frozen=True)
class Shape:
    """One primitive shape of a link: ``box`` (size = full extents x, y, z), ``cylinder`` (radius, length),
    ``sphere`` (radius)."""

    kind: Literal["box", "cylinder", "sphere"]
    size: tuple[float, ...]
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)
    rgba: RGBA = (0.8, 0.8, 0.8, 1.0)

    def half_extents(self) -> Vec3:
        """Axis-aligned half extents in the shape's own frame."""
        if self.kind == "box":
            return (self.size[0] / 2, self.size[1] / 2, self.size[2] / 2)
        if self.kind == "sphere":
            return (self.size[0], self.size[0], self.size[0])
        return (self.size[0], self.size[0], self.size[1] / 2)

    def volume(self) -> float:
        if self.kind == "box":
            return self.size[0] * self.size[1] * self.size[2]
        if self.kind == "sphere":
            return 4 / 3 * math.pi * self.size[0] ** 3
        return math.pi * self.size[0] ** 2 * self.size[1]


@dataclass(frozen=True)
class Link:
    """A URDF link made of shapes; ``mass`` 0 makes it static when it is the base of a fixed body."""

    name: str
    shapes: tuple[Shape, ...]
    mass: float


@dataclass(frozen=True)
class Joint:
    """A URDF joint from ``parent`` to ``child``; limits in metres (prismatic) or radians (revolute)."""

    name: str
    kind: Literal["prismatic", "revolute", "fixed"]
    parent: str
    child: str
    xyz: Vec3
    axis: Vec3 = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0


@dataclass(frozen=True)
class Interior:
    """An axis-aligned interior volume of a container in the frame of ``link`` (its URDF link name).

    ``center`` and ``half_extents`` in metres; ``round`` marks a cylindrical interior (radius =
    ``half_extents[0]``) of a bowl or mug.
    """

    link: str
    center: Vec3
    half_extents: Vec3
    round: bool = False


Pose = tuple[Sequence[float], Sequence[float]]
"""A placed frame: position (3,) m and quaternion (4,) xyzw, world frame (``KitchenScene.pose``)."""


def to_world(frame: Pose, local: Sequence[float]) -> np.ndarray:
    """World position (3,) of the point ``local`` (m) of a frame placed at ``frame``."""
    position, orientation = frame
    return np.asarray(position, float) + Rotation.from_quat(orientation).apply(np.asarray(local, float))


@dataclass(frozen=True)
class Hinge:
    """A revolute joint in its parent link's frame: ``origin`` (m), a point of its axis and the origin of the
    child link's frame, and the unit ``axis``; the child turns by the joint angle about it (right-handed)."""

    origin: Vec3
    axis: Vec3

    def axis_in_world(self, frame: Pose) -> tuple[np.ndarray, np.ndarray]:
        """A point (3,) of the axis and the axis direction (3,), world frame, with the parent at ``frame``."""
        return to_world(frame, self.origin), Rotation.from_quat(frame[1]).apply(np.asarray(self.axis, float))

    def to_world(self, frame: Pose, angle: float, local: Sequence[float]) -> np.ndarray:
        """World position (3,) of the point ``local`` (m, child link frame) with the joint at ``angle`` (rad)
        and the parent's frame placed at ``frame``."""
        turned = Rotation.from_rotvec(angle * np.asarray(self.axis, float)).apply(np.asarray(local, float))
        return to_world(frame, np.asarray(self.origin, float) + turned)


@dataclass(frozen=True)
class Asset:
    """A generated asset: URDF path plus the interiors of its containers (by condition name)."""

    path: Path
    interiors: dict[str, Interior] = field(default_factory=dict)


def _fmt(v: tuple[float, ...]) -> str:
    return " ".join(f"{x:.6g}" for x in v)


def _geometry(shape: Shape) -> str:
    if shape.kind == "box":
        return f'<box size="{_fmt(shape.size)}"/>'
    if shape.kind == "sphere":
        return f'<sphere radius="{shape.size[0]:.6g}"/>'
    return f'<cylinder radius="{shape.size[0]:.6g}" length="{shape.size[1]:.6g}"/>'


def _inertial(link: Link) -> str:
    """Inertia of the link approximated by a solid box over the shapes' bounding box, centred at the
    volume-weighted centroid of the shapes."""
    vol = sum(s.volume() for s in link.shapes) or 1.0
    com = [sum(s.volume() * s.xyz[i] for s in link.shapes) / vol for i in range(3)]
    lo = [min(s.xyz[i] - s.half_extents()[i] for s in link.shapes) for i in range(3)]
    hi = [max(s.xyz[i] + s.half_extents()[i] for s in link.shapes) for i in range(3)]
    d = [max(hi[i] - lo[i], 1e-3) for i in range(3)]
    m = link.mass
    ixx, iyy, izz = (
        m / 12 * (d[1] ** 2 + d[2] ** 2),
        m / 12 * (d[0] ** 2 + d[2] ** 2),
        m / 12 * (d[0] ** 2 + d[1] ** 2),
    )
    return (
        f'<inertial><origin xyz="{_fmt(tuple(com))}"/><mass value="{m:.6g}"/>'
        f'<inertia ixx="{ixx:.6g}" iyy="{iyy:.6g}" izz="{izz:.6g}" ixy="0" ixz="0" iyz="0"/></inertial>'
    )


def _link_xml(link: Link) -> str:
    parts = [f'<link name="{link.name}">', _inertial(link)]
    for s in link.shapes:
        origin = f'<origin xyz="{_fmt(s.xyz)}" rpy="{_fmt(s.rpy)}"/>'
        parts.append(
            f"<visual>{origin}<geometry>{_geometry(s)}</geometry>"
            f'<material name="c{_fmt(s.rgba).replace(" ", "_")}"><color rgba="{_fmt(s.rgba)}"/></material>'
            "</visual>"
        )
        parts.append(f"<collision>{origin}<geometry>{_geometry(s)}</geometry></collision>")
    parts.append("</link>")
    return "\n".join(parts)


def _joint_xml(j: Joint) -> str:
    limit = (
        f'<limit lower="{j.lower:.6g}" upper="{j.upper:.6g}" effort="100" velocity="2"/>'
        if j.kind != "fixed"
        else ""
    )
    return (
        f'<joint name="{j.name}" type="{j.kind}"><parent link="{j.parent}"/><child link="{j.child}"/>'
        f'<origin xyz="{_fmt(j.xyz)}"/><axis xyz="{_fmt(j.axis)}"/>{limit}</joint>'
    )


def urdf_text(name: str, links: list[Link], joints: list[Joint] | None = None) -> str:
    """URDF XML of a robot made of ``links`` (the first is the base) connected by ``joints``, one element
    per line (PyBullet's parser refused a long one-line URDF: BENCHMARKS.md, "LHT2* mended")."""
    body = "\n".join([*(_link_xml(link) for link in links), *(_joint_xml(j) for j in joints or [])])
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}\n</robot>\n'


def asset_dir() -> Path:
    """Directory of generated assets: ``$TASKCOND_ASSET_DIR`` or a per-user directory under the system
    temporary directory (never the working directory)."""
    env = os.environ.get("TASKCOND_ASSET_DIR")
    uid = os.getuid() if hasattr(os, "getuid") else 0
    path = Path(env) if env else Path(tempfile.gettempdir()) / f"taskcond-assets-{uid}"
    path.mkdir(parents=True, exist_ok=True)
    return path


def write_urdf(name: str, text: str) -> Path:
    """Write URDF ``text`` once (atomically) under :func:`asset_dir`, named by its content hash."""
    digest = hashlib.sha1(text.encode()).hexdigest()[:16]
    path = asset_dir() / f"{name}-{digest}.urdf"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)
    return path


# --------------------------------------------------------------------------------------------- specs
@dataclass(frozen=True)
class BottleSpec:
    """A bottle: cylindrical body plus a neck; total height ``height + neck_height``."""

    radius: float = 0.03
    height: float = 0.10
    neck_radius: float = 0.012
    neck_height: float = 0.03
    mass: float = 0.2
    rgba: RGBA = (0.15, 0.45, 0.2, 1.0)

    @property
    def total_height(self) -> float:
        return self.height + self.neck_height

    def links(self) -> list[Link]:
        return [
            Link(
                "base",
                (
                    Shape("cylinder", (self.radius, self.height), (0, 0, self.height / 2), rgba=self.rgba),
                    Shape(
                        "cylinder",
                        (self.neck_radius, self.neck_height),
                        (0, 0, self.height + self.neck_height / 2),
                        rgba=(0.9, 0.9, 0.85, 1.0),
                    ),
                ),
                self.mass,
            )
        ]


@dataclass(frozen=True)
class VesselSpec:
    """An open vessel (bowl or mug): a polygonal ring wall of ``segments`` boxes on a round base.

    24 segments, shorter than a finger pad is wide, so that a vessel turning in the opening hand does not
    catch the pads on the corners between two boxes (BENCHMARKS.md, "LHT2* mended").

    ``handle`` adds a mug handle on the -y side.
    """

    outer_radius: float = 0.034
    height: float = 0.045
    wall: float = 0.006
    base: float = 0.008
    segments: int = 24
    handle: bool = False
    mass: float = 0.15
    rgba: RGBA = (0.9, 0.9, 0.88, 1.0)

    @property
    def inner_radius(self) -> float:
        return self.outer_radius - self.wall

    @property
    def wall_radius(self) -> float:
        """Radius (m) of the middle of the wall, where the wall's boxes stand and a wall grasp closes."""
        return self.outer_radius - self.wall / 2

    def links(self) -> list[Link]:
        r = self.wall_radius
        seg = 2 * self.outer_radius * math.tan(math.pi / self.segments) + 0.002
        wall_h = self.height - self.base
        shapes = [Shape("cylinder", (self.outer_radius, self.base), (0, 0, self.base / 2), rgba=self.rgba)]
        for k in range(self.segments):
            a = 2 * math.pi * k / self.segments
            shapes.append(
                Shape(
                    "box",
                    (self.wall, seg, wall_h),
                    (r * math.cos(a), r * math.sin(a), self.base + wall_h / 2),
                    (0, 0, a),
                    self.rgba,
                )
            )
        if self.handle:
            shapes.append(
                Shape(
                    "box",
                    (0.012, 0.025, self.height * 0.6),
                    (0, -(self.outer_radius + 0.0125), self.height * 0.5),
                    rgba=self.rgba,
                )
            )
        return [Link("base", tuple(shapes), self.mass)]

    def interior(self) -> Interior:
        half_h = (self.height - self.base) / 2
        return Interior(
            "base", (0, 0, self.base + half_h), (self.inner_radius, self.inner_radius, half_h), True
        )


@dataclass(frozen=True)
class BlockSpec:
    """A rectangular block standing on its bottom face (toothpaste tube, distractor cube)."""

    size: Vec3 = (0.022, 0.03, 0.095)
    mass: float = 0.05
    rgba: RGBA = (0.95, 0.95, 0.95, 1.0)

    def links(self) -> list[Link]:
        return [Link("base", (Shape("box", self.size, (0, 0, self.size[2] / 2), rgba=self.rgba),), self.mass)]


@dataclass(frozen=True)
class SpatulaSpec:
    """A spatula lying on the table along +x: a chunky handle and a thin blade at the +x end."""

    handle: Vec3 = (0.12, 0.022, 0.03)
    blade: Vec3 = (0.07, 0.06, 0.006)
    mass: float = 0.08
    rgba: RGBA = (0.2, 0.2, 0.25, 1.0)

    def links(self) -> list[Link]:
        hx = self.handle[0]
        return [
            Link(
                "base",
                (
                    Shape("box", self.handle, (0, 0, self.handle[2] / 2), rgba=self.rgba),
                    Shape(
                        "box",
                        self.blade,
                        (hx / 2 + self.blade[0] / 2, 0, self.blade[2] / 2),
                        rgba=(0.6, 0.6, 0.62, 1.0),
                    ),
                ),
                self.mass,
            )
        ]


@dataclass(frozen=True)
class BoxSpec:
    """A box with a hinged lid and a lip handle at the lid's front edge (paper LHT1: "close the box")."""

    size: Vec3 = (0.20, 0.20, 0.15)
    wall: float = 0.01
    lid: float = 0.01
    lip: Vec3 = (0.035, 0.10, 0.01)
    open_angle: float = 1.68
    """Upper limit (rad) of the lid's hinge, its stop and its fully open position: past vertical (pi/2), so
    that gravity holds an open lid on the stop."""
    lid_mass: float = 0.15
    rgba: RGBA = (0.72, 0.5, 0.3, 1.0)
    lid_rgba: RGBA = (0.62, 0.42, 0.25, 1.0)

    @property
    def hinge(self) -> Hinge:
        """The lid's hinge in the base frame: along y at the back (+x) top edge; the lid frame's origin."""
        return Hinge((self.size[0] / 2, 0.0, self.size[2]), (0.0, 1.0, 0.0))

    @property
    def lip_center(self) -> Vec3:
        """Centre (m, lid frame) of the lip handle, beyond the lid's front edge."""
        return (-self.size[0] - self.lip[0] / 2, 0.0, self.lid / 2)

    @property
    def lid_front_top(self) -> Vec3:
        """Middle (m, lid frame) of the front edge of the lid's top face."""
        return (-self.size[0], 0.0, self.lid)

    def links(self) -> list[Link]:
        dx, dy, dz = self.size
        w = self.wall
        base = (
            Shape("box", (dx, dy, w), (0, 0, w / 2), rgba=self.rgba),
            Shape("box", (w, dy, dz - w), (dx / 2 - w / 2, 0, w + (dz - w) / 2), rgba=self.rgba),
            Shape("box", (w, dy, dz - w), (-dx / 2 + w / 2, 0, w + (dz - w) / 2), rgba=self.rgba),
            Shape("box", (dx - 2 * w, w, dz - w), (0, dy / 2 - w / 2, w + (dz - w) / 2), rgba=self.rgba),
            Shape("box", (dx - 2 * w, w, dz - w), (0, -dy / 2 + w / 2, w + (dz - w) / 2), rgba=self.rgba),
        )
        lid = (
            Shape("box", (dx, dy, self.lid), (-dx / 2, 0, self.lid / 2), rgba=self.lid_rgba),
            Shape("box", self.lip, self.lip_center, rgba=(0.3, 0.2, 0.1, 1.0)),
        )
        return [Link("base", base, 0.0), Link("lid", lid, self.lid_mass)]

    def joints(self) -> list[Joint]:
        hinge = self.hinge
        return [Joint("lid_hinge", "revolute", "base", "lid", hinge.origin, hinge.axis, 0.0, self.open_angle)]

    def interior(self) -> Interior:
        dx, dy, dz = self.size
        w = self.wall
        return Interior("base", (0, 0, w + (dz - w) / 2), (dx / 2 - w, dy / 2 - w, (dz - w) / 2))


@dataclass(frozen=True)
class CabinetSpec:
    """A cabinet with a top and a bottom drawer on prismatic joints, each with a vertical bar handle."""

    width: float = 0.30
    depth: float = 0.30
    height: float = 0.31
    wall: float = 0.01
    drawer_height: float = 0.12
    travel: float = 0.22
    handle_standoff: float = 0.05
    handle_length: float = 0.08
    drawer_mass: float = 0.5
    rgba: RGBA = (0.85, 0.6, 0.35, 1.0)
    drawer_rgba: RGBA = (0.75, 0.75, 0.78, 1.0)

    drawer_links: tuple[tuple[str, str], ...] = (
        ("bottom drawer", "bottom_drawer"),
        ("top drawer", "top_drawer"),
    )
    """(condition name, URDF link name) of each drawer, bottom first: the order of the drawer joints, so
    the k-th drawer is PyBullet link k of the cabinet."""
    sheet: float = 0.008
    """Thickness (m) of a drawer's floor, sides and back."""

    def drawer_bottoms(self) -> tuple[float, float]:
        """Heights (m, cabinet frame) of the bottom faces of the bottom and the top drawer."""
        gap = (self.height - 3 * self.wall - 2 * self.drawer_height) / 2
        first = self.wall + gap / 2
        return first, first + self.drawer_height + self.wall + gap

    @property
    def drawer_size(self) -> Vec3:
        """Outer depth (x), width (y) and height (z) of a drawer's tray (m), front panel and handle apart."""
        return self.depth - self.wall - 0.02, self.width - 2 * self.wall - 0.01, self.drawer_height

    @property
    def handle_center(self) -> Vec3:
        """Centre (m, drawer link frame: centre of the front's bottom edge) of a drawer's vertical bar."""
        return (-self.handle_standoff, 0.0, self.drawer_height / 2)

    def _drawer(self, name: str) -> Link:
        d, w, h = self.drawer_size
        t = self.sheet
        c = self.drawer_rgba
        s = self.handle_standoff
        shapes = (
            Shape("box", (d, w, t), (d / 2, 0, t / 2), rgba=c),
            Shape("box", (d, t, h), (d / 2, w / 2 - t / 2, h / 2), rgba=c),
            Shape("box", (d, t, h), (d / 2, -w / 2 + t / 2, h / 2), rgba=c),
            Shape("box", (t, w, h), (d - t / 2, 0, h / 2), rgba=c),
            Shape("box", (0.015, self.width - 0.01, h + 0.015), (-0.0075, 0, h / 2), rgba=self.rgba),
            Shape("box", (0.02, 0.02, self.handle_length), self.handle_center, rgba=(0.15, 0.15, 0.15, 1.0)),
            Shape(
                "box",
                (s, 0.012, 0.012),
                (-s / 2, 0, h / 2 + self.handle_length / 2 - 0.006),
                rgba=(0.15, 0.15, 0.15, 1.0),
            ),
            Shape(
                "box",
                (s, 0.012, 0.012),
                (-s / 2, 0, h / 2 - self.handle_length / 2 + 0.006),
                rgba=(0.15, 0.15, 0.15, 1.0),
            ),
        )
        return Link(name, shapes, self.drawer_mass)

    def links(self) -> list[Link]:
        w, d, h, t = self.width, self.depth, self.height, self.wall
        z_bottom, z_top = self.drawer_bottoms()
        mid = z_bottom + self.drawer_height + (z_top - z_bottom - self.drawer_height) / 2
        carcass = (
            Shape("box", (d, w, t), (d / 2, 0, t / 2), rgba=self.rgba),
            Shape("box", (d, w, t), (d / 2, 0, h - t / 2), rgba=self.rgba),
            Shape("box", (d, w - 2 * t, t), (d / 2, 0, mid), rgba=self.rgba),
            Shape("box", (d, t, h), (d / 2, w / 2 - t / 2, h / 2), rgba=self.rgba),
            Shape("box", (d, t, h), (d / 2, -w / 2 + t / 2, h / 2), rgba=self.rgba),
            Shape("box", (t, w, h), (d - t / 2, 0, h / 2), rgba=self.rgba),
        )
        return [Link("carcass", carcass, 0.0), *(self._drawer(link) for _, link in self.drawer_links)]

    def joints(self) -> list[Joint]:
        return [
            Joint(
                f"{link.removesuffix('_drawer')}_slide",
                "prismatic",
                "carcass",
                link,
                (0.0, 0, z),
                (-1, 0, 0),
                0.0,
                self.travel,
            )
            for (_, link), z in zip(self.drawer_links, self.drawer_bottoms(), strict=True)
        ]

    def interiors(self) -> dict[str, Interior]:
        d, w, h = self.drawer_size
        t = self.sheet
        return {
            name: Interior(link, (d / 2, 0, t + (h - t) / 2), (d / 2 - t, w / 2 - t, (h - t) / 2))
            for name, link in self.drawer_links
        }


@dataclass(frozen=True)
class MicrowaveSpec:
    """A microwave oven with a door hinged on its right (-y) side; the handle is a fin standing on the
    door's top edge at its free end (``fin``: thickness x, length y, height z), pinched from above."""

    width: float = 0.30
    depth: float = 0.25
    height: float = 0.20
    wall: float = 0.01
    door: float = 0.015
    fin: Vec3 = (0.012, 0.05, 0.03)
    fin_inset: float = 0.01
    """Distance (m) from the fin's outer end to the door's free edge."""
    open_angle: float = 1.6
    door_mass: float = 0.3
    rgba: RGBA = (0.25, 0.25, 0.27, 1.0)

    def links(self) -> list[Link]:
        w, d, h, t = self.width, self.depth, self.height, self.wall
        shell = (
            Shape("box", (d, w, t), (d / 2, 0, t / 2), rgba=self.rgba),
            Shape("box", (d, w, t), (d / 2, 0, h - t / 2), rgba=self.rgba),
            Shape("box", (d, t, h), (d / 2, w / 2 - t / 2, h / 2), rgba=self.rgba),
            Shape("box", (d, t, h), (d / 2, -w / 2 + t / 2, h / 2), rgba=self.rgba),
            Shape("box", (t, w, h), (d - t / 2, 0, h / 2), rgba=self.rgba),
        )
        door = (
            Shape("box", (self.door, w, h), (-self.door / 2, w / 2, h / 2), rgba=(0.12, 0.12, 0.14, 1.0)),
            Shape("box", self.fin, self.fin_center, rgba=(0.7, 0.7, 0.7, 1.0)),
        )
        return [Link("shell", shell, 0.0), Link("door", door, self.door_mass)]

    @property
    def hinge(self) -> Hinge:
        """The door's hinge in the shell frame: vertical, at the front right (-y) corner; the door's frame
        sits on it."""
        return Hinge((0.0, -self.width / 2, 0.0), (0.0, 0.0, 1.0))

    @property
    def fin_center(self) -> Vec3:
        """Centre (m, door frame) of the fin handle on the door's top edge, near its free end."""
        _, fy, fz = self.fin
        return (-self.door / 2, self.width - fy / 2 - self.fin_inset, self.height + fz / 2)

    def joints(self) -> list[Joint]:
        hinge = self.hinge
        return [
            Joint("door_hinge", "revolute", "shell", "door", hinge.origin, hinge.axis, 0.0, self.open_angle)
        ]

    def interior(self) -> Interior:
        w, d, h, t = self.width, self.depth, self.height, self.wall
        return Interior("shell", (d / 2, 0, h / 2), (d / 2 - t, w / 2 - t, h / 2 - t))


@dataclass(frozen=True)
class SolidSpec:
    """A declared object of one primitive shape standing on its bottom face (issue 31, "objects a user
    brings"): ``shape`` ``box`` (``size`` = full extents x, y, z), ``cylinder`` (radius, height) or
    ``sphere`` (radius); metres, ``mass`` kg, ``rgba`` in [0, 1]. Origin at the centre of the bottom."""

    shape: Literal["box", "cylinder", "sphere"]
    size: tuple[float, ...]
    mass: float = 0.1
    rgba: RGBA = (0.6, 0.6, 0.6, 1.0)

    def links(self) -> list[Link]:
        if self.shape == "box":
            shape = Shape("box", self.size, (0, 0, self.size[2] / 2), rgba=self.rgba)
        elif self.shape == "cylinder":
            shape = Shape("cylinder", self.size, (0, 0, self.size[1] / 2), rgba=self.rgba)
        else:
            shape = Shape("sphere", self.size, (0, 0, self.size[0]), rgba=self.rgba)
        return [Link("base", (shape,), self.mass)]


@dataclass(frozen=True)
class MeshSpec:
    """A declared object from a file (issue 31): a URDF, loaded as it is scaled by ``scale``, or a Wavefront
    ``.obj`` mesh wrapped in a one-link URDF (the mesh scaled by ``scale`` as visual and collision shape;
    PyBullet takes a moving body's mesh as its convex hull), its inertia that of a solid box over the mesh's
    bounds.

    Attributes:
        path: absolute path of the ``.urdf`` or ``.obj`` file.
        scale: uniform scale of the file's geometry.
        mass: kg; None keeps the URDF's (an ``.obj`` gets 0.1 kg).
        rgba: colour in [0, 1]; None keeps the file's.
        rpy: roll, pitch, yaw (rad) that stand the file's geometry upright (pybullet_data's duck is modelled
            with y up: ``(pi/2, 0, 0)``); the scene turns the body by it and then by its yaw.

    The body's frame need not be at the bottom of its geometry: the scene places a file object by its
    bounding box (:meth:`taskcond.sim.scene.KitchenScene.place`).
    """

    path: str
    scale: float = 1.0
    mass: float | None = None
    rgba: RGBA | None = None
    rpy: Vec3 = (0.0, 0.0, 0.0)

    @property
    def is_urdf(self) -> bool:
        return self.path.lower().endswith(".urdf")

    def mesh_urdf(self, name: str) -> str:
        """URDF text of a ``.obj`` mesh (see the class doc)."""
        lo, hi = obj_bounds(self.path)
        lo, hi = lo * self.scale, hi * self.scale
        d = np.maximum(hi - lo, 1e-3)
        m = 0.1 if self.mass is None else self.mass
        com = _fmt(tuple((lo + hi) / 2))
        inertia = (
            m / 12 * (d[1] ** 2 + d[2] ** 2),
            m / 12 * (d[0] ** 2 + d[2] ** 2),
            m / 12 * (d[0] ** 2 + d[1] ** 2),
        )
        geometry = f'<mesh filename="{self.path}" scale="{_fmt((self.scale,) * 3)}"/>'
        rgba = _fmt(self.rgba or (0.7, 0.7, 0.7, 1.0))
        return (
            f'<?xml version="1.0"?>\n<robot name="{name}">\n<link name="base">\n'
            f'<inertial><origin xyz="{com}"/><mass value="{m:.6g}"/><inertia ixx="{inertia[0]:.6g}" '
            f'iyy="{inertia[1]:.6g}" izz="{inertia[2]:.6g}" ixy="0" ixz="0" iyz="0"/></inertial>\n'
            f'<visual><geometry>{geometry}</geometry><material name="m"><color rgba="{rgba}"/></material>'
            f"</visual>\n<collision><geometry>{geometry}</geometry></collision>\n</link>\n</robot>\n"
        )


def obj_bounds(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners (3,) of the vertices (``v x y z`` lines) of a Wavefront ``.obj`` file, in
    its units.

    Raises:
        ValueError: the file has no vertex.
    """
    rows = [
        [float(v) for v in line.split()[1:4]]
        for line in Path(path).read_text(encoding="utf-8", errors="replace").splitlines()
        if line.startswith("v ")
    ]
    if not rows:
        raise ValueError(f"{path} has no vertices ('v x y z' lines)")
    points = np.array(rows)
    return points.min(axis=0), points.max(axis=0)


ShapeClass = Literal["cylinder", "vessel", "box", "sphere", "flat", "mesh"]
"""The shape class of a free object (:func:`shape_class`): what the similarity of a demonstrated and an
undemonstrated object compares beside their sizes."""
ROUND_CLASSES: tuple[ShapeClass, ...] = ("cylinder", "vessel", "sphere")
"""Shape classes that look the same turned about their vertical axis: a grasp may come from any side."""


def shape_class(spec: object) -> ShapeClass:
    """The shape class of a free object's spec: a bottle or a can ``cylinder``, a bowl or mug ``vessel``,
    a block ``box``, the spatula ``flat``, a declared solid its shape, a file object ``mesh``."""
    if isinstance(spec, BottleSpec):
        return "cylinder"
    if isinstance(spec, VesselSpec):
        return "vessel"
    if isinstance(spec, BlockSpec):
        return "box"
    if isinstance(spec, SpatulaSpec):
        return "flat"
    if isinstance(spec, SolidSpec):
        return spec.shape
    return "mesh"


@dataclass(frozen=True)
class TableSpec:
    """The counter: a static slab whose top face is at world z = 0."""

    size: Vec3 = (1.3, 1.7, 0.05)
    center: tuple[float, float] = (0.35, 0.0)
    rgba: RGBA = (0.42, 0.42, 0.44, 1.0)

    def links(self) -> list[Link]:
        return [Link("base", (Shape("box", self.size, (0, 0, -self.size[2] / 2), rgba=self.rgba),), 0.0)]


AssetSpec = (
    BottleSpec
    | VesselSpec
    | BlockSpec
    | SpatulaSpec
    | SolidSpec
    | MeshSpec
    | BoxSpec
    | CabinetSpec
    | MicrowaveSpec
    | TableSpec
)


def interiors_of(name: str, spec: AssetSpec) -> dict[str, Interior]:
    """The container interiors of the asset ``name`` built from ``spec``: a drawer's by its condition name, a
    box's, microwave's or vessel's by ``name``; none for the rest."""
    if isinstance(spec, CabinetSpec):
        return spec.interiors()
    if isinstance(spec, BoxSpec | MicrowaveSpec | VesselSpec):
        return {name: spec.interior()}
    return {}


def build_asset(name: str, spec: AssetSpec) -> Asset:
    """Write the URDF of ``spec`` (cached by content) and return it with its container interiors; a URDF
    file object (:class:`MeshSpec`) is its own file."""
    if isinstance(spec, MeshSpec):
        return Asset(Path(spec.path) if spec.is_urdf else write_urdf(name, spec.mesh_urdf(name)))
    joints = spec.joints() if isinstance(spec, BoxSpec | CabinetSpec | MicrowaveSpec) else []
    path = write_urdf(name, urdf_text(name, spec.links(), joints))
    return Asset(path, interiors_of(name, spec))
