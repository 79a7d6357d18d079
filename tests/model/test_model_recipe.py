"""The training recipe's options against closed forms and torch's own implementations: lr
schedules, the weight average, the focal validity loss, the first N scenes, kept epochs."""

import io
import json
import math
import zipfile

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from symgrasp import rotation
from symgrasp.config import NetworkConfig, TrainConfig, ValidityLoss
from symgrasp.data.dataset import GraspDataset, in_split
from symgrasp.detect.pretrained import export_model
from symgrasp.model import GraspNet, GraspOutput, grasp_losses, load_model, train
from symgrasp.model.averaging import WeightAverage
from symgrasp.model.checkpoint import load_checkpoint
from symgrasp.model.loss import focal_loss
from symgrasp.model.schedule import learning_rate
from symgrasp.model.synthetic import SyntheticGraspDataset, collate_scenes
from symgrasp.model.train import FirstScenes, evaluate
from symgrasp.names import SCHEDULES

SMALL = NetworkConfig(widths=(2, 2, 4, 4), features=4)


def _config(tmp_path=None, name="run", **kwargs):
    out = str(tmp_path / name) if tmp_path else "r"
    # on the CPU: the oracles below recompute in float32 what CUDA would train under bfloat16
    defaults = dict(data="synthetic", out=out, epochs=2, batch_size=2, network=SMALL, device="cpu")
    return TrainConfig(**{**defaults, **kwargs})


def _data(scenes=3):
    return SyntheticGraspDataset(scenes), SyntheticGraspDataset(1, seed=9), collate_scenes


# -- learning-rate schedules ------------------------------------------------------------------


def test_constant_schedule_is_the_lr_at_every_step():
    config = _config()
    assert all(learning_rate(config, step, 50) == config.lr for step in range(50))


def test_cosine_schedule_against_its_closed_form():
    lr, low, total = 2e-3, 1e-5, 101
    config = _config(lr=lr, schedule="cosine", warmup=0.1, min_lr=low)
    warm = 10  # round(0.1 · 101)
    rates = [learning_rate(config, step, total) for step in range(total)]
    # linear warm-up from 0: equal increments of lr / W
    assert rates[0] == 0
    assert np.allclose(np.diff(rates[: warm + 1]), lr / warm, rtol=1e-12, atol=0)
    for step in range(warm, total):
        t = (step - warm) / (total - 1 - warm)
        expected = low + 0.5 * (lr - low) * (1 + math.cos(math.pi * t))
        assert rates[step] == pytest.approx(expected, rel=1e-12)
    assert rates[warm] == lr and rates[-1] == low
    assert all(a >= b for a, b in zip(rates[warm:], rates[warm + 1 :], strict=False))


def test_constant_schedule_with_warm_up():
    config = _config(warmup=0.25)
    rates = [learning_rate(config, step, 40) for step in range(40)]
    assert rates[:10] == pytest.approx([config.lr * s / 10 for s in range(10)], rel=1e-12)
    assert rates[10:] == [config.lr] * 30


@pytest.mark.parametrize("total", [7, 40, 333])
@pytest.mark.parametrize("low", [0.0, 3e-6])
def test_onecycle_schedule_is_torchs_one_cycle(total, low):
    lr, warmup = 1e-3, 0.3
    config = _config(lr=lr, schedule="onecycle", warmup=warmup, min_lr=low)
    weight = torch.nn.Parameter(torch.zeros(1))
    optimizer = torch.optim.Adam([weight], lr=lr)
    scheduler = torch.optim.lr_scheduler.OneCycleLR(
        optimizer, max_lr=lr, total_steps=total, pct_start=warmup, anneal_strategy="cos",
        cycle_momentum=False, div_factor=25.0,
        final_div_factor=(lr / 25) / low if low else math.inf,
    )  # fmt: skip
    for step in range(total):
        assert learning_rate(config, step, total) == pytest.approx(
            optimizer.param_groups[0]["lr"], rel=1e-12, abs=1e-18
        ), step
        optimizer.step()
        scheduler.step()
    assert learning_rate(config, 0, total) == pytest.approx(lr / 25, rel=1e-12)
    assert learning_rate(config, total - 1, total) == pytest.approx(low, rel=1e-12, abs=1e-18)
    assert max(learning_rate(config, s, total) for s in range(total)) <= lr


