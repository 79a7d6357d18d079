"""Fast geometric collision check of the open hand, at a grasp and along its approach.

The open hand is a few oriented boxes (palm, finger links, pads) read from its simulated model
(`World.hand_boxes`), so the check and the physics see the same hand. Data generation labels
with it and the declutter benchmark chooses grasps with it.
Along the straight approach from the pre-grasp (``PREGRASP_DISTANCE`` back along ``e_x``)
each box sweeps a box ⊕ segment; a scene point lies in that swept volume exactly when the
three slab intervals of the segment parameter intersect. Scenes are surface point samples
of the objects plus the table plane. No physics is run.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from symgrasp.sim.grippers import GripperSpec
from symgrasp.sim.protocol import PREGRASP_DISTANCE
from symgrasp.sim.world import World
from symgrasp.workspace import TABLE_HEIGHT


@dataclass(frozen=True)
class HandBoxes:
    """Boxes of the open hand in the TCP frame: centres (B, 3), rotations (B, 3, 3) whose
    columns are the box axes, half-extents (B, 3) [m]."""

    centre: np.ndarray
    rotation: np.ndarray
    half: np.ndarray


@cache
def hand_boxes(gripper: GripperSpec) -> HandBoxes:
    """The open ``gripper``'s box geoms (its simulated model at the open configuration)."""
    return HandBoxes(*World([], gripper=gripper).hand_boxes())


def hand_collides(
    T_world_tcp: np.ndarray,
    gripper: GripperSpec,
    points: np.ndarray,
    tolerance: float = 0.002,
    sweep: float = PREGRASP_DISTANCE,
    table_height: float = TABLE_HEIGHT,
) -> np.ndarray:
    """Whether the open hand, anywhere between pre-grasp and grasp, hits the table or holds a
    scene point deeper than ``tolerance`` [m] inside one of its boxes.

    Args:
        T_world_tcp: (G, 4, 4) grasp poses.
        gripper: the hand.
        points: (P, 3) scene surface samples in the world frame [m].
        tolerance: boxes are shrunk by this much (touching contacts are allowed).
        sweep: approach length [m] behind the grasp.
        table_height: z of the table plane [m].

    Returns:
        (G,) bool.
    """
    T = np.asarray(T_world_tcp, dtype=float)
    boxes = hand_boxes(gripper)
    half = np.maximum(boxes.half - tolerance, 1e-4)  # tolerance < 0 grows the boxes
    hit = np.zeros(len(T), dtype=bool)
    # table: a corner of any box, at the grasp or at the pre-grasp, below the plane
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    corners = boxes.centre[:, None] + np.einsum(
        "bij,bcj->bci", boxes.rotation, signs * half[:, None]
    )
    corners = np.concatenate([corners, corners - [sweep, 0, 0]], axis=1).reshape(-1, 3)
    z = T[:, 2, 3][:, None] + np.einsum("j,gjc->gc", [0, 0, 1.0], T[:, :3, :3] @ corners.T)
    hit |= (z < table_height - tolerance).any(axis=1)
    if len(points) == 0:
        return hit
    pts = np.asarray(points, dtype=np.float32)
    reach = float(np.max(np.linalg.norm(corners, axis=1)))
    for g in np.flatnonzero(~hit):
        R, t = T[g, :3, :3], T[g, :3, 3]
        near = pts[np.sum((pts - t) ** 2, axis=1) < reach**2]
        if not len(near):
            continue
        p_hand = (near - t) @ R  # (P, 3) in the TCP frame
        for c, Rb, h in zip(boxes.centre, boxes.rotation, half, strict=True):
            q = (p_hand - c) @ Rb  # in the box frame; the box moves by s·u, s ∈ [0, sweep]
            u = -Rb[0, :]  # hand −x seen in the box frame
            lo, hi = np.zeros(len(q)), np.full(len(q), sweep)
            for a in range(3):
                if abs(u[a]) < 1e-12:
                    inside = np.abs(q[:, a]) < h[a]
                    hi = np.where(inside, hi, -1.0)
                else:
                    s1, s2 = (q[:, a] - h[a]) / u[a], (q[:, a] + h[a]) / u[a]
                    lo = np.maximum(lo, np.minimum(s1, s2))
                    hi = np.minimum(hi, np.maximum(s1, s2))
            if np.any(lo <= hi):
                hit[g] = True
                break
    return hit
