"""The judging rounds' collation (experiments/judge.py): each run's numbers from its rounds,
the run each model ships by SR + CR, the seeds' paired difference, and runs that cannot be
read yet (not judged, judged with another best.pt) holding their model's pick back."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from symgrasp.digest import file_sha256

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
ROUNDS = {  # (successes, executed) of each judging round, 5 objects presented each
    "m-bingham2d-s0": [(3, 4), (2, 5), (4, 4)],
    "m-bingham2d-s1": [(4, 5), (3, 3), (5, 5)],
    "other-bingham2d-s0": [(1, 1), (1, 1), (1, 1)],
}

OLD_RULE = ["--table-clearance", "-0.002", "--surface-clearance", "-0.002"]
"""The folders record no clearances: played by the approach check before 2026-11-27."""


def _round(seed, successes, executed):
    attempt = {"target": "box", "score": 1.0, "confidence": 20.0, "candidates": 3,
               "rejected": 0, "planning_s": 0.1}  # fmt: skip
    attempts = [{**attempt, "outcome": "success", "mode": "success"}] * successes + [
        {**attempt, "outcome": "slipped", "mode": "slipped"}] * (executed - successes)  # fmt: skip
    return {"seed": seed, "objects": 5, "renderer": "gl", "successes": successes,
            "executed": executed, "attempts": attempts}  # fmt: skip


def _campaign(root):
    for name, counts in ROUNDS.items():
        run = root / "runs" / name
        run.mkdir(parents=True)
        (run / "best.pt").write_bytes(name.encode())
        (run / "selection.json").write_text(json.dumps({
            "by": "declutter_sr_cr",
            "chosen": {"checkpoint": "epoch_002.pt", "epoch": 2, "sha256": "ab" * 32},
            "declutter": {"folder": str(run / "selection" / "declutter" / "settings")},
            "checkpoints": [{"checkpoint": "epoch_002.pt", "declutter_sr": 0.9,
                             "declutter_cr": 0.7}],
        }))  # fmt: skip
        folder = root / "bench" / "judge" / name
        folder.mkdir(parents=True)
        config = {"model": str(run / "best.pt"), "objects": "vgn-pile-train", "scene": "pile",
                  "num_objects": 5, "rounds": 3, "seed": 2_000_000}  # fmt: skip
        (folder / "config.json").write_text(json.dumps(config))
        played = run / "best.pt" if name != "other-bingham2d-s0" else run / "selection.json"
        (folder / "model.sha256").write_text(file_sha256(played) + "\n")
        (folder / "rounds.jsonl").write_text(
            "".join(json.dumps(_round(2_000_000 + i, *c)) + "\n" for i, c in enumerate(counts))
        )


def test_each_model_ships_its_highest_sr_plus_cr_and_waits_for_runs_not_judged_as_selected(
    tmp_path,
):
    _campaign(tmp_path)
    done = subprocess.run(
        [sys.executable, "experiments/judge.py", "--root", str(tmp_path), "--rounds", "3",
         "--runs", *ROUNDS, "--result", str(tmp_path / "judge"), *OLD_RULE],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "judge.json").read_text())
    runs = {r["run"]: r for r in result["cells"]}

    def pooled(name):  # SR: successes over executed grasps; CR: over the 15 objects presented
        counts = ROUNDS[name]
        successes = sum(s for s, _ in counts)
        return successes / sum(e for _, e in counts), successes / 15

    for name in ("m-bingham2d-s0", "m-bingham2d-s1"):
        sr, cr = pooled(name)
        assert runs[name]["success_ratio"] == pytest.approx(sr)
        assert runs[name]["clear_ratio"] == pytest.approx(cr)
        assert runs[name]["epoch"] == 2 and runs[name]["validation_sr"] == 0.9
    assert "another best.pt" in runs["other-bingham2d-s0"]["missing"]
    picks = {p["model"]: p for p in result["picks"]}
    assert picks["m-bingham2d"]["ships"] == "m-bingham2d-s1"  # 12/13 + 12/15 against 9/13 + 9/15
    (difference,) = picks["m-bingham2d"]["seed_differences"]
    assert difference["success_ratio"][0] == pytest.approx(
        pooled("m-bingham2d-s0")[0] - pooled("m-bingham2d-s1")[0]
    )
    assert picks["other-bingham2d"]["waiting"] == ["other-bingham2d-s0"]


def test_a_run_name_without_its_training_seed_is_refused_by_name(tmp_path):
    done = subprocess.run(
        [sys.executable, "experiments/judge.py", "--root", str(tmp_path), "--runs", "wide"],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 2 and "--runs" in done.stderr and "'wide'" in done.stderr


def test_a_judging_folder_from_before_the_model_record_is_taken_as_it_is(tmp_path):
    _campaign(tmp_path)
    (tmp_path / "bench" / "judge" / "m-bingham2d-s0" / "model.sha256").unlink()
    done = subprocess.run(
        [sys.executable, "experiments/judge.py", "--root", str(tmp_path), "--rounds", "3",
         "--runs", "m-bingham2d-s0", "--result", str(tmp_path / "judge"), *OLD_RULE],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    (cell,) = json.loads((tmp_path / "judge.json").read_text())["cells"]
    assert "missing" not in cell and cell["success_ratio"] > 0


def _judge(root, *options):
    return subprocess.run(
        [sys.executable, "experiments/judge.py", "--root", str(root), "--rounds", "3",
         "--result", str(root / "judge"), *OLD_RULE, *options],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip


def test_a_shipped_model_is_a_one_run_model_that_runs_are_contrasted_with(tmp_path):
    _campaign(tmp_path)
    from symgrasp.detect.pretrained import shipped_path

    folder = tmp_path / "bench" / "judge" / "shipped-bingham2d-franka"
    folder.mkdir(parents=True)
    config = {"model": "bingham2d-franka", "objects": "vgn-pile-train", "scene": "pile",
              "num_objects": 5, "rounds": 3, "seed": 2_000_000}  # fmt: skip
    (folder / "config.json").write_text(json.dumps(config))
    (folder / "model.sha256").write_text(file_sha256(shipped_path("bingham2d-franka")) + "\n")
    # one success fewer than m-bingham2d-s1's in every round, the same grasps executed
    rounds = [(3, 5), (2, 3), (4, 5)]
    (folder / "rounds.jsonl").write_text(
        "".join(json.dumps(_round(2_000_000 + i, *c)) + "\n" for i, c in enumerate(rounds))
    )
    done = _judge(tmp_path, "--runs", "m-bingham2d-s1", "other-bingham2d-s0",
                  "--shipped", "bingham2d-franka",
                  "--contrast", "m-bingham2d", "shipped-bingham2d-franka",
                  "--contrast", "other-bingham2d", "shipped-bingham2d-franka")  # fmt: skip
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "judge.json").read_text())
    shipped = next(r for r in result["cells"] if r["run"] == "shipped-bingham2d-franka")
    assert shipped["success_ratio"] == pytest.approx(9 / 13)
    assert "shipped-bingham2d-franka" not in {p["model"] for p in result["picks"]}
    lead, waiting = result["contrasts"]
    # three more successes of 13 grasps and of 15 objects; ahead in every resample of the rounds
    point, low, _ = lead["change"]["sr_plus_cr"]
    assert point == pytest.approx(3 / 13 + 3 / 15) and low > 0
    assert lead["verdict"] == "beats" and lead["ahead"] == 1
    assert waiting["waiting"] == ["other-bingham2d-s0"]  # judged another best.pt
    assert "| m-bingham2d − shipped-bingham2d-franka | 3 |" in done.stdout


def test_a_contrast_of_a_model_not_judged_is_refused_by_name(tmp_path):
    done = _judge(tmp_path, "--runs", "m-bingham2d-s0", "--contrast", "m-bingham2d", "wide")
    assert done.returncode == 2 and "--contrast: 'wide' is none of the models" in done.stderr


def test_test_rounds_are_reported_without_a_pick(tmp_path):
    _campaign(tmp_path)
    for name in ("m-bingham2d-s0", "m-bingham2d-s1"):  # the judging rounds, as test rounds
        judging, test = (tmp_path / "bench" / n / name for n in ("judge", "test-packed"))
        test.parent.mkdir(parents=True, exist_ok=True)
        judging.rename(test)
        config = json.loads((test / "config.json").read_text())
        (test / "config.json").write_text(json.dumps({**config, "scene": "packed"}))
    runs = ["--runs", "m-bingham2d-s0", "m-bingham2d-s1"]
    assert "not judged" in _judge(tmp_path, *runs).stdout  # the judging rounds are gone
    wrong_scene = _judge(tmp_path, *runs, "--test", "test-packed")
    assert "its scene differ" in wrong_scene.stdout
    done = _judge(tmp_path, *runs, "--test", "test-packed", "--scene", "packed")
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "judge.json").read_text())
    assert result["picks"] == [] and "ships" not in done.stdout
    assert all("missing" not in run for run in result["cells"])
    assert "test rounds (`test-packed`, no pick made on them)" in done.stdout
