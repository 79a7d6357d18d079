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

The camera sees an object's front only: behind each point left out, along its camera ray, the
object may go on unseen (a tall box's back, above the cube). Where the points come with the
cameras that saw them, each point left out also stands for its **shadow**, the ray behind it
up to `SHADOW` deep, sampled every `SHADOW_CELL` at most; the samples still outside the cube and
above the table's band count as points. A depth scale error (the ``dex`` noise's) moves the seen
surface along the same rays: where it reads short, the object lies behind its points, in their
shadows.

`mark_cut` flags (`Grasp.cut`) or removes them with one `CutObjectWarning`: what
`GraspDetector` runs on its grasps after decoding and the approach check (its
``cut_objects``). numpy and the collision check's k-d tree only: a built-in hand's boxes are
stored, so no simulator loads.
"""

from __future__ import annotations

import itertools
import math
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

SHADOW = 0.10
"""[m] How deep behind a point left out, along its camera ray, an object may go on unseen: a
household object's depth and more. Of 5, 7.5 and 10 cm, the one that flagged the most grasps
whose hand meets a true object outside the cube, at most 5 % of the others flagged, on the
rendered study's first 30 scenes (docs/reports/real_scenes.md): 90 % of them against 86 %
without shadows, 2.3 % of the others against 1.1 %."""

SHADOW_CELL = 2 * CELL
"""[m] The shadows' spacing, along their rays and across them (one ray per cube of this edge):
a volume sampled every `CELL` holds 8× as many samples, and made the check several times
slower on the study's tables; this is about the hand's thinnest boxes (its pads, 6 mm thick
and more, 8 mm with the clearance)."""

TABLE_BAND = 0.02
"""[m] Depth points less than this above the table plane count as the table, which runs on past
the cube's sides: a depth scale error of 3 % (the ``dex`` noise's SD) moves a table seen from
half a metre by 1.5 cm."""


class CutObjectWarning(UserWarning):
    """A detection's grasps include some whose hand meets depth points the workspace cube left
    out, or their shadows (the message says how many, and whether they were flagged or
    removed).
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
) -> tuple[np.ndarray, np.ndarray]:
    """The world points (N, 3) [m] of the pixels of depth images ``views`` (V, H, W) [m,
    0 = missing] taken by ``intrinsic`` from ``T_world_camera`` (V, 4, 4) that lie more than
    `TABLE_BAND` above the table (``origin``'s z + `TABLE_HEIGHT`): the only ones
    `left_out` can keep; and the centre (N, 3) [m, world frame] of the camera that saw each
    (its shadow's start, `cut_grasps`). Each pixel's height is found first, from one
    image-sized product, and only the raised pixels become points: most of a tabletop image is
    table."""
    floor = float(np.asarray(origin, dtype=float)[2]) + TABLE_HEIGHT + TABLE_BAND
    u = (np.arange(intrinsic.width) - intrinsic.cx) / intrinsic.fx
    v = (np.arange(intrinsic.height) - intrinsic.cy) / intrinsic.fy
    found, eyes = [np.empty((0, 3))], [np.empty((0, 3))]
    for depth, T in zip(views, np.asarray(T_world_camera, dtype=float), strict=True):
        R, t = T[:3, :3], T[:3, 3]
        rise = R[2, 0] * u[None, :] + R[2, 1] * v[:, None] + R[2, 2]  # world z per metre of depth
        rows, cols = np.nonzero((depth > 0) & (depth * rise + t[2] > floor))
        d = depth[rows, cols].astype(float)
        # einsum, not @: a BLAS call leaves OpenBLAS' threads spinning beside the next network
        found.append(np.einsum("nj,ij->ni", np.stack([u[cols] * d, v[rows] * d, d], axis=1), R) + t)
        eyes.append(np.broadcast_to(t, (len(d), 3)))
    return np.concatenate(found), np.concatenate(eyes)


