"""Loss, metrics and the synthetic dataset against closed forms and invariances."""

import math

import pytest
import torch
import torch.nn.functional as F

from symgrasp import rotation
from symgrasp.config import ValidityLoss
from symgrasp.model import GraspOutput, grasp_losses
from symgrasp.model.loss import at_voxels, focal_loss, ignored_voxels
from symgrasp.model.metrics import average_precision, rotation_errors
from symgrasp.model.synthetic import SyntheticGraspDataset, collate_scenes


def _about_x(angle: float) -> torch.Tensor:
    c, s = math.cos(angle), math.sin(angle)
    return torch.tensor([[1.0, 0, 0], [0, c, -s], [0, s, c]], dtype=torch.float64)


def test_average_precision_closed_forms():
    label = torch.tensor([1.0, 0, 1, 0])
    assert average_precision(torch.tensor([0.9, 0.8, 0.7, 0.1]), label) == pytest.approx(
        (1 + 2 / 3) / 2
    )
    assert average_precision(torch.tensor([0.9, 0.1, 0.8, 0.2]), label) == 1.0
    assert math.isnan(average_precision(torch.rand(4), torch.zeros(4)))
    with pytest.raises(ValueError, match="equal shape"):
        average_precision(torch.rand(4), torch.zeros(3))


