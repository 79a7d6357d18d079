"""A small analytic grasp dataset that follows the dataset contract of ``symgrasp.data``.

Tests, benchmarks and smoke runs of the trainer need scenes without the simulator: each scene
here is one to three boxes standing on a table, yawed about z, with grasps known in closed form.
Items are exactly what `symgrasp.data.dataset.GraspDataset` yields (see ``docs/model.md``):

- ``tsdf [1, 40, 40, 40]``: the analytic signed distance to the table and boxes, divided by the
  truncation distance (4 voxels) and clipped to [−1, 1] (positive in free space);
- ``valid``, ``score [40, 40, 40]``, ``voxel_index [M, 3]``, ``rotations [M, K_max, 3, 3]``,
  ``rotation_mask [M, K_max]``, ``width [M]``.

Grasps of a box with long axis u, narrow axis v (its width fits the gripper) and half-height h:

- **top-down**: approach e_x = −z, closing axis e_z = ±v, TCP on the box's long centre line
  1.25–2.75 cm below its top face; score 0.8 at the centre falling to 0.4 at the ends;
- **end-on**: approach e_x = ∓u into either end face, e_z = ±v, TCP 1.25–2.75 cm inside the
  face on a vertical line from 1 cm above the table to 4.5 cm below the top; score 0.3.

The sign of e_z is drawn at random per grasp, so both twins of the 180° flip appear, across
voxels and inside one voxel. Grasps are sampled every 2.5 mm along their TCP lines and each
belongs to the voxel containing its TCP, as in the contract.
"""

from __future__ import annotations

import math

import torch
from torch.utils.data import Dataset

from symgrasp.perception.tsdf import TRUNCATION_VOXELS
from symgrasp.sim.grippers import ROBOTIQ_2F85, GripperSpec
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE

Tensor = torch.Tensor

TRUNCATION = TRUNCATION_VOXELS * VOXEL_SIZE
"""[m], as `symgrasp.perception.TSDFVolume` truncates."""
GRASP_DEPTHS = (0.0125, 0.02, 0.0275)
"""[m] how far inside the face the TCPs of a synthetic grasp line lie."""
END_ON_GAP = 0.045
"""[m] end-on TCPs stay this far below the top face: ≥ 2 voxels from the top-down ones, so no
voxel mixes the two approach directions (a distribution over e_z would fit such a voxel, but its
single approach vector could only be their compromise)."""
SAMPLE_SPACING = 0.0025
"""[m] spacing of grasp samples along their TCP lines."""


class SyntheticGraspDataset(Dataset):
    """``num_scenes`` analytic scenes; item ``i`` depends only on ``(seed, i)``.

    Args:
        num_scenes: number of scenes.
        gripper: the gripper the labels claim to be for.
        k_max: targets per voxel kept (the first ``k_max`` grasps of a voxel).
        seed: scene generator seed.
    """

    object_set = "synthetic-boxes"

    def __init__(
        self,
        num_scenes: int,
        gripper: GripperSpec = ROBOTIQ_2F85,
        k_max: int = 8,
        seed: int = 0,
    ) -> None:
        if num_scenes < 1:
            raise ValueError(f"num_scenes must be ≥ 1, got {num_scenes}")
        if k_max < 1:
            raise ValueError(f"k_max must be ≥ 1, got {k_max}")
        self.num_scenes, self.k_max, self.seed = num_scenes, k_max, seed
        self.gripper = gripper
        self.manifest = {
            "gripper": self.gripper.to_dict(),
            "object_set": self.object_set,
            "k_max": k_max,
            "resolution": RESOLUTION,
            "voxel_size": VOXEL_SIZE,
            "num_scenes": num_scenes,
            "dataset_hash": f"synthetic-{num_scenes}-{k_max}-{seed}",
            "symgrasp_version": "synthetic",
        }

    def __len__(self) -> int:
        return self.num_scenes

    def __getitem__(self, index: int) -> dict[str, Tensor]:
        if not 0 <= index < self.num_scenes:
            raise IndexError(f"scene index {index} out of range [0, {self.num_scenes})")
        generator = torch.Generator().manual_seed(self.seed * 1_000_003 + index)
        boxes = _random_boxes(generator)
        return {"tsdf": _tsdf(boxes)[None], **_labels(boxes, self.k_max, generator)}


def collate_scenes(items: list[dict[str, Tensor]]) -> dict[str, Tensor]:
    """The contract's collate: stack the volumes, concatenate the voxels with a batch column.

    ``voxel_index`` becomes int64 ``[ΣM, 4]`` = (b, i, j, k); the other per-voxel tensors are
    concatenated along their first dimension.
    """
    batch = {key: torch.stack([item[key] for item in items]) for key in ("tsdf", "valid", "score")}
    batch["voxel_index"] = torch.cat(
        [
            torch.cat([torch.full((len(item["voxel_index"]), 1), b), item["voxel_index"]], dim=1)
            for b, item in enumerate(items)
        ]
    )
    for key in ("rotations", "rotation_mask", "width"):
        batch[key] = torch.cat([item[key] for item in items])
    return batch


class _Box:
    """An upright box on the table: centre [m], yaw [rad], half-sizes (long, narrow, height)."""

    def __init__(self, centre: Tensor, yaw: float, half: Tensor) -> None:
        self.centre, self.half = centre, half
        self.long = torch.tensor([math.cos(yaw), math.sin(yaw), 0.0])
        self.narrow = torch.tensor([-math.sin(yaw), math.cos(yaw), 0.0])

    def signed_distance(self, points: Tensor) -> Tensor:
        """``[N, 3]`` → ``[N]`` exact signed distance (negative inside)."""
        local = points - self.centre
        axes = torch.stack([self.long, self.narrow, torch.tensor([0.0, 0.0, 1.0])], dim=1)
        q = (local @ axes).abs() - self.half
        outside = q.clamp(min=0).norm(dim=-1)
        inside = q.amax(dim=-1).clamp(max=0)
        return outside + inside


