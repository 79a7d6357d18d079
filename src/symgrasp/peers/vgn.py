"""VGN's network run by symgrasp: Breyer, Chung, Ott, Siegwart and Nieto, "Volumetric Grasping
Network: Real-time 6 DOF Grasp Detection in Clutter", CoRL 2020, from its public trained
weights (``vgn_conv.pth``, BSD 3-Clause, read from the data folder's ``peers/vgn/``; never part
of this package). Its conventions are read from its code (``ethz-asl/vgn``) and from GIGA's
evaluation of it (Jiang et al., RSS 2021; ``UT-Austin-RPL/GIGA``), whose single-view numbers
the field's table quotes; docs/peers.md gives the evidence for each.

- **Input** (`fuse`, `vgn_grid`): VGN fuses depth with Open3D's ``UniformTSDFVolume`` (40³
  over 0.30 m, truncation 4 voxels, the signed distance measured along each pixel's ray,
  depth beyond 2 m dropped) and reads it through Open3D's voxel-grid extraction: a voxel
  observed with −0.98 ≤ tsdf < 0.98 holds (tsdf + 1) / 2, every other voxel (unseen, free
  beyond the band, hidden behind it) holds 0. A surface therefore reads 0.5, free space
  above it, the inside of an object below it.
- **Network** (`VGNNet`): three stride-2 3D convolutions (16, 32, 64 channels; kernels 5,
  3, 3; ReLU) down to 5³, three convolutions (64, 32, 16; kernels 3, 3, 5; ReLU) each followed
  by nearest-neighbour upsampling to 10³, 20³, 40³, and three 5³ heads: grasp quality
  (sigmoid), rotation (a unit quaternion, scalar last) and opening width (in voxels).
- **Decoding** (`decode`, GIGA's ``detection.VGN`` with ``--best --force``): the quality
  smoothed by a Gaussian of σ = 1 voxel; voxels kept within two 6-connected steps of the free
  side of a surface (grid > 0.5) without crossing its inside; widths outside [1.33, 9.33]
  voxels (10–70 mm) dropped; 2 voxels at the x and y borders and the 7 lowest layers dropped
  (GIGA's bound); quality ≥ 0.9 kept, or, when none is, the single best voxel of quality
  ≥ 0.5; non-maximum suppression over a 4³ window; best quality first.
- **Grasp frame** (`to_symgrasp`): VGN's grasp at voxel (i, j, k) has its TCP at (i, j, k) ×
  7.5 mm (VGN's labels round a TCP to the nearest voxel index, a corner of the TSDF's voxel,
  not its centre), approaches along its z and closes along its y; its TCP lies
  `FINGER_REACH` behind the fingertips of its Panda hand. symgrasp's frame is
  [e_x approach, e_y, e_z closing] = [z, x, y] of VGN's, and its hands' TCPs lie
  ``tip_beyond_tcp`` behind their fingertips: the TCP moves forward by the difference, so the
  fingertips reach where VGN's would.
"""

from __future__ import annotations

import time
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from scipy import ndimage
from torch import nn
from torch.nn import functional as F

from symgrasp.detect.grasp import Grasp
from symgrasp.detect.planner import Observation
from symgrasp.digest import file_sha256
from symgrasp.objects.folder import DATA_ENV, MissingData, data_folder
from symgrasp.perception import CameraIntrinsic, TSDFVolume
from symgrasp.rotation.geometry import quaternion_to_matrix
from symgrasp.sim.grippers import FRANKA, GripperSpec
from symgrasp.workspace import RESOLUTION, VOXEL_SIZE

Tensor = torch.Tensor

WEIGHTS = Path("peers") / "vgn" / "vgn_conv.pth"
"""VGN's trained weights, relative to the data folder (`symgrasp.objects.folder`)."""

WEIGHTS_SHA256 = "ba3391d0805e9c9b178cd18106866313cee808ff2b654f689663e92a814cec4b"
"""The SHA-256 of the public ``vgn_conv.pth`` (``ethz-asl/vgn`` at b47ab53); another file is
loaded with its own hash recorded, not refused."""

