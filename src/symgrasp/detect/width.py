"""What a hand needs of each grasp beyond its pose: how far to open, measured on the fused
scene between its fingers (docs/robot.md, "What a robot needs of each grasp").

The closing region of a grasp, in its frame (e_x approach, e_y, e_z closing; origin the TCP),
is the box the open hand's fingers enclose: along e_x from the palm face to the fingertips
(``tip_beyond_tcp - finger_depth`` to ``tip_beyond_tcp``), along e_y the pads' width
(±``pad_width / 2``), along e_z the open pads' gap (±``max_width / 2``). Points less than
`TABLE_BAND` above the table are left out. Of the points in it:

- ``object_width`` [m]: the extent along e_z (max − min) of the seen surface's points: the
  object as the camera saw it between the fingers. A single view sees one side of an object,
  so this tends to fall short of its width (None: no point there);
- ``opening_width`` [m]: ``2 · max |z| + OPENING_MARGIN`` over the surface's points and the
  points the TSDF holds to be inside the object (its voxels below 0, up to the truncation
  distance behind the seen surface), capped at the hand's ``max_width`` (and ``max_width``
  where no point lies there): the fingers close symmetrically about the TCP, so each must start
  outside the farthest point on its side, and the side the camera did not see lies behind
  the surface it saw.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch
from scipy.spatial import cKDTree

from symgrasp.detect.grasp import Grasp
from symgrasp.perception import surface_points
from symgrasp.sim.grippers import GripperSpec
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE, WORKSPACE_SIZE

OPENING_MARGIN = 0.02
"""[m] added to the opening the points need, 1 cm per finger: on rendered single views of 40
boxes the true box reached up to 9 mm past the points the TSDF holds (its unseen back, edges
the TSDF rounds), so that no finger met it (docs/robot.md)."""

TABLE_BAND = VOXEL_SIZE
"""[m] points less than this above the table are the table's, not the object's: the table's
TSDF surface strays from its plane by up to about a voxel under sensor noise, and a table point
between the fingertips would open the hand fully for nothing."""


def closing_region(gripper: GripperSpec) -> tuple[np.ndarray, np.ndarray]:
    """The box ``(lo (3,), hi (3,))`` [m] in the grasp frame between the open fingers of
    ``gripper``."""
    half_y, half_z = gripper.pad_width / 2, gripper.max_width / 2
    lo = np.array([gripper.tip_beyond_tcp - gripper.finger_depth, -half_y, -half_z])
    hi = np.array([gripper.tip_beyond_tcp, half_y, half_z])
    return lo, hi


def measured_widths(
    grasps: list[Grasp], gripper: GripperSpec, tsdf: torch.Tensor, origin: np.ndarray
) -> list[Grasp]:
    """`with_widths` on a workspace TSDF ``tsdf`` (40, 40, 40) in [-1, 1] whose cube's corner
    is ``origin`` (3,) [m], the table `TABLE_HEIGHT` above it: its surface points seen, and
    the centres of its voxels below 0 inside."""
    corner = tuple(float(x) for x in origin)
    seen = surface_points(tsdf, WORKSPACE_SIZE, corner).cpu().numpy()
    index = torch.nonzero(tsdf < 0).cpu().numpy()
    inside = np.asarray(origin) + (index + 0.5) * (WORKSPACE_SIZE / RESOLUTION)
    return with_widths(grasps, gripper, seen, corner[2] + TABLE_HEIGHT, inside)


def with_widths(
    grasps: list[Grasp],
    gripper: GripperSpec,
    seen: np.ndarray,
    table_height: float,
    inside: np.ndarray | None = None,
) -> list[Grasp]:
    """``grasps`` for the hand ``gripper``, each with its ``object_width`` measured on the seen
    surface's points ``seen`` (M, 3) [m, world frame], its ``opening_width`` on those and the
    points ``inside`` (K, 3) [m] the object fills behind them (None: none) (the module's rule),
    points less than `TABLE_BAND` above ``table_height`` [m, world z] left out; and the hand's
    ``tcp_offset``, which places its flange (`Grasp.flange_pose`). Order and all else kept."""
    seen = np.asarray(seen, dtype=float).reshape(-1, 3)
    inside = np.empty((0, 3)) if inside is None else np.asarray(inside, dtype=float).reshape(-1, 3)
    points = np.concatenate([seen, inside])
    is_seen = np.arange(len(points)) < len(seen)
    above = points[:, 2] > table_height + TABLE_BAND
    points, is_seen = points[above], is_seen[above]
    lo, hi = closing_region(gripper)
    reach = float(np.linalg.norm(np.maximum(-lo, hi)))  # the region's farthest corner
    near = [[] for _ in grasps]
    if len(points) and grasps:
        near = cKDTree(points).query_ball_point(np.array([g.position for g in grasps]), reach)
    measured = []
    for grasp, index in zip(grasps, near, strict=True):
        # einsum, not @: a BLAS call leaves OpenBLAS' threads spinning beside the next network
        local = np.einsum("nj,ji->ni", points[index] - grasp.position, grasp.pose[:3, :3])
        between = np.all((local >= lo) & (local <= hi), axis=1)
        z, z_seen = local[between, 2], local[between & is_seen[index], 2]
        opening = gripper.max_width
        if len(z):
            opening = min(2 * float(np.abs(z).max()) + OPENING_MARGIN, opening)
        width = float(z_seen.max() - z_seen.min()) if len(z_seen) else None
        measured.append(
            replace(grasp, opening_width=opening, object_width=width, tcp_offset=gripper.tcp_offset)
        )
    return measured
