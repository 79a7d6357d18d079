"""Pinhole camera: intrinsics, look-at extrinsics and the default view of the workspace.

Camera frames follow OpenCV: ``x`` right, ``y`` down, ``z`` forward along the optical axis.
Pixel ``(u, v)`` (column, row) has its centre at integer coordinates, so a point ``p`` in the
camera frame projects to ``u = fx · x / z + cx``, ``v = fy · y / z + cy``. A depth image
holds the ``z`` coordinate [m] of the surface seen by each pixel, 0 where nothing is seen.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, fields

import numpy as np

from symgrasp.workspace import WORKSPACE_SIZE

DEFAULT_EYE_OFFSET = (0.5, 0.0, 0.5)
"""Default camera position relative to the workspace centre [m] (GIGA/VGN-like side view)."""


@dataclass(frozen=True)
class CameraIntrinsic:
    """Image size [px], integers, and pinhole parameters [px], numbers (not bools or strings:
    refused, as a JSON ``"fx": true`` would otherwise be 1 px)."""

    width: int = 640
    height: int = 480
    fx: float = 540.0
    fy: float = 540.0
    cx: float = 320.0
    cy: float = 240.0

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            kind = numbers.Integral if field.name in ("width", "height") else numbers.Real
            if isinstance(value, bool) or not isinstance(value, kind):
                what = "an integer" if kind is numbers.Integral else "a number"
                raise TypeError(f"{field.name} must be {what} [px], got {value!r}")
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"width and height must be positive, got {self.width}×{self.height}")
        if not (self.fx > 0 and self.fy > 0 and np.isfinite([self.fx, self.fy]).all()):
            raise ValueError(f"fx and fy must be positive and finite, got {self.fx}, {self.fy}")
        if not np.isfinite([self.cx, self.cy]).all():
            raise ValueError(f"cx and cy must be finite, got {self.cx}, {self.cy}")

    @classmethod
    def from_matrix(cls, K: np.ndarray, width: int, height: int) -> CameraIntrinsic:
        """The camera of images ``width`` × ``height`` [px] with calibration matrix ``K``
        (3, 3) (OpenCV's: fx, fy on the diagonal, cx, cy in the last column)."""
        K = np.asarray(K, dtype=float)
        if K.shape != (3, 3):
            raise ValueError(f"a camera matrix must be 3×3, got shape {K.shape}")
        return cls(int(width), int(height), K[0, 0], K[1, 1], K[0, 2], K[1, 2])

    @property
    def K(self) -> np.ndarray:
        """The 3×3 calibration matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def pixel_rays(self) -> np.ndarray:
        """Ray of every pixel in the camera frame, scaled to ``z = 1``: (height, width, 3).

        ``depth[v, u] * rays[v, u]`` is the 3D point seen by pixel ``(u, v)``.
        """
        u, v = np.meshgrid(np.arange(self.width), np.arange(self.height))
        return np.stack(
            [(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones(u.shape)], axis=-1
        )

    def scaled(self, factor: float) -> CameraIntrinsic:
        """The same camera at ``factor`` times the resolution (e.g. 0.25 for a thumbnail)."""
        return CameraIntrinsic(
            round(self.width * factor),
            round(self.height * factor),
            self.fx * factor,
            self.fy * factor,
            (self.cx + 0.5) * factor - 0.5,
            (self.cy + 0.5) * factor - 0.5,
        )


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray = (0.0, 0.0, 1.0)) -> np.ndarray:
    """``T_world_camera`` of a camera at ``eye`` looking at ``target`` with image-up ≈ ``up``."""
    eye, target, up = (np.asarray(a, dtype=float) for a in (eye, target, up))
    forward = target - eye
    if np.linalg.norm(forward) < 1e-9:
        raise ValueError("eye and target must be different points")
    z = forward / np.linalg.norm(forward)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:
        raise ValueError("up must not be parallel to the viewing direction")
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.c_[x, np.cross(z, x), z]
    T[:3, 3] = eye
    return T


def orbit_extrinsic(
    target: np.ndarray, distance: float, polar: float, azimuth: float
) -> np.ndarray:
    """``T_world_camera`` of a camera ``distance`` [m] from ``target`` looking at it, at the
    spherical angles ``polar`` (from the vertical, rad) and ``azimuth`` (from world +x toward
    +y, rad): its eye at ``target + distance (sin θ cos φ, sin θ sin φ, cos θ)``, image-up ≈
    world +z (`look_at`), ``π/2 − polar`` below horizontal."""
    eye = np.asarray(target, dtype=float) + distance * np.array(
        [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)]
    )
    return look_at(eye, target)


def vector3(value: np.ndarray, name: str) -> np.ndarray:
    """``value`` as 3 finite floats; ValueError naming the argument ``name`` otherwise."""
    vector = np.asarray(value, dtype=float)
    if vector.shape != (3,) or not np.isfinite(vector).all():
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return vector


def is_rigid(T: np.ndarray, tolerance: float = 1e-4) -> bool:
    """Whether every transform of ``T`` (..., 4, 4) is rigid: finite, its rotation block
    orthonormal with det +1 (within ``tolerance``) and its last row (0, 0, 0, 1)."""
    T = np.asarray(T, dtype=float)
    R = T[..., :3, :3]
    return bool(
        np.isfinite(T).all()
        and np.allclose(R @ np.swapaxes(R, -1, -2), np.eye(3), atol=tolerance)
        and np.allclose(np.linalg.det(R), 1.0, atol=tolerance)
        and np.allclose(T[..., 3, :], [0, 0, 0, 1])
    )


def default_extrinsic(offset: np.ndarray = DEFAULT_EYE_OFFSET) -> np.ndarray:
    """``T_world_camera`` looking at the workspace centre from ``centre + offset`` [m]."""
    centre = np.full(3, WORKSPACE_SIZE / 2)
    return look_at(centre + np.asarray(offset, dtype=float), centre)


def depth_to_points(
    depth: np.ndarray,
    intrinsic: CameraIntrinsic,
    T_world_camera: np.ndarray,
    crop: bool = True,
    origin: np.ndarray = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """The world points (N, 3) [m] seen by the pixels of ``depth`` (H, W) [m] that saw
    something (depth > 0); with ``crop``, only those inside the workspace cube
    ``origin + [0, WORKSPACE_SIZE]³``. Denser than a TSDF's surface points: the pictures draw
    these."""
    depth = np.asarray(depth, dtype=float)
    if depth.shape != (intrinsic.height, intrinsic.width):
        raise ValueError(
            f"depth must have shape ({intrinsic.height}, {intrinsic.width}) as the intrinsic "
            f"says, got {depth.shape}"
        )
    T_world_camera = np.asarray(T_world_camera, dtype=float)
    if T_world_camera.shape != (4, 4):
        raise ValueError(f"T_world_camera must be 4×4, got {T_world_camera.shape}")
    seen = np.isfinite(depth) & (depth > 0)
    points_camera = depth[seen][:, None] * intrinsic.pixel_rays()[seen]
    points = points_camera @ T_world_camera[:3, :3].T + T_world_camera[:3, 3]
    if crop:
        offset = points - np.asarray(origin, dtype=float)
        points = points[np.all((offset >= 0.0) & (offset <= WORKSPACE_SIZE), axis=1)]
    return points
