"""Training: checkpoints, resume equivalence, clear errors, the CLI, and a tiny overfit."""

import csv

import pytest
import torch

from symgrasp.cli import main
from symgrasp.model import GraspNet, NetworkConfig, TrainConfig, grasp_losses, load_model, train
from symgrasp.model.checkpoint import load_checkpoint, save_checkpoint
from symgrasp.model.metrics import MetricAccumulator
from symgrasp.model.synthetic import SyntheticGraspDataset, collate_scenes
from symgrasp.sim import ROBOTIQ_2F85

SMALL = (2, 2, 4, 4)  # widths of a tiny network: these tests check the loop, not learning


def _data(gripper="robotiq-2f85", scenes=3):
    return (
        SyntheticGraspDataset(scenes, gripper=gripper),
        SyntheticGraspDataset(1, gripper=gripper, seed=9),
        collate_scenes,
    )


def _config(tmp_path, name="run", **kwargs):
    defaults = dict(
        data="synthetic", out=str(tmp_path / name), epochs=2, batch_size=2, widths=SMALL, features=4
    )
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


def test_resume_gives_the_same_weights_as_an_uninterrupted_run(tmp_path):
    train(_config(tmp_path, "straight", epochs=2), _data())
    train(_config(tmp_path, "resumed", epochs=1), _data())
    train(_config(tmp_path, "resumed", epochs=2, resume=True), _data())
    straight = load_checkpoint(tmp_path / "straight" / "last.pt")["model"]
    resumed = load_checkpoint(tmp_path / "resumed" / "last.pt")["model"]
    assert all(torch.equal(straight[key], resumed[key]) for key in straight)
    with pytest.raises(ValueError, match="already holds a run"):
        train(_config(tmp_path, "straight"), _data())


def test_clear_errors_for_another_gripper_or_representation(tmp_path):
    with pytest.raises(ValueError, match="produced for the gripper 'franka'"):
        train(_config(tmp_path), _data(gripper="franka"))
    train(_config(tmp_path, "franka", gripper="franka", epochs=1), _data(gripper="franka"))
    with pytest.raises(ValueError, match="trained for the gripper 'franka'"):
        train(_config(tmp_path, "franka", epochs=2, resume=True), _data())
    with pytest.raises(ValueError, match=r"'bingham2d' model.*'rotmat6d'"):
        train(
            _config(
                tmp_path,
                "franka",
                gripper="franka",
                representation="rotmat6d",
                epochs=2,
                resume=True,
            ),
            _data(gripper="franka"),
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
