"""Point clouds as depth images: a cloud becomes the depth image its camera would have taken,
so that the TSDF fuses it along the same rays as a real image.

The TSDF is built from rays (a voxel is free in front of the surface its pixel sees, behind it
within the truncation band, unseen deeper): a cloud alone has no rays, so it needs the camera
it was seen from, ``T_world_camera`` or only a viewpoint. The rule (a z-buffer):

- every finite point is projected through the camera's pinhole; a pixel keeps the **nearest**
  point's depth ``z``, as the sensor itself would; points behind the camera or outside the
  image are dropped, and a pixel that no point falls into is missing;
- the image is then fused like any other: a voxel up to the truncation distance (4 voxels,
  3 cm) behind the depth its pixel holds is observed as inside, deeper ones are unobserved
  (`symgrasp.perception.tsdf`).

With the sensor's own intrinsic, a cloud back-projected from a depth image (organised or not,
in any order, its missing pixels dropped) gives that image again, to float rounding, and so
the same TSDF. Without one, a virtual camera at the same pose covers the workspace cube with
pixels `DEFAULT_PIXEL_SIZE` wide at the cube's centre, coarser than a sensor's so that each
holds several points of a sensor-dense cloud; a missing pixel one of whose 8 neighbours holds
a point takes the farthest of their depths (`fill_holes`: a cloud up to twice as sparse as the
pixels leaves no holes; objects shrink by at most one pixel at their outline).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from scipy.ndimage import binary_dilation, maximum_filter

from symgrasp.perception.camera import CameraIntrinsic, is_rigid, look_at, vector3
from symgrasp.workspace import VOXEL_SIZE, WORKSPACE_SIZE

DEFAULT_PIXEL_SIZE = VOXEL_SIZE / 2
"""[m] width of a virtual camera's pixel at the workspace centre (3.75 mm): half a voxel, so
that every voxel centre the TSDF projects lands on its own pixel."""

MAX_VIRTUAL_PIXELS = 2048
"""Most pixels along a virtual image's side (a viewpoint very near the workspace, or a tiny
``pixel_size``, would otherwise ask for an image of any size)."""

MAX_HALF_ANGLE = math.radians(70)
"""A virtual camera sees at most this far from its optical axis (the cube seen from nearby
would otherwise stretch its image without bound)."""

FRAMES = ("world", "camera")
"""The frames a cloud may be given in."""


def points_depth(points_camera: np.ndarray, intrinsic: CameraIntrinsic) -> np.ndarray:
    """The depth image (H, W) float32 [m, 0 = missing] of ``points_camera`` (N, 3) [m] in the
    camera frame (OpenCV axes) seen by ``intrinsic``: each pixel holds the nearest point's
    ``z`` (a z-buffer); non-finite points, points with ``z ≤ 0`` and points outside the image
    are dropped. A pixel is the square around its integer centre, as `TSDFVolume` rounds."""
    p = np.asarray(points_camera, dtype=np.float64).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1) & (p[:, 2] > 0)]
    u = np.round(intrinsic.fx * p[:, 0] / p[:, 2] + intrinsic.cx)
    v = np.round(intrinsic.fy * p[:, 1] / p[:, 2] + intrinsic.cy)
    inside = (u >= 0) & (u < intrinsic.width) & (v >= 0) & (v < intrinsic.height)
    index = torch.as_tensor((v[inside] * intrinsic.width + u[inside]).astype(np.int64))
    depth = torch.full((intrinsic.height * intrinsic.width,), math.inf, dtype=torch.float64)
    depth.scatter_reduce_(0, index, torch.as_tensor(p[inside, 2]), reduce="amin")
    depth = depth.numpy().reshape(intrinsic.height, intrinsic.width)
    return np.where(np.isfinite(depth), depth, 0.0).astype(np.float32)


def fill_holes(depth: np.ndarray, pixels: int = 1) -> np.ndarray:
    """``depth`` (H, W) [m, 0 = missing] with holes up to ``pixels`` wide from their edge
    filled: ``pixels`` times, each missing pixel with a seen neighbour (of its 8) takes the
    **farthest** of their depths; seen pixels are unchanged. The farthest, because the holes
    of a real sensor's image border the objects (the shadow of a structured-light or stereo
    sensor lies on the background, and the mixed pixels at an edge are dropped): filling them
    with the background keeps objects their size, where the nearest would grow them."""
    if not (isinstance(pixels, int | np.integer) and pixels >= 0):
        raise ValueError(f"pixels must be an integer ≥ 0, got {pixels!r}")
    filled = np.where(np.isfinite(depth) & (depth > 0), depth, 0.0).astype(np.float32)
    for _ in range(pixels):
        missing = filled == 0
        if not missing.any():
            break
        filled = np.where(missing, maximum_filter(filled, size=3, mode="constant"), filled)
    return filled


def edge_holes(depth: np.ndarray, jump: float = 0.02, width: int = 2) -> np.ndarray:
    """``depth`` (H, W) [m] with the pixels within ``width`` of a depth jump over ``jump`` [m]
    between neighbouring pixels dropped (0, missing), as a stereo or structured-light sensor
    drops them at object edges: the holes `fill_holes` fills, made in a rendered image to
    measure what they cost (experiments/sensor_depth.py, tests/detect)."""
    if not (isinstance(width, int | np.integer) and width >= 1):
        raise ValueError(f"width must be an integer ≥ 1, got {width!r}")
    if not jump > 0:
        raise ValueError(f"jump must be > 0 [m], got {jump!r}")
    edge = np.zeros(depth.shape, dtype=bool)
    rows, cols = np.abs(np.diff(depth, axis=0)) > jump, np.abs(np.diff(depth, axis=1)) > jump
    edge[1:] |= rows
    edge[:-1] |= rows
    edge[:, 1:] |= cols
    edge[:, :-1] |= cols
    return np.where(binary_dilation(edge, iterations=width), 0.0, depth).astype(np.float32)


def virtual_camera(
    T_world_camera: np.ndarray,
    origin: np.ndarray = (0.0, 0.0, 0.0),
    pixel_size: float = DEFAULT_PIXEL_SIZE,
) -> CameraIntrinsic:
    """A pinhole camera at ``T_world_camera`` whose image covers the workspace cube
    ``origin + [0, WORKSPACE_SIZE]³`` (the part in front of it, at most `MAX_HALF_ANGLE` off
    its axis), with square pixels ``pixel_size`` [m] wide at the cube's centre and at most
    `MAX_VIRTUAL_PIXELS` along a side. ValueError when the cube's centre is not in front of
    the camera."""
    if not (math.isfinite(pixel_size) and pixel_size > 0):
        raise ValueError(f"pixel_size must be a positive number of metres, got {pixel_size}")
    T = np.asarray(T_world_camera, dtype=float)
    corners = np.asarray(origin, dtype=float) + WORKSPACE_SIZE * np.array(
        [[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=float
    )
    in_camera = (np.r_[corners, corners.mean(axis=0, keepdims=True)] - T[:3, 3]) @ T[:3, :3]
    centre_depth = in_camera[-1, 2]
    if centre_depth <= 0:
        raise ValueError(
            "the workspace is behind the camera: its centre is at depth "
            f"{centre_depth:.3g} m in the camera frame of T_world_camera (the camera must face it)"
        )
    limit = math.tan(MAX_HALF_ANGLE)
    corners = in_camera[:-1]
    if (corners[:, 2] > 0).all():
        slopes = corners[:, :2] / corners[:, 2:]
        lo, hi = (
            np.clip(slopes.min(axis=0), -limit, limit),
            np.clip(slopes.max(axis=0), -limit, limit),
        )
    else:  # the camera stands inside the cube's slab: everything up to the angle limit
        lo, hi = np.full(2, -limit), np.full(2, limit)
    focal = min(centre_depth / pixel_size, (MAX_VIRTUAL_PIXELS - 1) / float(np.max(hi - lo)))
    size = np.ceil(focal * (hi - lo)).astype(int) + 1
    return CameraIntrinsic(int(size[0]), int(size[1]), focal, focal, -focal * lo[0], -focal * lo[1])


def viewpoint_extrinsic(viewpoint: np.ndarray, origin: np.ndarray = (0.0, 0.0, 0.0)) -> np.ndarray:
    """``T_world_camera`` of a camera at ``viewpoint`` (3,) [m] looking at the centre of the
    workspace cube from ``origin``, its image's up towards world +z (towards +x when it looks
    straight down)."""
    eye = vector3(viewpoint, "viewpoint")
    centre = np.asarray(origin, dtype=float) + WORKSPACE_SIZE / 2
    if np.linalg.norm(eye - centre) < 1e-6:
        raise ValueError(f"viewpoint {eye.tolist()} is the workspace centre: rays need a camera")
    along = (centre - eye) / np.linalg.norm(centre - eye)
    up = (1.0, 0.0, 0.0) if abs(along[2]) > 1 - 1e-9 else (0.0, 0.0, 1.0)
    return look_at(eye, centre, up)


def points_view(
    points: np.ndarray,
    T_world_camera: np.ndarray | None = None,
    *,
    viewpoint: np.ndarray | None = None,
    intrinsic: CameraIntrinsic | np.ndarray | None = None,
    frame: str = "world",
    origin: np.ndarray = (0.0, 0.0, 0.0),
    pixel_size: float = DEFAULT_PIXEL_SIZE,
) -> tuple[np.ndarray, CameraIntrinsic, np.ndarray]:
    """The depth image a cloud gives (the module's rule): ``(depth (H, W) [m, 0 = missing],
    intrinsic, T_world_camera (4, 4))``, what `GraspDetector.detect` takes.

    Args:
        points: (N, 3) or organised (H, W, 3) [m]; rows with a NaN or infinite coordinate are
            missing points (an organised cloud's holes).
        T_world_camera: the camera's pose (4, 4); or
        viewpoint: only where the camera stood (3,) [m, world frame]: a camera there looking at
            the workspace centre (`viewpoint_extrinsic`). Exactly one of the two.
        intrinsic: the sensor's camera (a `CameraIntrinsic`; a 3×3 matrix for an organised
            cloud, whose shape is the image's): its pixels are the image's, nothing filled.
            None: a `virtual_camera` of ``pixel_size`` at the pose, holes of one pixel filled
            (`fill_holes`).
        frame: ``"world"`` (the default) or ``"camera"``: the frame ``points`` are given in
            (``"camera"``, a sensor's own cloud, needs ``T_world_camera``).
        origin: the workspace cube's corner [m, world frame].
        pixel_size: a virtual camera's pixel width at the workspace centre [m].
    """
    if (T_world_camera is None) == (viewpoint is None):
        raise ValueError("give the camera's pose T_world_camera or its viewpoint, exactly one")
    if frame not in FRAMES:
        raise ValueError(f"frame must be one of {', '.join(FRAMES)}, got {frame!r}")
    if frame == "camera" and T_world_camera is None:
        raise ValueError(
            "points in the camera frame need T_world_camera (a viewpoint does not fix the "
            "camera's axes)"
        )
    cloud = np.asarray(points)
    if (
        cloud.ndim not in (2, 3)
        or cloud.shape[-1] != 3
        or not np.issubdtype(cloud.dtype, np.number)
    ):
        raise ValueError(
            f"points must be numbers of shape (N, 3) or organised (H, W, 3) [m], got "
            f"{cloud.dtype} of shape {cloud.shape}"
        )
    if np.issubdtype(cloud.dtype, np.complexfloating):
        raise ValueError(f"points must be real numbers [m], got {cloud.dtype}")
    if intrinsic is not None and not isinstance(intrinsic, CameraIntrinsic):
        if cloud.ndim != 3:
            raise ValueError(
                "the intrinsic of an unorganised (N, 3) cloud must be a CameraIntrinsic, which "
                "knows the image size; a 3×3 matrix only goes with an organised (H, W, 3) cloud"
            )
        intrinsic = CameraIntrinsic.from_matrix(intrinsic, cloud.shape[1], cloud.shape[0])
    cloud = cloud.reshape(-1, 3).astype(np.float64)
    T = viewpoint_extrinsic(viewpoint, origin) if T_world_camera is None else _rigid(T_world_camera)
    in_camera = cloud if frame == "camera" else (cloud - T[:3, 3]) @ T[:3, :3]
    if intrinsic is not None:
        return points_depth(in_camera, intrinsic), intrinsic, T
    camera = virtual_camera(T, origin, pixel_size)
    return fill_holes(points_depth(in_camera, camera)), camera, T


def _rigid(T_world_camera: np.ndarray) -> np.ndarray:
    T = np.asarray(T_world_camera, dtype=float)
    if T.shape != (4, 4):
        raise ValueError(f"T_world_camera must be 4×4, got shape {T.shape}")
    if not is_rigid(T):
        raise ValueError(
            "T_world_camera is not a rigid transform: its rotation block must be orthonormal "
            "with det +1 and its last row (0, 0, 0, 1)"
        )
    return T
