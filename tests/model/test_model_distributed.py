"""Data-parallel training: two CPU processes (gloo) follow the one-process run with the same
global batch, resume, and shard every global batch into disjoint slices."""

import csv

import pytest
import torch

from symgrasp.model import NetworkConfig, TrainConfig, train
from symgrasp.model.checkpoint import load_checkpoint, load_model
from symgrasp.model.distributed import ShardedBatches, launch, start
from symgrasp.model.synthetic import SyntheticGraspDataset, collate_scenes

SMALL = NetworkConfig(widths=(2, 2, 4, 4), features=4)


def test_ranks_take_disjoint_slices_that_make_up_the_one_process_batches():
    def batches(rank, world, size=11, batch=4):
        generator = torch.Generator().manual_seed(7)
        return list(ShardedBatches(size, batch, generator, rank, world))

    alone = batches(0, 1)
    expected = torch.randperm(11, generator=torch.Generator().manual_seed(7)).tolist()
    assert [i for b in alone for i in b] == expected  # a RandomSampler's batches
    halves = [batches(0, 2), batches(1, 2)]
    assert len(halves[0]) == len(halves[1]) == len(alone) == 3
    for step, whole in enumerate(alone[:-1]):  # full batches: split exactly
        assert halves[0][step] + halves[1][step] == whole
        assert not set(halves[0][step]) & set(halves[1][step])
    last = halves[0][-1] + halves[1][-1]  # 3 scenes for 2 ranks: padded with its first
    assert last == [*alone[-1], alone[-1][0]]
    with pytest.raises(ValueError, match="batch_size 3 must be a multiple of the 2"):
        ShardedBatches(11, 3, torch.Generator(), 0, 2)


def _rows(run):
    with open(run / "metrics.csv") as file:
        return list(csv.DictReader(file))


def test_two_processes_follow_the_one_process_loss_curve_and_resume(tmp_path):
    data = (SyntheticGraspDataset(8), SyntheticGraspDataset(2, seed=9), collate_scenes)
    # gloo on the CPU: two ranks need two GPUs, and CI has none
    config = dict(data="synthetic", batch_size=4, network=SMALL, lr=3e-3, device="cpu")
    train(TrainConfig(out=str(tmp_path / "one"), epochs=2, **config), data)
    two = str(tmp_path / "two")
    launch(train, (TrainConfig(out=two, epochs=1, **config), data), 2)
    # resumed in chunks of one scene: each rank passes its slice scene by scene and the ranks
    # average their gradients once, after the last (micro_batch does not change the run)
    launch(train, (TrainConfig(out=two, epochs=2, resume=True, micro_batch=1, **config), data), 2)

    one, two = _rows(tmp_path / "one"), _rows(tmp_path / "two")
    assert [r["world_size"] for r in one + two] == ["1", "1", "2", "2"]
    assert all(r["global_batch_size"] == "4" and float(r["lr"]) == 3e-3 for r in one + two)
    # Seen: the training losses agree to 1e-7 in the first epoch and to 1.1e-4 in the second
    # (in chunks of one scene oneDNN blocks the convolutions otherwise: float32 outputs move by
    # up to 1e-3); Adam turns float noise in near-zero gradients into steps of ±lr, which moved
    # the validation losses by up to 1.3e-4 and validity AP, a ranking of nearly tied voxels,
    # by 2e-4 on the 2-core AMD EPYC; on a 16-core Intel Xeon (8 threads a rank) AP moved by
    # 3e-3 of its 0.0036, 1.1e-5 absolute; on an AVX2-only AMD EPYC (2026-11-27) the second
    # epoch's validation score loss moved by 3.2e-3 of it (the other losses ≤ 2.5e-4).
    # Plain DDP (each rank's mean loss, no voxel share) is 2e-2 off in training and 1e-1 in
    # the validation score loss: the tolerances below stay a factor ≥ 10 from it.
    for a, b in zip(one, two, strict=True):
        for key in ("train_total", "train_validity", "train_score", "train_rotation"):
            assert float(b[key]) == pytest.approx(float(a[key]), rel=1e-3), key
        for key in ("val_total", "val_score", "val_rotation"):
            assert float(b[key]) == pytest.approx(float(a[key]), rel=1e-2), key
        assert float(b["validity_ap"]) == pytest.approx(float(a["validity_ap"]), abs=5e-5)
    assert float(one[1]["train_total"]) != pytest.approx(float(one[0]["train_total"]), rel=1e-4)
    states = [load_checkpoint(tmp_path / run / "last.pt") for run in ("one", "two")]
    assert states[1]["world_size"] == 2 and states[1]["config"]["batch_size"] == 4
    # the same network: its outputs agree (conv biases before a GroupNorm get no gradient but
    # float noise, which Adam turns into steps of ±lr, so weights are not compared one by one).
    # Seen: float summation order alone moved them by up to 2.6e-4 in the default memory layout
    # and 3.6e-3 in channels-last; plain DDP moves them by 0.1–0.23. 2e-2 is a factor ≥ 5 from
    # both.
    tsdf = SyntheticGraspDataset(1, seed=5)[0]["tsdf"][None]
    one, two = (load_model(tmp_path / run / "last.pt")[0](tsdf) for run in ("one", "two"))
    for name in ("validity", "score", "rotation"):
        torch.testing.assert_close(getattr(two, name), getattr(one, name), rtol=0, atol=2e-2)


