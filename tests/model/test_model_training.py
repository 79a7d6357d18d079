"""Training: checkpoints, resume equivalence, clear errors, the CLI, and a tiny overfit."""

import csv
import math
from pathlib import Path

import pytest
import torch

from symgrasp.cli import main
from symgrasp.config import ValidityLoss
from symgrasp.model import GraspNet, NetworkConfig, TrainConfig, grasp_losses, load_model, train
from symgrasp.model.checkpoint import load_checkpoint, save_checkpoint
from symgrasp.model.metrics import MetricAccumulator
from symgrasp.model.synthetic import SyntheticGraspDataset, collate_scenes
from symgrasp.model.train import accumulate_gradient, collate_chunks
from symgrasp.sim import FRANKA, ROBOTIQ_2F85

SMALL = (2, 2, 4, 4)  # widths of a tiny network: these tests check the loop, not learning
TINY = NetworkConfig(widths=SMALL, features=4)


class _Stop(Exception):
    """Stands for a run killed between two epochs."""


class _StopsAt(SyntheticGraspDataset):
    """Synthetic scenes whose run is killed when epoch ``stop`` (0-based) is about to start."""

    def __init__(self, scenes, gripper, stop):
        super().__init__(scenes, gripper=gripper)
        self.stop = stop

    def set_epoch(self, epoch):
        if epoch == self.stop:
            raise _Stop


def _data(gripper=ROBOTIQ_2F85, scenes=3, stop_at=None):
    return (
        SyntheticGraspDataset(scenes, gripper=gripper)
        if stop_at is None
        else _StopsAt(scenes, gripper, stop_at),
        SyntheticGraspDataset(1, gripper=gripper, seed=9),
        collate_scenes,
    )


def _config(tmp_path, name="run", **kwargs):
    # on the CPU: the oracles below recompute in float32 what CUDA would train under bfloat16
    defaults = dict(
        data="synthetic", out=str(tmp_path / name), epochs=2, batch_size=2, network=TINY,
        device="cpu",
    )  # fmt: skip
    return TrainConfig(**{**defaults, **kwargs})


def test_training_writes_checkpoints_metrics_and_a_curve(tmp_path):
    history = train(_config(tmp_path), _data())
    out = tmp_path / "run"
    assert [row["epoch"] for row in history] == [1, 2]
    with open(out / "metrics.csv") as file:
        rows = list(csv.DictReader(file))
    assert len(rows) == 2
    for key in (
        "train_total",
        "val_total",
        "validity_ap",
        "score_mae",
        "ex_median_deg",
        "ez_median_deg",
        "confidence_correct",
        "confidence_wrong",
    ):
        assert key in rows[0]
    assert (out / "learning_curve.png").stat().st_size > 1000
    state = load_checkpoint(out / "last.pt")
    assert state["representation"] == "bingham2d"
    assert state["gripper"] == ROBOTIQ_2F85.to_dict()  # the whole spec, not a name
    assert state["dataset_hash"] == SyntheticGraspDataset(3).manifest["dataset_hash"]
    assert state["symgrasp_version"] and state["config"]["epochs"] == 2
    assert (out / "best.pt").exists()


def test_checkpoints_store_the_configuration_flat_as_the_shipped_models_hold_it():
    """The shipped models were written before ``network`` and ``validity`` were nested in
    `TrainConfig`: their flat record reads back (``autocast`` and ``ignore_band``, newer, at their
    defaults) and is written again key for key."""
    from symgrasp.detect.pretrained import shipped_path
    from symgrasp.names import PRETRAINED

    for name in PRETRAINED:
        state = load_checkpoint(shipped_path(name))
        config = TrainConfig.from_record(state["config"])
        assert config.network == NetworkConfig(**state["network"])
        assert config.validity == ValidityLoss()
        assert config.record() == {**state["config"], "autocast": True, "ignore_band": 0}
    focal = _config(Path("r"), validity=ValidityLoss("focal", 1.5, 0.25, ignore_band=2))
    record = focal.record()
    keys = ("validity_loss", "focal_gamma", "focal_alpha", "ignore_band", "widths")
    assert {k: record[k] for k in keys} == {
        "validity_loss": "focal", "focal_gamma": 1.5, "focal_alpha": 0.25, "ignore_band": 2,
        "widths": SMALL,
    }  # fmt: skip
    assert "network" not in record and "validity" not in record
    assert TrainConfig.from_record(record) == focal


