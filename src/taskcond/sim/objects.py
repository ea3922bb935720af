"""Objects a user brings, without a code change (issue 31): declared in a TOML or JSON file, like primitives
(:mod:`taskcond.primitives`), and kept in the scene exactly like the suite's objects.

A declaration (:func:`load_objects`) registers each object in :data:`taskcond.sim.scene.DECLARED`; from then
on every :class:`~taskcond.sim.scene.SceneConfig` of the process has it among its ``free_objects`` (spec and
nominal placement) and its ``roles``, and :func:`taskcond.sim.scene.scene_aliases` reads its aliases. So a
declared object is placed by ``--start random``, perceived (box, relations, grasp), named in the objects an
instruction may use and in the environment information the conditions see, like the bottle. The skill
library is learned in the suite's scene without it (:func:`taskcond.sim.scene.suite_config`); its skill is
the most similar demonstrated object's (:func:`taskcond.execution.skills.dissimilarity`).

The file::

    [[object]]                                # JSON: {"object": [{...}, ...]}
    name = "soup can"                         # letters, digits, '_', '-', spaces
    aliases = ["soup"]                        # other words for it
    shape = "cylinder"                        # box | cylinder | sphere | bottle | vessel | block
    size = [0.033, 0.11]                      # metres, see SIZES
    mass = 0.3                                # kg
    color = [0.8, 0.2, 0.1]                   # RGB or RGBA in [0, 1]
    roles = ["graspable"]                     # graspable | container (shape vessel) | surface | vessel
    place = [0.45, 0.05]                      # nominal x, y (m) of a task start; default a spare spot

    [[object]]
    name = "rubber duck"
    file = "pybullet_data:duck_vhacd.urdf"    # .urdf or .obj; relative to this file, or pybullet_data:
    scale = 0.7
    upright = [1.5708, 0.0, 0.0]              # roll, pitch, yaw (rad) that stand the file's model upright
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from typing import Any

from taskcond.conditions import ConditionError, normalize_name
from taskcond.primitives import read_declarations
from taskcond.sim.assets import (
    AssetSpec,
    BlockSpec,
    BottleSpec,
    MeshSpec,
    SolidSpec,
    VesselSpec,
)
from taskcond.sim.scene import (
    ALIASES,
    DECLARED,
    ROLES,
    SUITE_ROLES,
    DeclaredObject,
    Placement,
)

OBJECTS_ENV = "TASKCOND_OBJECTS"
"""Environment variable naming declaration files of user objects (several separated by the path separator,
``:`` on Linux), read by the command line like ``--objects``."""
SIZES: dict[str, tuple[str, ...]] = {
    "box": ("x", "y", "z"),
    "cylinder": ("radius", "height"),
    "sphere": ("radius",),
    "bottle": ("radius", "height", "neck radius", "neck height"),
    "vessel": ("outer radius", "height"),
    "block": ("x", "y", "z"),
}
"""Each shape's ``size`` entries in order (metres): a ``box``, ``cylinder`` or ``sphere`` is a plain solid
(:class:`~taskcond.sim.assets.SolidSpec`); ``bottle``, ``vessel`` (an open bowl, a container) and ``block``
are the suite's kinds (the bottle's, the bowl's and the toothpaste's specs)."""
FIELDS = ("name", "aliases", "shape", "size", "file", "scale", "upright", "mass", "color", "roles", "place")
SPARE_SPOTS: tuple[tuple[float, float], ...] = ((0.36, -0.45), (0.56, 0.08), (0.48, -0.32), (0.38, 0.08))
"""Nominal spots (x, y m) of declared objects without a ``place``, in declaration order: the spots of the
counter farthest from the suite's nominal layout, each chosen in turn (a 9 cm footprint keeps 8, 6, 4 and
2 cm from every object, drawer, lid and door, open or closed, and from the spots before it)."""
RESERVED = ("table", "cabinet", "robot", "kinova", "cloth", "position", "gripper", "kinova gripper")
"""Names of the scene that are not free objects but may appear in conditions."""
TABLE_AREA = ((0.0, 0.95), (-0.8, 0.8))
"""x and y ranges (m) a declared ``place`` must lie in: on the counter."""


class ObjectError(ValueError):
    """A declaration that cannot be used, one line naming the file and the entry."""


def _names_taken(skip: str | None = None) -> dict[str, str]:
    """Every name the scene already uses → what it is (the suite's objects, their aliases, the declared
    objects and their aliases but ``skip``'s)."""
    taken = {
        name: "an object of the scene" for name in (*SUITE_ROLES, *RESERVED, "top drawer", "bottom drawer")
    }
    taken |= {alias: f"an alias of {name!r}" for alias, name in ALIASES.items()}
    for d in DECLARED.values():
        if d.name != skip:
            taken[d.name] = f"declared in {d.source}"
            taken |= {a: f"an alias of the declared {d.name!r}" for a in d.aliases}
    return taken


def _numbers(value: Any, what: str, count: tuple[int, ...]) -> tuple[float, ...]:
    if (
        not isinstance(value, list)
        or len(value) not in count
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    ):
        n = " or ".join(map(str, count))
        raise ObjectError(f"{what} must be a list of {n} numbers, not {value!r}")
    values = tuple(float(v) for v in value)
    if not all(math.isfinite(v) for v in values):
        raise ObjectError(f"{what} must be finite, not {value!r}")
    return values


def _file(value: Any, base: Path) -> Path:
    """The file a declaration names: ``pybullet_data:NAME`` in PyBullet's data directory, else relative to
    the declaration file's directory."""
    if not isinstance(value, str) or not value:
        raise ObjectError(f"file must be a path, not {value!r}")
    if value.startswith("pybullet_data:"):
        import pybullet_data

        path = Path(pybullet_data.getDataPath()) / value.removeprefix("pybullet_data:")
    else:
        path = (base / value).resolve()
    if path.suffix.lower() not in (".urdf", ".obj"):
        raise ObjectError(f"file {value!r}: use a .urdf or .obj file")
    if not path.is_file():
        raise ObjectError(f"file {value!r} not found ({path})")
    return path


def _spec(entry: dict[str, Any], base: Path, rgba: tuple[float, float, float, float] | None) -> AssetSpec:
    """The asset of one declaration (see the module doc)."""
    has_shape, has_file = "shape" in entry, "file" in entry
    if has_shape == has_file:
        raise ObjectError("give either 'shape' (with 'size') or 'file', not both or neither")
    mass = entry.get("mass")
    if mass is not None and (not isinstance(mass, int | float) or isinstance(mass, bool) or not mass > 0):
        raise ObjectError(f"mass must be a positive number of kg, not {mass!r}")
    if has_file:
        for key in ("size",):
            if key in entry:
                raise ObjectError(f"'{key}' applies to a shape; a file object is sized by 'scale'")
        scale = entry.get("scale", 1.0)
        if not isinstance(scale, int | float) or isinstance(scale, bool) or not scale > 0:
            raise ObjectError(f"scale must be a positive number, not {scale!r}")
        upright = _numbers(entry.get("upright", [0, 0, 0]), "upright", (3,))
        path = _file(entry["file"], base)
        if path.suffix.lower() == ".obj":
            from taskcond.sim.assets import obj_bounds

            try:
                obj_bounds(path)
            except ValueError as exc:
                raise ObjectError(str(exc)) from None
        return MeshSpec(str(path), float(scale), None if mass is None else float(mass), rgba, upright)  # type: ignore[arg-type]
    for key in ("scale", "upright"):
        if key in entry:
            raise ObjectError(f"'{key}' applies to a file object, not to a shape")
    shape = entry["shape"]
    if shape not in SIZES:
        raise ObjectError(f"unknown shape {shape!r}; valid: {', '.join(SIZES)}")
    if "size" not in entry:
        raise ObjectError(f"shape {shape!r} needs 'size' = [{', '.join(SIZES[shape])}] in metres")
    size = _numbers(entry["size"], f"size of a {shape} ([{', '.join(SIZES[shape])}])", (len(SIZES[shape]),))
    if not all(v > 0 for v in size):
        raise ObjectError(f"size {list(size)} must be positive ([{', '.join(SIZES[shape])}], metres)")
    kw: dict[str, Any] = {} if mass is None else {"mass": float(mass)}
    if rgba is not None:
        kw["rgba"] = rgba
    if shape in ("box", "cylinder", "sphere"):
        return SolidSpec(shape, size, **kw)
    if shape == "bottle":
        if size[2] > size[0]:
            raise ObjectError(f"a bottle's neck radius {size[2]} must not exceed its radius {size[0]}")
        return BottleSpec(*size, **kw)
    if shape == "vessel":
        vessel = VesselSpec(size[0], size[1], **kw)
        if vessel.inner_radius <= 0 or vessel.height <= vessel.base:
            raise ObjectError(f"a vessel of size {list(size)} has no room inside (wall 6 mm, base 8 mm)")
        return vessel
    return BlockSpec(size, **kw)  # type: ignore[arg-type]


def _color(value: Any) -> tuple[float, float, float, float] | None:
    if value is None:
        return None
    rgba = _numbers(value, "color (RGB or RGBA in [0, 1])", (3, 4))
    if not all(0.0 <= v <= 1.0 for v in rgba):
        raise ObjectError(f"color {value!r} must lie in [0, 1]")
    return (*rgba, 1.0) if len(rgba) == 3 else rgba  # type: ignore[return-value]


def _declaration(entry: dict[str, Any], base: Path, spare: int, source: str) -> DeclaredObject:
    """One entry as a :class:`DeclaredObject` (not registered yet); ``spare``: index of the spare spot it
    gets without a ``place``."""
    unknown = sorted(set(entry) - set(FIELDS))
    if unknown:
        raise ObjectError(f"unknown key(s) {unknown}; valid: {', '.join(FIELDS)}")
    try:
        name = normalize_name(str(entry["name"]))
        aliases = entry.get("aliases", [])
        if not isinstance(aliases, list) or not all(isinstance(a, str) for a in aliases):
            raise ObjectError(f"aliases must be a list of strings, not {aliases!r}")
        aliases = tuple(dict.fromkeys(normalize_name(a) for a in aliases))
    except ConditionError as exc:
        raise ObjectError(str(exc)) from None
    taken = _names_taken(skip=name)
    for word in (name, *aliases):
        if word in taken:
            raise ObjectError(f"{word!r} is already {taken[word]}; choose another name")
    if name in aliases:
        raise ObjectError(f"{name!r} is its own alias")
    roles = entry.get("roles", ["graspable"])
    if not isinstance(roles, list) or not all(r in ROLES for r in roles):
        raise ObjectError(f"roles {roles!r}: use a list of {', '.join(ROLES)}")
    spec = _spec(entry, base, _color(entry.get("color")))
    if "container" in roles and not isinstance(spec, VesselSpec):
        raise ObjectError("role 'container' needs shape 'vessel' (an open vessel with an interior)")
    if "place" in entry:
        xy = _numbers(entry["place"], "place ([x, y] in metres)", (2,))
        (x0, x1), (y0, y1) = TABLE_AREA
        if not (x0 <= xy[0] <= x1 and y0 <= xy[1] <= y1):
            raise ObjectError(f"place {list(xy)} is off the counter (x in [{x0}, {x1}], y in [{y0}, {y1}])")
    elif spare < len(SPARE_SPOTS):
        xy = SPARE_SPOTS[spare]
    else:
        raise ObjectError(f"no spare spot left for it ({len(SPARE_SPOTS)} are taken); give it a 'place'")
    return DeclaredObject(name, aliases, spec, Placement(xy), frozenset(roles), source)  # type: ignore[arg-type]


def register_object(obj: DeclaredObject) -> DeclaredObject:
    """Add a declared object to the scene (:data:`DECLARED`); declaring the same object again is allowed.

    Raises:
        ObjectError: another object of that name is declared already.
    """
    reason = _redeclared(obj)
    if reason is not None:
        raise ObjectError(f"{obj.source}: {reason}")
    DECLARED[obj.name] = obj
    return obj


def _redeclared(obj: DeclaredObject) -> str | None:
    """Why ``obj`` cannot be declared over an object of its name already declared otherwise, or None."""
    old = DECLARED.get(obj.name)
    if old is None or (old.spec, old.placement, old.roles, old.aliases) == (
        obj.spec,
        obj.placement,
        obj.roles,
        obj.aliases,
    ):
        return None
    return f"{obj.name!r} is declared differently in {old.source}"


def unregister_object(name: str) -> None:
    """Forget a declared object (the suite's cannot be removed)."""
    if name not in DECLARED:
        raise ObjectError(f"{name!r} is not a declared object; declared: {', '.join(DECLARED) or 'none'}")
    del DECLARED[name]


_FILES: dict[str, str] = {}
"""Declaration file (resolved path) → ``<path>@<SHA-256 prefix>`` of its bytes and of the files it names."""


def load_objects(path: str | Path) -> list[DeclaredObject]:
    """Declare the objects of a TOML or JSON file (format in the module doc).

    Raises:
        ObjectError: an unreadable file or a bad declaration, in one line naming the file and the entry
            (number and name), what is wrong and what is valid; nothing of the file is declared then.
    """
    path = Path(path)
    read = read_declarations(path, "object", ObjectError)
    declared: list[DeclaredObject] = []
    own = {e.get("name") for e in read.entries if isinstance(e, dict)}  # declared again: keep their spots
    spare = sum(1 for d in DECLARED.values() if d.placement.xy in SPARE_SPOTS and d.name not in own)
    hashes = hashlib.sha256(read.raw)
    for k, entry in enumerate(read.entries, start=1):
        label = f"object {k}" + (
            f" ({entry['name']!r})" if isinstance(entry, dict) and "name" in entry else ""
        )
        if not isinstance(entry, dict) or "name" not in entry:
            raise ObjectError(f"{path}: {label} needs a 'name'")
        try:
            obj = _declaration(entry, path.resolve().parent, spare, f"{path} {label}")
            if obj.name in (d.name for d in declared):
                raise ObjectError(f"{obj.name!r} is declared twice in this file")
            clash = set((obj.name, *obj.aliases)) & {w for d in declared for w in (d.name, *d.aliases)}
            if clash:
                raise ObjectError(f"{sorted(clash)[0]!r} names another object of this file")
            if (reason := _redeclared(obj)) is not None:
                raise ObjectError(reason)
        except ObjectError as exc:
            raise ObjectError(f"{path}: {label}: {exc}") from None
        if "place" not in entry:
            spare += 1
        if isinstance(obj.spec, MeshSpec):
            hashes.update(Path(obj.spec.path).read_bytes())
        declared.append(obj)
    for obj in declared:
        register_object(obj)
    resolved = str(path.resolve())
    _FILES[resolved] = f"{resolved}@{hashes.hexdigest()[:12]}"
    return declared


def objects_files() -> list[str]:
    """``<path>@<SHA-256 prefix>`` of every declaration file loaded in this process (its bytes and those of
    the model files it names), sorted: what a result records of the objects it was made with."""
    return sorted(_FILES.values())


def loaded_files() -> list[str]:
    """The declaration files loaded in this process (resolved paths), for worker processes to load."""
    return sorted(_FILES)


def forget_objects() -> None:
    """Forget every declared object and declaration file (tests)."""
    DECLARED.clear()
    _FILES.clear()


__all__ = [
    "OBJECTS_ENV",
    "ObjectError",
    "forget_objects",
    "load_objects",
    "loaded_files",
    "objects_files",
    "register_object",
    "unregister_object",
]
