"""What each object of a kitchen is for (issue 31): graspable, container (with its inside's size and the part
that closes it), surface, fixed, vessel, and its size, all derived from the specs that build the assets
(:mod:`taskcond.sim.assets`) and from where :class:`~taskcond.sim.scene.SceneConfig` puts them.

The roles are the scene config's (:attr:`~taskcond.sim.scene.SceneConfig.roles`: the suite's
:data:`~taskcond.sim.scene.SUITE_ROLES` and each declared object's), so that a declared object enters
everything built on :func:`scene_roles` (the combination benchmark, :mod:`taskcond.combinations`) without a
code change. Whether an object is free (moved by the arm) or fixed
(standing furniture something can be put in front of) is where the scene config puts it, not a role.

Sizes are in metres, along the object's own x, y, z standing at yaw 0.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from itertools import product

import numpy as np
import pybullet as p
from scipy.spatial.transform import Rotation

from taskcond.relations import THRESHOLDS
from taskcond.sim.assets import (
    AssetSpec,
    BoxSpec,
    CabinetSpec,
    Link,
    MeshSpec,
    MicrowaveSpec,
    build_asset,
    interiors_of,
)
from taskcond.sim.scene import ARTICULATED, ROLES, TABLE, SceneConfig

Vec3 = tuple[float, float, float]

CLEARANCE = 0.005
"""Least gap (m) on each side between an object and the inside of a container it is put into."""


@dataclass(frozen=True)
class ObjectRoles:
    """What an object affords, as a user declares it (issue 31, item 4).

    Attributes:
        graspable: the hand can pick it up (a free object only).
        container: it has an inside something can be put into (its interior comes from the spec).
        surface: its top is flat and something can stand on it.
        vessel: it holds a liquid: it can be tilted to pour.
    """

    graspable: bool = False
    container: bool = False
    surface: bool = False
    vessel: bool = False

    @classmethod
    def of(cls, roles: Iterable[str]) -> ObjectRoles:
        """The flags of a set of :data:`~taskcond.sim.scene.ROLES` names."""
        names = set(roles)
        return cls(*(r in names for r in ROLES))


@dataclass(frozen=True)
class SceneObject:
    """One object of a kitchen and its roles.

    Attributes:
        name: the condition name (``"top drawer"``).
        roles: what it affords.
        free: the arm can move it (a free object of the scene config); else it stands fixed.
        size: its outer extents (m) standing at yaw 0 (a drawer: its tray).
        interior: a container's inside extents (m; a round inside: diameter, diameter, depth), else None.
        round_interior: the inside is a vertical cylinder (bowl, mug).
        part: what opens it (``"lid"``, ``"door"``; ``"drawer"`` for a drawer, which is its own part), or
            None when it has no joint.
        owner: the body it belongs to (a drawer: ``"cabinet"``; else its own name).
        side_opening: the inside is entered through a side (the microwave: a door hinged about a vertical
            axis), not from above like a drawer's, a lidded box's or a vessel's.
    """

    name: str
    roles: ObjectRoles
    free: bool
    size: Vec3
    interior: Vec3 | None = None
    round_interior: bool = False
    part: str | None = None
    owner: str = ""
    side_opening: bool = False

    @property
    def closable(self) -> bool:
        return self.part is not None


def link_extents(link: Link) -> Vec3:
    """Extents (m) of the axis-aligned box around a link's shapes, in the link's frame."""
    lo, hi = [float("inf")] * 3, [float("-inf")] * 3
    for shape in link.shapes:
        rot = Rotation.from_euler("xyz", shape.rpy)
        for signs in product((-1.0, 1.0), repeat=3):
            corner = rot.apply([s * h for s, h in zip(signs, shape.half_extents(), strict=True)])
            for k in range(3):
                lo[k] = min(lo[k], shape.xyz[k] + corner[k])
                hi[k] = max(hi[k], shape.xyz[k] + corner[k])
    return (float(hi[0] - lo[0]), float(hi[1] - lo[1]), float(hi[2] - lo[2]))


def file_extents(name: str, spec: MeshSpec) -> Vec3:
    """Extents (m) of a file object (:class:`~taskcond.sim.assets.MeshSpec`) standing upright, as the scene
    loads it (scaled, turned by its ``rpy``): the box PyBullet puts around it in a client of its own."""
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(
            str(build_asset(name.replace(" ", "_"), spec).path),
            baseOrientation=p.getQuaternionFromEuler(spec.rpy),
            globalScaling=spec.scale if spec.is_urdf else 1.0,
            physicsClientId=client,
        )
        boxes = [
            p.getAABB(body, link, physicsClientId=client)
            for link in range(-1, p.getNumJoints(body, physicsClientId=client))
        ]
    finally:
        p.disconnect(client)
    lo = [min(b[0][k] for b in boxes) for k in range(3)]
    hi = [max(b[1][k] for b in boxes) for k in range(3)]
    return (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])


def _part(spec: AssetSpec) -> str | None:
    """The moving part of a spec with one joint: the last word of its child link's name (``lid``)."""
    joints = spec.joints() if isinstance(spec, BoxSpec | MicrowaveSpec) else []
    return joints[0].child.split("_")[-1] if joints else None


def _side_opening(spec: AssetSpec) -> bool:
    """Whether a spec's inside opens at a side: its one joint is a hinge about a vertical axis (a door)."""
    joints = spec.joints() if isinstance(spec, BoxSpec | MicrowaveSpec) else []
    return bool(joints) and joints[0].kind == "revolute" and abs(joints[0].axis[2]) > 0.9


