"""The cloth of the task suite (paper §IV: "soft object manipulation such as grasp the cloth", PT6, LHT4):
a PyBullet mass-spring soft body built from a generated square grid mesh, its state read back from the
simulation mesh, grasps held by soft-body anchors, and the fold measure.

Frames and units: metres, world frame, z up. The cloth is generated flat in the xy-plane; node ``(i, j)``
(``i`` along the cloth's local x, ``j`` along its local y, both ``0 .. n - 1``) sits at rest at
``origin + (i, j) * spacing`` in the cloth's frame, whose origin is the centre of the cloth. The grid's
nodes are stored row-major: node index ``k = i * n + j``.

A soft body lives only in PyBullet's deformable world, which must be requested by
``p.resetSimulation(p.RESET_USE_DEFORMABLE_WORLD)`` before anything is loaded into the client (see
:class:`taskcond.sim.scene.KitchenScene`).

Grasping (:class:`ClothGrips`): PyBullet's soft-rigid contact does not hold a thin cloth between two
rigid pads (squeezed between them, the nodes are shot away), so a closed grasp is represented by soft-body
anchors. An anchor fixes a node to a finger link, and is created only while the gripper is commanded closed,
its pads are at most :attr:`ClothSpec.pinch_opening` apart (the fingers have actually closed on something
thin) and the node lies in the box swept between the two pads (:func:`nodes_between_fingers`). Opening the
gripper removes the anchors. Rigid objects are never anchored: they stay grasped by friction.

The finger links collide with the cloth (:attr:`ClothSpec.pad_contact`), except those of a gripper with
cloth nodes between its pads (the box between them, no wider than the pads, reaching
:attr:`ClothSpec.pad_margin` beyond the fingertips) or holding anchors: these pass through the cloth, so
that closing on the cloth, holding it and letting go do not squeeze nodes between the pads (measured with
the pads colliding throughout: nodes shot 15 mm in one control step as the pads closed, 41 mm when they
opened, and the rising fingers dragged the folded layer up, failing the fold), and collide again once no
node is within ``pad_margin`` of the pads.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field

import numpy as np
import pybullet as p

from taskcond.sim.assets import asset_dir


@dataclass(frozen=True)
class ClothSpec:
    """A square cloth.

    Attributes:
        size: edge length (m).
        resolution: nodes per edge (``n``); ``n * n`` nodes, ``2 (n - 1)^2`` triangles.
        mass: total mass (kg).
        elastic_stiffness, damping_stiffness, bending_stiffness: PyBullet mass-spring parameters.
        friction: soft-rigid friction coefficient.
        collision_margin: soft-body collision margin (m); the cloth rests this far above a surface.
        self_collision: PyBullet soft self-collision (the folded layers do not pass through each other).
        rgba: colour.
        pinch_opening: largest opening (m) between the pads at which a closed gripper counts as closed on
            the cloth (the cloth is thinner than this).
        pad_margin: metres by which the box between the pads is grown for anchoring (the nodes lie at the
            cloth's mid-surface, the fingertips stop above the table). 20 mm: the fold's grasps catch the
            cloth with the fingertips 0-16 mm above the table (12 mm: 0-8 mm, too narrow a window for
            the executor's goals, which move with the perceived cloth's height, σ = 5 mm).
        max_anchors: anchors per gripper (the nodes nearest the grasp point).
        pad_contact: the finger links collide with the cloth unless cloth nodes lie between the pads (see
            the module docstring); ``False``: they never do.
        substeps: physics sub-steps per 240 Hz step of a scene with the cloth
            (``setPhysicsEngineParameter(numSubSteps=...)``): a rigid object resting on the cloth is stable
            only from 2 sub-steps (see :func:`taskcond.sim.scene.KitchenScene`).
    """

    size: float = 0.26
    resolution: int = 15
    mass: float = 0.1
    elastic_stiffness: float = 40.0
    damping_stiffness: float = 0.1
    bending_stiffness: float = 2.0
    friction: float = 4.0
    collision_margin: float = 0.004
    self_collision: bool = True
    rgba: tuple[float, float, float, float] = (0.25, 0.55, 0.85, 1.0)
    pinch_opening: float = 0.02
    pad_margin: float = 0.02
    max_anchors: int = 3
    pad_contact: bool = True
    substeps: int = 2

    def __post_init__(self) -> None:
        if self.resolution < 3:
            raise ValueError(f"cloth resolution must be at least 3 nodes per edge, not {self.resolution}")
        if self.size <= 0 or self.mass <= 0:
            raise ValueError(f"cloth size and mass must be positive, not {self.size} m, {self.mass} kg")
        if self.substeps < 1:
            raise ValueError(f"cloth substeps must be at least 1, not {self.substeps}")

    @property
    def spacing(self) -> float:
        """Rest distance (m) between neighbouring nodes."""
        return self.size / (self.resolution - 1)

    def rest_nodes(self) -> np.ndarray:
        """(n*n, 2) node positions (m) in the flat cloth's frame (centre at the origin), row-major."""
        n = self.resolution
        axis = (np.arange(n) - (n - 1) / 2) * self.spacing
        ii, jj = np.meshgrid(axis, axis, indexing="ij")
        return np.stack([ii.ravel(), jj.ravel()], axis=1)

    def triangles(self) -> np.ndarray:
        """(2 (n-1)^2, 3) node indices of the mesh's triangles, counter-clockwise seen from +z."""
        n = self.resolution
        i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
        a = (i * n + j).ravel()
        b, c, d = a + n, a + n + 1, a + 1
        return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])

    def edge(self, side: str) -> np.ndarray:
        """Node indices (n,) of one edge, ordered by the other coordinate: ``"-x"``, ``"+x"``, ``"-y"``,
        ``"+y"`` (local frame)."""
        n = self.resolution
        grid = np.arange(n * n).reshape(n, n)
        edges = {"-x": grid[0], "+x": grid[-1], "-y": grid[:, 0], "+y": grid[:, -1]}
        if side not in edges:
            raise ValueError(f"unknown cloth edge {side!r}; valid: {', '.join(edges)}")
        return edges[side]