def _random_boxes(generator: torch.Generator) -> list[_Box]:
    """One to three boxes on the table whose footprints (as circles) do not overlap."""

    def uniform(low: float, high: float) -> float:
        return low + (high - low) * torch.rand((), generator=generator).item()

    boxes: list[_Box] = []
    count = int(torch.randint(1, 4, (), generator=generator))
    for _ in range(50 * count):
        if len(boxes) == count:
            break
        half = torch.tensor([uniform(0.03, 0.06), uniform(0.015, 0.035), uniform(0.03, 0.05)])
        centre = torch.tensor([uniform(0.08, 0.22), uniform(0.08, 0.22), TABLE_HEIGHT + half[2]])
        radius = half[:2].norm()
        if all((centre[:2] - b.centre[:2]).norm() > radius + b.half[:2].norm() for b in boxes):
            boxes.append(_Box(centre, uniform(-math.pi, math.pi), half))
    return boxes


def voxel_centres() -> Tensor:
    """``[40, 40, 40, 3]`` world positions [m] of the voxel centres ((i + ½) · 7.5 mm, …)."""
    idx = (torch.arange(RESOLUTION, dtype=torch.float32) + 0.5) * VOXEL_SIZE
    return torch.stack(torch.meshgrid(idx, idx, idx, indexing="ij"), dim=-1)


def _tsdf(boxes: list[_Box]) -> Tensor:
    points = voxel_centres().reshape(-1, 3)
    distance = points[:, 2] - TABLE_HEIGHT
    for box in boxes:
        distance = torch.minimum(distance, box.signed_distance(points))
    return (distance / TRUNCATION).clamp(-1, 1).reshape((RESOLUTION,) * 3)


def _grasp_lines(box: _Box) -> list[tuple[Tensor, Tensor, Tensor, float, float]]:
    """(start, end, approach, score at the centre, score at the ends) of each TCP line."""
    up = torch.tensor([0.0, 0.0, 1.0])
    long, height = box.half[0].item(), box.half[2].item()
    lines = []
    for depth in GRASP_DEPTHS:
        top = box.centre + (height - depth) * up
        reach = long - 0.01
        lines.append((top - reach * box.long, top + reach * box.long, -up, 0.8, 0.4))
        for sign in (1.0, -1.0):
            face = box.centre + sign * (long - depth) * box.long
            bottom, top_end = face - (height - 0.01) * up, face + (height - END_ON_GAP) * up
            lines.append((bottom, top_end, -sign * box.long, 0.3, 0.3))
    return lines


def _labels(boxes: list[_Box], k_max: int, generator: torch.Generator) -> dict[str, Tensor]:
    tcps, rotations, scores, widths = [], [], [], []
    for box in boxes:
        for start, end, approach, centre_score, end_score in _grasp_lines(box):
            n = max(2, math.ceil((end - start).norm().item() / SAMPLE_SPACING) + 1)
            t = torch.linspace(0, 1, n)
            tcps.append(start + t[:, None] * (end - start))
            sign = torch.where(torch.rand(n, generator=generator) < 0.5, -1.0, 1.0)
            closing = sign[:, None] * box.narrow
            frame = torch.stack(
                [
                    approach.expand(n, 3),
                    torch.linalg.cross(closing, approach.expand(n, 3)),
                    closing,
                ],
                dim=-1,
            )
            rotations.append(frame)
            scores.append(end_score + (centre_score - end_score) * (1 - (2 * t - 1).abs()))
            widths.append(torch.full((n,), 2 * box.half[1].item()))
    tcp, rotation, score, width = map(torch.cat, (tcps, rotations, scores, widths))
    voxel = (tcp / VOXEL_SIZE).floor().long().clamp(0, RESOLUTION - 1)
    flat = (voxel[:, 0] * RESOLUTION + voxel[:, 1]) * RESOLUTION + voxel[:, 2]
    cells, owner = torch.unique(flat, return_inverse=True)
    m = len(cells)
    voxel_index = torch.stack(
        [cells // RESOLUTION**2, (cells // RESOLUTION) % RESOLUTION, cells % RESOLUTION], dim=1
    )
    targets = torch.eye(3).repeat(m, k_max, 1, 1)
    mask = torch.zeros(m, k_max, dtype=torch.bool)
    best_score = torch.full((m,), -1.0)
    best_width = torch.zeros(m)
    filled = torch.zeros(m, dtype=torch.long)
    for g in range(len(tcp)):
        v = owner[g].item()
        if filled[v] < k_max:
            targets[v, filled[v]] = rotation[g]
            mask[v, filled[v]] = True
            filled[v] += 1
        if score[g] > best_score[v]:
            best_score[v], best_width[v] = score[g], width[g]
    valid = torch.zeros((RESOLUTION,) * 3)
    score_volume = torch.zeros((RESOLUTION,) * 3)
    i, j, k = voxel_index.unbind(1)
    valid[i, j, k] = 1.0
    score_volume[i, j, k] = best_score
    return {
        "valid": valid,
        "score": score_volume,
        "voxel_index": voxel_index,
        "rotations": targets,
        "rotation_mask": mask,
        "width": best_width,
    }