def cut_grasps(
    T_world_tcp: np.ndarray,
    gripper: GripperSpec,
    points: np.ndarray,
    origin: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0),
    clearance: float = SURFACE_CLEARANCE,
    viewpoints: np.ndarray | None = None,
) -> np.ndarray:
    """(G,) Whether each grasp's hand meets a depth point the workspace cube left out, or
    the shadow behind one.

    Args:
        T_world_tcp: (G, 4, 4) grasp poses.
        gripper: the hand.
        points: (N, 3) depth points [m, world frame], all of a scene or any part of it that
            holds those `left_out` keeps (`raised_points`); the others are ignored.
        origin: the workspace cube's corner [m, world frame].
        clearance: how far [m] the hand's boxes, open and swept from the pre-grasp
            (`hand_collides`) and the `closing_box`, are grown before a point in them counts.
        viewpoints: (N, 3) or (3,) [m, world frame] the centre of the camera that saw each
            point: each point left out then stands for its shadow too, `SHADOW` deep along its
            ray (the module's rule). None: the points alone (a whole surface: nothing behind
            them unseen).

    The points are thinned to one per `CELL` first, the shadows' rays to one per
    `SHADOW_CELL`.
    """
    T = np.asarray(T_world_tcp, dtype=float)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise ValueError(f"T_world_tcp must be (G, 4, 4) grasp poses, got shape {T.shape}")
    seen = np.asarray(points, dtype=float)
    if seen.ndim != 2 or seen.shape[1] != 3:
        raise ValueError(f"points must be (N, 3) [m], got shape {seen.shape}")
    if viewpoints is not None:
        eyes = np.asarray(viewpoints, dtype=float)
        if eyes.shape not in ((3,), seen.shape):
            raise ValueError(
                f"viewpoints must be (3,) or points' shape {seen.shape} [m], got {eyes.shape}"
            )
        eyes = np.broadcast_to(eyes, seen.shape)
    cut = np.zeros(len(T), dtype=bool)
    if not len(T):
        return cut
    out = left_out(seen, origin)
    tcp = T[:, :3, 3]
    middle, radius = _ball(gripper, clearance)
    middle = tcp + np.einsum("nij,j->ni", T[:, :3, :3], middle)
    lo, hi = middle.min(axis=0) - radius, middle.max(axis=0) + radius
    cloud = seen[_thinned(seen, origin, keep=out & _within(seen, lo, hi))]
    balls = cKDTree(middle)
    if viewpoints is not None:  # a shadow reaches a hand from up to SHADOW away
        near = np.flatnonzero(out & _within(seen, lo - SHADOW, hi + SHADOW))
        near = near[np.isfinite(balls.query(seen[near], distance_upper_bound=radius + SHADOW)[0])]
        behind = _shadow(seen[near], eyes[near], origin)
        cloud = np.concatenate([cloud, behind[left_out(behind, origin) & _within(behind, lo, hi)]])
    cloud = cloud[np.isfinite(balls.query(cloud, distance_upper_bound=radius)[0])]
    if not len(cloud):
        return cut
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
    viewpoints: np.ndarray | None = None,
) -> list[Grasp]:
    """``grasps`` with those `cut_grasps` finds on ``points`` (and their shadows, from
    ``viewpoints``) flagged (``mode`` ``"flag"``: `Grasp.cut` set, order kept) or left out
    (``"remove"``), with one `CutObjectWarning` naming how many when there are any;
    ``"ignore"``: ``grasps`` as they are, unchecked. ``stacklevel``: the line the warning
    names, 1 the one that called `mark_cut`, 2 its caller's, …"""
    if check_cut_objects(mode) == "ignore" or not grasps:
        return grasps
    poses = np.array([g.pose for g in grasps])
    cut = cut_grasps(poses, gripper, points, origin, viewpoints=viewpoints)
    if not cut.any():
        return grasps
    done = "flagged (Grasp.cut)" if mode == "flag" else "removed"
    warnings.warn(
        f"{int(cut.sum())} of {len(grasps)} grasps {done}: the hand, approaching or closed, "
        f"meets depth points, or the unseen space behind them, above the top or past the sides "
        f"of the workspace, the "
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


def _thinned(
    points: np.ndarray,
    origin: np.ndarray | tuple[float, float, float],
    cell: float = CELL,
    keep: np.ndarray | None = None,
) -> np.ndarray:
    """The indices of one of ``points`` (N, 3) [m] (of those ``keep`` (N,) marks, if given) in
    each occupied ``cell`` [m] of a grid from ``origin``."""
    index = np.arange(len(points)) if keep is None else np.flatnonzero(keep)
    if not len(index):
        return index
    cell = np.floor((points[index] - np.asarray(origin, dtype=float)) / cell).astype(np.int64)
    cell -= cell.min(axis=0)
    span = cell.max(axis=0) + 1
    _, first = np.unique(
        (cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2], return_index=True
    )
    return index[first]


def _shadow(
    points: np.ndarray, eyes: np.ndarray, origin: np.ndarray | tuple[float, float, float]
) -> np.ndarray:
    """(M, 3) [m] The shadows of ``points`` (N, 3) [m], one per `SHADOW_CELL` (`_thinned`):
    samples at most `SHADOW_CELL` apart along the ray from its camera's centre ``eyes`` (N, 3)
    beyond it, the last `SHADOW` deep."""
    first = _thinned(points, origin, SHADOW_CELL)
    ray = points[first] - eyes[first]
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    steps = math.ceil(SHADOW / SHADOW_CELL)
    depths = SHADOW * np.arange(1, steps + 1) / steps
    return (points[first, None, :] + depths[None, :, None] * ray[:, None, :]).reshape(-1, 3)


def _ball(gripper: GripperSpec, clearance: float) -> tuple[np.ndarray, float]:
    """The ball that holds the hand's boxes grown by ``clearance`` [m], open and swept from the
    pre-grasp or closed: its centre (3,) in the TCP frame and its radius [m]; no point outside
    every grasp's ball can meet a hand."""
    boxes = hand_boxes(gripper)
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))  # (8, 3)
    grown = signs[None] * (boxes.half[:, None] + clearance)
    open_hand = boxes.centre[:, None] + np.einsum("bij,bkj->bki", boxes.rotation, grown)
    open_hand = open_hand.reshape(-1, 3)
    centre, half = closing_box(gripper)
    corners = np.concatenate([
        open_hand, open_hand - [PREGRASP_DISTANCE, 0.0, 0.0], centre + signs * (half + clearance)
    ])  # fmt: skip
    middle = (corners.min(axis=0) + corners.max(axis=0)) / 2
    return middle, float(np.linalg.norm(corners - middle, axis=1).max())
