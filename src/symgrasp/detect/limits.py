"""Grasps on objects the workspace cube cuts.

The detector sees the 30 cm cube alone (`symgrasp.workspace`): the TSDF fusion drops every
depth point outside it, so an object taller than the cube, or one standing across its side, is
cut, and the cut reads as a thin graspable edge. A grasp there can score high and pass the
approach check (which sees the fused surface only), yet its hand would enter the part of the
object the cube left out. `cut_grasps` finds such grasps among the depth points the cube left
out: those above its top or past its sides, and more than `TABLE_BAND` above the table (which
runs on past the sides). A grasp is cut where one of them lies in its hand, open and swept in
from the pre-grasp (`symgrasp.sim.collision.hand_collides`, the approach check's test on these
points) or closed (`closing_box`, the space its fingers close through), both grown by the
approach check's clearance (`SURFACE_CLEARANCE`). A grasp on a cut object whose hand keeps clear
of its part outside the cube (a side grasp low on a tall bottle) is not cut: all its hand meets
is inside the cube, seen.

`mark_cut` flags (`Grasp.cut`) or removes them with one `CutObjectWarning`: what
`GraspDetector` runs on its grasps after decoding and the approach check (its
``cut_objects``). numpy and the collision check's k-d tree only: a built-in hand's boxes are
stored, so no simulator loads.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from symgrasp.config import SURFACE_CLEARANCE
from symgrasp.detect.grasp import Grasp
from symgrasp.names import CUT_OBJECTS
from symgrasp.perception import CameraIntrinsic
from symgrasp.sim.collision import hand_boxes, hand_collides
from symgrasp.sim.grippers import GripperSpec
from symgrasp.sim.protocol import PREGRASP_DISTANCE
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

CELL = 0.003
"""[m] The points left out are thinned to one per cube of this edge (on a grid from the
workspace's corner) before the hand meets them: a depth image's points lie about a millimetre
apart at half a metre, and testing them all costs about 5× as much on a scene with tall
objects, for a check against boxes of 6 mm and more and a detector whose grid is 7.5 mm."""

TABLE_BAND = 0.02
"""[m] Depth points less than this above the table plane count as the table, which runs on past
the cube's sides: a depth scale error of 3 % (the ``dex`` noise's SD) moves a table seen from
half a metre by 1.5 cm."""


class CutObjectWarning(UserWarning):
    """A detection's grasps include some whose hand meets depth points the workspace cube left
    out (the message says how many, and whether they were flagged or removed).
    ``warnings.simplefilter("ignore", CutObjectWarning)`` silences it."""


def check_cut_objects(mode: str) -> str:
    """``mode`` if it is one of `CUT_OBJECTS`, else ValueError naming them."""
    if mode not in CUT_OBJECTS:
        raise ValueError(f"cut_objects must be one of {', '.join(CUT_OBJECTS)}, got {mode!r}")
    return mode


def closing_box(gripper: GripperSpec) -> tuple[np.ndarray, np.ndarray]:
    """The space ``gripper``'s fingers close through, a box in the TCP frame: centre (3,) and
    half-extents (3,) [m], along e_x from the palm's face to the fingertips, across e_y the
    pads' width, along e_z the opening between the open pads. With the open hand's boxes it
    holds the hand closed."""
    tip, depth = gripper.tip_beyond_tcp, gripper.finger_depth
    centre = np.array([tip - depth / 2, 0.0, 0.0])
    return centre, np.array([depth / 2, gripper.pad_width / 2, gripper.max_width / 2])


def left_out(points: np.ndarray, origin: np.ndarray | tuple[float, float, float]) -> np.ndarray:
    """(N,) Whether each of ``points`` (N, 3) [m, world frame] lies outside the workspace cube
    ``origin + [0, WORKSPACE_SIZE]³`` and more than `TABLE_BAND` above the table
    (``origin``'s z + `TABLE_HEIGHT`): the points the fusion drops that can belong to an object;
    a non-finite point does not."""
    offset = np.asarray(points, dtype=float) - np.asarray(origin, dtype=float)
    inside = _within(offset, np.zeros(3), np.full(3, WORKSPACE_SIZE))
    finite = np.isfinite(offset[:, 0]) & np.isfinite(offset[:, 1]) & np.isfinite(offset[:, 2])
    return ~inside & (offset[:, 2] > TABLE_HEIGHT + TABLE_BAND) & finite


def raised_points(
    views: np.ndarray,
    intrinsic: CameraIntrinsic,
    T_world_camera: np.ndarray,
    origin: np.ndarray | tuple[float, float, float],
) -> np.ndarray:
    """The world points (N, 3) [m] of the pixels of depth images ``views`` (V, H, W) [m,
    0 = missing] taken by ``intrinsic`` from ``T_world_camera`` (V, 4, 4) that lie more than
    `TABLE_BAND` above the table (``origin``'s z + `TABLE_HEIGHT`): the only ones
    `left_out` can keep. Each pixel's height is found first, from one image-sized product, and
    only the raised pixels become points: most of a tabletop image is table."""
    floor = float(np.asarray(origin, dtype=float)[2]) + TABLE_HEIGHT + TABLE_BAND
    u = (np.arange(intrinsic.width) - intrinsic.cx) / intrinsic.fx
    v = (np.arange(intrinsic.height) - intrinsic.cy) / intrinsic.fy
    found = [np.empty((0, 3))]
    for depth, T in zip(views, np.asarray(T_world_camera, dtype=float), strict=True):
        R, t = T[:3, :3], T[:3, 3]
        rise = R[2, 0] * u[None, :] + R[2, 1] * v[:, None] + R[2, 2]  # world z per metre of depth
        rows, cols = np.nonzero((depth > 0) & (depth * rise + t[2] > floor))
        d = depth[rows, cols].astype(float)
        # einsum, not @: a BLAS call leaves OpenBLAS' threads spinning beside the next network
        found.append(np.einsum("nj,ij->ni", np.stack([u[cols] * d, v[rows] * d, d], axis=1), R) + t)
    return np.concatenate(found)


def cut_grasps(
    T_world_tcp: np.ndarray,
    gripper: GripperSpec,
    points: np.ndarray,
    origin: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0),
    clearance: float = SURFACE_CLEARANCE,
) -> np.ndarray:
    """(G,) Whether each grasp's hand meets a depth point the workspace cube left out.

    Args:
        T_world_tcp: (G, 4, 4) grasp poses.
        gripper: the hand.
        points: (N, 3) depth points [m, world frame], all of a scene or any part of it that
            holds those `left_out` keeps (`raised_points`); the others are ignored.
        origin: the workspace cube's corner [m, world frame].
        clearance: how far [m] the hand's boxes, open and swept from the pre-grasp
            (`hand_collides`) and the `closing_box`, are grown before a point in them counts.

    The points are thinned to one per `CELL` first.
    """
    T = np.asarray(T_world_tcp, dtype=float)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise ValueError(f"T_world_tcp must be (G, 4, 4) grasp poses, got shape {T.shape}")
    cloud = np.asarray(points, dtype=float)
    if cloud.ndim != 2 or cloud.shape[1] != 3:
        raise ValueError(f"points must be (N, 3) [m], got shape {cloud.shape}")
    cut = np.zeros(len(T), dtype=bool)
    if not len(T):
        return cut
    cloud = cloud[left_out(cloud, origin)]
    tcp = T[:, :3, 3]
    reach = _reach(gripper) + clearance
    cloud = cloud[_within(cloud, tcp.min(axis=0) - reach, tcp.max(axis=0) + reach)]
    if not len(cloud):
        return cut
    cloud = _thinned(cloud, origin)
    cut |= hand_collides(T, gripper, cloud, tolerance=-clearance, table_height=-np.inf)
    todo = np.flatnonzero(~cut)
    if not len(todo):
        return cut
    # the closed hand: the points a k-d tree finds in the ball around each closing box, tested
    centre, half = closing_box(gripper)
    half = half + clearance
    middle = tcp[todo] + np.einsum("nij,j->ni", T[todo, :3, :3], centre)
    near = cKDTree(cloud).query_ball_point(middle, float(np.linalg.norm(half)), return_sorted=False)
    count = np.fromiter(map(len, near), dtype=np.int64, count=len(near))
    grasp = np.repeat(todo, count)
    point = np.fromiter(itertools.chain.from_iterable(near), dtype=np.int64, count=count.sum())
    in_tcp = np.einsum("nj,nji->ni", cloud[point] - tcp[grasp], T[grasp, :3, :3]) - centre
    cut[grasp[(np.abs(in_tcp) <= half).all(axis=1)]] = True
    return cut


def mark_cut(
    grasps: list[Grasp],
    gripper: GripperSpec,
    points: np.ndarray,
    origin: np.ndarray | tuple[float, float, float],
    mode: str,
    stacklevel: int = 1,
) -> list[Grasp]:
    """``grasps`` with those `cut_grasps` finds on ``points`` flagged (``mode`` ``"flag"``:
    `Grasp.cut` set, order kept) or left out (``"remove"``), with one `CutObjectWarning`
    naming how many when there are any; ``"ignore"``: ``grasps`` as they are, unchecked.
    ``stacklevel``: the line the warning names, 1 the one that called `mark_cut`, 2 its
    caller's, …"""
    if check_cut_objects(mode) == "ignore" or not grasps:
        return grasps
    cut = cut_grasps(np.array([g.pose for g in grasps]), gripper, points, origin)
    if not cut.any():
        return grasps
    done = "flagged (Grasp.cut)" if mode == "flag" else "removed"
    warnings.warn(
        f"{int(cut.sum())} of {len(grasps)} grasps {done}: the hand, approaching or closed, "
        f"meets depth points above the top or past the sides of the workspace, the "
        f"{WORKSPACE_SIZE * 100:g} cm cube from {tuple(round(float(x), 3) for x in origin)} m "
        "(an object the cube cuts, whose cut reads as an edge): move the workspace "
        "(workspace_origin) to hold the object, or check those grasps",
        CutObjectWarning,
        stacklevel=stacklevel + 1,
    )
    if mode == "remove":
        return [grasp for grasp, c in zip(grasps, cut, strict=True) if not c]
    return [replace(grasp, cut=True) if c else grasp for grasp, c in zip(grasps, cut, strict=True)]


def _within(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(N,) Whether each of ``points`` (N, 3) lies in the box ``lo``–``hi`` (3,), column by
    column: a reduction along the rows' 3 coordinates costs numpy several times as much."""
    inside = np.ones(len(points), dtype=bool)
    for axis in range(3):
        inside &= (points[:, axis] >= lo[axis]) & (points[:, axis] <= hi[axis])
    return inside


def _thinned(points: np.ndarray, origin: np.ndarray | tuple[float, float, float]) -> np.ndarray:
    """One of ``points`` (N, 3) [m] in each occupied `CELL` of a grid from ``origin``."""
    cell = np.floor((points - np.asarray(origin, dtype=float)) / CELL).astype(np.int64)
    cell -= cell.min(axis=0)
    span = cell.max(axis=0) + 1
    _, first = np.unique(
        (cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2], return_index=True
    )
    return points[first]


def _reach(gripper: GripperSpec) -> float:
    """[m] How far from the TCP the hand reaches, open and swept from the pre-grasp or closed:
    no point farther from every grasp can meet it."""
    boxes = hand_boxes(gripper)
    swept = np.linalg.norm(boxes.centre, axis=1) + np.linalg.norm(boxes.half, axis=1)
    closed = sum(map(np.linalg.norm, closing_box(gripper)))
    return float(max(swept.max() + PREGRASP_DISTANCE, closed))