def test_a_rank_without_a_gpu_of_its_own_is_told_how_many_there_are(monkeypatch):
    monkeypatch.setenv("WORLD_SIZE", "2")
    monkeypatch.setenv("LOCAL_WORLD_SIZE", "2")
    monkeypatch.setenv("LOCAL_RANK", "1")
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    with pytest.raises(ValueError, match=r"2 training processes .* it has 1: pass --nproc 1"):
        start(torch.device("cuda"))


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device here")
def test_more_ranks_than_gpus_is_a_value_error_before_training(tmp_path):
    data = (SyntheticGraspDataset(4), SyntheticGraspDataset(1, seed=9), collate_scenes)
    ranks = torch.cuda.device_count() + 1
    config = TrainConfig(data="synthetic", out=str(tmp_path), epochs=1, batch_size=2 * ranks,
                         network=SMALL, device="cuda")  # fmt: skip
    with pytest.raises(ValueError, match=f"it has {ranks - 1}: pass --nproc {ranks - 1}"):
        launch(train, (config, data), ranks)
    assert not (tmp_path / "last.pt").exists()


def test_a_ranks_bad_input_is_a_value_error(tmp_path):
    data = (SyntheticGraspDataset(4), SyntheticGraspDataset(1, seed=9), collate_scenes)
    config = TrainConfig(data="synthetic", out=str(tmp_path), epochs=1, batch_size=2,
                         network=SMALL, gripper="franka", device="cpu")  # fmt: skip
    with pytest.raises(ValueError, match="produced for the gripper 'robotiq-2f85'"):
        launch(train, (config, data), 2)


@pytest.mark.parametrize("rank", [None, "0", "1"])
def test_only_rank_zero_reports_the_run(rank, monkeypatch, capsys):
    """torchrun runs ``symgrasp train`` on every rank, and a rank above 0 returns no history:
    the run is reported once, by rank 0 (or the process alone)."""
    import importlib

    from symgrasp.cli import main

    def trained(config):
        return [{"epoch": 0.0}] if rank in (None, "0") else []

    monkeypatch.setattr(importlib.import_module("symgrasp.model.train"), "train", trained)
    if rank is None:
        monkeypatch.delenv("RANK", raising=False)
    else:
        monkeypatch.setenv("RANK", rank)
    main(["train", "--data", "d", "--out", "run", "--epochs", "1"])
    reported = "1 epochs; checkpoints and metrics in run\n"
    assert capsys.readouterr().out == (reported if rank != "1" else "")


@pytest.mark.slow
def test_torchrun_and_nproc_train_a_dataset_folder_alike(tmp_path):
    """``torchrun --nproc-per-node 2 -m symgrasp train`` and ``symgrasp train --nproc 2`` on a
    generated dataset: the same run."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    from symgrasp.cli import main

    data = str(tmp_path / "data")
    main(["data", "generate", "--objects", "blocks", "--gripper", "franka", "--pool-size", "2",
          "--grasps", "40", "--directions", "8", "--scenes", "12", "--out", data])  # fmt: skip
    argv = ["train", "--data", data, "--gripper", "franka", "--epochs", "2", "--batch-size", "2",
            "--widths", "2", "2", "4", "4", "--features", "4", "--device", "cpu"]  # fmt: skip
    torchrun = shutil.which("torchrun", path=str(Path(sys.executable).parent))
    ranks = subprocess.run([torchrun, "--nproc-per-node", "2", "-m", "symgrasp", *argv, "--out",
                            str(tmp_path / "torchrun")], check=True, capture_output=True,
                           text=True)  # fmt: skip
    assert ranks.stdout.count("epochs; checkpoints and metrics in") == 1  # rank 0 reports
    main([*argv, "--nproc", "2", "--out", str(tmp_path / "nproc")])
    by_torchrun, by_nproc = _rows(tmp_path / "torchrun"), _rows(tmp_path / "nproc")
    assert [r["world_size"] for r in by_torchrun + by_nproc] == ["2"] * 4
    for a, b in zip(by_torchrun, by_nproc, strict=True):
        assert float(a["train_total"]) == pytest.approx(float(b["train_total"]), rel=1e-5)