def cloth_obj_path(spec: ClothSpec) -> str:
    """Write the flat grid mesh of ``spec`` as a Wavefront OBJ once (content-hashed, atomically) into the
    asset cache and return its path. Vertices in metres, cloth frame, z = 0."""
    nodes = spec.rest_nodes()
    lines = ["# taskcond cloth grid"]
    lines += [f"v {x:.6f} {y:.6f} 0.000000" for x, y in nodes]
    lines += [f"vt {(x / spec.size) + 0.5:.6f} {(y / spec.size) + 0.5:.6f}" for x, y in nodes]
    lines += ["vn 0 0 1"]
    lines += [f"f {a + 1}/{a + 1}/1 {b + 1}/{b + 1}/1 {c + 1}/{c + 1}/1" for a, b, c in spec.triangles()]
    text = "\n".join(lines) + "\n"
    digest = hashlib.sha1(text.encode()).hexdigest()[:16]
    path = asset_dir() / f"cloth-{digest}.obj"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)
    return str(path)


_SELF_COLLIDING_LOADED = [0]


def self_colliding_loaded() -> int:
    """How many self-colliding cloths this process has loaded (:func:`load_cloth`): after the first, a
    cloth's simulation depends on what the earlier ones did
    (:attr:`~taskcond.sim.scene.SceneConfig.repeatable_in_process`)."""
    return _SELF_COLLIDING_LOADED[0]


def load_cloth(client: int, spec: ClothSpec, center: tuple[float, float, float], yaw: float = 0.0) -> int:
    """Load the cloth as a soft body, flat, centred at ``center`` (3,) m, turned ``yaw`` rad about z.

    The client must be a deformable world (see the module docstring). Returns the body id.
    """
    _SELF_COLLIDING_LOADED[0] += int(spec.self_collision)
    body = p.loadSoftBody(
        cloth_obj_path(spec),
        basePosition=list(center),
        baseOrientation=p.getQuaternionFromEuler((0.0, 0.0, yaw)),
        scale=1.0,
        mass=spec.mass,
        useNeoHookean=0,
        useBendingSprings=1,
        useMassSpring=1,
        springElasticStiffness=spec.elastic_stiffness,
        springDampingStiffness=spec.damping_stiffness,
        springDampingAllDirections=1,
        springBendingStiffness=spec.bending_stiffness,
        useSelfCollision=int(spec.self_collision),
        frictionCoeff=spec.friction,
        useFaceContact=1,
        collisionMargin=spec.collision_margin,
        physicsClientId=client,
    )
    p.changeVisualShape(
        body, -1, rgbaColor=list(spec.rgba), flags=p.VISUAL_SHAPE_DOUBLE_SIDED, physicsClientId=client
    )
    return body


