"""Objects: rigid unions of convex parts, procedural ones built from MuJoCo primitives.

An object is a rigid union of parts given in the object frame, whose origin is the centre of
the object's base and whose +z is "up" when it stands upright. A part is a :class:`Part`
primitive (box, cylinder, …) or a :class:`ConvexPart` (the convex hull of a vertex set: a
piece of a real object's convex decomposition, `symgrasp.objects`). The same parts give the
MuJoCo geoms (collision and rendering) and a trimesh surface (for sampling and ray casting),
so both always describe the same shape.

Families drawn by :func:`object_set`:

- training and test: ``box``, ``cylinder`` (cans), ``bottle`` (body + neck), ``l_shape``,
  ``sphere``, ``capsule``, ``disc``, ``ellipsoid``;
- test only: ``mug`` (cylinder + handle), ``t_shape`` (drill-like), ``cup`` (hollow: a ring
  of thin walls on a base).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import trimesh
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from symgrasp.folders import check_file_name
from symgrasp.names import PROCEDURAL_OBJECT_SETS
from symgrasp.sim.physics import OBJECT_TORSION_ROLL

PART_KINDS = ("box", "cylinder", "capsule", "sphere", "ellipsoid")


@dataclass(frozen=True)
class Part:
    """One MuJoCo primitive in the object frame.

    ``size`` follows MuJoCo: box half-extents (3), cylinder and capsule (radius, half-length
    along local z), sphere (radius,), ellipsoid semi-axes (3). Metres.
    """

    kind: str
    size: tuple[float, ...]
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)  # w, x, y, z

    def __post_init__(self) -> None:
        expected = {"box": 3, "cylinder": 2, "capsule": 2, "sphere": 1, "ellipsoid": 3}
        if self.kind not in expected:
            raise ValueError(f"kind must be one of {PART_KINDS}, got {self.kind!r}")
        if len(self.size) != expected[self.kind] or min(self.size) <= 0:
            raise ValueError(
                f"size of a {self.kind} must be {expected[self.kind]} positive numbers, "
                f"got {self.size}"
            )

    @property
    def volume(self) -> float:
        """Volume [m³]."""
        s = self.size
        if self.kind == "box":
            return 8.0 * s[0] * s[1] * s[2]
        if self.kind == "cylinder":
            return np.pi * s[0] ** 2 * 2.0 * s[1]
        if self.kind == "capsule":
            return np.pi * s[0] ** 2 * 2.0 * s[1] + 4.0 / 3.0 * np.pi * s[0] ** 3
        if self.kind == "sphere":
            return 4.0 / 3.0 * np.pi * s[0] ** 3
        return 4.0 / 3.0 * np.pi * s[0] * s[1] * s[2]

    def transform(self) -> np.ndarray:
        """``T_object_part``, 4×4."""
        T = np.eye(4)
        w, x, y, z = self.quat
        T[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
        T[:3, 3] = self.pos
        return T

    def mesh(self) -> trimesh.Trimesh:
        """Surface mesh in the object frame."""
        s = self.size
        if self.kind == "box":
            m = trimesh.creation.box(extents=2.0 * np.asarray(s))
        elif self.kind == "cylinder":
            m = trimesh.creation.cylinder(radius=s[0], height=2.0 * s[1], sections=32)
        elif self.kind == "capsule":
            m = trimesh.creation.capsule(height=2.0 * s[1], radius=s[0], count=[16, 16])
        elif self.kind == "sphere":
            m = trimesh.creation.icosphere(subdivisions=3, radius=s[0])
        else:
            m = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
            m.apply_scale(s)
        m.apply_transform(self.transform())
        return m

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether points (N, 3) in the object frame lie strictly inside this part, (N,)."""
        T = self.transform()
        p = (points - T[:3, 3]) @ T[:3, :3]
        s = np.asarray(self.size)
        eps = 1e-6
        if self.kind == "box":
            return np.all(np.abs(p) < s - eps, axis=1)
        if self.kind == "sphere":
            return np.linalg.norm(p, axis=1) < s[0] - eps
        if self.kind == "ellipsoid":
            return np.sum((p / s) ** 2, axis=1) < 1.0 - eps
        radial = np.linalg.norm(p[:, :2], axis=1)
        if self.kind == "cylinder":
            return (radial < s[0] - eps) & (np.abs(p[:, 2]) < s[1] - eps)
        axial = np.clip(p[:, 2], -s[1], s[1])
        return np.linalg.norm(p - np.c_[0 * axial, 0 * axial, axial], axis=1) < s[0] - eps


