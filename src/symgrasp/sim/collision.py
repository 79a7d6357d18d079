"""Fast geometric collision check of the open hand, at a grasp and along its approach.

The open hand is a few oriented boxes (palm, finger links, pads) read from its simulated model
(`World.hand_boxes`), so the check and the physics see the same hand. Data generation labels
with it, the declutter benchmark chooses grasps with it, and a detector with its approach check
on filters its grasps with it. The built-in hands' boxes are stored (`STORED`), so that the
check runs on a robot without MuJoCo loaded; another hand's are read from its simulated model.
Along the straight approach from the pre-grasp (``PREGRASP_DISTANCE`` back along ``e_x``)
each box sweeps a box ⊕ segment; a scene point lies in that swept volume exactly when the
three slab intervals of the segment parameter intersect. Scenes are surface point samples
of the objects plus the table plane. No physics is run.

Only the points that can lie in a swept box are tested: a k-d tree of the scene's points
(`scipy.spatial.cKDTree`) gives those in `PIECES` balls that cover each swept box along its
sweep, and the slab test runs on those (grasp, point) pairs at once; a box is tested only for
the grasps no earlier box has hit. A check of a few grasps (`ALL_PAIRS`) tests every point.
The answer is the exact test's over every point, as tests/sim/test_collision.py checks
against the test run on all of them.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from symgrasp.atomic import write_atomic
from symgrasp.names import GRIPPERS
from symgrasp.sim.grippers import GripperSpec, get_gripper
from symgrasp.sim.protocol import PREGRASP_DISTANCE
from symgrasp.workspace import TABLE_HEIGHT

PIECES = 3
"""Balls per swept box, each around a third of the sweep: fewer hold many points that cannot be
inside the box, more cost a query each (3 was the fastest on scenes of VGN's objects)."""
MARGIN = 1e-5
"""[m] Added to each ball's radius, so that rounding never leaves out a point on its boundary."""
CHUNK = 512
"""Grasps checked together: bounds the (grasp, point) pairs held at once."""
SIGNS = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
"""(8, 3) The signs of a box's corners along its axes."""
ALL_PAIRS = 2**16
"""Up to this many (grasp, point) pairs, every point is tested without a search: building the
tree costs more than it saves for the few grasps of a declutter attempt."""


@dataclass(frozen=True)
class HandBoxes:
    """Boxes of the open hand in the TCP frame: centres (B, 3), rotations (B, 3, 3) whose
    columns are the box axes, half-extents (B, 3) [m]."""

    centre: np.ndarray
    rotation: np.ndarray
    half: np.ndarray


STORED = Path(__file__).with_name("hand_boxes.json")
"""The built-in hands' open boxes with the spec each was built from: `simulated_hand_boxes`'s
numbers to the bit on the machine that wrote them (`store_hand_boxes`; tests/sim/test_collision.py
checks them against the simulated hands)."""
BOXES = ("centre", "rotation", "half")


@cache
def hand_boxes(gripper: GripperSpec) -> HandBoxes:
    """The open ``gripper``'s box geoms: stored for a built-in hand whose spec is the one they
    were built from (no MuJoCo loaded), else `simulated_hand_boxes`."""
    stored = json.loads(STORED.read_text()).get(gripper.name)
    if stored is not None and stored["spec"] == _as_stored(gripper.to_dict()):
        return HandBoxes(*(np.array(stored[key], dtype=float) for key in BOXES))
    return simulated_hand_boxes(gripper)


def simulated_hand_boxes(gripper: GripperSpec) -> HandBoxes:
    """The open ``gripper``'s box geoms, read from its simulated model at the open
    configuration (loads MuJoCo)."""
    from symgrasp.sim.world import World

    return HandBoxes(*World([], gripper=gripper).hand_boxes())


def store_hand_boxes(path: Path = STORED) -> Path:
    """Write the built-in hands' `simulated_hand_boxes` and specs to ``path`` (after a change
    to a built-in hand, its spec or the code that builds it)."""
    stored = {}
    for gripper in map(get_gripper, GRIPPERS):
        boxes = simulated_hand_boxes(gripper)
        stored[gripper.name] = {"spec": _as_stored(gripper.to_dict()),
                                **{key: getattr(boxes, key).tolist() for key in BOXES}}  # fmt: skip
    return write_atomic(path, lambda file: file.write(json.dumps(stored, indent=1) + "\n"), "w")


def _as_stored(value: object) -> object:
    """``value`` as JSON gives it back (tuples as lists): what a stored spec compares with."""
    return json.loads(json.dumps(value))


def _corners(boxes: HandBoxes, half: np.ndarray) -> np.ndarray:
    """(B, 8, 3) The corners, in the TCP frame, of ``boxes`` with half-extents ``half``."""
    return boxes.centre[:, None] + np.einsum("bij,bcj->bci", boxes.rotation, SIGNS * half[:, None])


def hand_collides(
    T_world_tcp: np.ndarray,
    gripper: GripperSpec,
    points: np.ndarray,
    tolerance: float = 0.002,
    sweep: float = PREGRASP_DISTANCE,
    table_height: float = TABLE_HEIGHT,
    table_tolerance: float | None = None,
) -> np.ndarray:
    """Whether the open hand, anywhere between pre-grasp and grasp, hits the table or holds a
    scene point deeper than ``tolerance`` [m] inside one of its boxes.

    Args:
        T_world_tcp: (G, 4, 4) grasp poses.
        gripper: the hand.
        points: (P, 3) scene surface samples in the world frame [m].
        tolerance: boxes are shrunk by this much (touching contacts are allowed; negative:
            grown, a clearance kept).
        sweep: approach length [m] behind the grasp.
        table_height: z of the table plane [m].
        table_tolerance: the same for the table (default: ``tolerance``): a corner of the
            boxes shrunk by it may lie down to ``table_tolerance`` below the plane. A positive
            value counts twice (a tilted box sinks up to ≈ 2.7 × it), so a planner that
            knows where its table is passes a negative one, a clearance
            (`symgrasp.benchmark.declutter.first_free`).

    Returns:
        (G,) bool.
    """
    T = np.asarray(T_world_tcp, dtype=float)
    boxes = hand_boxes(gripper)
    table_tolerance = tolerance if table_tolerance is None else table_tolerance
    hit = np.zeros(len(T), dtype=bool)
    # table: a corner of any box, at the grasp or at the pre-grasp, below the plane
    on_table = _corners(boxes, np.maximum(boxes.half - table_tolerance, 1e-4))
    ends = np.concatenate([on_table, on_table - [sweep, 0, 0]], axis=1).reshape(-1, 3)
    z = T[:, 2, 3][:, None] + np.einsum("j,gjc->gc", [0, 0, 1.0], T[:, :3, :3] @ ends.T)
    hit |= (z < table_height - table_tolerance).any(axis=1)
    if len(points) == 0:
        return hit
    half = np.maximum(boxes.half - tolerance, 1e-4)  # tolerance < 0 grows the boxes
    corners = _corners(boxes, half)
    pts = np.asarray(points, dtype=np.float32).astype(float)
    tree = cKDTree(pts) if len(T) * len(pts) > ALL_PAIRS else None
    for start in range(0, len(T), CHUNK):
        chunk = slice(start, start + CHUNK)
        hit[chunk] = _points_hit(T[chunk], hit[chunk], boxes, corners, half, sweep, pts, tree)
    return hit


def _points_hit(
    T: np.ndarray,
    hit: np.ndarray,
    boxes: HandBoxes,
    corners: np.ndarray,
    half: np.ndarray,
    sweep: float,
    pts: np.ndarray,
    tree: cKDTree | None,
) -> np.ndarray:
    """``hit`` (G,) or'd with whether a point of ``pts`` (P, 3) lies in a box (``boxes`` with
    half-extents ``half`` and ``corners`` (B, 8, 3)) of a grasp ``T`` (G, 4, 4) swept by
    ``sweep``: the points near each box found by ``tree`` (of ``pts``), or every point where
    ``tree`` is None."""
    hit = hit.copy()
    if tree is None:  # every point of every grasp, in the TCP frame: (G, P, 3)
        every = (pts[None] - T[:, None, :3, 3]) @ T[:, :3, :3]
    for c, Rb, h, box in zip(boxes.centre, boxes.rotation, half, corners, strict=True):
        todo = np.flatnonzero(~hit)
        if not len(todo):
            break
        if tree is None:
            grasp = np.repeat(np.arange(len(todo)), len(pts))
            p_hand = every[todo].reshape(-1, 3)
        else:
            R, t = T[todo, :3, :3], T[todo, :3, 3]
            grasp, point = _near(tree, R, t, box, sweep)
            p_hand = np.einsum("nj,nji->ni", pts[point] - t[grasp], R[grasp])  # TCP frame
        q = (p_hand - c) @ Rb  # in the box frame; the box moves by s·u, s ∈ [0, sweep]
        u = -Rb[0, :]  # hand −x seen in the box frame
        lo, hi = np.zeros(len(q)), np.full(len(q), sweep)
        for a in range(3):
            if abs(u[a]) < 1e-12:
                hi = np.where(np.abs(q[:, a]) < h[a], hi, -1.0)
            else:
                s1, s2 = (q[:, a] - h[a]) / u[a], (q[:, a] + h[a]) / u[a]
                lo = np.maximum(lo, np.minimum(s1, s2))
                hi = np.minimum(hi, np.maximum(s1, s2))
        hit[todo[grasp[lo <= hi]]] = True
    return hit


def _near(
    tree: cKDTree, R: np.ndarray, t: np.ndarray, corners: np.ndarray, sweep: float
) -> tuple[np.ndarray, np.ndarray]:
    """The (grasp, point) pairs, as index arrays, whose point ``tree`` finds in one of the
    `PIECES` balls that cover the box of ``corners`` (8, 3) (TCP frame) swept by ``sweep``
    along −x, for the grasps at ``R`` (G, 3, 3) and ``t`` (G, 3)."""
    grasp, point = [], []
    for j in range(PIECES):
        piece = np.concatenate([corners - [sweep * j / PIECES, 0, 0],
                                corners - [sweep * (j + 1) / PIECES, 0, 0]])  # fmt: skip
        mid = piece.mean(axis=0)
        radius = float(np.max(np.linalg.norm(piece - mid, axis=1))) + MARGIN
        near = tree.query_ball_point(t + R @ mid, radius, return_sorted=False)
        count = np.fromiter(map(len, near), dtype=np.int64, count=len(near))
        grasp.append(np.repeat(np.arange(len(t)), count))
        point.append(np.fromiter(itertools.chain.from_iterable(near), dtype=np.int64,
                                 count=int(count.sum())))  # fmt: skip
    return np.concatenate(grasp), np.concatenate(point)
