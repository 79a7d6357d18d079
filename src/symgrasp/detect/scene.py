"""Detection beyond one cube: the whole table, and the object asked for.

A detector sees one 30 cm cube (`symgrasp.workspace`); a lab table holds objects over a metre.
Both calls here run the detector in cubes placed on the objects, each a copy of it at another
``workspace_origin`` sharing its network, in the detector's world frame (z up, the table top
at ``z = workspace_origin_z + TABLE_HEIGHT``; after `symgrasp.perception.fit_table`, the
fitted cube's frame, ``fit.T_workspace_camera``, as for `GraspDetector.detect`):

- `detect_table`: **one cube per group of objects**, not a grid over the table. The points
  standing `MIN_HEIGHT` – `MAX_HEIGHT` above the table are joined into clusters on a
  `CLUSTER_CELL` grid in the table's plane (`fit_table`'s objects), those beside the table's
  own points (its extent: nothing hovering past its edge) kept; clusters are gathered into as
  few cubes as hold them (first fit, largest first) within a cube's **core**, the cube less
  `hand_margin` on each side. A grid of cubes over a 1 m × 0.6 m table needs 15 (a core's
  stride, 5 × 3) whatever stands on it, each a network run; objects in a few groups need a few,
  an empty table none. A cluster wider than a core (objects touching in a row) is cut into
  pieces of at most a core, whose cubes then overlap by twice the margin: the open hand's span,
  so that whatever a hand can close across lies whole in one of them.
- `detect_object`: a boolean mask of the depth image, a pixel ``(u, v)`` or a box ``(u0, v0,
  u1, v1)`` selects an object's pixels; one cube is centred on them (their points' centroid on
  the table, the cube's floor `TABLE_HEIGHT` below the table top, as in training).

The cubes share what one detection of the images needs once: the images are prepared
(`GraspDetector.prepared`) and checked once, the depth points left out of the cubes for the
cut check found once (`symgrasp.detect.limits.raised_points`: the cubes' floors lie at one
height), and the cubes' TSDFs go through the network `NETWORK_BATCH` at a time, one forward pass
each (`GraspDetector.predict_many`); each cube's grasps are those its own detection gives, up to
the float rounding of a batched pass.

Each cube keeps the grasps that close on its own objects (`holds`): the object points between
the open pads, the swept region the closing fingers cross, mostly its objects' and at least
`MIN_HELD_POINTS` of them. A grasp on a neighbour the cube sees cut at its side is left to the
neighbour's cube. The whole table's grasps are then merged: ranked by score (forced decoding's
tier after the thresholds', as the detector ranks them), a grasp dropped where a better one of
another cube has its TCP within `MERGE_RADIUS` (two cubes seeing the same object). No
simulator import.
"""

from __future__ import annotations

import copy
import time
import warnings
from dataclasses import dataclass

import numpy as np
import torch
from scipy import ndimage
from scipy.spatial import cKDTree

from symgrasp.detect.detector import GraspDetector, NoGraspWarning, check_views
from symgrasp.detect.grasp import Grasp
from symgrasp.detect.limits import raised_points
from symgrasp.model.ranking import DEFAULT_NMS_RADIUS
from symgrasp.perception import CameraIntrinsic
from symgrasp.perception.table import CLUSTER_CELL, MAX_HEIGHT, MIN_CLUSTER_POINTS, MIN_HEIGHT
from symgrasp.sim.grippers import GripperSpec
from symgrasp.workspace import TABLE_HEIGHT, VOXEL_SIZE, WORKSPACE_SIZE

MERGE_RADIUS = DEFAULT_NMS_RADIUS * VOXEL_SIZE
"""[m] `detect_table` drops a grasp whose TCP lies this close to a better one of another cube:
the detector's own non-maximum suppression radius (2 voxels, 15 mm), which within one cube
keeps no two grasps closer."""

MIN_HELD_POINTS = 10
"""Object points between the open pads that make a grasp one on that object (`holds`): a
few stray points of sensor noise are not an object."""

