"""Voxel labels from a list of grasps on the 40³ workspace grid.

A grasp belongs to the voxel that contains its TCP; voxel ``[i, j, k]`` spans
``[i, i+1) · voxel_size`` along world x (``j`` along y, ``k`` along z), the convention of
:class:`symgrasp.perception.TSDFVolume`. Per valid voxel: the best score, the width of the
best-scoring grasp and up to ``k_max`` distinct rotations (best first; two rotations are the
same when they differ by less than ``same_angle`` up to the 180° flip).

A grasp that holds usually still holds with its TCP moved a little (along the approach, along
e_y, along the closing axis within the fingers' clearance): `spread_poses` lists the other
voxels whose centre such a move reaches, for the paper's "filling all voxels with a grasp"
(Ko et al., CoRL 2024, Appx. C) and `symgrasp.data.scenes` keeps those where the open hand is
free there too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from symgrasp.workspace import RESOLUTION, VOXEL_SIZE

FLIP = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class VoxelLabels:
    """Labels of the ``M`` valid voxels of one scene.

    Attributes:
        voxel_index: (M, 3) int (i, j, k).
        score: (M,) best gravity-rejection score in the voxel.
        width: (M,) finger opening [m] of the best-scoring grasp.
        rotations: (M, k_max, 3, 3) rotation targets, padded with the identity.
        mask: (M, k_max) which targets are real.
        dropped: rotations that were distinct but beyond ``k_max`` (all voxels together).
    """

    voxel_index: np.ndarray
    score: np.ndarray
    width: np.ndarray
    rotations: np.ndarray
    mask: np.ndarray
    dropped: int


def rotation_angle_up_to_flip(R1: np.ndarray, R2: np.ndarray) -> np.ndarray:
    """Geodesic angle [rad] between (..., 3, 3) rotations, the smaller of R2 and R2·flip."""
    cos = (np.einsum("...ij,...ij->...", R1, R2) - 1) / 2
    cos_f = (np.einsum("...ij,...ij->...", R1, R2 @ FLIP) - 1) / 2
    return np.arccos(np.clip(np.maximum(cos, cos_f), -1.0, 1.0))


def voxel_of(positions: np.ndarray) -> np.ndarray:
    """Voxel index (N, 3) of world positions (N, 3) [m]; outside the grid gives −1 or 40+."""
    return np.floor(np.asarray(positions) / VOXEL_SIZE).astype(np.int64)


def voxel_centre(index: np.ndarray) -> np.ndarray:
    """World position (N, 3) [m] of the centres of voxels ``index`` (N, 3): where the detector
    puts the TCP of a voxel's grasp."""
    return (np.asarray(index) + 0.5) * VOXEL_SIZE


