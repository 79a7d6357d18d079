"""Truncated signed distance fusion of depth images into a dense voxel grid, in torch.

The grid covers the cube ``origin + [0, size]³`` with ``resolution³`` voxels; voxel
``[i, j, k]`` has its centre at ``origin + (i + ½, j + ½, k + ½) · voxel_size`` (``i`` along
world x). Values are the signed distance to the nearest surface along the viewing ray divided
by the truncation distance and clipped to [-1, 1]: positive in front of the surface (free
space seen by a camera), negative behind it. Unobserved voxels have weight 0. The distance is
the depth difference along the optical axis, or with ``along_ray`` the distance along the
pixel's viewing ray, as Open3D's ``UniformTSDFVolume`` measures it (VGN's fusion,
`symgrasp.peers.vgn`).
"""

from __future__ import annotations

import functools

import numpy as np
import torch

from symgrasp.perception.camera import CameraIntrinsic
from symgrasp.workspace import RESOLUTION, WORKSPACE_SIZE

TRUNCATION_VOXELS = 4.0
"""Default truncation distance [voxels]."""


class TSDFVolume:
    """A dense TSDF grid (default: 40³ voxels of 7.5 mm over the 0.30 m workspace).

    Args:
        size: edge of the cube [m].
        resolution: voxels per edge.
        truncation_voxels: truncation distance in voxels.
        origin: (3,) world position of the cube's corner [m].
        device: torch device of the grid (fusion runs there).
        along_ray: measure the signed distance along each pixel's viewing ray (the depth
            difference times ``√(1 + ((u − cx)/fx)² + ((v − cy)/fy)²)`` at pixel (u, v), Open3D's
            convention) instead of along the optical axis.
    """

    def __init__(
        self,
        size: float = WORKSPACE_SIZE,
        resolution: int = RESOLUTION,
        truncation_voxels: float = TRUNCATION_VOXELS,
        origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
        device: str | torch.device = "cpu",
        along_ray: bool = False,
    ) -> None:
        if size <= 0 or resolution <= 0 or truncation_voxels <= 0:
            raise ValueError(
                f"size, resolution and truncation_voxels must be positive, "
                f"got {size}, {resolution}, {truncation_voxels}"
            )
        self.size, self.resolution = float(size), int(resolution)
        self.voxel_size = self.size / self.resolution
        self.truncation = truncation_voxels * self.voxel_size
        self.device = torch.device(device)
        self.along_ray = bool(along_ray)
        self.origin = torch.tensor(origin, dtype=torch.float32, device=self.device)
        shape = (self.resolution,) * 3
        self.tsdf = torch.ones(shape, device=self.device)
        self.weight = torch.zeros(shape, device=self.device)
        self._corner = tuple(float(x) for x in origin)
        self._centres = _voxel_centres(self.size, self.resolution, self._corner, self.device)

    def integrate(
        self,
        depth: np.ndarray | torch.Tensor,
        intrinsic: CameraIntrinsic,
        T_world_camera: np.ndarray | torch.Tensor,
    ) -> None:
        """Fuse depth images (V, H, W) or (H, W) [m, 0 = no return] seen from poses
        ``T_world_camera`` (V, 4, 4) or (4, 4), all at once, by weighted averaging."""
        depth = torch.as_tensor(depth, dtype=torch.float32, device=self.device)
        T = torch.as_tensor(T_world_camera, dtype=torch.float32, device=self.device)
        if depth.ndim == 2:
            depth = depth[None]
        if T.ndim == 2:
            T = T[None]
        if depth.shape[1:] != (intrinsic.height, intrinsic.width):
            raise ValueError(
                f"depth must be (V, {intrinsic.height}, {intrinsic.width}), "
                f"got {tuple(depth.shape)}"
            )
        if T.shape != (depth.shape[0], 4, 4):
            raise ValueError(
                f"T_world_camera must be ({depth.shape[0]}, 4, 4), got {tuple(T.shape)}"
            )

        # voxel centres in every camera frame: p_cam = Rᵀ (p − t)
        p = torch.einsum("vji,vnj->vni", T[:, :3, :3], self._centres[None] - T[:, None, :3, 3])
        z = p[..., 2]
        safe_z = z.clamp_min(1e-6)
        u = torch.round(intrinsic.fx * p[..., 0] / safe_z + intrinsic.cx).long()
        v = torch.round(intrinsic.fy * p[..., 1] / safe_z + intrinsic.cy).long()
        inside = (z > 0) & (u >= 0) & (u < intrinsic.width) & (v >= 0) & (v < intrinsic.height)
        views = torch.arange(depth.shape[0], device=self.device)[:, None].expand_as(u)
        d = depth[views, v.clamp(0, intrinsic.height - 1), u.clamp(0, intrinsic.width - 1)]
        sdf = d - z
        if self.along_ray:
            sdf = sdf * torch.sqrt(
                1
                + ((u - intrinsic.cx) / intrinsic.fx) ** 2
                + ((v - intrinsic.cy) / intrinsic.fy) ** 2
            )
        # seen, and not hidden deeper than the truncation band behind the surface
        valid = inside & (d > 0) & (sdf >= -self.truncation)
        observed = (sdf / self.truncation).clamp(max=1.0) * valid
        added = valid.float().sum(dim=0).reshape(self.tsdf.shape)
        total = self.weight + added
        fused = (
            self.tsdf * self.weight + observed.sum(dim=0).reshape(self.tsdf.shape)
        ) / total.clamp_min(1)
        self.tsdf = torch.where(total > 0, fused, self.tsdf)
        self.weight = total

    def grid(self) -> torch.Tensor:
        """The TSDF values (R, R, R) in [-1, 1]; unobserved voxels read 1 (free)."""
        return self.tsdf.clone()

    def point_cloud(self) -> torch.Tensor:
        """Surface points (M, 3) [m] of the fused volume (`surface_points` of its grid)."""
        return surface_points(self.tsdf, self.size, self._corner)