def cloth_nodes(client: int, body: int) -> np.ndarray:
    """(n*n, 3) world positions (m) of the cloth's simulation-mesh nodes, in the order of the grid."""
    _, vertices = p.getMeshData(body, -1, flags=p.MESH_DATA_SIMULATION_MESH, physicsClientId=client)
    return np.asarray(vertices, dtype=float)


# ------------------------------------------------------------------------------------------------- grasp
@dataclass(frozen=True)
class FingerFrame:
    """Where a parallel gripper's pads are: ``center`` (3,) midpoint between the two finger links,
    ``closing`` (3,) unit axis from one finger to the other, ``approach`` (3,) unit axis pointing out of the
    hand (towards the fingertips), ``half_opening`` (m), ``pad_half_width`` and ``pad_half_length`` (m): the
    pads' half extents across the closing axis, horizontally and along the approach axis, and
    ``pad_thickness`` (m): a finger link's extent along the closing axis."""

    center: np.ndarray
    closing: np.ndarray
    approach: np.ndarray
    half_opening: float
    pad_half_width: float
    pad_half_length: float
    pad_thickness: float


def finger_frame(client: int, body: int, finger_links: tuple[int, int], ee_link: int) -> FingerFrame:
    """The pads of a gripper, from the world AABBs and link frames of its finger links and its
    end-effector link (works for the Franka and the Kinova: both have the approach axis along the
    end-effector link's z)."""
    states = [
        p.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)
        for link in finger_links
    ]
    a, b = np.array(states[0][0]), np.array(states[1][0])  # link centres of mass (pad centres)
    ee = p.getLinkState(body, ee_link, computeForwardKinematics=True, physicsClientId=client)
    rot = np.array(p.getMatrixFromQuaternion(ee[5])).reshape(3, 3)
    approach = rot[:, 2]
    closing = b - a
    distance = float(np.linalg.norm(closing))
    closing = closing / distance if distance > 1e-9 else rot[:, 1]
    lo, hi = np.array(p.getAABB(body, finger_links[0], physicsClientId=client))
    extent = hi - lo
    across = np.cross(approach, closing)
    return FingerFrame(
        center=(a + b) / 2,
        closing=closing,
        approach=approach,
        half_opening=distance / 2,
        pad_half_width=float(abs(across) @ extent) / 2,
        pad_half_length=float(abs(approach) @ extent) / 2,
        pad_thickness=float(abs(closing) @ extent),
    )


def nodes_between_fingers(
    nodes: np.ndarray,
    frame: FingerFrame,
    margin: float,
    closing_margin: float = 0.0,
    across_margin: float | None = None,
) -> np.ndarray:
    """Indices of the ``nodes`` (k, 3) lying in the box between the two pads, grown by ``margin`` m along
    the approach axis, by ``across_margin`` m (default ``margin``) across it and by ``closing_margin`` m
    along the closing axis (0: a node must be between the fingers)."""
    rel = nodes - frame.center
    across = np.cross(frame.approach, frame.closing)
    widen = margin if across_margin is None else across_margin
    inside = (
        (np.abs(rel @ frame.closing) <= frame.half_opening + closing_margin)
        & (np.abs(rel @ across) <= frame.pad_half_width + widen)
        & (np.abs(rel @ frame.approach) <= frame.pad_half_length + margin)
    )
    return np.flatnonzero(inside)