OBJECT_EDGE = 0.02
"""[m] a depth jump between neighbouring pixels over this parts two objects (`detect_object`'s
pixel and box): a surface seen at 1–2 mm per pixel steps far less, except at grazing angles."""

NETWORK_BATCH = 4
"""Cubes per forward pass of the network: on one thread of the 2-core CPU a batch of 2–5 cubes
cost ≈ 20 ms a cube against ≈ 32 ms alone, one of 8 more again (its activations outgrow the
caches; docs/reports/real_scenes.md)."""

TABLE_STRIDE = 8
"""Every how many of the table's points mark its extent's cells: a 1 cm cell seen at 1–2 mm per
pixel holds dozens."""


@dataclass(frozen=True)
class SceneDetection:
    """The grasps of several workspace cubes.

    Attributes:
        grasps: best first, ``pose`` ``T_world_tcp`` in the detector's world frame; each
            grasp's ``voxel`` indexes its own cube's grid.
        origins: (K, 3) [m] the cubes' ``workspace_origin``s, world frame (axes the world's).
        workspace: for each grasp, the index of its cube in ``origins``.
        timing: milliseconds: ``objects`` (back-projection, the objects found), the
            detector's stages (`GraspDetector.timing`) summed over the cubes, ``select`` (the
            grasps that hold their cube's objects, merged) and ``total``.
    """

    grasps: list[Grasp]
    origins: np.ndarray
    workspace: tuple[int, ...]
    timing: dict[str, float]


def hand_margin(gripper: GripperSpec) -> float:
    """[m] half the open hand's span across its closing axis, ``max_width / 2 + pad_thickness``:
    the pads of a grasp at an object's side reach this far past it, so a cube keeps this much
    room around its objects (4.85 cm for the Robotiq 2F-85, 5 cm for the Franka hand; their
    cores are ≈ 20 cm, the box training's piles were dropped into)."""
    return gripper.max_width / 2 + gripper.pad_thickness


def detect_table(
    detector: GraspDetector,
    depth: np.ndarray,
    intrinsic: CameraIntrinsic | np.ndarray,
    T_world_camera: np.ndarray,
    *,
    merge_radius: float = MERGE_RADIUS,
) -> SceneDetection:
    """Grasps over the whole table in depth images ``depth`` (H, W) or (V, H, W) [m] taken by
    ``intrinsic`` from ``T_world_camera`` (4, 4) or (V, 4, 4), as `GraspDetector.detect` takes
    them: one cube per group of objects on the table (the module's rule), each cube's grasps on
    its objects, merged within ``merge_radius`` [m] and ranked by score; ``detector.top_k``
    applies to the merged list. Sets ``detector.timing`` to the call's `SceneDetection.timing`.

    A table with nothing on it gives no grasp and a `NoGraspWarning` saying where the table
    was expected; so does one whose cubes' grasps all miss their objects (the cubes' own
    warnings, if any, say why)."""
    if not merge_radius >= 0:
        raise ValueError(f"merge_radius must be ≥ 0 m, got {merge_radius}")
    start = time.perf_counter()
    views, intrinsic, T = check_views(depth, intrinsic, T_world_camera)
    views = detector.prepared(views, intrinsic, T)
    rays = intrinsic.pixel_rays()
    height = _heights(views, rays, T) - _table_z(detector)
    seen = views > 0
    standing = seen & (height > MIN_HEIGHT) & (height < MAX_HEIGHT)
    table = np.flatnonzero(seen & (np.abs(height) <= MIN_HEIGHT))[::TABLE_STRIDE]
    points = _world_points(views, rays, T, np.flatnonzero(standing))
    cluster = _clusters(points[:, :2], _world_points(views, rays, T, table)[:, :2])
    groups = _groups(points[:, :2], cluster, WORKSPACE_SIZE - 2 * hand_margin(detector.gripper))
    timing = {"objects": _ms(start)}
    if not groups:
        warnings.warn(
            f"no grasp found: no object stands on the table: none of the {int(seen.sum())} seen "
            f"points lies {MIN_HEIGHT * 100:g}–{MAX_HEIGHT * 100:g} cm above the table top z = "
            f"{_table_z(detector):.3f} m in clusters of ≥ {MIN_CLUSTER_POINTS} beside the "
            "table's own points (is the table at workspace_origin z + 5 cm, z up?)",
            NoGraspWarning,
            stacklevel=2,
        )
    objects, cloud = cluster[cluster >= 0], points[cluster >= 0]
    origins = [np.r_[centre - WORKSPACE_SIZE / 2, detector.origin[2]] for _, centre in groups]
    cubes = _run_cubes(detector, origins, (views, intrinsic, T), timing)
    selecting = time.perf_counter()
    tree = cKDTree(cloud)
    found = []
    for k, ((members, _), (_, grasps, _)) in enumerate(zip(groups, cubes, strict=True)):
        held = _holds(detector.gripper, grasps, tree, np.isin(objects, members))
        found += [(grasp, k) for grasp, ok in zip(grasps, held, strict=True) if ok]
    kept = _merged(found, detector.validity_threshold, merge_radius)
    timing["select"] = _ms(selecting)
    if groups and not kept:
        _warn_missed(cubes, "their objects", (views, intrinsic, T))
    return _result(detector, kept, origins, timing, start)