def test_every_schedule_name_is_implemented():
    for schedule in SCHEDULES:
        config = _config(schedule=schedule, warmup=0.2)
        assert all(0 <= learning_rate(config, s, 20) <= config.lr for s in range(20))


# -- the weight average -----------------------------------------------------------------------


def test_weight_average_against_its_closed_form():
    torch.manual_seed(0)
    net = torch.nn.Sequential(torch.nn.Linear(3, 2), torch.nn.BatchNorm1d(2)).double()
    decay = 0.7
    average = WeightAverage(net, decay)
    start = [p.detach().clone() for p in net.parameters()]
    steps = []
    for _ in range(5):
        with torch.no_grad():
            for p in net.parameters():
                p.copy_(torch.randn_like(p))
        net(torch.randn(4, 3, dtype=torch.float64))  # moves the BatchNorm's running statistics
        average.update(net)
        steps.append([p.detach().clone() for p in net.parameters()])
    n = len(steps)
    for i, averaged in enumerate(average.module.parameters()):
        expected = decay**n * start[i] + (1 - decay) * sum(
            decay ** (n - k) * steps[k - 1][i] for k in range(1, n + 1)
        )
        torch.testing.assert_close(averaged, expected, rtol=1e-12, atol=1e-14)
    for averaged, buffer in zip(average.module.buffers(), net.buffers(), strict=True):
        assert torch.equal(averaged, buffer)  # copied, not averaged
    assert not any(p.requires_grad for p in average.module.parameters())


def test_training_with_ema_validates_and_saves_the_average(tmp_path):
    history = train(_config(tmp_path, epochs=1, ema=0.5), _data())
    state = load_checkpoint(tmp_path / "run" / "last.pt")
    assert set(state["model"]) == set(state["model_raw"])
    assert any(not torch.equal(state["model"][k], state["model_raw"][k]) for k in state["model"])
    averaged, _ = load_model(tmp_path / "run" / "last.pt")
    loader = torch.utils.data.DataLoader(_data()[1], batch_size=2, collate_fn=collate_scenes)
    assert evaluate(averaged, loader)[0]["total"] == history[-1]["val_total"]
    raw = GraspNet(_config().network)
    raw.load_state_dict(state["model_raw"])
    assert evaluate(raw, loader)[0]["total"] != history[-1]["val_total"]
    shipped = load_checkpoint(export_model(tmp_path / "run" / "last.pt", tmp_path / "small.pt"))
    assert "model_raw" not in shipped and "optimizer" not in shipped


# -- the focal validity loss ------------------------------------------------------------------


def test_focal_loss_with_gamma_0_is_the_cross_entropy_exactly():
    generator = torch.Generator().manual_seed(0)
    logits = torch.randn(2, 40, 40, 40, generator=generator) * 4
    labels = (torch.rand(2, 40, 40, 40, generator=generator) < 0.01).float()
    bce = F.binary_cross_entropy_with_logits(logits, labels, reduction="none")
    assert torch.equal(focal_loss(logits, labels, 0.0, None), bce)
    batch = collate_scenes([SyntheticGraspDataset(2, seed=5)[i] for i in range(2)])
    output = GraspOutput(
        score=torch.randn(2, 40, 40, 40, generator=generator),
        validity=logits,
        rotation=torch.randn(2, 6, 40, 40, 40, generator=generator),
    )
    representation = rotation.get("rotmat6d")
    plain = grasp_losses(output, batch, representation)
    focal = grasp_losses(output, batch, representation, None, ValidityLoss("focal", 0.0))
    assert torch.equal(plain["validity"], focal["validity"])
    assert torch.equal(plain["total"], focal["total"])