def test_rotation_errors_are_flip_invariant_and_exact():
    q = torch.randn(5, 4, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    R = rotation.quaternion_to_matrix(F.normalize(q, dim=-1))
    theta = 0.3
    # Turning about the approach axis moves e_z by θ; turning about e_z moves e_x by θ.
    about_approach = R @ _about_x(theta)
    about_closing = R @ _about_x(theta)[[2, 0, 1]][:, [2, 0, 1]]
    mask = torch.ones(5, 1, dtype=torch.bool)
    ex, ez = rotation_errors(rotation.flip(R), R[:, None], mask)
    assert ex.abs().max() < 1e-3 and ez.abs().max() < 1e-3
    ex, ez = rotation_errors(about_approach, rotation.flip(R)[:, None], mask)
    assert ex.abs().max() < 1e-3
    assert ez == pytest.approx(torch.full((5,), math.degrees(theta), dtype=torch.float64), abs=1e-3)
    ex, ez = rotation_errors(about_closing, R[:, None], mask)
    assert ex == pytest.approx(torch.full((5,), math.degrees(theta), dtype=torch.float64), abs=1e-3)
    # The nearest valid target counts; masked-out targets are ignored even when exact.
    targets = torch.stack([about_approach, R], dim=1)
    ex, ez = rotation_errors(R, targets, torch.tensor([[True, False]] * 5))
    assert ez == pytest.approx(torch.full((5,), math.degrees(theta), dtype=torch.float64), abs=1e-3)


def test_losses_against_their_definitions():
    dataset = SyntheticGraspDataset(2, seed=5)
    batch = collate_scenes([dataset[0], dataset[1]])
    representation = rotation.get("rotmat6d")
    generator = torch.Generator().manual_seed(0)
    output = GraspOutput(
        score=torch.randn(2, 40, 40, 40, generator=generator),
        validity=torch.randn(2, 40, 40, 40, generator=generator),
        rotation=torch.randn(2, 6, 40, 40, 40, generator=generator),
    )
    losses = grasp_losses(output, batch, representation)
    index = batch["voxel_index"]
    m = len(index)
    bce = F.binary_cross_entropy_with_logits(output.validity, batch["valid"], reduction="sum") / m
    b, i, j, k = index.T
    score = (output.score[b, i, j, k] - batch["score"][b, i, j, k]).square().mean()
    pred = output.rotation.permute(0, 2, 3, 4, 1)[b, i, j, k]
    rot = representation.loss(pred, batch["rotations"], batch["rotation_mask"]).mean()
    assert losses["validity"] == pytest.approx(bce.item(), rel=1e-5)
    assert losses["score"] == pytest.approx(score.item(), rel=1e-5)
    assert losses["rotation"] == pytest.approx(rot.item(), rel=1e-5)
    assert losses["total"] == pytest.approx((bce + score + rot).item(), rel=1e-5)
    assert torch.equal(at_voxels(output.rotation, index), pred)


def _two_scenes_one_valid_voxel_each() -> dict[str, torch.Tensor]:
    """Scene 0 valid at (5, 6, 7), scene 1 at the corner (0, 0, 39)."""
    valid = torch.zeros(2, 40, 40, 40)
    valid[0, 5, 6, 7] = valid[1, 0, 0, 39] = 1
    index = torch.tensor([[0, 5, 6, 7], [1, 0, 0, 39]])
    return {"valid": valid, "score": valid * 0.5, "voxel_index": index,
            "rotations": torch.eye(3).expand(2, 1, 3, 3), "rotation_mask": torch.ones(2, 1, dtype=torch.bool)}  # fmt: skip


def test_the_ignore_band_leaves_out_the_invalid_cube_around_each_valid_voxel():
    batch = _two_scenes_one_valid_voxel_each()
    for band in (1, 2):
        ignored = ignored_voxels(batch["valid"], band)
        # oracle: the (2d + 1)³ cube about each valid voxel, clipped by the grid, less itself
        cube = torch.zeros_like(ignored)
        cube[0, 5 - band : 6 + band, 6 - band : 7 + band, 7 - band : 8 + band] = True
        cube[1, : band + 1, : band + 1, 39 - band :] = True
        cube[0, 5, 6, 7] = cube[1, 0, 0, 39] = False
        assert torch.equal(ignored, cube)
        assert (
            ignored[0].sum() == (2 * band + 1) ** 3 - 1 and ignored[1].sum() == (band + 1) ** 3 - 1
        )
    assert not ignored_voxels(torch.zeros(1, 40, 40, 40), 3).any()


@pytest.mark.parametrize("kind", ["bce", "focal"])
def test_the_ignore_band_drops_exactly_those_voxels_from_the_validity_loss(kind):
    batch = _two_scenes_one_valid_voxel_each()
    generator = torch.Generator().manual_seed(1)
    output = GraspOutput(
        score=torch.randn(2, 40, 40, 40, generator=generator),
        validity=torch.randn(2, 40, 40, 40, generator=generator),
        rotation=torch.randn(2, 6, 40, 40, 40, generator=generator),
    )
    representation = rotation.get("rotmat6d")
    plain = ValidityLoss(kind)
    banded = ValidityLoss(kind, ignore_band=1)
    keep = ~ignored_voxels(batch["valid"], 1)
    logits, labels = output.validity[keep], batch["valid"][keep]
    per_voxel = F.binary_cross_entropy_with_logits(logits, labels, reduction="none")
    if kind == "focal":  # γ = 2: (1 − p_t)² CE
        p = torch.sigmoid(logits)
        per_voxel = per_voxel * (1 - torch.where(labels == 1, p, 1 - p)).square()
    banded_loss = grasp_losses(output, batch, representation, validity_loss=banded)
    assert banded_loss["validity"] == pytest.approx(per_voxel.sum().item() / 2, rel=1e-5)
    # off, the loss is the one before the option existed, to the bit; score and rotation unchanged
    off = grasp_losses(output, batch, representation, validity_loss=plain)
    if kind == "bce":
        before = F.binary_cross_entropy_with_logits(
            output.validity, batch["valid"], reduction="sum"
        )
    else:
        before = focal_loss(output.validity, batch["valid"], plain.focal_gamma, None).sum()
    assert torch.equal(off["validity"], before / 2)
    assert off["validity"] > banded_loss["validity"]
    assert torch.equal(off["rotation"], banded_loss["rotation"])
    assert torch.equal(off["score"], banded_loss["score"])


def test_synthetic_scenes_follow_the_dataset_contract():
    dataset = SyntheticGraspDataset(3, k_max=4, seed=7)
    item = dataset[1]
    assert item["tsdf"].shape == (1, 40, 40, 40) and item["tsdf"].dtype == torch.float32
    assert item["tsdf"].min() >= -1 and item["tsdf"].max() <= 1
    m = len(item["voxel_index"])
    assert m > 0 and item["voxel_index"].dtype == torch.int64
    assert item["rotations"].shape == (m, 4, 3, 3) and item["rotation_mask"].shape == (m, 4)
    assert item["width"].shape == (m,) and item["rotation_mask"].any(1).all()
    i, j, k = item["voxel_index"].T
    assert item["valid"].sum() == m and (item["valid"][i, j, k] == 1).all()
    assert (item["score"][item["valid"] == 0] == 0).all() and (item["score"][i, j, k] > 0).all()
    assert (item["tsdf"][0, i, j, k] < 0).all()  # grasp centres lie inside the boxes
    R = item["rotations"][item["rotation_mask"]]
    assert torch.allclose(R.transpose(-1, -2) @ R, torch.eye(3).expand_as(R), atol=1e-5)
    assert torch.allclose(torch.linalg.det(R), torch.ones(len(R)), atol=1e-5)
    assert (R[:, :, 2] @ torch.tensor([1.0, 1.0, 0.0]) > 0).any()  # both flips occur
    assert (R[:, :, 2] @ torch.tensor([1.0, 1.0, 0.0]) < 0).any()
    again = SyntheticGraspDataset(3, k_max=4, seed=7)[1]
    assert all(torch.equal(item[key], again[key]) for key in item)
    batch = collate_scenes([dataset[0], item])
    assert batch["tsdf"].shape == (2, 1, 40, 40, 40)
    assert batch["voxel_index"].shape == (len(dataset[0]["voxel_index"]) + m, 4)
    assert torch.equal(batch["voxel_index"][-m:, 1:], item["voxel_index"])
    assert (batch["voxel_index"][-m:, 0] == 1).all()