@dataclass(frozen=True, eq=False)
class ConvexPart:
    """The convex hull of ``vertices`` ((V, 3) array in the object frame [m], V ≥ 4, not all
    in one plane): one piece of a mesh object's convex decomposition. MuJoCo collides a mesh
    geom as its convex hull, so each piece is its own geom."""

    vertices: np.ndarray = field(repr=False)

    kind = "mesh"

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4 or not np.isfinite(v).all():
            raise ValueError(f"vertices must be a finite (V ≥ 4, 3) array, got shape {v.shape}")
        try:
            hull = ConvexHull(v)
        except Exception:  # qhull refuses flat and repeated point sets
            hull = None
        if hull is None or hull.volume <= 1e-12:
            raise ValueError("vertices span no volume (a flat or degenerate convex part)")
        v.setflags(write=False)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "_hull", hull)

    @property
    def volume(self) -> float:
        """Volume of the hull [m³]."""
        return float(self._hull.volume)

    def transform(self) -> np.ndarray:
        """``T_object_part``: the identity (vertices are in the object frame)."""
        return np.eye(4)

    def scaled(self, factor: float) -> ConvexPart:
        """This part scaled by ``factor`` about the object origin."""
        return ConvexPart(self.vertices * factor)

    @functools.cached_property
    def _mesh(self) -> trimesh.Trimesh:
        return trimesh.Trimesh(self.vertices, self._hull.simplices, process=True).convex_hull

    def mesh(self) -> trimesh.Trimesh:
        """Surface mesh of the hull in the object frame, faces wound outward (a copy of one
        computed once per part: every scene built from a part asks for it again)."""
        return self._mesh.copy()

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether points (N, 3) in the object frame lie strictly inside the hull, (N,)."""
        eq = self._hull.equations  # outward normal · x + offset ≤ 0 inside
        return np.all(points @ eq[:, :3].T + eq[:, 3] < -1e-6, axis=1)


@dataclass(frozen=True)
class ObjectSpec:
    """A rigid object: its parts, mass [kg], sliding friction coefficient and colour.

    ``name`` is one file name (`symgrasp.folders.check_file_name`): it names the object's files
    (its grasp database caches). ``family`` groups objects in the benchmark's per-family
    counts: the procedural family (``box``, ``mug``, …) or, for a mesh object, the object's
    own name."""

    name: str
    family: str
    parts: tuple[Part | ConvexPart, ...]
    mass: float
    friction: float
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)

    def __post_init__(self) -> None:
        check_file_name(self.name)
        if not self.parts:
            raise ValueError("parts must hold at least one Part")
        if self.mass <= 0:
            raise ValueError(f"mass must be positive [kg], got {self.mass}")
        if self.friction <= 0:
            raise ValueError(f"friction must be positive, got {self.friction}")

    def assets_xml(self, prefix: str) -> str:
        """The ``<mesh>`` assets of the object's convex parts, named ``{prefix}_{j}``."""
        return "".join(
            f'<mesh name="{prefix}_{j}" vertex="{" ".join(f"{x:.6f}" for x in p.vertices.ravel())}"/>'
            for j, p in enumerate(self.parts)
            if isinstance(p, ConvexPart)
        )

    def geoms_xml(self, prefix: str) -> str:
        """The object's ``<geom>`` elements (convex parts use `assets_xml`'s meshes of the same
        ``prefix``); the mass is shared out by volume."""
        total = sum(p.volume for p in self.parts)
        friction = f"{self.friction:.4f} {OBJECT_TORSION_ROLL[0]} {OBJECT_TORSION_ROLL[1]}"
        rgba = " ".join(f"{c:.3f}" for c in self.rgba)
        lines = []
        for j, part in enumerate(self.parts):
            mass = self.mass * part.volume / total
            if isinstance(part, ConvexPart):
                shape = f'class="mesh_object" type="mesh" mesh="{prefix}_{j}"'
            else:
                size = " ".join(f"{v:.5f}" for v in part.size)
                pos = " ".join(f"{v:.5f}" for v in part.pos)
                quat = " ".join(f"{v:.6f}" for v in part.quat)
                shape = f'class="object" type="{part.kind}" size="{size}" pos="{pos}" quat="{quat}"'
            lines.append(f'<geom {shape} mass="{mass:.6f}" friction="{friction}" rgba="{rgba}"/>')
        return "\n".join(lines)

    def scaled(self, factor: float) -> ObjectSpec:
        """This object scaled by ``factor`` about its origin, mass unchanged (as VGN's
        simulator scales its objects). Only for objects made of convex parts."""
        if not all(isinstance(p, ConvexPart) for p in self.parts):
            raise ValueError(f"only mesh objects scale; {self.name} has primitive parts")
        if not 0 < factor <= 10:
            raise ValueError(f"factor must be in (0, 10], got {factor}")
        parts = tuple(p.scaled(factor) for p in self.parts)
        return ObjectSpec(self.name, self.family, parts, self.mass, self.friction, self.rgba)

    def mesh(self) -> trimesh.Trimesh:
        """Surface mesh of the union (parts concatenated; inner faces stay inside)."""
        return trimesh.util.concatenate([p.mesh() for p in self.parts])

    def hull_points(self) -> np.ndarray:
        """Points (P, 3) in the object frame with the convex hull of `mesh`'s vertices: a convex
        part's own vertices, a primitive part's mesh vertices. Bounds and farthest distances
        read from them are `mesh`'s to the bit, without the hulls that a just-scaled object
        (every scene's) would first build."""
        return np.concatenate(
            [p.vertices if isinstance(p, ConvexPart) else p.mesh().vertices for p in self.parts]
        )

    def sample_surface(self, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Exactly ``n`` points on the outer surface and their outward normals, both (n, 3)
        (`surface_samples` until there are enough)."""
        if n <= 0:
            raise ValueError(f"n must be a positive number of points, got {n}")
        rng = np.random.default_rng(seed)
        points, normals = np.empty((0, 3)), np.empty((0, 3))
        while len(points) < n:
            p, normal = surface_samples(self, n, rng)
            points, normals = np.vstack([points, p]), np.vstack([normals, normal])
        return points[:n], normals[:n]

    def footprint(self) -> tuple[np.ndarray, float]:
        """Smallest-ish circle holding the upright object seen from above: its centre (2,) in
        the object frame (the bounding-box centre) and its radius [m]."""
        xy = self.hull_points()[:, :2]
        centre = (xy.min(axis=0) + xy.max(axis=0)) / 2
        return centre, float(np.max(np.linalg.norm(xy - centre, axis=1)))


def surface_samples(
    obj: ObjectSpec, n: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """About ``n`` points (P, 3) on the outer surface of ``obj`` and their outward normals.

    Each part's mesh is sampled in proportion to its area and points inside *another* part
    are dropped, so the samples lie on the surface of the union. (A point is not tested
    against its own part: on the faceted mesh of a sphere, capsule or ellipsoid nearly every
    sample lies inside the exact shape.)
    """
    meshes = [p.mesh() for p in obj.parts]
    areas = np.array([m.area for m in meshes])
    points, normals = [], []
    for i, (mesh, count) in enumerate(
        zip(meshes, rng.multinomial(n, areas / areas.sum()), strict=True)
    ):
        if count == 0:
            continue
        p, face = trimesh.sample.sample_surface(mesh, int(count), seed=int(rng.integers(2**31)))
        keep = np.ones(len(p), dtype=bool)
        for j, other in enumerate(obj.parts):
            if j != i:
                keep &= ~other.contains(p)
        points.append(p[keep])
        normals.append(mesh.face_normals[face[keep]])
    return np.concatenate(points), np.concatenate(normals)


def _quat_about(axis: str, angle: float) -> tuple[float, float, float, float]:
    x, y, z, w = Rotation.from_euler(axis, angle).as_quat()
    return (float(w), float(x), float(y), float(z))


_Y90 = _quat_about("y", np.pi / 2)  # turns a local-z cylinder/capsule to lie along x

# Each family maps a generator to parts, base at z = 0. Sizes keep at least one
# grasp width ≤ 7 cm so that both grippers (80 and 85 mm) can close on the object.
Family = Callable[[np.random.Generator], tuple[Part, ...]]


def _box(rng: np.random.Generator) -> tuple[Part, ...]:
    a, b = rng.uniform(0.015, 0.035), rng.uniform(0.015, 0.05)
    c = rng.uniform(0.015, 0.06)
    return (Part("box", (a, b, c), (0, 0, c)),)


def _cylinder(rng: np.random.Generator) -> tuple[Part, ...]:
    r, h = rng.uniform(0.02, 0.035), rng.uniform(0.03, 0.07)
    return (Part("cylinder", (r, h), (0, 0, h)),)


def _bottle(rng: np.random.Generator) -> tuple[Part, ...]:
    r, h = rng.uniform(0.022, 0.035), rng.uniform(0.04, 0.07)
    rn, hn = rng.uniform(0.008, 0.6 * r), rng.uniform(0.015, 0.03)
    return (
        Part("cylinder", (r, h), (0, 0, h)),
        Part("cylinder", (rn, hn), (0, 0, 2 * h + hn)),
    )


def _l_shape(rng: np.random.Generator) -> tuple[Part, ...]:
    t, w = rng.uniform(0.01, 0.02), rng.uniform(0.015, 0.03)
    a, b = rng.uniform(0.04, 0.07), rng.uniform(0.03, 0.06)
    return (
        Part("box", (a, w, t), (0, 0, t)),
        Part("box", (t, w, b), (a - t, 0, 2 * t + b)),
    )


def _sphere(rng: np.random.Generator) -> tuple[Part, ...]:
    r = rng.uniform(0.02, 0.035)
    return (Part("sphere", (r,), (0, 0, r)),)


def _capsule(rng: np.random.Generator) -> tuple[Part, ...]:
    r, h = rng.uniform(0.015, 0.03), rng.uniform(0.02, 0.06)
    return (Part("capsule", (r, h), (0, 0, r), _Y90),)


def _disc(rng: np.random.Generator) -> tuple[Part, ...]:
    r, h = rng.uniform(0.035, 0.06), rng.uniform(0.008, 0.015)
    return (Part("cylinder", (r, h), (0, 0, h)),)


def _ellipsoid(rng: np.random.Generator) -> tuple[Part, ...]:
    a, b, c = rng.uniform(0.025, 0.05), rng.uniform(0.02, 0.035), rng.uniform(0.02, 0.03)
    return (Part("ellipsoid", (a, b, c), (0, 0, c)),)


def _mug(rng: np.random.Generator) -> tuple[Part, ...]:
    r, h = rng.uniform(0.025, 0.035), rng.uniform(0.035, 0.05)
    t, reach = 0.005, rng.uniform(0.015, 0.025)
    span = 0.6 * h
    return (
        Part("cylinder", (r, h), (0, 0, h)),
        Part("capsule", (t, reach / 2), (r + reach / 2, 0, h + span), _Y90),
        Part("capsule", (t, reach / 2), (r + reach / 2, 0, h - span), _Y90),
        Part("capsule", (t, span), (r + reach, 0, h)),
    )


def _t_shape(rng: np.random.Generator) -> tuple[Part, ...]:
    rg, hg = rng.uniform(0.015, 0.022), rng.uniform(0.04, 0.06)
    rb, hb = rng.uniform(0.025, 0.035), rng.uniform(0.05, 0.08)
    return (
        Part("cylinder", (rg, hg), (0, 0, hg)),
        Part("cylinder", (rb, hb), (hb * 0.4, 0, 2 * hg + rb), _Y90),
    )


def _cup(rng: np.random.Generator) -> tuple[Part, ...]:
    r, h, t = rng.uniform(0.028, 0.038), rng.uniform(0.03, 0.05), 0.004
    n = 12
    half_chord = r * np.tan(np.pi / n) + 0.5 * t
    walls = tuple(
        Part(
            "box",
            (t / 2, half_chord, h),
            (r * np.cos(a), r * np.sin(a), h),
            _quat_about("z", a),
        )
        for a in np.arange(n) * 2 * np.pi / n
    )
    return (Part("cylinder", (r, t / 2), (0, 0, t / 2)), *walls)


FAMILIES: dict[str, Family] = {
    "box": _box,
    "cylinder": _cylinder,
    "bottle": _bottle,
    "l_shape": _l_shape,
    "sphere": _sphere,
    "capsule": _capsule,
    "disc": _disc,
    "ellipsoid": _ellipsoid,
    "mug": _mug,
    "t_shape": _t_shape,
    "cup": _cup,
}
TRAIN_FAMILIES = ("box", "cylinder", "bottle", "l_shape", "sphere", "capsule", "disc", "ellipsoid")
TEST_FAMILIES = (*TRAIN_FAMILIES, "mug", "t_shape", "cup")

LARGE_BOX_SIZE = (0.07, 0.2, 0.03)
"""The paper's precision case (Appx. D): 70 × 200 mm footprint, 30 mm thick, laid flat."""

THIN_BOX_TRAIN_SIZES = ((0.06, 0.18, 0.025), (0.065, 0.16, 0.035))
"""The thin boxes of ``thin-boxes-train`` [m], laid flat: 60 × 180 × 25 mm and 65 × 160 × 35
mm, thinner and thicker than `LARGE_BOX_SIZE` and of other footprints, so that a choice made on
training objects sees what thin flat objects need without seeing the test box."""

LARGE_BOX_DENSITY = 0.25 / np.prod(LARGE_BOX_SIZE)
"""[kg/m³] the large box's 0.25 kg over its volume, the thin training boxes' density too."""

_SET_STREAM = {name: i for i, name in enumerate(PROCEDURAL_OBJECT_SETS)}  # disjoint seed streams


def make_object(family: str, rng: np.random.Generator, name: str = "") -> ObjectSpec:
    """One random object of ``family`` with density 150–800 kg/m³ and friction 0.4–1.0."""
    if family not in FAMILIES:
        raise ValueError(f"family must be one of {sorted(FAMILIES)}, got {family!r}")
    parts = FAMILIES[family](rng)
    volume = sum(p.volume for p in parts)
    mass = float(np.clip(rng.uniform(150.0, 800.0) * volume, 0.02, 1.0))
    rgba = (*rng.uniform(0.15, 0.95, size=3).round(3), 1.0)
    return ObjectSpec(name or family, family, parts, mass, float(rng.uniform(0.4, 1.0)), rgba)


def large_box(name: str = "large_box") -> ObjectSpec:
    """The 30 × 70 × 200 mm box of the paper, 0.25 kg, friction 0.6, lying flat."""
    return flat_box(LARGE_BOX_SIZE, "large_box", name)


def flat_box(size: tuple[float, float, float], family: str, name: str) -> ObjectSpec:
    """A box of ``size`` (x, y, thickness) [m] lying flat, of the large box's density and
    friction (0.6)."""
    half = np.asarray(size) / 2
    part = Part("box", tuple(float(h) for h in half), (0.0, 0.0, float(half[2])))
    mass = float(LARGE_BOX_DENSITY * np.prod(size))
    return ObjectSpec(name, family, (part,), mass, 0.6, (0.8, 0.55, 0.25, 1.0))


def block(rng: np.random.Generator, name: str = "block") -> ObjectSpec:
    """A plain cuboid with 2–6 cm sides, 0.05–0.2 kg, friction 0.8."""
    half = rng.uniform(0.01, 0.03, size=3)
    part = Part("box", tuple(float(h) for h in half), (0.0, 0.0, float(half[2])))
    rgba = (*rng.uniform(0.15, 0.95, size=3).round(3), 1.0)
    return ObjectSpec(name, "block", (part,), float(rng.uniform(0.05, 0.2)), 0.8, rgba)


def object_set(name: str, n: int, seed: int = 0) -> list[ObjectSpec]:
    """``n`` objects drawn from the named set; the same (name, n, seed) gives the same list.

    Sets: ``household-train`` (training families), ``household-test`` (all families, with
    ``mug``, ``t_shape`` and ``cup`` only here; its own seed stream so no parameter draw is
    shared with training), ``large-box`` (``n`` copies of the paper's precision box),
    ``blocks`` (cuboids for debugging), ``thin-boxes-train`` (``n`` thin boxes of
    `THIN_BOX_TRAIN_SIZES`, each size drawn, for choices on training objects).
    """
    if name not in _SET_STREAM:
        raise ValueError(f"name must be one of {PROCEDURAL_OBJECT_SETS}, got {name!r}")
    if n < 0:
        raise ValueError(f"n must be a non-negative count, got {n}")
    if seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed}")
    rng = np.random.default_rng([seed, _SET_STREAM[name]])
    if name == "large-box":
        return [large_box(f"large_box_{i}") for i in range(n)]
    if name == "blocks":
        return [block(rng, f"block_{i}") for i in range(n)]
    if name == "thin-boxes-train":
        sizes = rng.choice(len(THIN_BOX_TRAIN_SIZES), size=n)
        return [flat_box(THIN_BOX_TRAIN_SIZES[k], "thin_box", f"thin_box_{i}")
                for i, k in enumerate(sizes)]  # fmt: skip
    families = TRAIN_FAMILIES if name == "household-train" else TEST_FAMILIES
    chosen = rng.choice(len(families), size=n)
    return [make_object(families[k], rng, f"{families[k]}_{i}") for i, k in enumerate(chosen)]