def detect_object(
    detector: GraspDetector,
    depth: np.ndarray,
    intrinsic: CameraIntrinsic | np.ndarray,
    T_world_camera: np.ndarray,
    *,
    mask: np.ndarray | None = None,
    pixel: tuple[int, int] | None = None,
    box: tuple[int, int, int, int] | None = None,
) -> SceneDetection:
    """Grasps on one object of a depth image ``depth`` (H, W) [m] taken by ``intrinsic`` from
    ``T_world_camera`` (4, 4), selected by exactly one of:

    - ``mask`` (H, W): booleans (or 0/1), the object's pixels (a segmentation's);
    - ``pixel`` ``(u, v)``: a pixel on the object (column, row): its pixels are those joined to
      it without a depth jump over `OBJECT_EDGE`;
    - ``box`` ``(u0, v0, u1, v1)``: the pixel box (inclusive) holding it: its largest such
      region inside the box.

    Only the selected pixels standing over `MIN_HEIGHT` above the table count. One cube is
    centred on their points and keeps the grasps that hold them (`holds`). Sets
    ``detector.timing``. ValueError when the selection is malformed or holds no object point;
    a `NoGraspWarning` when the cube's grasps all miss the object."""
    start = time.perf_counter()
    views, intrinsic, T = check_views(depth, intrinsic, T_world_camera)
    if len(views) != 1:
        raise ValueError(f"mask, pixel and box select in one depth image, got {len(views)}")
    views = detector.prepared(views, intrinsic, T)
    rays = intrinsic.pixel_rays()
    above = (views[0] > 0) & (_heights(views, rays, T)[0] - _table_z(detector) > MIN_HEIGHT)
    target = _selected(views[0], above, mask, pixel, box)
    points = _world_points(views, rays, T, np.flatnonzero(target))
    origin = np.r_[points[:, :2].mean(axis=0) - WORKSPACE_SIZE / 2, detector.origin[2]]
    timing = {"objects": _ms(start)}
    cubes = _run_cubes(detector, [origin], (views, intrinsic, T), timing)
    selecting = time.perf_counter()
    other = _world_points(views, rays, T, np.flatnonzero(above & ~target))
    grasps = cubes[0][1]
    held = holds(detector.gripper, grasps, points, other)
    kept = [(grasp, 0) for grasp, ok in zip(grasps, held, strict=True) if ok]
    timing["select"] = _ms(selecting)
    if not kept:
        _warn_missed(cubes, "the object", (views, intrinsic, T))
    return _result(detector, kept, [origin], timing, start)


