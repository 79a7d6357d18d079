"""The top-k validation metrics against hand-built scenes whose picks are known by
construction, and the ranking they share with the detector."""

import math

import numpy as np
import pytest
import torch

from symgrasp import rotation
from symgrasp.bingham import sym_to_triu
from symgrasp.detect import GraspDetector
from symgrasp.model.metrics import TOP_K, MetricAccumulator
from symgrasp.model.network import GraspOutput
from symgrasp.model.ranking import rank_voxels
from symgrasp.sim import ROBOTIQ_2F85

R = 40
FLIP = torch.diag(torch.tensor([1.0, -1.0, -1.0], dtype=torch.float64))


def _rotation(approach, closing) -> torch.Tensor:
    e_x = torch.tensor(approach, dtype=torch.float64)
    e_x = e_x / e_x.norm()
    e_z = torch.tensor(closing, dtype=torch.float64)
    e_z = e_z / e_z.norm()
    return torch.stack([e_x, torch.linalg.cross(e_z, e_x), e_z], dim=1)


def _turned(Rot: torch.Tensor, degrees: float) -> torch.Tensor:
    """``Rot`` turned about its own approach axis e_x: e_x stays, e_z moves by ``degrees``."""
    a = math.radians(degrees)
    about_x = torch.tensor(
        [[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]],
        dtype=torch.float64,
    )
    return Rot @ about_x


ROT_A = _rotation([0, 0, -1], [1, 0, 0])
ROT_B = _rotation([1, 0, -1], [0, 1, 0])  # e_x 45° from ROT_A's, e_z 90°


def _channels(rep: str, Rot: torch.Tensor, gaps=(20.0, 10.0)) -> torch.Tensor:
    """Channels of ``rep`` that decode to ``Rot`` (bingham2d: confidence sum of ``gaps``)."""
    if rep == "bingham2d":
        A = Rot @ torch.diag(torch.tensor([-gaps[0], -gaps[1], 0.0], dtype=Rot.dtype)) @ Rot.T
        return torch.cat([sym_to_triu(A), Rot[:, 0]]).float()
    assert rep == "rotmat6d"
    return torch.cat([Rot[:, 0], Rot[:, 2]]).float()


def _scene(rep: str, predicted: dict, labels: dict, scenes: int = 2, flip_targets=False):
    """A batch of ``scenes`` scenes; scene 0 holds ``predicted`` {voxel: (score, validity,
    rotation, gaps)} and ``labels`` {voxel: [targets]}; the others hold the labels and no
    candidate (validity 0.01 everywhere)."""
    c = rotation.get(rep).channels
    score = torch.zeros(scenes, R, R, R)
    validity = torch.full((scenes, R, R, R), float(torch.logit(torch.tensor(0.01))))
    rot = torch.zeros(scenes, c, R, R, R)
    rot[:, 0] = 1.0  # a harmless default rotation
    for (i, j, k), (s, v, Rot, gaps) in predicted.items():
        score[0, i, j, k] = s
        validity[0, i, j, k] = torch.logit(torch.tensor(v))
        rot[0, :, i, j, k] = _channels(rep, Rot, gaps)
    valid = torch.zeros(scenes, R, R, R)
    index, targets, masks = [], [], []
    for b in range(scenes):
        for voxel, rots in labels.items():
            valid[(b, *voxel)] = 1.0
            index.append([b, *voxel])
            t = torch.eye(3).repeat(4, 1, 1)
            for n, Rot in enumerate(rots):
                t[n] = (Rot @ FLIP if flip_targets else Rot).float()
            targets.append(t)
            masks.append(torch.arange(4) < len(rots))
    batch = {
        "valid": valid,
        "score": torch.zeros(scenes, R, R, R),
        "voxel_index": torch.tensor(index),
        "rotations": torch.stack(targets),
        "rotation_mask": torch.stack(masks),
    }
    return GraspOutput(score, validity, rot), batch


P1, P2, P3, P4, P7 = (10, 10, 10), (20, 20, 21), (30, 30, 30), (5, 5, 5), (25, 5, 5)
P0, P6, P8 = (11, 11, 10), (35, 35, 35), (15, 30, 5)
LABELS = {
    P1: [ROT_A],
    (20, 20, 20): [ROT_B],  # P2's neighbour; P2 itself is not labelled
    P3: [ROT_A],
    P7: [ROT_A, ROT_B],
}
PREDICTED = {
    P1: (0.9, 0.5, ROT_A, (20, 10)),  # valid, correct
    P2: (0.8, 0.5, ROT_B, (20, 10)),  # not labelled; its neighbour's target matches
    P3: (0.7, 0.5, ROT_B, (20, 10)),  # valid, wrong: e_x 45°, e_z 90°
    P4: (0.6, 0.5, ROT_A, (20, 10)),  # nothing labelled near
    P7: (0.55, 0.5, _turned(ROT_A, 10), (20, 10)),  # valid, e_z 10° off: correct
    P0: (0.5, 0.5, ROT_A, (20, 10)),  # within 2 voxels of P1, lower score: suppressed
    P6: (1.0, 0.05, ROT_A, (20, 10)),  # validity 0.05 < 0.08: not a candidate
    P8: (0.99, 0.5, ROT_A, (8, 5)),  # confidence 13 < 15: not a candidate (bingham2d)
}
EXPECTED = {  # scene 0's shares; scene 1 has no candidate and counts 0
    "top1_valid": 1.0, "top1_correct": 1.0, "top1_valid_near": 1.0, "top1_correct_near": 1.0,
    "top5_valid": 3 / 5, "top5_correct": 2 / 5, "top5_valid_near": 4 / 5,
    "top5_correct_near": 3 / 5,
}  # fmt: skip