def voxel_grasp(
    index: np.ndarray, rotations: np.ndarray, mask: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """The grasp one labelled voxel teaches, as the detector would execute it:
    ``T_world_tcp`` (4, 4) with the TCP at the centre of voxel ``index`` (3,) and one of its
    rotation targets ``rotations`` (k_max, 3, 3) where ``mask`` (k_max,) is set, drawn
    uniformly with ``rng``."""
    T = np.eye(4)
    T[:3, :3] = rotations[rng.choice(np.flatnonzero(mask))]
    T[:3, 3] = voxel_centre(index)
    return T


def added_voxels(voxel_index: np.ndarray, T_world_tcp: np.ndarray) -> np.ndarray:
    """(M,) bool: which of the labelled voxels ``voxel_index`` (M, 3) hold none of the TCPs
    of the grasps ``T_world_tcp`` (G, 4, 4) they were labelled from, i.e. the voxels a
    spread (`spread_poses`) added. All False for labels without a spread (`voxelise`)."""
    own = {tuple(v) for v in voxel_of(np.asarray(T_world_tcp)[:, :3, 3]).tolist()}
    return np.array([tuple(v) not in own for v in np.asarray(voxel_index).tolist()], dtype=bool)


def spread_poses(
    T_world_tcp: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The grasps ``T_world_tcp`` (G, 4, 4) moved to every voxel centre they reach.

    A voxel centre ``c`` is reached by grasp ``g`` when its offset in the grasp frame,
    ``R_gᵀ (c − t_g)``, lies in the box ``lower ≤ · ≤ upper`` ((3,) each, [m], along e_x, e_y,
    e_z; ``lower ≤ 0 ≤ upper``). The voxel holding ``t_g`` itself and voxels outside the grid
    are left out.

    Returns the poses (N, 4, 4): rotation ``R_g``, translation ``c``; and ``source`` (N,),
    the index ``g`` of each pose's grasp, in the order of the grasps.
    """
    T = np.asarray(T_world_tcp, dtype=float).reshape(-1, 4, 4)
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    if lower.shape != (3,) or upper.shape != (3,) or np.any(lower > 0) or np.any(upper < 0):
        raise ValueError(
            f"lower and upper must be (3,) with lower ≤ 0 ≤ upper, got {lower}, {upper}"
        )
    reach = int(np.ceil(np.max(np.maximum(-lower, upper)) * np.sqrt(3) / VOXEL_SIZE)) + 1
    steps = np.arange(-reach, reach + 1)
    offsets = np.stack(np.meshgrid(steps, steps, steps, indexing="ij"), -1).reshape(-1, 3)
    own = voxel_of(T[:, :3, 3])  # (G, 3)
    index = own[:, None, :] + offsets[None]  # (G, O, 3)
    d = np.einsum("gji,goj->goi", T[:, :3, :3], voxel_centre(index) - T[:, None, :3, 3])
    eps = 1e-9  # a centre exactly on the box's face is inside
    keep = np.all((d >= lower - eps) & (d <= upper + eps), axis=-1)
    keep &= np.any(offsets != 0, axis=-1)[None] & np.all((index >= 0) & (index < RESOLUTION), -1)
    source, which = np.nonzero(keep)
    poses = T[source].copy()
    poses[:, :3, 3] = voxel_centre(index[source, which])
    return poses, source


def voxelise(
    T_world_tcp: np.ndarray,
    score: np.ndarray,
    width: np.ndarray,
    k_max: int = 8,
    same_angle: float = np.deg2rad(5.0),
) -> VoxelLabels:
    """Labels from grasps ``T_world_tcp`` (G, 4, 4) with ``score`` and ``width`` (G,).

    Grasps whose TCP lies outside the workspace are ignored.
    """
    if k_max < 1:
        raise ValueError(f"k_max must be ≥ 1, got {k_max}")
    idx = voxel_of(T_world_tcp[:, :3, 3]).reshape(-1, 3)
    inside = np.all((idx >= 0) & (idx < RESOLUTION), axis=1)
    order = np.flatnonzero(inside)[np.argsort(-score[inside], kind="stable")]
    voxels: dict[tuple[int, int, int], list[int]] = {}
    for g in order:  # best first, so each voxel's first grasp is its best
        voxels.setdefault(tuple(int(v) for v in idx[g]), []).append(int(g))
    keys = sorted(voxels)
    m = len(keys)
    rotations = np.tile(np.eye(3), (m, k_max, 1, 1))
    mask = np.zeros((m, k_max), dtype=bool)
    dropped = 0
    for v, key in enumerate(keys):
        kept: list[np.ndarray] = []
        for g in voxels[key]:
            R = T_world_tcp[g, :3, :3]
            if all(rotation_angle_up_to_flip(R, K) >= same_angle for K in kept):
                kept.append(R)
        dropped += max(0, len(kept) - k_max)
        kept = kept[:k_max]
        rotations[v, : len(kept)] = kept
        mask[v, : len(kept)] = True
    best = np.array([voxels[k][0] for k in keys], dtype=np.int64)
    return VoxelLabels(
        voxel_index=np.array(keys, dtype=np.int64).reshape(m, 3),
        score=score[best].astype(np.float32),
        width=width[best].astype(np.float32),
        rotations=rotations.astype(np.float32),
        mask=mask,
        dropped=dropped,
    )