def surface_points(
    tsdf: torch.Tensor, size: float = WORKSPACE_SIZE, origin: tuple[float, ...] = (0.0, 0.0, 0.0)
) -> torch.Tensor:
    """Surface points (M, 3) [m] of a TSDF grid (R, R, R) in [-1, 1] over the cube of side
    ``size`` [m] whose corner is ``origin`` (3,) [m]: the zero crossings between neighbouring
    voxels that are both inside the truncation band (|d| < 1), linearly interpolated. A grid
    alone suffices: unobserved voxels read exactly 1, so a crossing never involves one."""
    resolution = tsdf.shape[0]
    centres = _voxel_centres(float(size), resolution, tuple(origin), tsdf.device)
    centres = centres.reshape(*tsdf.shape, 3)
    points = []
    for axis in range(3):
        a, b = tsdf.narrow(axis, 0, resolution - 1), tsdf.narrow(axis, 1, resolution - 1)
        crossing = (a * b < 0) & (a.abs() < 1) & (b.abs() < 1)
        t = (a / (a - b))[crossing][:, None]
        pa = centres.narrow(axis, 0, resolution - 1)[crossing]
        pb = centres.narrow(axis, 1, resolution - 1)[crossing]
        points.append(pa + t * (pb - pa))
    return torch.cat(points)


@functools.lru_cache(maxsize=8)
def _voxel_centres(
    size: float, resolution: int, origin: tuple[float, ...], device: torch.device
) -> torch.Tensor:
    """The (resolution³, 3) voxel centres [m] of a grid, built once per geometry: a detector
    fuses a fresh volume for every image, and rebuilding them took a sixth of the fusion.
    Read only."""
    idx = torch.arange(resolution, device=device, dtype=torch.float32)
    grid = torch.stack(torch.meshgrid(idx, idx, idx, indexing="ij"), dim=-1)
    offset = torch.tensor(origin, dtype=torch.float32, device=device)
    return ((grid + 0.5) * (size / resolution) + offset).reshape(-1, 3)