def test_focal_loss_closed_form_and_normalisation():
    logits = torch.tensor([2.0, -1.0, 0.5, -3.0, 0.0], dtype=torch.float64)
    labels = torch.tensor([1.0, 0.0, 0.0, 1.0, 1.0], dtype=torch.float64)
    gamma, alpha = 2.0, 0.25
    expected = []
    for x, y in zip(logits.tolist(), labels.tolist(), strict=True):
        p = 1 / (1 + math.exp(-x))
        p_t, alpha_t = (p, alpha) if y == 1 else (1 - p, 1 - alpha)
        expected.append(-alpha_t * (1 - p_t) ** gamma * math.log(p_t))
    got = focal_loss(logits, labels, gamma, alpha)
    assert got.tolist() == pytest.approx(expected, rel=1e-12)
    # in grasp_losses: summed over all voxels, divided by the number of valid voxels
    batch = collate_scenes([SyntheticGraspDataset(1, seed=5)[0]])
    generator = torch.Generator().manual_seed(1)
    output = GraspOutput(
        score=torch.zeros(1, 40, 40, 40),
        validity=torch.randn(1, 40, 40, 40, generator=generator),
        rotation=torch.randn(1, 6, 40, 40, 40, generator=generator),
    )
    loss = ValidityLoss("focal", gamma, alpha)
    got = grasp_losses(output, batch, rotation.get("rotmat6d"), None, loss)["validity"]
    valid = batch["valid"].double()
    by_hand = focal_loss(output.validity.double(), valid, gamma, alpha).sum() / valid.sum()
    assert got.item() == pytest.approx(by_hand.item(), rel=1e-5)


@pytest.mark.parametrize("gamma", [0.5, 2.0, 5.0])
@pytest.mark.parametrize("alpha", [None, 0.25])
def test_focal_loss_gradient_points_towards_the_label(gamma, alpha):
    logits = torch.tensor([-200.0, -8.0, -1.0, 0.0, 1.0, 8.0, 200.0], requires_grad=True)
    for label in (0.0, 1.0):
        labels = torch.full_like(logits, label)
        (grad,) = torch.autograd.grad(focal_loss(logits, labels, gamma, alpha).sum(), logits)
        assert torch.isfinite(grad).all()
        # towards the label: down for 0, up for 1; strictly, but where p_t rounds to 1
        sign = 1 if label == 0 else -1
        strict = grad[1:] if label == 0 else grad[:-1]
        assert (sign * strict > 0).all() and (sign * grad >= 0).all()
    # focusing: a well-classified voxel weighs less than under the cross-entropy
    x, one = torch.tensor([3.0]), torch.ones(1)
    ratio = focal_loss(x, one, gamma, None) / focal_loss(x, one, 0.0, None)
    assert ratio.item() == pytest.approx((1 - torch.sigmoid(x).item()) ** gamma, rel=1e-5)


# -- the first N scenes, kept epochs ----------------------------------------------------------


def test_first_scenes_are_the_first_train_ids(tmp_path):
    ids = [23, 3, 0, 11, 19, 9, 1, 14, 2, 5, 8, 4, 7, 6, 10, 12, 13]  # not sorted, 9/19 val
    manifest = {"gripper": "franka", "object_set": "blocks", "k_max": 4, "scene_ids": ids}
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    (tmp_path / "scenes").mkdir()
    tsdf = io.BytesIO()
    np.save(tsdf, np.zeros((40, 40, 40), np.float32))  # a TSDF of the contract's shape
    for scene_id in ids:
        path = tmp_path / "scenes" / f"scene_{scene_id:06d}.npz"
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("tsdf.npy", tsdf.getvalue())
    dataset = GraspDataset(tmp_path, split="train")
    train_ids = sorted(i for i in ids if in_split(i, "train"))
    for count in (1, 5, 12, len(train_ids)):
        first = FirstScenes(dataset, count)
        assert first.scene_ids == train_ids[:count]
        assert [dataset.paths[i].name for i in first.indices] == [
            f"scene_{i:06d}.npz" for i in train_ids[:count]
        ]
        assert first.gripper == dataset.gripper and first.manifest is dataset.manifest
    with pytest.raises(ValueError, match=r"train_scenes must be in \[1, 15\], .* got 16"):
        FirstScenes(dataset, 16)
    with pytest.raises(ValueError, match=r"val_scenes must be in \[1, 15\], .* got 16"):
        FirstScenes(dataset, 16, "val_scenes")