def test_checkpoint_round_trip_and_wrong_representation(tmp_path):
    torch.manual_seed(0)
    model = GraspNet(NetworkConfig("quaternion", SMALL, 4))
    path = tmp_path / "model.pt"
    save_checkpoint(
        path,
        {
            "representation": "quaternion",
            "network": {"representation": "quaternion", "widths": SMALL, "features": 4},
            "model": model.state_dict(),
        },
    )
    loaded, _ = load_model(path, representation="quaternion")
    tsdf = torch.rand(1, 1, 16, 16, 16)
    assert torch.equal(model(tsdf).rotation, loaded(tsdf).rotation)
    with pytest.raises(ValueError, match=r"'quaternion' model.*'bingham2d'"):
        load_model(path, representation="bingham2d")
    with pytest.raises(ValueError, match="no file"):
        load_checkpoint(tmp_path / "missing.pt")


def test_checkpoint_with_non_finite_or_corrupted_weights_is_refused_naming_the_file(tmp_path):
    """Weights are checked when loaded: every floating tensor finite (``model`` and, to resume,
    ``model_raw``), every byte as written (the zip archive's CRC-32s, which torch.load skips)."""
    weights = GraspNet(TINY).state_dict()
    state = {"representation": "bingham2d", "network": {"widths": SMALL, "features": 4}}
    for entry in ("model", "model_raw"):
        broken = {**weights, "enc0.weight": weights["enc0.weight"].clone()}
        broken["enc0.weight"][0, 0, 0, 0, 1] = torch.inf
        save_checkpoint(tmp_path / "diverged.pt", {**state, "model": weights, entry: broken})
        with pytest.raises(
            ValueError,
            match=rf"diverged.pt holds non-finite weights: {entry}\['enc0.weight'\] has 1 NaN",
        ):
            load_model(tmp_path / "diverged.pt")
    save_checkpoint(tmp_path / "good.pt", {**state, "model": weights})
    whole = bytearray((tmp_path / "good.pt").read_bytes())
    whole[whole.index(weights["rotation_head.bias"].numpy().tobytes())] ^= 0x01
    (tmp_path / "flipped.pt").write_bytes(bytes(whole))
    torch.load(tmp_path / "flipped.pt", weights_only=True)  # one weight one bit off: loads
    corrupted = r"flipped.pt is not a readable symgrasp checkpoint: its bytes are corrupted"
    with pytest.raises(ValueError, match=corrupted + r" \(the entry .*/data/\d+ fails its CRC-32"):
        load_model(tmp_path / "flipped.pt")
    (tmp_path / "cut.pt").write_bytes(bytes(whole[:300]))
    with pytest.raises(
        ValueError, match=r"cut.pt is not a readable symgrasp checkpoint \(truncated or corrupted"
    ):
        load_checkpoint(tmp_path / "cut.pt")


def test_resume_gives_the_same_weights_as_an_uninterrupted_run(tmp_path):
    train(_config(tmp_path, "straight", epochs=2), _data())
    train(_config(tmp_path, "resumed", epochs=1, resume=True), _data())  # nothing yet: a start
    train(_config(tmp_path, "resumed", epochs=2, resume=True), _data())
    straight = load_checkpoint(tmp_path / "straight" / "last.pt")["model"]
    resumed = load_checkpoint(tmp_path / "resumed" / "last.pt")["model"]
    assert all(torch.equal(straight[key], resumed[key]) for key in straight)
    with pytest.raises(ValueError, match="already holds a run"):
        train(_config(tmp_path, "straight"), _data())


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device here")
def test_cuda_without_autocast_trains_the_cpu_run_up_to_float_rounding(tmp_path):
    """The CPU run, float32, is the oracle: CUDA with --no-autocast (float32, no TF32) follows
    its losses closely; bfloat16 autocast is what the option turns off."""
    cpu = train(_config(tmp_path, "cpu", epochs=1), _data())
    float32 = train(_config(tmp_path, "fp32", epochs=1, device="cuda", autocast=False), _data())
    for key in ("train_total", "val_total"):
        assert float32[0][key] == pytest.approx(cpu[0][key], rel=1e-4), key