@dataclass(frozen=True)
class GripperHandle:
    """What :class:`ClothGrips` needs of one gripper: its name, arm body, finger links, end-effector link,
    and callables telling whether it is commanded closed and its current pad opening (m)."""

    name: str
    body: int
    finger_links: tuple[int, int]
    ee_link: int
    closed: object  # Callable[[], bool]
    opening: object  # Callable[[], float]


@dataclass
class ClothGrips:
    """Soft-body anchors standing in for the grips of the grippers on the cloth, and the finger links'
    collisions with it (see the module docstring).

    Call :meth:`update` after every control step and :meth:`reset_contacts` after the cloth is reloaded;
    :attr:`anchors` maps a gripper name to its anchor constraint ids, :attr:`nodes` to the anchored node
    indices, and :attr:`passing` holds the names of the grippers whose finger links pass through the cloth.
    """

    client: int
    cloth: int
    spec: ClothSpec
    grippers: list[GripperHandle]
    anchors: dict[str, list[int]] = field(default_factory=dict)
    nodes: dict[str, list[int]] = field(default_factory=dict)
    passing: set[str] = field(default_factory=set)

    def __post_init__(self) -> None:
        self.reset_contacts()

    def reset_contacts(self) -> None:
        """Let every finger link collide with the (re)loaded cloth, or none with ``pad_contact`` off."""
        self.passing = set()
        for g in self.grippers:
            self._pass_through(g, not self.spec.pad_contact, force=True)

    def _pass_through(self, g: GripperHandle, passing: bool, force: bool = False) -> None:
        """Turn the collisions between the cloth and the finger links of ``g`` off (``passing``) or on."""
        if not force and passing == (g.name in self.passing):
            return
        for link in g.finger_links:
            p.setCollisionFilterPair(
                self.cloth, g.body, -1, link, int(not passing), physicsClientId=self.client
            )
        if passing:
            self.passing.add(g.name)
        else:
            self.passing.discard(g.name)

    def update(self) -> None:
        """Anchor the cloth to every gripper closed on it; release every gripper that opened; with
        ``pad_contact``, let the finger links of a gripper pass through the cloth from when nodes lie between
        its pads until it holds no anchor and no node lies within ``pad_margin`` of its pads."""
        positions = cloth_nodes(self.client, self.cloth)
        for g in self.grippers:
            frame = finger_frame(self.client, g.body, g.finger_links, g.ee_link)
            if not g.closed():  # type: ignore[operator]
                self.release(g.name)
            elif not self.anchors.get(g.name) and float(g.opening()) <= self.spec.pinch_opening:  # type: ignore[operator]
                self._anchor(g, positions, frame)
            if not self.spec.pad_contact:
                continue
            if self.holding(g.name):
                passing = True
            elif g.name in self.passing:
                margin = self.spec.pad_margin
                near = nodes_between_fingers(positions, frame, margin, frame.pad_thickness + margin)
                passing = near.size > 0
            else:
                between = nodes_between_fingers(positions, frame, self.spec.pad_margin)
                passing = bool(g.closed()) and between.size > 0  # type: ignore[operator]
            self._pass_through(g, passing)

    def _anchor(self, g: GripperHandle, positions: np.ndarray, frame: FingerFrame) -> None:
        """Anchor the nodes between the closed pads of ``g`` (at most :attr:`ClothSpec.max_anchors`, the
        nearest to the pads' centre) to its first finger link."""
        found = nodes_between_fingers(positions, frame, self.spec.pad_margin)
        if found.size > 0:
            order = np.argsort(np.linalg.norm(positions[found] - frame.center, axis=1))
            chosen = found[order[: self.spec.max_anchors]]
            self.anchors[g.name] = [
                p.createSoftBodyAnchor(
                    self.cloth, int(k), g.body, g.finger_links[0], physicsClientId=self.client
                )
                for k in chosen
            ]
            self.nodes[g.name] = [int(k) for k in chosen]

    def release(self, name: str) -> None:
        """Remove the anchors of gripper ``name``."""
        for anchor in self.anchors.pop(name, []):
            p.removeConstraint(anchor, physicsClientId=self.client)
        self.nodes.pop(name, None)

    def release_all(self) -> None:
        for name in list(self.anchors):
            self.release(name)

    def holding(self, name: str) -> bool:
        """Whether gripper ``name`` holds the cloth (has anchors on it)."""
        return bool(self.anchors.get(name))