def scene_roles(config: SceneConfig | None = None) -> dict[str, SceneObject]:
    """Every object of the single-arm kitchen of ``config`` (default :class:`SceneConfig`) with its roles,
    in the scene's order: the table, the cabinet and its drawers, the box, the microwave, the free
    objects."""
    cfg = config or SceneConfig()
    fixed: dict[str, AssetSpec] = {
        TABLE: cfg.table,
        "cabinet": cfg.cabinet,
        "box": cfg.box,
        "microwave": cfg.microwave,
    }
    out: dict[str, SceneObject] = {}
    for name, spec in [*fixed.items(), *((n, s) for n, (s, _) in cfg.free_objects.items())]:
        free = name in cfg.free_objects
        roles = ObjectRoles.of(cfg.roles.get(name, ()))
        inner = interiors_of(name.replace(" ", "_"), spec).get(name.replace(" ", "_"))
        out[name] = SceneObject(
            name,
            roles,
            free,
            file_extents(name, spec) if isinstance(spec, MeshSpec) else link_extents(spec.links()[0]),
            None if inner is None or not roles.container else _inside(inner.half_extents),
            bool(inner and inner.round),
            _part(spec),
            name,
            _side_opening(spec),
        )
        if isinstance(spec, CabinetSpec):
            for drawer, inside in spec.interiors().items():
                out[drawer] = SceneObject(
                    drawer,
                    ObjectRoles.of(cfg.roles.get(drawer, ())),
                    False,
                    spec.drawer_size,
                    _inside(inside.half_extents),
                    False,
                    "drawer",
                    name,
                )
    missing = [n for n in ARTICULATED if not (n in out and out[n].closable)]
    if missing:
        raise ValueError(f"{missing[0]!r} has a joint but no part that opens it")
    return out


def part_aliases(objects: Iterable[SceneObject]) -> dict[str, str]:
    """Words that name an object by the part that opens it (alias → the object's name; issue 31, item 5:
    "its door" is the microwave's): "the microwave's door" and "the microwave door" for every object with a
    part, and the part alone ("the door", "its door") where only one of ``objects`` has that part, so the
    words have one meaning. A drawer is its own part: none."""
    parts = [o for o in objects if o.part not in (None, "drawer")]
    aliases: dict[str, str] = {}
    for obj in parts:
        aliases |= {f"{obj.name}'s {obj.part}": obj.name, f"{obj.name} {obj.part}": obj.name}
        if sum(other.part == obj.part for other in parts) == 1:
            aliases |= {f"its {obj.part}": obj.name, f"{obj.part}": obj.name}
    return aliases


def hand_enters(a: SceneObject, c: SceneObject) -> str | None:
    """Why the kitchen's hand cannot put A into container C where A fits it (:func:`fits_into`), or None.
    C must open from above (not :attr:`~SceneObject.side_opening`): every grasp of the kitchen holds its
    object from above, and the arm over a held object cannot pass under the top of a container entered
    through its side (the microwave's inside is 18 cm tall; the Panda's hand and wrist stand about 20 cm
    above its fingertips). A rule of this robot's skills, not of the two objects: a side grasp would lift
    it."""
    assert c.interior is not None
    if not c.side_opening:
        return None
    return (
        f"the {c.name} opens at its side, and every grasp here holds the {a.name} from above: the arm "
        f"over it cannot pass under the {c.name}'s top ({c.interior[2] * 100:.0f} cm inside)"
    )


def fits_into(a: SceneObject, c: SceneObject) -> str | None:
    """Why A cannot be put into container C (sizes from the specs), or None: A's footprint must fit C's
    inside with :data:`CLEARANCE` on each side; A must fit whole under a lid, door or drawer that closes
    over it, and at least the ``inside`` relation's fraction of its height must be inside an open vessel."""
    assert c.interior is not None
    ax, ay, az = a.size
    cx, cy, depth = c.interior
    if c.round_interior:
        reach = float(np.hypot(ax, ay)) / 2
        if reach > cx / 2 - CLEARANCE:
            return (
                f"the {a.name} ({reach * 200:.1f} cm across its corners) does not fit the {c.name}'s round "
                f"inside ({cx * 100:.1f} cm wide)"
            )
    elif (
        sorted((ax, ay))[0] > sorted((cx, cy))[0] - 2 * CLEARANCE or max(ax, ay) > max(cx, cy) - 2 * CLEARANCE
    ):
        return (
            f"the {a.name} ({ax * 100:.1f} x {ay * 100:.1f} cm) does not fit the {c.name}'s inside "
            f"({cx * 100:.1f} x {cy * 100:.1f} cm)"
        )
    if c.closable and az > depth:
        return (
            f"the {a.name} ({az * 100:.1f} cm tall) stands out of the {c.name} ({depth * 100:.1f} cm deep), "
            f"whose {c.part} could not close over it"
        )
    if az * THRESHOLDS.inside_fraction > depth:
        return f"less than half of the {a.name} ({az * 100:.1f} cm tall) would be inside the {c.name}"
    return None


def _inside(half: Vec3) -> Vec3:
    return (2 * half[0], 2 * half[1], 2 * half[2])


__all__ = [
    "CLEARANCE",
    "ObjectRoles",
    "SceneObject",
    "file_extents",
    "fits_into",
    "hand_enters",
    "link_extents",
    "part_aliases",
    "scene_roles",
]