def holds(
    gripper: GripperSpec, grasps: list[Grasp], target: np.ndarray, other: np.ndarray
) -> np.ndarray:
    """(G,) bool: whether each of ``grasps`` closes on the points ``target`` (N, 3) [m]: the
    points between its open pads (``|y| ≤ pad_width / 2``, ``|z| ≤ max_width / 2`` in the TCP's
    frame, ``x`` from the palm face to the fingertips) are at least `MIN_HELD_POINTS` of
    ``target`` and more of them than of ``other`` (M, 3) (the other objects' points)."""
    if not grasps:
        return np.zeros(0, dtype=bool)
    cloud = np.concatenate([target, other])
    return _holds(gripper, grasps, cKDTree(cloud), np.arange(len(cloud)) < len(target))


def _holds(
    gripper: GripperSpec, grasps: list[Grasp], tree: cKDTree, is_target: np.ndarray
) -> np.ndarray:
    """`holds` on the points of ``tree`` (N, 3) [m], ``is_target`` (N,) marking the target's:
    one tree for every cube of a table."""
    if not grasps:
        return np.zeros(0, dtype=bool)
    half = np.array([gripper.finger_depth / 2, gripper.pad_width / 2, gripper.max_width / 2])
    centre_x = gripper.tip_beyond_tcp - half[0]  # the region's middle along e_x from the TCP
    cloud = tree.data
    held = np.zeros(len(grasps), dtype=bool)
    for g, grasp in enumerate(grasps):
        R, tcp = grasp.pose[:3, :3], grasp.pose[:3, 3]
        middle = tcp + centre_x * R[:, 0]
        near = np.asarray(tree.query_ball_point(middle, float(np.linalg.norm(half))), dtype=int)
        local = (cloud[near] - middle) @ R
        inside = near[np.all(np.abs(local) <= half, axis=1)]
        ours = int(is_target[inside].sum())
        held[g] = ours >= MIN_HELD_POINTS and ours > len(inside) - ours
    return held


def _table_z(detector: GraspDetector) -> float:
    return float(detector.origin[2] + TABLE_HEIGHT)