RECIPE = dict(
    schedule="cosine", warmup=0.3, min_lr=1e-5, ema=0.8, weight_decay=0.01,
    validity=ValidityLoss("focal", focal_alpha=0.25),
)  # fmt: skip
"""Every option that carries state across epochs: the step count of the schedule, the weight
average, AdamW's decay."""


def test_a_run_stopped_between_epochs_resumes_bit_for_bit(tmp_path):
    train(_config(tmp_path, "straight", epochs=3, **RECIPE), _data())
    with pytest.raises(_Stop):
        train(_config(tmp_path, "stopped", epochs=3, **RECIPE), _data(stop_at=1))
    assert load_checkpoint(tmp_path / "stopped" / "last.pt")["epoch"] == 1
    train(_config(tmp_path, "stopped", epochs=3, resume=True, **RECIPE), _data())
    straight, resumed = (
        load_checkpoint(tmp_path / run / "last.pt") for run in ("straight", "stopped")
    )
    for key in ("model", "model_raw"):  # the weight average and the trained weights
        assert all(torch.equal(straight[key][name], resumed[key][name]) for name in straight[key])
    for column in ("lr", "train_total", "val_total"):
        assert [row[column] for row in straight["history"]] == [
            row[column] for row in resumed["history"]
        ]
    rates = [row["lr"] for row in straight["history"]]
    # step 1 of 6 warms up (lr / 2), step 3 is past the cosine's peak, step 5 its end: min_lr
    assert rates == [
        5e-4,
        pytest.approx(1e-5 + (1e-3 - 1e-5) * 0.5 * (1 + math.cos(math.pi / 3))),
        1e-5,
    ]


def test_the_default_recipe_is_adam_at_a_constant_lr(tmp_path):
    """The oracle: a plain Adam loop over the same batches gives the same weights."""
    config = _config(tmp_path, epochs=1)
    train(config, _data())
    state = load_checkpoint(tmp_path / "run" / "last.pt")
    torch.manual_seed(config.seed)
    net = GraspNet(config.network)
    optimizer = torch.optim.Adam(net.parameters(), lr=config.lr)
    scenes = _data()[0]
    order = torch.randperm(3, generator=torch.Generator().manual_seed(config.seed * 1_000_003))
    for batch in order.split(config.batch_size):
        batch = collate_scenes([scenes[i] for i in batch.tolist()])
        loss = grasp_losses(net(batch["tsdf"]), batch, net.representation)["total"]
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    assert all(torch.equal(state["model"][name], v) for name, v in net.state_dict().items())
    assert "model_raw" not in state and state["history"][0]["lr"] == config.lr


def test_clear_errors_for_another_gripper_or_representation(tmp_path):
    with pytest.raises(ValueError, match="produced for the gripper 'franka'"):
        train(_config(tmp_path), _data(gripper=FRANKA))
    train(_config(tmp_path, "franka", gripper="franka", epochs=1), _data(gripper=FRANKA))
    with pytest.raises(ValueError, match="trained for the gripper 'franka'"):
        train(_config(tmp_path, "franka", epochs=2, resume=True), _data())
    with pytest.raises(ValueError, match=r"'bingham2d' model.*'rotmat6d'"):
        train(
            _config(
                tmp_path,
                "franka",
                gripper="franka",
                network=NetworkConfig("rotmat6d", SMALL, 4),
                epochs=2,
                resume=True,
            ),
            _data(gripper=FRANKA),
        )


