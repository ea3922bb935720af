"""What each object of a kitchen is for (issue 31): graspable, container (with its inside's size and the part
that closes it), surface, fixed, vessel, and its size, all derived from the specs that build the assets
(:mod:`taskcond.sim.assets`) and from where :class:`~taskcond.sim.scene.SceneConfig` puts them.

The one role table is :data:`SPEC_ROLES` (a spec type → its :class:`ObjectRoles`). A spec that carries its own
``roles`` attribute (an :class:`ObjectRoles`, as a user's declared object will) is read from that instead,
so that a declared object enters everything built on :func:`scene_roles` (the combination benchmark,
:mod:`taskcond.combinations`) without a code change. Whether an object is free (moved by the arm) or fixed
(standing furniture something can be put in front of) is where the scene config puts it, not a role.

Sizes are in metres, along the object's own x, y, z standing at yaw 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

from scipy.spatial.transform import Rotation

from taskcond.sim.assets import (
    AssetSpec,
    BlockSpec,
    BottleSpec,
    BoxSpec,
    CabinetSpec,
    Link,
    MicrowaveSpec,
    SpatulaSpec,
    TableSpec,
    VesselSpec,
    interiors_of,
)
from taskcond.sim.scene import ARTICULATED, TABLE, SceneConfig

Vec3 = tuple[float, float, float]


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


SPEC_ROLES: dict[type, ObjectRoles] = {
    BottleSpec: ObjectRoles(graspable=True, vessel=True),
    VesselSpec: ObjectRoles(graspable=True, container=True, vessel=True),
    BlockSpec: ObjectRoles(graspable=True),
    SpatulaSpec: ObjectRoles(graspable=True),
    BoxSpec: ObjectRoles(container=True, surface=True),
    CabinetSpec: ObjectRoles(surface=True),
    MicrowaveSpec: ObjectRoles(container=True, surface=True),
    TableSpec: ObjectRoles(surface=True),
}
"""The role table: the roles of the suite's spec types (a spec's own ``roles`` attribute wins)."""


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
    """

    name: str
    roles: ObjectRoles
    free: bool
    size: Vec3
    interior: Vec3 | None = None
    round_interior: bool = False
    part: str | None = None
    owner: str = ""

    @property
    def closable(self) -> bool:
        return self.part is not None


def roles_of(spec: AssetSpec) -> ObjectRoles:
    """``spec.roles`` when the spec declares it, else the roles of its type (:data:`SPEC_ROLES`).

    Raises:
        KeyError: a spec type of neither kind (name it in :data:`SPEC_ROLES`).
    """
    own = getattr(spec, "roles", None)
    return own if isinstance(own, ObjectRoles) else SPEC_ROLES[type(spec)]


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


def _part(spec: AssetSpec) -> str | None:
    """The moving part of a spec with one joint: the last word of its child link's name (``lid``)."""
    joints = spec.joints() if isinstance(spec, BoxSpec | MicrowaveSpec) else []
    return joints[0].child.split("_")[-1] if joints else None


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
        roles = roles_of(spec)
        inner = interiors_of(name.replace(" ", "_"), spec).get(name.replace(" ", "_"))
        out[name] = SceneObject(
            name,
            roles,
            free,
            link_extents(spec.links()[0]),
            None if inner is None or not roles.container else _inside(inner.half_extents),
            bool(inner and inner.round),
            _part(spec),
            name,
        )
        if isinstance(spec, CabinetSpec):
            for drawer, inside in spec.interiors().items():
                out[drawer] = SceneObject(
                    drawer,
                    ObjectRoles(container=True),
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


def _inside(half: Vec3) -> Vec3:
    return (2 * half[0], 2 * half[1], 2 * half[2])


__all__ = ["SPEC_ROLES", "ObjectRoles", "SceneObject", "link_extents", "roles_of", "scene_roles"]