def _metrics(rep="bingham2d", predicted=PREDICTED, **kwargs):
    accumulator = MetricAccumulator(rotation.get(rep))
    accumulator.update(*_scene(rep, predicted, LABELS, **kwargs))
    return accumulator.compute()


def test_picks_and_shares_known_by_construction():
    out, _ = _scene("bingham2d", PREDICTED, LABELS)
    ranked = rank_voxels(
        out.score[0], out.validity[0].sigmoid(), out.rotation[0].movedim(0, -1),
        rotation.get("bingham2d"), confidence_threshold=15.0, top_k=5,
    )  # fmt: skip
    assert [tuple(v) for v in ranked.index.tolist()] == [P1, P2, P3, P4, P7]
    metrics = _metrics()
    for name, share in EXPECTED.items():
        assert metrics[name] == pytest.approx(share / 2), name  # averaged with scene 1's 0
    assert metrics["top_empty"] == 0.5
    assert metrics["top1_ex_deg"] == pytest.approx(0, abs=1e-3)
    assert metrics["top1_ez_deg"] == pytest.approx(0, abs=1e-3)
    # valid picks P1, P3, P7: e_x 0°, 45°, 0° and e_z 0°, 90°, 10°
    assert metrics["top5_ex_deg"] == pytest.approx(0, abs=1e-3)
    assert metrics["top5_ez_deg"] == pytest.approx(10, abs=1e-3)
    assert {f"top{k}_{m}" for k in TOP_K for m in ("valid", "ex_deg")} <= set(metrics)
    assert {"validity_ap", "score_mae", "ex_median_deg", "ez_median_deg"} <= set(metrics)


def test_representations_without_confidence_rank_without_the_threshold():
    metrics = _metrics("rotmat6d")  # P8 (score 0.99) is now the top pick, and not labelled
    assert metrics["top1_valid"] == 0.0 and metrics["top1_valid_near"] == 0.0
    # top 5: P8, P1, P2, P3, P4 → valid P1, P3; correct P1; near adds P2 (correct)
    assert metrics["top5_valid"] == pytest.approx(2 / 5 / 2)
    assert metrics["top5_correct"] == pytest.approx(1 / 5 / 2)
    assert metrics["top5_valid_near"] == pytest.approx(3 / 5 / 2)
    assert metrics["top5_correct_near"] == pytest.approx(2 / 5 / 2)


@pytest.mark.parametrize("rep", ["bingham2d", "rotmat6d"])
def test_flipping_e_z_of_predictions_or_targets_changes_nothing(rep):
    flipped = {v: (s, p, Rot @ FLIP, g) for v, (s, p, Rot, g) in PREDICTED.items()}
    reference = _metrics(rep)
    for metrics in (_metrics(rep, flipped), _metrics(rep, flip_targets=True)):
        assert metrics.keys() == reference.keys()
        for key, value in reference.items():
            if math.isnan(value):
                assert math.isnan(metrics[key]), key
            else:
                assert metrics[key] == pytest.approx(value, abs=1e-4), key


def test_no_candidate_anywhere_gives_zero_shares_and_nan_angles():
    metrics = _metrics(predicted={})
    assert all(metrics[name] == 0.0 for name in EXPECTED)
    assert math.isnan(metrics["top1_ex_deg"]) and math.isnan(metrics["top5_ez_deg"])
    assert metrics["top_empty"] == 1.0


class _Fixed(torch.nn.Module):
    def __init__(self, out: GraspOutput):
        super().__init__()
        self.representation = rotation.get("bingham2d")
        self.out = out

    def forward(self, tsdf):
        return GraspOutput(*(x[:1] for x in self.out))


def test_the_detector_picks_the_same_voxels():
    out, _ = _scene("bingham2d", PREDICTED, LABELS)
    detector = GraspDetector(_Fixed(out), ROBOTIQ_2F85, device="cpu", top_k=5)
    grasps = detector.detect_tsdf(np.ones((R, R, R)))
    assert [g.voxel for g in grasps] == [P1, P2, P3, P4, P7]
