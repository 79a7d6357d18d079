"""The workspace found by itself: the table plane fitted in a depth image, the workspace cube
placed on it; and, where the table's place is known, the depth scale that puts it there.

A trained detector knows one geometry (`symgrasp.workspace`): the 30 cm cube with the table
top `TABLE_HEIGHT` above its floor and gravity along −z. `fit_table` finds the table in the
camera's own frame and returns the pose of that cube, so that no world frame has to be set up
by hand:

1. **Plane** (RANSAC, Fischler & Bolles, CACM 1981): planes through 3 random back-projected
   points, the one with the most points within ``threshold`` wins, refitted by least squares
   (the smallest principal axis of its inliers) and counted again. Its normal points towards the
   camera, which sees the table from above; with ``up`` (the world's up in the camera frame,
   which a robot knows from its kinematics) planes tilted more than ``max_tilt`` from it are
   not candidates and the normal points along it.
2. **Centre**: the point ``around`` projected onto the plane; else the centroid of the largest
   cluster of points standing `MIN_HEIGHT` – `MAX_HEIGHT` above the plane (connected on a
   1 cm grid in the plane: the objects); else where the optical axis meets the table.
3. **Cube**: z along the normal, x the horizontal direction from the centre towards the camera
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

SCALE_BAND = 0.01
"""[m] height band along the up axis that holds the table's pixels in `table_depth_scale`
(the dex noise's smooth field, 3.3 mm RMS, stays within it; a 1 cm tall object does not)."""

MAX_SCALE_ERROR = 0.2
"""`table_depth_scale` refuses a depth scale off by more than this fraction: it would be
another surface taken for the table, not a sensor's scale error. The dex noise's factor,
Gamma(1000, 0.001), is off by more than 10 % in about one image of 600 (the benchmark met one
in its first 100 rounds), by more than 20 % in about one of 10⁹."""


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
    """

    normal: np.ndarray
    distance: float
    centre: np.ndarray
    centred_on: str
    inliers: int
    points: int
    T_camera_workspace: np.ndarray

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
    max_tilt: float = math.radians(30),
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
        max_tilt: [rad] with ``up``, planes tilted further than this from it are not candidates.
        iterations: RANSAC hypotheses.
        seed: the random stream of the hypotheses and of the scored subset.

    ValueError when fewer than 3 pixels are seen or no plane candidate is found.
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
    normal, distance = _ransac(sample, threshold, up_axis, max_tilt, iterations, rng)
    inliers = np.abs(points @ normal + distance) < threshold
    normal, distance = _refit(points[inliers], normal)
    inliers = np.abs(points @ normal + distance) < threshold
    if (up_axis is not None and normal @ up_axis < 0) or (up_axis is None and distance < 0):
        normal, distance = -normal, -distance  # the camera (the origin) above the plane
    if around is not None:
        centre, centred_on = _on_plane(vector3(around, "around"), normal, distance), "around"
    else:
        centre, centred_on = _cluster_centre(points, normal, distance), "cluster"
        if centre is None:
            centre, centred_on = _axis_centre(points[inliers], normal, distance), "optical axis"
    return TableFit(
        normal, float(distance), centre, centred_on, int(inliers.sum()), len(points),
        _workspace_pose(normal, centre),
    )  # fmt: skip


def _ransac(
    points: np.ndarray,
    threshold: float,
    up: np.ndarray | None,
    max_tilt: float,
    iterations: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray, float]:
    """The plane ``(normal, distance)`` through 3 of ``points`` that the most of them support."""
    a, b, c = (points[rng.integers(len(points), size=iterations)] for _ in range(3))
    normals = np.cross(b - a, c - a)
    length = np.linalg.norm(normals, axis=1)
    usable = length > 1e-12
    normals = normals / np.where(usable, length, 1.0)[:, None]
    if up is not None:
        usable &= np.abs(normals @ up) >= math.cos(max_tilt)
    if not usable.any():
        raise ValueError(
            "fit_table found no plane candidate"
            + ("" if up is None else f" within {math.degrees(max_tilt):.0f}° of up")
            + ": does the depth image show the table?"
        )
    normals, a = normals[usable], a[usable]
    distances = -np.einsum("ij,ij->i", normals, a)
    support = (np.abs(points @ normals.T + distances) < threshold).sum(axis=0)
    best = int(np.argmax(support))
    return normals[best], float(distances[best])


def _refit(points: np.ndarray, guess: np.ndarray) -> tuple[np.ndarray, float]:
    """The least-squares plane of ``points``: its normal the direction of least variance,
    signed like ``guess``."""
    mean = points.mean(axis=0)
    normal = np.linalg.svd(points - mean, full_matrices=False)[2][-1]
    normal = normal if normal @ guess >= 0 else -normal
    return normal, float(-normal @ mean)


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
    is off by more than ``max_error`` (another surface than the table)."""
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
    below = np.sort(-(depth[seen][:, None] * intrinsic.pixel_rays()[seen]) @ T[2, :3])
    inside = np.searchsorted(below, below + band, side="right") - np.arange(len(below))
    start = int(np.argmax(inside))
    scale = float(np.median(below[start : start + inside[start]])) / height
    if abs(scale - 1) > max_error:
        raise ValueError(
            f"the densest plane at the table's tilt lies {scale * height:.3f} m below the camera "
            f"along the up axis, where the table should be {height:.3f} m below it: a depth "
            f"scale of {scale:.3f}, off by more than max_error = {max_error} (does the image "
            "show the table, and is T_world_camera right?)"
        )
    return scale


def table_scaled(
    views: np.ndarray, intrinsic: CameraIntrinsic, T_world_camera: np.ndarray, table_z: float
) -> np.ndarray:
    """Depth images ``views`` (V, H, W) [m] taken from ``T_world_camera`` (V, 4, 4), each
    divided by its `table_depth_scale`: what a robot that knows its table fuses."""
    return np.stack([view / table_depth_scale(view, intrinsic, T, table_z)
                     for view, T in zip(views, T_world_camera, strict=True)])  # fmt: skip