def _heights(views: np.ndarray, rays: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(V, H, W) [m]: the world z of each pixel's point of depth images ``views`` (V, H, W) [m]
    seen along ``rays`` (H, W, 3) (`CameraIntrinsic.pixel_rays`) from ``T`` (V, 4, 4)
    ``T_world_camera`` (a missing pixel's: the camera's); one product per pixel, the points
    themselves made only where needed (`_world_points`)."""
    # einsum, not @: a BLAS call leaves OpenBLAS' threads spinning beside the next network
    rise = np.einsum("hwj,vj->vhw", rays, T[:, 2, :3])  # world z per metre of depth
    return views * rise + T[:, 2, 3, None, None]


def _world_points(
    views: np.ndarray, rays: np.ndarray, T: np.ndarray, pixels: np.ndarray
) -> np.ndarray:
    """(N, 3) [m]: the world points of ``pixels`` (N,), flat indices into ``views`` (V, H, W)
    [m], seen along ``rays`` (H, W, 3) from ``T`` (V, 4, 4) ``T_world_camera``."""
    view, row, col = np.unravel_index(pixels, views.shape)
    camera = views[view, row, col, None] * rays[row, col]
    return np.einsum("nj,nij->ni", camera, T[view, :3, :3]) + T[view, :3, 3]


def _cells(xy: np.ndarray, low: np.ndarray) -> np.ndarray:
    return np.floor((xy - low) / CLUSTER_CELL).astype(int)


def _clusters(xy: np.ndarray, table: np.ndarray) -> np.ndarray:
    """(N,) the cluster of each point (−1: none) of ``xy`` (N, 2) [m], the points standing
    `MIN_HEIGHT` – `MAX_HEIGHT` above the table: joined on the `CLUSTER_CELL` grid
    (8-connected), clusters of at least `MIN_CLUSTER_POINTS` beside a cell of the table's own
    points ``table`` (M, 2) [m] (within `MIN_HEIGHT` of it)."""
    cluster = np.full(len(xy), -1)
    if not (len(xy) and len(table)):
        return cluster
    low = np.minimum(xy.min(axis=0), table.min(axis=0))
    cell, table_cell = _cells(xy, low), _cells(table, low)
    size = np.maximum(cell.max(axis=0), table_cell.max(axis=0)) + 1
    grid, on_table = np.zeros(size, dtype=bool), np.zeros(size, dtype=bool)
    grid[tuple(cell.T)] = True
    on_table[tuple(table_cell.T)] = True
    labels, count = ndimage.label(grid, structure=np.ones((3, 3)))
    label = labels[tuple(cell.T)]
    beside = np.unique(labels[ndimage.binary_dilation(on_table, np.ones((3, 3)))])
    big = np.bincount(label, minlength=count + 1) >= MIN_CLUSTER_POINTS
    keep = np.zeros(count + 1, dtype=bool)
    keep[beside] = True
    keep &= big
    keep[0] = False
    return np.where(keep[label], label, -1)


def _groups(xy: np.ndarray, cluster: np.ndarray, core: float) -> list[tuple[list[int], np.ndarray]]:
    """The cubes over the clusters ``cluster`` (N,) of points ``xy`` (N, 2) [m]: each the
    clusters it holds and its centre (2,) [m]. A cluster wider than ``core`` is cut into a grid
    of pieces at most ``core`` wide; pieces, largest first, join the first cube whose objects
    with them still fit in ``core`` × ``core`` (each cube's centre: its objects' box's)."""
    pieces = []  # (cluster, points' box low (2,), high (2,), points)
    for label in np.unique(cluster[cluster >= 0]):
        own = xy[cluster == label]
        low, high = own.min(axis=0), own.max(axis=0)
        cuts = np.maximum(np.ceil((high - low) / core), 1)
        if np.all(cuts == 1):  # most clusters: np.unique over rows costs a millisecond
            pieces.append((int(label), low, high, len(own)))
            continue
        piece = np.minimum(np.floor((own - low) / (high - low + 1e-12) * cuts), cuts - 1)
        for key in np.unique(piece, axis=0):
            part = own[np.all(piece == key, axis=1)]
            pieces.append((int(label), part.min(axis=0), part.max(axis=0), len(part)))
    cubes: list[list] = []  # [clusters, low, high]
    for label, low, high, _ in sorted(pieces, key=lambda p: -p[3]):
        for cube in cubes:
            joined_low, joined_high = np.minimum(cube[1], low), np.maximum(cube[2], high)
            if np.all(joined_high - joined_low <= core):
                cube[0].add(label)
                cube[1], cube[2] = joined_low, joined_high
                break
        else:
            cubes.append([{label}, low, high])
    return [(sorted(labels), (low + high) / 2) for labels, low, high in cubes]


def _selected(
    depth: np.ndarray,
    above: np.ndarray,
    mask: np.ndarray | None,
    pixel: tuple[int, int] | None,
    box: tuple[int, int, int, int] | None,
) -> np.ndarray:
    """(H, W) bool: the object's pixels of ``depth`` (H, W) [m] that ``mask``, ``pixel`` or
    ``box`` select (exactly one) among those ``above`` the table."""
    given = [
        name
        for name, value in (("mask", mask), ("pixel", pixel), ("box", box))
        if value is not None
    ]
    if len(given) != 1:
        raise ValueError(f"give exactly one of mask, pixel and box, got {given or 'none'}")
    height, width = depth.shape
    if mask is not None:
        selected = _mask(mask, depth.shape) & above
        what = f"mask ({int(np.count_nonzero(mask))} pixels)"
    elif pixel is not None:
        u, v = _pixels(pixel, "pixel", (width, height))
        labels = _regions(depth, above)
        if not above[v, u]:
            seen = "the table or what lies below it" if depth[v, u] > 0 else "no depth"
            raise ValueError(f"pixel (u, v) = ({u}, {v}) sees {seen}, not an object on the table")
        # an edge pixel belongs to the region nearest it
        _, (rows, cols) = ndimage.distance_transform_edt(labels == 0, return_indices=True)
        selected = labels == labels[rows[v, u], cols[v, u]]
        what = f"pixel ({u}, {v})"
    else:
        u0, v0, u1, v1 = _pixels(box, "box", (width, height) * 2)
        if u0 > u1 or v0 > v1:
            raise ValueError(f"box (u0, v0, u1, v1) must have u0 ≤ u1 and v0 ≤ v1, got {box}")
        inside = np.zeros_like(above)
        inside[v0 : v1 + 1, u0 : u1 + 1] = True
        labels = _regions(depth, above & inside)
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        selected = labels == int(np.argmax(sizes)) if sizes.any() else np.zeros_like(above)
        what = f"box ({u0}, {v0}, {u1}, {v1})"
    if not selected.any():
        raise ValueError(
            f"the {what} selects no depth point standing over {MIN_HEIGHT * 100:g} cm above the "
            "table: is it the depth image's, and does the table lie at workspace_origin z + 5 cm?"
        )
    return selected


def _mask(mask: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    values = np.asarray(mask)
    if values.shape != shape:
        raise ValueError(f"mask must have the depth image's shape {shape}, got {values.shape}")
    if values.dtype != bool:
        numeric = np.issubdtype(values.dtype, np.number)
        if not (numeric and np.isin(values, (0, 1)).all()):
            raise ValueError("mask must hold booleans or 0 and 1 (the object's pixels: 1)")
    return values.astype(bool)


def _pixels(values: tuple[int, ...], name: str, limits: tuple[int, ...]) -> tuple[int, ...]:
    """``values`` as pixel coordinates, each an integer in ``[0, limit)``."""
    letters = {2: "(u, v)", 4: "(u0, v0, u1, v1)"}[len(limits)]
    values = tuple(values) if isinstance(values, list | tuple | np.ndarray) else (values,)
    if len(values) != len(limits) or not all(
        isinstance(x, int | np.integer) and not isinstance(x, bool) and 0 <= x < limit
        for x, limit in zip(values, limits, strict=False)
    ):
        raise ValueError(
            f"{name} must be {letters}: integer pixels, u in [0, {limits[0]}) and v in "
            f"[0, {limits[1]}), got {values!r}"
        )
    return tuple(int(x) for x in values)


def _regions(depth: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """(H, W) int: the 4-connected regions of the ``candidates`` pixels of ``depth`` that no
    depth jump over `OBJECT_EDGE` parts (0: none; a pixel at such a jump is in none)."""
    jump = np.zeros_like(candidates)
    across = np.abs(np.diff(depth, axis=1)) > OBJECT_EDGE
    down = np.abs(np.diff(depth, axis=0)) > OBJECT_EDGE
    jump[:, 1:] |= across
    jump[:, :-1] |= across
    jump[1:] |= down
    jump[:-1] |= down
    return ndimage.label(candidates & ~jump)[0]


def _run_cubes(
    detector: GraspDetector,
    origins: list[np.ndarray],
    views: tuple[np.ndarray, CameraIntrinsic, np.ndarray],
    timing: dict[str, float],
) -> list[tuple[GraspDetector, list[Grasp], dict[str, torch.Tensor]]]:
    """Each cube (``detector`` with its workspace from ``origins[k]`` (3,) [m]), its grasps and
    its network outputs, of the prepared images ``views`` (`GraspDetector.prepared`: fused as they
    are; checked, `check_views`): one TSDF per cube, `NETWORK_BATCH` cubes per forward pass,
    the points the cubes leave out found once. Adds each stage's milliseconds over the cubes
    to ``timing``."""
    cubes = [_cube(detector, origin) for origin in origins]
    start = time.perf_counter()
    volumes = [cube.fuse(*views).tsdf for cube in cubes]
    _add(timing, {"tsdf": _ms(start)})
    start = time.perf_counter()
    outs = []
    for first in range(0, len(volumes), NETWORK_BATCH):
        outs += detector.predict_many(torch.stack(volumes[first : first + NETWORK_BATCH]))
    _add(timing, {"network": _ms(start)})
    raised = None, None
    if detector.cut_objects != "ignore" and cubes:
        start = time.perf_counter()
        raised = raised_points(*views, detector.origin)  # the cubes' floors: one height
        _add(timing, {"cut": _ms(start)})
    found = []
    for cube, volume, out in zip(cubes, volumes, outs, strict=True):
        found.append((cube, cube.grasps_from(out, volume, views, *raised), out))
        _add(timing, cube.timing)
    return found


def _cube(detector: GraspDetector, origin: np.ndarray) -> GraspDetector:
    """``detector`` with its workspace from ``origin``, sharing its network; the images are
    prepared once for all cubes."""
    cube = copy.copy(detector)
    cube.origin = origin
    cube.fill_holes, cube.table_scale, cube.depth_scale = 0, False, None
    return cube


def _merged(
    found: list[tuple[Grasp, int]], validity_threshold: float, radius: float
) -> list[tuple[Grasp, int]]:
    """``found`` (grasp, cube) ranked as the detector ranks them, the grasps above the validity
    threshold first, then by score, each dropped where a kept one of another cube has its TCP
    within ``radius``."""
    ranked = sorted(found, key=lambda f: (f[0].validity < validity_threshold, -f[0].score))
    kept: list[tuple[Grasp, int]] = []
    positions = np.empty((0, 3))
    cubes = np.empty(0, dtype=int)
    for grasp, cube in ranked:
        near = np.linalg.norm(positions - grasp.position, axis=1) <= radius
        if not np.any(near & (cubes != cube)):
            kept.append((grasp, cube))
            positions = np.vstack([positions, grasp.position])
            cubes = np.r_[cubes, cube]
    return kept


def _result(
    detector: GraspDetector,
    kept: list[tuple[Grasp, int]],
    origins: list[np.ndarray],
    timing: dict[str, float],
    start: float,
) -> SceneDetection:
    """The `SceneDetection` of the grasps ``kept`` (grasp, its cube), ``detector.top_k`` of
    them, in the cubes from ``origins``; ``timing`` completed and set as the detector's."""
    pairs = kept[: detector.top_k]
    timing["total"] = _ms(start)
    detector.timing = timing
    return SceneDetection(
        [grasp for grasp, _ in pairs],
        np.array(origins, dtype=float).reshape(-1, 3),
        tuple(cube for _, cube in pairs),
        timing,
    )


def _add(timing: dict[str, float], stages: dict[str, float]) -> None:
    for stage, ms in stages.items():
        timing[stage] = timing.get(stage, 0.0) + ms


def _warn_missed(
    cubes: list[tuple[GraspDetector, list[Grasp], dict[str, torch.Tensor]]],
    what: str,
    views: tuple[np.ndarray, CameraIntrinsic, np.ndarray],
) -> None:
    """Warn that none of the grasps the ``cubes`` (`_run_cubes`) gave closes on ``what`` or,
    when they gave none, the first cause a cube's detector sees in ``views``
    (`GraspDetector.no_grasp_cause`), if any."""
    # stacklevel 3: the line that called detect_table or detect_object
    count = sum(len(grasps) for _, grasps, _ in cubes)
    if count:
        warnings.warn(
            f"no grasp found: none of the {count} grasps of the cubes closes on {what} (as many "
            f"as {MIN_HELD_POINTS} of the object points between the open pads, and most of them)",
            NoGraspWarning,
            stacklevel=3,
        )
        return
    for cube, _, out in cubes:
        if cause := cube.no_grasp_cause(out, views):
            warnings.warn(cause, NoGraspWarning, stacklevel=3)
            return


def _ms(start: float) -> float:
    return 1e3 * (time.perf_counter() - start)


__all__ = [
    "MERGE_RADIUS",
    "MIN_HELD_POINTS",
    "SceneDetection",
    "detect_object",
    "detect_table",
    "hand_margin",
    "holds",
]