def test_cli_help_lists_every_option(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["train", "--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    for option in (
        "--data",
        "--rep",
        "--gripper",
        "--out",
        "--epochs",
        "--batch-size",
        "--device",
        "--resume",
        "--seed",
    ):
        assert option in text


def test_a_batch_in_chunks_has_the_whole_batchs_loss_and_gradient():
    """The oracle: one forward and backward pass of the whole batch. Chunks of 1, 2 and 3 + 1
    scenes (``micro_batch``) must give its losses and gradient up to float rounding. In float64,
    where the network's output for a scene does not depend on the batch at all; in float32
    oneDNN's convolutions blocked for another batch size move the outputs by up to 1e-3 and
    the gradient by up to 5e-4 of its largest element (seen), which Adam makes float noise."""
    torch.manual_seed(0)
    net = GraspNet(NetworkConfig("bingham2d", SMALL, 4)).double()
    items = [SyntheticGraspDataset(4, seed=3)[i] for i in range(4)]
    items = [{**item, "tsdf": item["tsdf"].double()} for item in items]
    whole = collate_scenes(items)
    assert len({len(item["voxel_index"]) for item in items}) > 1  # chunks weigh differently
    expected = grasp_losses(net(whole["tsdf"]), whole, net.representation)
    net.zero_grad()
    expected["total"].backward()
    grad = torch.cat([p.grad.flatten() for p in net.parameters()])
    scale = grad.abs().max()

    def chunked(size, equal_weights=False):
        net.zero_grad()
        chunks = collate_chunks(collate_scenes, size, items)
        if equal_weights:  # what a plain mean of the chunks' losses would train on
            for chunk in chunks:
                losses = grasp_losses(net(chunk["tsdf"]), chunk, net.representation)
                (losses["total"] / len(chunks)).backward()
        else:
            config = _config(Path("unused"), micro_batch=size)
            losses = accumulate_gradient(net, net, chunks, config, world=1, step=1)
        return losses, torch.cat([p.grad.flatten() for p in net.parameters()])

    for size in (1, 2, 3):
        losses, chunked_grad = chunked(size)
        for key, value in expected.items():
            assert losses[key] == pytest.approx(value.item(), rel=1e-5), (size, key)
        torch.testing.assert_close(chunked_grad, grad, rtol=0, atol=1e-5 * scale)
    # Seen: equal weights are off by ≈ 0.15 of the largest gradient element.
    _, plain = chunked(1, equal_weights=True)
    assert (plain - grad).abs().max() > 1e-2 * scale


@pytest.mark.slow
def test_tiny_overfit_on_one_scene():
    """bingham2d on one synthetic scene, 500 full-batch Adam steps (≈ 30 s on 2 CPU cores)."""
    torch.manual_seed(0)
    batch = collate_scenes([SyntheticGraspDataset(1, seed=1)[0]])
    model = GraspNet(NetworkConfig("bingham2d"))
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
    first = None
    for _ in range(500):
        losses = grasp_losses(model(batch["tsdf"]), batch, model.representation)
        first = first if first is not None else losses["validity"].item()
        optimizer.zero_grad()
        losses["total"].backward()
        optimizer.step()
    with torch.no_grad():
        output = model(batch["tsdf"])
    metrics = MetricAccumulator(model.representation)
    metrics.update(output, batch)
    result = metrics.compute()
    last = grasp_losses(output, batch, model.representation)["validity"].item()
    assert last < first / 10
    assert result["validity_ap"] > 0.9
    assert result["ex_median_deg"] < 10 and result["ez_median_deg"] < 10
    assert result["confidence_correct"] > 15  # the paper's threshold: correct grasps pass it


def test_cli_reports_bad_options_as_errors(tmp_path):
    with pytest.raises(
        SystemExit, match=r"error: epochs must be an integer in \[1, 100000\], got 0"
    ):
        main(["train", "--data", str(tmp_path), "--out", str(tmp_path / "run"), "--epochs", "0"])