# -------------------------------------------------------------------------------------------------- fold
@dataclass(frozen=True)
class FoldMeasure:
    """How well a cloth is folded in half, measured on its simulation mesh.

    Attributes:
        double_fraction: area of the table covered by at least two layers of cloth (rasterized projection
            onto the xy-plane), divided by half the cloth's area: 1 for a perfect fold in half, 0 flat.
        edge_distance: mean distance (m) between the nodes of the moved edge and the nodes of the opposite
            edge they were laid onto (matched by position along the edge).
        edge_offset: the same in the xy-plane (m): the moved edge's horizontal miss, whatever the height of
            what lies between the layers.
        max_height: highest node above the table (m).
    """

    double_fraction: float
    edge_distance: float
    edge_offset: float
    max_height: float


def covered_layers(nodes: np.ndarray, triangles: np.ndarray, cell: float) -> tuple[np.ndarray, float]:
    """Number of cloth layers over each cell of an xy raster of pitch ``cell`` m spanning the cloth's
    projection: counts (ny, nx) of the triangles whose xy projection contains the cell centre, and the cell
    area (m²). Degenerate (edge-on) triangles are skipped; a centre counts for a triangle only strictly
    inside it, so a flat layer counts once."""
    xy = nodes[:, :2]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    cell = max(cell, float((hi - lo).max()) / 400)  # a torn-apart cloth: at most 400 × 400 cells
    # Cell centres are shifted off the half-cell grid by an odd fraction, so that on a regular mesh they do
    # not fall on the triangles' shared edges (where the strict test below would miss both triangles).
    # Different shifts along x and y keep them off the diagonals too.
    xs = np.arange(lo[0] + cell * 0.5137, hi[0], cell)
    ys = np.arange(lo[1] + cell * 0.5291, hi[1], cell)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)  # (m, 2)
    a, b, c = xy[triangles[:, 0]], xy[triangles[:, 1]], xy[triangles[:, 2]]  # (t, 2)
    v0, v1 = b - a, c - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    keep = np.abs(det) > 1e-12
    a, v0, v1, det = a[keep], v0[keep], v1[keep], det[keep]
    rel = pts[:, None, :] - a[None]  # (m, t, 2)
    u = (rel[..., 0] * v1[:, 1] - rel[..., 1] * v1[:, 0]) / det
    v = (v0[:, 0] * rel[..., 1] - v0[:, 1] * rel[..., 0]) / det
    inside = (u > 0) & (v > 0) & (u + v < 1)
    return inside.sum(axis=1).reshape(gy.shape), cell * cell


def fold_measure(
    nodes: np.ndarray, spec: ClothSpec, moved: str, onto: str, cell: float = 0.005
) -> FoldMeasure:
    """Measure a fold that laid edge ``moved`` onto edge ``onto`` (sides as in :meth:`ClothSpec.edge`).

    Args:
        nodes: (n*n, 3) world node positions (m), from :func:`cloth_nodes`.
        spec: the cloth.
        moved, onto: the edges.
        cell: raster pitch (m) of the coverage count.
    """
    counts, area = covered_layers(nodes, spec.triangles(), cell)
    double = float((counts >= 2).sum() * area) / (spec.size**2 / 2)
    a, b = nodes[spec.edge(moved)], nodes[spec.edge(onto)]
    return FoldMeasure(
        double_fraction=double,
        edge_distance=float(np.linalg.norm(a - b, axis=1).mean()),
        edge_offset=float(np.linalg.norm((a - b)[:, :2], axis=1).mean()),
        max_height=float(nodes[:, 2].max()),
    )


__all__ = [
    "ClothGrips",
    "ClothSpec",
    "FingerFrame",
    "FoldMeasure",
    "GripperHandle",
    "cloth_nodes",
    "cloth_obj_path",
    "covered_layers",
    "finger_frame",
    "fold_measure",
    "load_cloth",
    "nodes_between_fingers",
]