TRUNCATION_VOXELS = 4.0
"""VGN's truncation distance [voxels] (``perception.TSDFVolume``: 4 × voxel size)."""

DEPTH_LIMIT = 2.0
"""[m] VGN's RGB-D images drop depth beyond this (Open3D's ``depth_trunc``)."""

BAND = 0.98
"""Open3D's voxel-grid extraction keeps voxels with −BAND ≤ tsdf < BAND."""

SURFACE = 0.5
"""The grid value of a surface; above it is free space, below it an object's inside."""

QUALITY_THRESHOLD = 0.9
"""Quality a grasp needs (VGN's and GIGA's ``threshold``/``qual_th``)."""

FORCED_QUALITY = 0.5
"""Quality of the one grasp kept when none reaches the threshold (GIGA's ``LOW_TH``)."""

WIDTH_RANGE = (1.33, 9.33)
"""Predicted opening widths kept [voxels] (10–70 mm; VGN's ``min_width``, ``max_width``)."""

BORDER = (2, 2, 7)
"""Voxels dropped at the x and y borders and at the bottom (GIGA's ``bound``: 2, 2 and 5.5 cm
over 7.5 mm voxels, rounded down)."""

NMS_SIZE = 4
"""Edge of the non-maximum suppression window [voxels] (``max_filter_size``)."""

FINGER_REACH = 0.0584 + 0.0539 - (0.04 + 0.022)
"""[m] How far the fingertips of VGN's simulated Panda hand reach past its TCP along the
approach (50.3 mm, VGN's "finger depth" of 50 mm): the fingers are mounted 58.4 mm along the
hand's z and the Franka finger mesh reaches 53.9 mm further; the TCP is 22 mm past the hand's
centre of mass (``simulation.Gripper.T_body_tcp``), which its URDF puts 40 mm along z."""

ORDERS = ("best", "random")
"""Grasp orders: best quality first (GIGA's ``--best``) or a random permutation (VGN's own
evaluation), seeded by the observation's bytes so that a round replays."""


