"""The workspace found by itself: the table plane fitted in a depth image, the workspace cube
placed on it; and, where the table's place is known, the depth scale that puts it there.

A trained detector knows one geometry (`symgrasp.workspace`): the 30 cm cube with the table
top `TABLE_HEIGHT` above its floor and gravity along −z. `fit_table` finds the table in the
camera's own frame and returns the pose of that cube, so that no world frame has to be set up
by hand:

1. **Planes** (RANSAC, Fischler & Bolles, CACM 1981): planes through 3 random back-projected
   points, the one with the most points within ``threshold`` wins, refitted by least squares
   (the smallest principal axis of its inliers); its points (within `MIN_HEIGHT`) are set aside
   and the next plane is sought, up to `MAX_PLANES` while each holds `MIN_PLANE_SHARE` of the
   points. A normal points towards the camera, which sees the table from above, or along
   ``up`` (the world's up in the camera frame, which a robot knows from its kinematics).
2. **The table**: of the planes within ``max_tilt`` of ``up`` (without it: of the largest
   plane) with the camera above them, the lowest of those within `MAX_HEIGHT` of the highest:
   objects stand on the table and the tops of large ones lie less than the workspace's height
   above it, a floor seen past its edge lies farther below. None within ``max_tilt``: refused.
   The fit says how sure it is (its share of the points, the competing planes) and warns
   (`TableWarning`) when it doubts: the plane holds less than `MIN_TABLE_SHARE` of the points
   off the planes below it (no dominant plane), or more than `MAX_BELOW_SHARE` of them are
   seen through it (below it, their rays crossing it within its extent).
3. **Centre**: the point ``around`` projected onto the plane; else the centroid of the largest
   cluster of points standing `MIN_HEIGHT` – `MAX_HEIGHT` above the plane (connected on a
   1 cm grid in the plane: the objects); else where the optical axis meets the table.
4. **Cube**: z along the normal, x the horizontal direction from the centre towards the camera
   (as the default camera sees the workspace, `symgrasp.perception.default_extrinsic`; training
   saw every azimuth), the table top at ``z = TABLE_HEIGHT`` and the centre at the cube's
   horizontal middle.

`table_depth_scale` does the converse for a robot that knows where its table is (the world
frame's workspace, as every detection is asked for) but not how well its sensor measures depth:
a depth scale error (a miscalibrated stereo baseline; the ``dex`` noise's Gamma factor of SD
3.2 %, `symgrasp.perception.noise`) moves the whole scene along the camera's rays, ≈ 19 mm at
0.6 m, enough for a fingertip to meet an object on its way in. Every table pixel is then seen at
``g`` times the camera's true height above the table along the world's up axis, and ``g`` is
read off them.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from symgrasp.perception.camera import CameraIntrinsic, vector3
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

MIN_HEIGHT = 0.01
"""[m] a point this far above the plane belongs to an object (clears the plane's noise)."""

MAX_HEIGHT = WORKSPACE_SIZE - TABLE_HEIGHT
"""[m] points higher above the table than the workspace's top belong to no object in it."""

CLUSTER_CELL = 0.01
"""[m] grid cell on the table plane that joins object points into clusters."""

MIN_CLUSTER_POINTS = 30
"""A cluster of fewer points is noise, not an object."""

SAMPLE_POINTS = 20_000
"""Points the RANSAC hypotheses are scored on (a random subset: the count is a proportion)."""

MAX_PLANES = 4
"""Planes `fit_table` looks for: the table, a floor seen past its edge, the tops of large
objects, a wall."""

MIN_PLANE_SHARE = 0.05
"""After the first, a plane holding less than this share of the points ends the search."""

MAX_TILT = math.radians(10)
"""[rad] `fit_table`'s default ``max_tilt``: a table is level within a degree and a robot's
``up`` off by a few (a hand-eye calibration's error); an 11.5° plane is no table."""

MIN_TABLE_SHARE = 0.2
"""A table holds at least this share of the seen points: `fit_table` warns below it (no
dominant plane; a floor seen past the table's edge not counted) and `table_depth_scale`
refuses to read a depth scale off fewer."""

MAX_BELOW_SHARE = 0.02
"""`fit_table` warns when more than this share of the seen points are seen through the plane:
`MIN_HEIGHT` below it, their rays crossing it within its extent (its inliers' cells on the
`CLUSTER_CELL` grid, holes filled). No sensor sees through a table."""

WINDOW_BINS = 64
"""Histogram bins per ``band`` that narrow `table_depth_scale`'s densest window to a few
thousand pixels to sort (sorting all 300 000 of a 640×480 image took ≈ 20 ms)."""

MAX_WINDOW_BINS = 1_000_000
"""Most histogram bins over the range of heights (a far outlier widens the bins instead)."""

SCALE_BAND = 0.01
"""[m] height band along the up axis that holds the table's pixels in `table_depth_scale`
(the dex noise's smooth field, 3.3 mm RMS, stays within it; a 1 cm tall object does not)."""

MAX_SCALE_ERROR = 0.2
"""`table_depth_scale` refuses a depth scale off by more than this fraction: it would be
another surface taken for the table, not a sensor's scale error. The dex noise's factor,
Gamma(1000, 0.001), is off by more than 10 % in about one image of 600 (the benchmark met one
in its first 100 rounds), by more than 20 % in about one of 10⁹."""


class TableWarning(UserWarning):
    """`fit_table` found a plane but doubts it is the table (the message says why): no dominant
    plane, or points seen through it. ``warnings.simplefilter("error", TableWarning)`` turns
    it into an exception."""


@dataclass(frozen=True)
class Plane:
    """A plane in the camera frame (OpenCV axes): ``{p : normal · p + distance = 0}``.

    Attributes:
        normal: (3,) unit normal, pointing up (along ``up``, or towards the camera).
        distance: [m] the camera's height above the plane along ``normal``.
        inliers: depth points within ``threshold`` of it.
    """

    normal: np.ndarray
    distance: float
    inliers: int


@dataclass(frozen=True)
class TableFit:
    """The table plane and the workspace on it, in the camera frame (OpenCV axes).

    Attributes:
        normal: (3,) unit normal of the table plane, pointing up (towards the camera, or
            along ``up``).
        distance: [m] the plane is ``{p : normal · p + distance = 0}``: ``distance`` is the
            camera's height above the table.
        centre: (3,) [m] the point of the table under the workspace's centre.
        centred_on: what chose ``centre``: ``"around"``, ``"cluster"`` or ``"optical axis"``.
        inliers: depth points within ``threshold`` of the plane.
        points: depth points seen.
        T_camera_workspace: (4, 4) the workspace frame in the camera frame.
        competing: the other planes found, largest first (a floor, a wall, a large object's
            top), as `Plane`.
        below: depth points seen through the plane: more than `MIN_HEIGHT` below it, their
            rays crossing it within its extent.
        doubts: why the plane may not be the table (each a clause of the `TableWarning`
            given); empty when none.
    """

    normal: np.ndarray
    distance: float
    centre: np.ndarray
    centred_on: str
    inliers: int
    points: int
    T_camera_workspace: np.ndarray
    competing: tuple[Plane, ...] = ()
    below: int = 0
    doubts: tuple[str, ...] = ()

    @property
    def share(self) -> float:
        """The share of the seen depth points that lie on the plane."""
        return self.inliers / self.points

    @property
    def warning(self) -> str:
        """The `TableWarning`'s message `fit_table` gave for ``doubts``; empty when none."""
        return (
            "fit_table: " + "; ".join(self.doubts) + ": is a table in view?" if self.doubts else ""
        )

    @property
    def T_workspace_camera(self) -> np.ndarray:
        """The camera's pose in the workspace frame: the ``T_world_camera`` to give
        `GraspDetector.detect` (workspace origin 0), whose grasps are then in that frame."""
        return np.linalg.inv(self.T_camera_workspace)


def fit_table(
    depth: np.ndarray,
    intrinsic: CameraIntrinsic,
    *,
    around: np.ndarray | None = None,
    up: np.ndarray | None = None,
    threshold: float = 0.005,
    max_tilt: float = MAX_TILT,
    iterations: int = 256,
    seed: int = 0,
) -> TableFit:
    """The table in ``depth`` (H, W) [m, 0 or non-finite = missing] seen by ``intrinsic``, and
    the workspace placed on it (the module's steps).

    Args:
        around: (3,) [m, camera frame] centre the workspace over this point's projection on the
            table instead of over the largest cluster of objects.
        up: (3,) the world's up direction in the camera frame (e.g. ``R_base_camera.T @ (0, 0,
            1)``); None: the plane's normal is turned towards the camera.
        threshold: [m] a point within this distance of a plane supports it.
        max_tilt: [rad] planes tilted further than this from ``up`` (without it: from the
            largest plane) are not the table.
        iterations: RANSAC hypotheses per plane.
        seed: the random stream of the hypotheses and of the scored subset.

    ValueError when fewer than 3 pixels are seen or no plane within ``max_tilt`` of ``up``
    has the camera above it; `TableWarning` when the plane found holds less than
    `MIN_TABLE_SHARE` of the points not on a plane below it (a floor), or more than
    `MAX_BELOW_SHARE` of them are seen through it.
    """
    depth = np.asarray(depth, dtype=np.float64)
    if depth.shape != (intrinsic.height, intrinsic.width):
        raise ValueError(
            f"depth must have shape ({intrinsic.height}, {intrinsic.width}) as the intrinsic "
            f"says, got {depth.shape}"
        )
    if not (threshold > 0 and 0 < max_tilt <= math.pi / 2 and iterations >= 1):
        raise ValueError(
            "threshold must be > 0 m, max_tilt in (0, π/2] rad and iterations ≥ 1, got "
            f"{threshold}, {max_tilt}, {iterations}"
        )
    up_axis = None if up is None else _unit(up, "up")
    seen = np.isfinite(depth) & (depth > 0)
    points = depth[seen][:, None] * intrinsic.pixel_rays()[seen]
    if len(points) < 3:
        raise ValueError(f"fit_table needs seen depth pixels, got {len(points)}")
    rng = np.random.default_rng(seed)
    sample = points[rng.choice(len(points), min(len(points), SAMPLE_POINTS), replace=False)]
    planes = [
        _settle(points, plane, threshold, up_axis)
        for plane in _planes(sample, threshold, iterations, rng)
    ]
    table, floor = _table(planes, up_axis, max_tilt)
    normal, distance = table.normal, table.distance
    if around is not None:
        centre, centred_on = _on_plane(vector3(around, "around"), normal, distance), "around"
    else:
        centre, centred_on = _cluster_centre(points, normal, distance), "cluster"
        if centre is None:
            table_points = points[np.abs(points @ normal + distance) < threshold]
            centre = _axis_centre(table_points, normal, distance)
            centred_on = "optical axis"
    below = _below(points, normal, distance, threshold)
    beside = len(points) - floor  # a floor seen past the table's edge is no doubt
    doubts = []
    if table.inliers < MIN_TABLE_SHARE * beside:
        doubts.append(
            f"the plane holds {table.inliers / beside:.0%} of the seen points off the planes "
            f"below it, under MIN_TABLE_SHARE = {MIN_TABLE_SHARE:.0%} (no dominant plane)"
        )
    if below > MAX_BELOW_SHARE * len(points):
        doubts.append(
            f"{below / len(points):.0%} of the seen points are seen through it, more than "
            f"{MIN_HEIGHT * 100:g} cm below it (MAX_BELOW_SHARE = {MAX_BELOW_SHARE:.0%})"
        )
    fit = TableFit(
        normal, distance, centre, centred_on, table.inliers, len(points),
        _workspace_pose(normal, centre), tuple(p for p in planes if p is not table), below,
        tuple(doubts),
    )  # fmt: skip
    if fit.doubts:
        warnings.warn(fit.warning, TableWarning, stacklevel=2)
    return fit


def _planes(
    points: np.ndarray, threshold: float, iterations: int, rng: np.random.Generator
) -> list[np.ndarray]:
    """Up to `MAX_PLANES` planes ``(normal, distance)`` (4,) in ``points``, largest first: each
    found by `_ransac` among the points farther than `MIN_HEIGHT` from those before it."""
    planes, left = [], points
    while len(planes) < MAX_PLANES and len(left) >= 3:
        plane = _ransac(left, threshold, iterations, rng)
        if plane is None:
            break
        on = np.abs(left @ plane[:3] + plane[3]) < threshold
        if planes and on.sum() < MIN_PLANE_SHARE * len(points):
            break
        plane = _refit(left[on], plane[:3])
        planes.append(plane)
        left = left[np.abs(left @ plane[:3] + plane[3]) >= max(threshold, MIN_HEIGHT)]
    if not planes:
        raise ValueError("fit_table found no plane: the depth points lie on a line")
    return planes


def _ransac(
    points: np.ndarray, threshold: float, iterations: int, rng: np.random.Generator
) -> np.ndarray | None:
    """The plane ``(normal, distance)`` (4,) through 3 of ``points`` that the most of them
    support, or None when no 3 drawn span one."""
    a, b, c = (points[rng.integers(len(points), size=iterations)] for _ in range(3))
    normals = np.cross(b - a, c - a)
    length = np.linalg.norm(normals, axis=1)
    usable = length > 1e-12
    if not usable.any():
        return None
    normals, a = normals[usable] / length[usable, None], a[usable]
    distances = -np.einsum("ij,ij->i", normals, a)
    support = (np.abs(points @ normals.T + distances) < threshold).sum(axis=0)
    best = int(np.argmax(support))
    return np.r_[normals[best], distances[best]]


def _settle(
    points: np.ndarray, plane: np.ndarray, threshold: float, up: np.ndarray | None
) -> Plane:
    """``plane`` (4,) refitted on its inliers among all ``points`` and counted again, its
    normal turned up: along ``up``, else towards the camera (the origin above the plane)."""
    plane = _refit(points[np.abs(points @ plane[:3] + plane[3]) < threshold], plane[:3])
    if (up is not None and plane[:3] @ up < 0) or (up is None and plane[3] < 0):
        plane = -plane
    inliers = int((np.abs(points @ plane[:3] + plane[3]) < threshold).sum())
    return Plane(plane[:3], float(plane[3]), inliers)


def _table(planes: list[Plane], up: np.ndarray | None, max_tilt: float) -> tuple[Plane, int]:
    """The table among ``planes`` (largest first): of the planes within ``max_tilt`` of ``up``
    (else of the largest) with the camera above them, the lowest within `MAX_HEIGHT` of the
    highest; and the inliers of those farther below (a floor)."""
    level = planes[0].normal if up is None else up
    candidates = [p for p in planes if p.normal @ level >= math.cos(max_tilt) and p.distance > 0]
    if not candidates:
        tilt = math.degrees(math.acos(min(1.0, abs(planes[0].normal @ level))))
        raise ValueError(
            f"fit_table found no plane candidate within {math.degrees(max_tilt):.0f}° of up "
            f"with the camera above it (the largest plane is tilted {tilt:.0f}° from it): does "
            "the depth image show the table, and is up the world's up in the camera frame?"
        )
    reach = min(p.distance for p in candidates) + MAX_HEIGHT
    table = max((p for p in candidates if p.distance <= reach), key=lambda p: p.distance)
    return table, sum(p.inliers for p in candidates if p.distance > reach)


def _refit(points: np.ndarray, guess: np.ndarray) -> np.ndarray:
    """The least-squares plane ``(normal, distance)`` (4,) of ``points``: its normal the
    direction of least variance, signed like ``guess``."""
    mean = points.mean(axis=0)
    normal = np.linalg.svd(points - mean, full_matrices=False)[2][-1]
    normal = normal if normal @ guess >= 0 else -normal
    return np.r_[normal, -normal @ mean]


def _on_plane(point: np.ndarray, normal: np.ndarray, distance: float) -> np.ndarray:
    return point - (normal @ point + distance) * normal


def _plane_basis(normal: np.ndarray) -> np.ndarray:
    """(2, 3): two unit vectors spanning the plane of ``normal``."""
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    first = np.cross(normal, helper)
    first /= np.linalg.norm(first)
    return np.stack([first, np.cross(normal, first)])


def _cluster_centre(points: np.ndarray, normal: np.ndarray, distance: float) -> np.ndarray | None:
    """The table point under the centroid of the largest cluster of ``points`` standing
    `MIN_HEIGHT` – `MAX_HEIGHT` above the plane, or None when no cluster has
    `MIN_CLUSTER_POINTS`."""
    height = points @ normal + distance
    above = points[(height > MIN_HEIGHT) & (height < MAX_HEIGHT)]
    if len(above) < MIN_CLUSTER_POINTS:
        return None
    flat = above @ _plane_basis(normal).T
    cell = np.floor((flat - flat.min(axis=0)) / CLUSTER_CELL).astype(int)
    grid = np.zeros(cell.max(axis=0) + 1, dtype=bool)
    grid[cell[:, 0], cell[:, 1]] = True
    labels, _ = ndimage.label(grid, structure=np.ones((3, 3)))
    label = labels[cell[:, 0], cell[:, 1]]
    counts = np.bincount(label)
    largest = int(np.argmax(counts[1:])) + 1
    if counts[largest] < MIN_CLUSTER_POINTS:
        return None
    return _on_plane(above[label == largest].mean(axis=0), normal, distance)


def _below(points: np.ndarray, normal: np.ndarray, distance: float, threshold: float) -> int:
    """How many ``points`` (camera frame) more than `MIN_HEIGHT` below the plane are seen
    through it: their rays cross it within its extent, the cells of its inliers (within
    ``threshold``) on the `CLUSTER_CELL` grid in the plane, with the holes the objects leave
    filled."""
    height = points @ normal + distance
    under = points[height < -MIN_HEIGHT]
    table = points[np.abs(height) < threshold]
    if not (len(under) and len(table)):
        return 0
    crossing = under * (distance / (distance - height[height < -MIN_HEIGHT]))[:, None]
    basis = _plane_basis(normal).T
    low = (table @ basis).min(axis=0)
    cell = np.floor((table @ basis - low) / CLUSTER_CELL).astype(int)
    extent = np.zeros(cell.max(axis=0) + 1, dtype=bool)
    extent[cell[:, 0], cell[:, 1]] = True
    extent = ndimage.binary_fill_holes(extent)
    cell = np.floor((crossing @ basis - low) / CLUSTER_CELL).astype(int)
    inside = ((cell >= 0) & (cell < extent.shape)).all(axis=1)
    return int(extent[cell[inside, 0], cell[inside, 1]].sum())


def _axis_centre(table: np.ndarray, normal: np.ndarray, distance: float) -> np.ndarray:
    """Where the optical axis meets the plane, if in front of the camera; else the centroid of
    the ``table`` points."""
    along = normal[2]
    if abs(along) > 1e-9 and -distance / along > 0:
        return np.array([0.0, 0.0, -distance / along])
    return _on_plane(table.mean(axis=0), normal, distance)


def _workspace_pose(normal: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """``T_camera_workspace``: z along ``normal``, x the horizontal direction from ``centre``
    towards the camera (the camera's image-up direction when it looks straight down), the
    table top at ``z = TABLE_HEIGHT`` and ``centre`` at the cube's horizontal middle."""
    towards = -centre - (-centre @ normal) * normal
    if np.linalg.norm(towards) < 1e-3 * np.linalg.norm(centre):  # straight down
        image_up = np.array([0.0, -1.0, 0.0])
        towards = image_up - (image_up @ normal) * normal
    x = towards / np.linalg.norm(towards)
    R = np.c_[x, np.cross(normal, x), normal]
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = centre - R @ np.array([WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2, TABLE_HEIGHT])
    return T


def _unit(value: np.ndarray, name: str) -> np.ndarray:
    vector = vector3(value, name)
    if np.linalg.norm(vector) < 1e-9:
        raise ValueError(f"{name} must be a direction, not zero")
    return vector / np.linalg.norm(vector)


def table_depth_scale(
    depth: np.ndarray,
    intrinsic: CameraIntrinsic,
    T_world_camera: np.ndarray,
    table_z: float,
    *,
    band: float = SCALE_BAND,
    max_error: float = MAX_SCALE_ERROR,
) -> float:
    """The factor ``g`` by which ``depth`` (H, W) [m, 0 or non-finite = missing] overstates
    the depth of the table plane ``z = table_z`` [m, world] seen by ``intrinsic`` from
    ``T_world_camera`` (4, 4): ``depth / g`` puts the table where the world frame says it is.

    A pixel's point ``p`` (camera frame) lies ``h' = −p · up`` below the camera along the
    world's up axis (``up``: world z in the camera frame); a table pixel of an image whose depth
    is ``g`` times the truth has ``h' = g h``, ``h`` the camera's height above the table. The
    table is the densest ``band`` [m] wide window of ``h'`` (objects stand above it: smaller
    ``h'``), and ``g`` the median ``h' / h`` of its pixels.

    ValueError when the camera is not above the table, fewer than 100 pixels are seen, or ``g``
    is off by more than ``max_error`` or the table's window holds less than `MIN_TABLE_SHARE` of
    the seen pixels (another surface than the table, or none)."""
    depth = np.asarray(depth, dtype=np.float64)
    if depth.shape != (intrinsic.height, intrinsic.width):
        raise ValueError(
            f"depth must have shape ({intrinsic.height}, {intrinsic.width}) as the intrinsic "
            f"says, got {depth.shape}"
        )
    T = np.asarray(T_world_camera, dtype=np.float64)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise ValueError(f"T_world_camera must be a finite (4, 4) transform, got shape {T.shape}")
    if not (band > 0 and 0 < max_error < 1):
        raise ValueError(f"band must be > 0 m and max_error in (0, 1), got {band}, {max_error}")
    height = T[2, 3] - table_z
    if not height > 0:
        raise ValueError(
            f"the camera (z = {T[2, 3]:.3f} m) must be above the table (z = {table_z:.3f} m)"
        )
    seen = np.isfinite(depth) & (depth > 0)
    if seen.sum() < 100:
        raise ValueError(f"table_depth_scale needs ≥ 100 seen depth pixels, got {seen.sum()}")
    # h' = −depth · (ray · up), each pixel's ray · up summed from its column and its row: no
    # (N, 3) points, no matrix product (a threaded BLAS call, whose idle threads then spin
    # beside the network's: docs/robot.md, "Depth from real sensors")
    up = T[2, :3]
    u = (np.arange(intrinsic.width) - intrinsic.cx) / intrinsic.fx
    v = (np.arange(intrinsic.height) - intrinsic.cy) / intrinsic.fy
    below = depth[seen] * np.add.outer(-up[1] * v - up[2], -up[0] * u)[seen]
    start, count = _densest_window(below, band)
    if count < MIN_TABLE_SHARE * len(below):
        raise ValueError(
            f"the densest plane at the table's tilt holds {count / len(below):.0%} of the seen "
            f"pixels, under MIN_TABLE_SHARE = {MIN_TABLE_SHARE:.0%}: no table to read the "
            "depth scale off (is the table in view, and is T_world_camera right?)"
        )
    table = below[(below >= start) & (below <= start + band)]
    scale = np.median(table, overwrite_input=True) / height
    if abs(scale - 1) > max_error:
        raise ValueError(
            f"the densest plane at the table's tilt lies {scale * height:.3f} m below the camera "
            f"along the up axis, where the table should be {height:.3f} m below it: a depth "
            f"scale of {scale:.3f}, off by more than max_error = {max_error} (does the image "
            "show the table, and is T_world_camera right?)"
        )
    return scale


def _densest_window(values: np.ndarray, band: float) -> tuple[float, int]:
    """The smallest ``x`` of ``values`` (N,) whose window ``[x, x + band]`` holds the most of
    them, and how many: what sorting them all and counting every window gives, with only the
    values where the best window can start sorted. A histogram of `WINDOW_BINS` bins per
    ``band`` (its bins runs of the sorted values: the binning is monotone) bounds the windows
    starting in each bin: at most the values of the bins they can reach, at least those of the
    bins the one from its smallest value covers. A window's count is then the values from its
    start on (the bins before it, its rank in its bin) to its end (the bins before the end's,
    the values of the end's bin up to it, counted against all the ends at once)."""
    width = max(band / WINDOW_BINS, float(np.ptp(values)) / MAX_WINDOW_BINS)
    low = values.min()

    def bin_of(x: np.ndarray) -> np.ndarray:
        return ((x - low) / width).astype(np.int64)

    bins = bin_of(values)
    counts = np.bincount(bins)
    total = np.r_[0, np.cumsum(counts)]  # the values in the bins before each
    first, reach = np.arange(len(counts)), band / width
    at_most = total[np.minimum(first + math.ceil(reach) + 2, len(counts))] - total[first]
    at_least = total[np.clip(first + math.floor(reach) - 1, first, len(counts))] - total[first]
    starts = (counts > 0) & (at_most >= at_least[counts > 0].max())
    x = np.sort(values[starts[bins]])  # every start that may be the best
    start_bin, ends = bin_of(x), x + band
    end_bin = np.minimum(bin_of(ends), len(counts))
    is_end = np.zeros(len(counts) + 1, dtype=bool)
    is_end[end_bin] = True
    # the values of the ends' bins up to each end, and those of the ends' bins before its own
    end_values = values[is_end[bins]]
    upto = np.cumsum(np.bincount(np.searchsorted(ends, end_values), minlength=len(ends) + 1))
    before = np.r_[0, np.cumsum(np.where(is_end[:-1], counts, 0))]
    count = (
        total[end_bin] + upto[: len(ends)] - before[end_bin]
        - total[start_bin] - (np.searchsorted(x, x) - np.searchsorted(start_bin, start_bin))
    )  # fmt: skip
    best = int(np.argmax(count))
    return float(x[best]), int(count[best])


def table_scaled(
    views: np.ndarray, intrinsic: CameraIntrinsic, T_world_camera: np.ndarray, table_z: float
) -> np.ndarray:
    """Depth images ``views`` (V, H, W) [m] taken from ``T_world_camera`` (V, 4, 4), each
    divided by its `table_depth_scale`: what a robot that knows its table fuses."""
    scaled = np.empty(np.shape(views), dtype=np.float64)
    for view, T, out in zip(views, T_world_camera, scaled, strict=True):
        np.divide(view, table_depth_scale(view, intrinsic, T, table_z), out=out)
    return scaled