class _Recording(SyntheticGraspDataset):
    """Synthetic scenes that note which items training read."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.read = set()

    def __getitem__(self, index):
        self.read.add(index)
        return super().__getitem__(index)


def test_train_scenes_val_scenes_and_keep_every(tmp_path):
    scenes, val = _Recording(5), _Recording(4, seed=9)
    train(_config(tmp_path, train_scenes=2, val_scenes=3, keep_every=1),
          (scenes, val, _data()[2]))  # fmt: skip
    assert scenes.read == {0, 1} and val.read == {0, 1, 2}
    out = tmp_path / "run"
    last = load_checkpoint(out / "last.pt")
    assert last["config"]["train_scenes"] == 2
    assert sorted(p.name for p in out.glob("epoch_*.pt")) == ["epoch_001.pt", "epoch_002.pt"]
    kept = load_checkpoint(out / "epoch_002.pt")
    assert kept["epoch"] == 2
    assert all(torch.equal(kept["model"][k], v) for k, v in last["model"].items())
    assert load_checkpoint(out / "epoch_001.pt")["epoch"] == 1
    assert not list(out.glob("*.tmp"))


# -- configuration and resuming ---------------------------------------------------------------


@pytest.mark.parametrize(
    "options, message",
    [
        ({"schedule": "step"}, "schedule must be one of constant, cosine, onecycle, got 'step'"),
        ({"warmup": 1.5}, r"warmup must be a number in \[0, 1\], got 1.5"),
        ({"schedule": "onecycle"}, r"onecycle schedule needs warmup in \(0, 1\)"),
        ({"schedule": "cosine", "min_lr": 0.1}, r"min_lr must be a number in \[0, 0.001\]"),
        ({"min_lr": 1e-5}, "min_lr is where a cosine or onecycle schedule ends"),
        ({"ema": 1.0}, r"ema must be a number in \[0, 1\) \(0: off\), got 1.0"),
        ({"ema": float("nan")}, "ema must be a number"),
        ({"weight_decay": -1e-4}, "weight_decay must be a number"),
        ({"validity_loss": "dice"}, "validity_loss must be one of bce, focal, got 'dice'"),
        ({"validity_loss": "focal", "focal_gamma": -1.0}, "focal_gamma must be a number"),
        ({"validity_loss": "focal", "focal_alpha": 2.0}, "focal_alpha must be a number"),
        ({"focal_gamma": 1.0}, "focal_gamma and focal_alpha are options of the focal loss"),
        ({"train_scenes": -1}, "train_scenes must be an integer"),
        ({"keep_every": 1.5}, "keep_every must be an integer"),
    ],
)
def test_bad_recipe_options_are_refused_by_name(options, message):
    with pytest.raises(ValueError, match=message):  # by the names of the flags and checkpoints
        TrainConfig.from_record({"data": "d", "out": "r", **options})


def test_resume_refuses_another_recipe_and_accepts_an_old_checkpoint(tmp_path):
    train(_config(tmp_path, epochs=1), _data())
    with pytest.raises(ValueError, match="checkpoint's run has schedule 'constant', epochs 1; "
                       "asked for schedule 'cosine', epochs 2"):  # fmt: skip
        train(_config(tmp_path, epochs=2, schedule="cosine", resume=True), _data())
    with pytest.raises(ValueError, match=r"ema 0\.0, validity_loss 'bce'; asked for ema 0\.9"):
        focal = ValidityLoss("focal")
        train(_config(tmp_path, epochs=2, ema=0.9, validity=focal, resume=True), _data())
    with pytest.raises(ValueError, match=r"lr 0\.001; asked for lr 0\.0001"):
        train(_config(tmp_path, epochs=2, lr=1e-4, resume=True), _data())
    with pytest.raises(ValueError, match="autocast True; asked for autocast False"):
        train(_config(tmp_path, epochs=2, autocast=False, resume=True), _data())
    # a checkpoint from before these options resumes with their defaults
    path = tmp_path / "run" / "last.pt"
    state = torch.load(path, weights_only=True)
    new = ("schedule", "warmup", "min_lr", "ema", "weight_decay", "validity_loss", "focal_gamma",
           "focal_alpha", "train_scenes", "keep_every", "autocast")  # fmt: skip
    state["config"] = {k: v for k, v in state["config"].items() if k not in new}
    torch.save(state, path)
    assert len(train(_config(tmp_path, epochs=2, resume=True), _data())) == 2


def test_a_schedule_keeps_its_length_on_resume(tmp_path):
    train(_config(tmp_path, epochs=1, schedule="cosine"), _data())  # planned: 1 epoch
    with pytest.raises(ValueError, match="epochs 1; asked for epochs 2"):
        train(_config(tmp_path, epochs=2, schedule="cosine", resume=True), _data())