class VGNNet(nn.Module):
    """VGN's fully convolutional network ("ConvNet"): a TSDF grid (B, 1, 40, 40, 40) in VGN's
    convention (`vgn_grid`) to quality (B, 40, 40, 40) in [0, 1], rotation (B, 4, 40, 40, 40)
    unit quaternions (x, y, z, w) and width (B, 40, 40, 40) [voxels]."""

    def __init__(self) -> None:
        super().__init__()
        self.down = nn.ModuleList(
            nn.Conv3d(c_in, c_out, k, stride=2, padding=k // 2)
            for c_in, c_out, k in ((1, 16, 5), (16, 32, 3), (32, 64, 3))
        )
        self.up = nn.ModuleList(
            nn.Conv3d(c_in, c_out, k, padding=k // 2)
            for c_in, c_out, k in ((64, 64, 3), (64, 32, 3), (32, 16, 5))
        )
        self.quality = nn.Conv3d(16, 1, 5, padding=2)
        self.rotation = nn.Conv3d(16, 4, 5, padding=2)
        self.width = nn.Conv3d(16, 1, 5, padding=2)

    def forward(self, grid: Tensor) -> tuple[Tensor, Tensor, Tensor]:
        x = grid
        for conv in self.down:
            x = F.relu(conv(x))
        for conv, size in zip(self.up, (10, 20, 40), strict=True):
            x = F.interpolate(F.relu(conv(x)), size=size, mode="nearest")
        quality = torch.sigmoid(self.quality(x))[:, 0]
        return quality, F.normalize(self.rotation(x), dim=1), self.width(x)[:, 0]


_STATE_KEYS = {
    **{f"encoder.conv{i + 1}": f"down.{i}" for i in range(3)},
    **{f"decoder.conv{i + 1}": f"up.{i}" for i in range(3)},
    "conv_qual": "quality",
    "conv_rot": "rotation",
    "conv_width": "width",
}
"""The layers of VGN's state dict (its module names) and `VGNNet`'s."""


def weights_path() -> Path:
    """Where VGN's weights are looked for: ``<data folder>/peers/vgn/vgn_conv.pth``."""
    return data_folder() / WEIGHTS


def check_weights(path: str | Path | None = None) -> Path:
    """The weights file ``path`` (default `weights_path`); `MissingData` naming where it was
    looked for and how to get it when it is not there."""
    if path is not None:
        if not Path(path).is_file():
            raise ValueError(f"VGN weights: no file at {path}")
        return Path(path)
    path = weights_path()
    if not path.is_file():
        raise MissingData(
            f"VGN's weights are not in the data folder: {path} does not exist; place "
            "vgn_conv.pth there (ethz-asl/vgn at commit b47ab53, assets/models/vgn_conv.pth, "
            f"BSD 3-Clause: docs/peers.md), or point {DATA_ENV} at a folder holding {WEIGHTS}"
        )
    return path


def load_network(path: str | Path | None = None) -> VGNNet:
    """`VGNNet` with the weights of ``path`` (default: the data folder's, `check_weights`), a
    torch state dict with VGN's layer names. ValueError naming the file when it is not one
    of VGN's (other layers or shapes)."""
    path = check_weights(path)
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # a legacy pickle, a zip, or neither: torch says which
        raise ValueError(f"VGN weights {path}: not a torch state dict ({error})") from None
    renamed = {}
    for key, value in state.items() if isinstance(state, dict) else ():
        layer, _, kind = key.rpartition(".")
        if layer in _STATE_KEYS:
            renamed[f"{_STATE_KEYS[layer]}.{kind}"] = value
    network = VGNNet()
    expected = {k: tuple(v.shape) for k, v in network.state_dict().items()}
    found = {k: tuple(v.shape) for k, v in renamed.items()}
    if found != expected or len(renamed) != len(state):
        raise ValueError(
            f"VGN weights {path}: not VGN's ConvNet (expected the layers "
            f"{', '.join(_STATE_KEYS)} with VGN's shapes, got {len(state) if isinstance(state, dict) else 0} "
            f"tensors of which {len(found)} match)"
        )
    network.load_state_dict(renamed)
    return network.eval()


def fuse(
    depth: np.ndarray,
    intrinsic: CameraIntrinsic,
    T_world_camera: np.ndarray,
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    device: str | torch.device = "cpu",
) -> TSDFVolume:
    """The 40³ TSDF of the workspace from depth images (V, H, W) [m, 0 = missing] at poses
    ``T_world_camera`` (V, 4, 4), fused as VGN's Open3D volume fuses them: the distance along
    each pixel's ray, truncation 4 voxels, depth beyond `DEPTH_LIMIT` dropped."""
    depth = np.asarray(depth, dtype=np.float32)
    depth = np.where(np.isfinite(depth) & (depth <= DEPTH_LIMIT), depth, 0.0)
    volume = TSDFVolume(
        truncation_voxels=TRUNCATION_VOXELS, origin=origin, device=device, along_ray=True
    )
    volume.integrate(depth, intrinsic, T_world_camera)
    return volume


def vgn_grid(volume: TSDFVolume) -> Tensor:
    """The network's input (40, 40, 40) from a fused ``volume``: (tsdf + 1) / 2 where a voxel
    was observed with −`BAND` ≤ tsdf < `BAND`, else 0 (Open3D's voxel-grid extraction, which
    VGN's ``TSDFVolume.get_grid`` reads)."""
    tsdf = volume.tsdf
    kept = (volume.weight > 0) & (tsdf >= -BAND) & (tsdf < BAND)
    return torch.where(kept, (tsdf + 1) / 2, torch.zeros_like(tsdf))


@dataclass(frozen=True)
class Decoded:
    """VGN's grasps in its own terms, best first (`decode`): voxel ``index`` (M, 3), ``quality``
    (M,), ``quaternion`` (M, 4) (x, y, z, w) of VGN's grasp frame, ``width`` (M,) [voxels]."""

    index: np.ndarray
    quality: np.ndarray
    quaternion: np.ndarray
    width: np.ndarray


def decode(
    grid: np.ndarray,
    quality: np.ndarray,
    rotation: np.ndarray,
    width: np.ndarray,
    threshold: float = QUALITY_THRESHOLD,
    force: bool = True,
) -> Decoded:
    """VGN's grasps from its input ``grid`` (40, 40, 40) and its outputs: ``quality`` (40, 40,
    40), ``rotation`` (40, 40, 40, 4), ``width`` (40, 40, 40) [voxels] (GIGA's decoding, module
    docstring). ``force``: when no voxel reaches ``threshold``, keep the best one of quality ≥
    `FORCED_QUALITY` (GIGA's ``--force``)."""
    quality = ndimage.gaussian_filter(quality.astype(np.float32), sigma=1.0, mode="nearest")
    free = grid > SURFACE
    inside = (grid > 1e-3) & (grid < SURFACE)
    near_free = ndimage.binary_dilation(free, iterations=2, mask=~inside)
    quality[~near_free] = 0.0
    quality[(width < WIDTH_RANGE[0]) | (width > WIDTH_RANGE[1])] = 0.0
    bx, by, bz = BORDER
    quality[:bx], quality[-bx:], quality[:, :by], quality[:, -by:] = 0.0, 0.0, 0.0, 0.0
    quality[:, :, :bz] = 0.0
    quality[quality < FORCED_QUALITY] = 0.0
    best_only = force and not (quality >= threshold).any()
    if not best_only:
        quality[quality < threshold] = 0.0
    peaks = (quality > 0) & (quality == ndimage.maximum_filter(quality, size=NMS_SIZE))
    index = np.argwhere(peaks)
    order = np.argsort(-quality[tuple(index.T)], kind="stable")[: 1 if best_only else None]
    index = index[order]
    at = tuple(index.T)
    return Decoded(index, quality[at], rotation[at], width[at])


def to_symgrasp(position: np.ndarray, quaternion: np.ndarray, gripper: GripperSpec) -> np.ndarray:
    """``T_world_tcp`` (M, 4, 4) in symgrasp's grasp frame for ``gripper`` of VGN's grasps with
    TCPs ``position`` (M, 3) [m] and rotations ``quaternion`` (M, 4) (x, y, z, w): e_x = VGN's
    z (approach), e_y = its x, e_z = its y (closing); the TCP moved `FINGER_REACH` −
    ``gripper.tip_beyond_tcp`` along e_x, so the fingertips reach where VGN's would."""
    q = torch.as_tensor(np.asarray(quaternion, dtype=np.float64)).reshape(-1, 4)
    R = quaternion_to_matrix(q / q.norm(dim=-1, keepdim=True)).numpy()[:, :, [2, 0, 1]]
    poses = np.tile(np.eye(4), (len(R), 1, 1))
    poses[:, :3, :3] = R
    shift = FINGER_REACH - gripper.tip_beyond_tcp
    poses[:, :3, 3] = np.asarray(position, dtype=float).reshape(-1, 3) + shift * R[:, :, 0]
    return poses


class VGN:
    """VGN's network as a `symgrasp.detect.planner.GraspPlanner` (module docstring).

    Args:
        gripper: the hand to execute its grasps with (default `FRANKA`, the Panda hand VGN
            was trained for).
        weights: the weights file (default: the data folder's, `check_weights`).
        quality_threshold: quality a grasp needs (`QUALITY_THRESHOLD`).
        force_detection: when none reaches it, return the single best grasp of quality ≥
            `FORCED_QUALITY` (GIGA's ``--force``).
        order: ``"best"`` (GIGA's ``--best``) or ``"random"`` (VGN's evaluation; `ORDERS`).
        workspace_origin: world position [m] of the workspace cube's corner.
        device: where fusion and network run.
    """

    name = "vgn"

    def __init__(
        self,
        gripper: GripperSpec = FRANKA,
        weights: str | Path | None = None,
        *,
        quality_threshold: float = QUALITY_THRESHOLD,
        force_detection: bool = True,
        order: str = "best",
        workspace_origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
        device: str | torch.device = "cpu",
    ) -> None:
        if not 0.0 <= quality_threshold <= 1.0:
            raise ValueError(f"quality_threshold must be in [0, 1], got {quality_threshold}")
        if order not in ORDERS:
            raise ValueError(f"order must be one of {ORDERS}, got {order!r}")
        origin = np.asarray(workspace_origin, dtype=float)
        if origin.shape != (3,) or not np.isfinite(origin).all():
            raise ValueError(
                f"workspace_origin must be 3 finite numbers [m], got {workspace_origin}"
            )
        self.gripper = gripper
        path = check_weights(weights)
        self.version = file_sha256(path)
        self.device = torch.device(device)
        self.network = load_network(path).to(self.device)
        self.quality_threshold = float(quality_threshold)
        self.force_detection = bool(force_detection)
        self.order = order
        self.origin = origin
        self.timing: dict[str, float] = {}
        """Milliseconds per stage of the last call (``tsdf``, ``network``, ``decode``)."""

    def __repr__(self) -> str:
        return f"VGN(gripper={self.gripper.name!r}, order={self.order!r})"

    def fuse(
        self, depth: np.ndarray, intrinsic: CameraIntrinsic, T_world_camera: np.ndarray
    ) -> TSDFVolume:
        """VGN's TSDF of depth images (V, H, W) or (H, W) [m] (`fuse`)."""
        return fuse(depth, intrinsic, T_world_camera, tuple(self.origin), self.device)

    @torch.no_grad()
    def predict(self, grid: Tensor) -> dict[str, Tensor]:
        """The network's outputs on VGN's input ``grid`` (40, 40, 40) (`vgn_grid`):
        ``quality`` (40, 40, 40), ``rotation`` (40, 40, 40, 4) (x, y, z, w), ``width`` (40,
        40, 40) [voxels]."""
        grid = torch.as_tensor(grid, dtype=torch.float32, device=self.device)
        if grid.shape != (RESOLUTION,) * 3:
            raise ValueError(f"grid must be ({RESOLUTION},) * 3, got {tuple(grid.shape)}")
        quality, rotation, width = self.network(grid[None, None])
        return {"quality": quality[0], "rotation": rotation[0].movedim(0, -1), "width": width[0]}

    def plan(self, observation: Observation) -> list[Grasp]:
        """Grasps for ``observation`` in symgrasp's frame for `gripper`, in `order`."""
        return self.detect(observation.depth, observation.intrinsic, observation.T_world_camera)

    def detect(
        self, depth: np.ndarray, intrinsic: CameraIntrinsic, T_world_camera: np.ndarray
    ) -> list[Grasp]:
        """Grasps from depth images (V, H, W) or (H, W) [m] at ``T_world_camera`` (V, 4, 4)
        or (4, 4): VGN's fusion, network and decoding, then its frame in symgrasp's."""
        start = time.perf_counter()
        grid = vgn_grid(self.fuse(depth, intrinsic, T_world_camera))
        tsdf_ms = 1e3 * (time.perf_counter() - start)
        start = time.perf_counter()
        out = {k: v.cpu().numpy() for k, v in self.predict(grid).items()}
        network_ms = 1e3 * (time.perf_counter() - start)
        start = time.perf_counter()
        found = decode(
            grid.cpu().numpy(), out["quality"], out["rotation"], out["width"],
            self.quality_threshold, self.force_detection,
        )  # fmt: skip
        index, quality = found.index, found.quality
        order = np.arange(len(index))
        if self.order == "random":
            seed = zlib.crc32(np.ascontiguousarray(depth, dtype=np.float32).tobytes())
            order = np.random.default_rng(seed).permutation(len(index))
        positions = self.origin + index * VOXEL_SIZE
        poses = to_symgrasp(positions, found.quaternion, self.gripper)
        grasps = [
            Grasp(poses[m], float(quality[m]), voxel=tuple(int(i) for i in index[m])) for m in order
        ]
        self.timing = {
            "tsdf": tsdf_ms,
            "network": network_ms,
            "decode": 1e3 * (time.perf_counter() - start),
        }
        return grasps
