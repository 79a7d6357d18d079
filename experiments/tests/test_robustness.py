"""The robustness table (experiments/robustness.py) takes its clean rounds from Table 1's cell
when that cell recorded the same configuration, and its campaign plan
(experiments/campaigns/robustness.toml), read as the driver reads it (``campaign.py show``),
plays every cell and condition the script collates by default, each in a step of one core of
its own after the Table 1 rounds are unpacked, and collates once all of them are done."""

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from symgrasp.config import SURFACE_CLEARANCE, TABLE_CLEARANCE

from .conftest import campaign_steps

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}


def test_the_plan_plays_every_cell_the_table_waits_for_once_and_collates_after_them(tmp_path):
    steps = campaign_steps("experiments/campaigns/robustness.toml")
    page = tmp_path / "page.md"
    page.write_text("<!-- robustness-table: begin -->\n<!-- robustness-table: end -->\n")
    collated = subprocess.run(
        [sys.executable, "experiments/robustness.py", "--collate-only", "--out",
         str(tmp_path / "none"), "--baselines", str(tmp_path / "none"), "--docs", str(page),
         "--result", str(tmp_path / "robustness")],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert collated.returncode == 0, collated.stderr
    cells = json.loads((tmp_path / "robustness.json").read_text())["cells"]
    assert all(c["waiting"] for c in cells)
    wanted = {(c["model"], f"{c['objects']}:{c['scene']}", c["condition"]) for c in cells}
    assert len(wanted) == 4 * 2 * 7

    played = []
    for step in steps.values():
        argv = shlex.split(step["run"])
        if "--play-only" not in argv:
            continue
        assert step["cores"] == 1 and step["needs"] == ["robustness-baselines"]
        assert argv[argv.index("--workers") + 1] == "1"
        value = {
            flag: argv[argv.index(flag) + 1] for flag in ("--models", "--sets", "--conditions")
        }
        played.append((value["--models"], value["--sets"], value["--conditions"]))
    assert sorted(played) == sorted(wanted)  # each once
    assert "declutter_rounds.tar.gz" in steps["robustness-baselines"]["run"]
    table = steps["robustness-table"]
    assert "--collate-only" in table["run"]
    assert set(table["needs"]) == {n for n, s in steps.items() if "--play-only" in s["run"]}


def test_the_clean_rounds_are_table_1s_where_it_recorded_the_same_configuration(tmp_path):
    # --quick plays the shipped Robotiq bingham2d (training seed 1) on 2 household-test objects
    cell = tmp_path / "table" / "robotiq-2f85" / "bingham2d" / "s1" / "household-test"
    cell.mkdir(parents=True)
    recorded = {"model": "/elsewhere/best.pt", "objects": "household-test", "mesh_unit": "auto",
                "scene": "pile", "num_objects": 2, "rounds": 100, "seed": 0, "options": [],
                "diagnose": True, "pictures": False, "table_clearance": TABLE_CLEARANCE,
                "surface_clearance": SURFACE_CLEARANCE}  # fmt: skip
    (cell / "config.json").write_text(json.dumps(recorded))
    attempts = [
        {
            "outcome": "success",
            "mode": "success",
            "target": "box",
            "score": 1.0,
            "confidence": 20.0,
            "candidates": 3,
            "rejected": 0,
            "planning_s": 0.1,
        }
    ] * 2
    stored = {"seed": 0, "objects": 2, "renderer": "gl", "successes": 2, "executed": 2,
              "attempts": attempts}  # fmt: skip
    (cell / "rounds.jsonl").write_text(json.dumps(stored) + "\n")

    def clean_cell(out):
        done = subprocess.run(
            [sys.executable, "experiments/robustness.py", "--quick", str(out),
             "--conditions", "clean"],
            cwd=ROOT, env=ENV, capture_output=True, text=True,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        (clean,) = json.loads((out / "robustness.json").read_text())["cells"]
        return clean

    clean = clean_cell(tmp_path)
    assert clean["source"] == str(cell)
    assert (clean["successes"], clean["executed"], clean["presented"]) == (2, 2, 2)
    assert not (tmp_path / "robustness").exists()  # nothing played
    recorded["options"] = [["confidence_threshold", 0.0]]  # another configuration: played
    (cell / "config.json").write_text(json.dumps(recorded))
    clean = clean_cell(tmp_path)
    assert clean["source"] == str(tmp_path / "robustness" / "robotiq-2f85" / "bingham2d"
                                  / "household-test" / "clean")  # fmt: skip


def _round(seed, successes, executed, objects=5):
    def attempt(outcome):
        return {"outcome": outcome, "mode": outcome, "target": "box", "score": 1.0,
                "confidence": 20.0, "candidates": 3, "rejected": 0, "planning_s": 0.1}  # fmt: skip

    attempts = [attempt("success")] * successes + [attempt("slipped")] * (executed - successes)
    return {"seed": seed, "objects": objects, "renderer": "gl", "successes": successes,
            "executed": executed, "attempts": attempts}  # fmt: skip


def _write(folder, config, rounds):
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps(config))
    (folder / "rounds.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rounds))


def _two_training_seeds(tmp_path):
    """Two training runs of one hand and representation (the shipped Robotiq model as seeds 0
    and 1), 3 rounds from round seed 100 each: clean in the runs' table cells, noise + side view
    played; the checkpoints and the collation's options."""
    import torch

    from symgrasp.detect.pretrained import shipped_path

    state = torch.load(shipped_path("bingham2d-robotiq-2f85"), weights_only=False)
    models = []
    for seed in (0, 1):
        state["config"]["seed"] = seed
        path = tmp_path / "runs" / f"both-bingham2d-s{seed}" / "best.pt"
        path.parent.mkdir(parents=True)
        torch.save(state, path)
        models.append(path)
    fields = {"objects": "vgn-pile-test", "mesh_unit": "auto", "scene": "pile", "num_objects": 5,
              "rounds": 3, "seed": 100, "options": [], "diagnose": True, "pictures": False,
              "noise": "none", "view": "fixed", "views": 1, "table_clearance": TABLE_CLEARANCE,
                "surface_clearance": SURFACE_CLEARANCE}  # fmt: skip
    for seed, path in enumerate(models):
        cell = tmp_path / "table" / "robotiq-2f85" / "bingham2d" / f"s{seed}"
        _write(cell / "vgn-pile-test-first-seed-100", {**fields, "model": "/elsewhere/best.pt"},
               [_round(100 + i, *c) for i, c in enumerate(CLEAN[seed])])  # fmt: skip
        played = (tmp_path / "out" / "robotiq-2f85" / "bingham2d" / f"s{seed}"
                  / "vgn-pile-test-first-seed-100" / "noise-side")  # fmt: skip
        _write(played, {**fields, "model": str(path.resolve()), "noise": "dex", "view": "side"},
               [_round(100 + i, *c) for i, c in enumerate(NOISY[seed])])  # fmt: skip
    page = tmp_path / "page.md"
    page.write_text("<!-- robustness-table: begin -->\n<!-- robustness-table: end -->\n")
    options = ["--sets", "vgn-pile-test:pile", "--conditions", "noise-side", "--rounds", "3",
               "--first-seed", "100", "--docs", str(page)]  # fmt: skip
    return models, options


CLEAN = {0: [(4, 5), (3, 4), (5, 5)], 1: [(2, 4), (4, 5), (3, 3)]}
"""Each training seed's clean rounds: (successes, executed)."""
NOISY = {0: [(2, 5), (3, 5), (2, 5)], 1: [(2, 5), (2, 4), (2, 5)]}


def _collate(*argv):
    return subprocess.run(
        [sys.executable, "experiments/robustness.py", "--collate-only", *map(str, argv)],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip


def test_training_runs_collate_over_their_seeds_against_the_target_and_vgns_numbers(tmp_path):
    models, options = _two_training_seeds(tmp_path)
    clean, noisy = CLEAN, NOISY
    page = tmp_path / "page.md"
    done = _collate("--models", *models, *options, "--out", tmp_path / "out",
                    "--baselines", tmp_path / "table", "--result", tmp_path / "robustness")  # fmt: skip
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "robustness.json").read_text())
    assert {c["model"] for c in result["cells"]} == {"both-bingham2d-s0", "both-bingham2d-s1"}
    assert not any(c.get("waiting") for c in result["cells"])
    rows = {r["condition"]: r for r in result["over_seeds"]}
    assert rows["clean"]["seeds"] == [0, 1] and rows["clean"]["rounds"] == 3

    def mean_sr(runs):  # the mean over seeds of each run's pooled SR
        return sum(sum(s for s, _ in r) / sum(e for _, e in r) for r in runs.values()) / 2

    def mean_cr(runs):  # each round presents 5 objects
        return sum(sum(s for s, _ in r) / 15 for r in runs.values()) / 2

    row = rows["noise-side"]
    assert row["ratios"]["success_ratio"][0] == pytest.approx(mean_sr(noisy))
    gap = row["minus_clean"]["change"]
    assert gap["success_ratio"][0] == pytest.approx(mean_sr(noisy) - mean_sr(clean))
    assert gap["clear_ratio"][0] == pytest.approx(mean_cr(noisy) - mean_cr(clean))
    assert row["minus_clean"]["target"] == "missed"  # every round loses: −27 points of CR
    high = row["ratios"]["success_ratio"][2]
    assert high < 0.607  # below the single-view VGN's published SR on the pile
    assert row["published"]["success_ratio"] == {"published": "60.7 ± 4.2", "above": "missed"}
    assert "round seeds 100–102" in page.read_text()


def test_a_model_that_is_neither_shipped_nor_a_checkpoint_is_refused_by_name(tmp_path):
    done = subprocess.run(
        [sys.executable, "experiments/robustness.py", "--collate-only", "--models",
         str(tmp_path / "missing.pt"), "--out", str(tmp_path)],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 2
    assert "--models" in done.stderr and "missing.pt" in done.stderr


def test_the_archive_collates_again_without_the_models_to_the_same_table_and_bytes(tmp_path):
    import tarfile

    models, options = _two_training_seeds(tmp_path)
    first = _collate("--models", *models, *options, "--out", tmp_path / "out",
                     "--baselines", tmp_path / "table", "--result", tmp_path / "first")  # fmt: skip
    assert first.returncode == 0, first.stderr
    again = tmp_path / "again"
    with tarfile.open(tmp_path / "first_rounds.tar.gz") as tar:
        tar.extractall(again, filter="data")
    for model in models:  # the checkpoints are not on the machine that collates again
        model.unlink()
    second = _collate("--models-from", again / "models.json", *options, "--out", again / "out",
                      "--baselines", again / "baselines", "--result", tmp_path / "second")  # fmt: skip
    assert second.returncode == 0, second.stderr

    def numbers(stem):
        result = json.loads((tmp_path / f"{stem}.json").read_text())
        cells = [{k: v for k, v in c.items() if k != "source"} for c in result["cells"]]
        return cells, result["over_seeds"]

    cells, over_seeds = numbers("first")
    assert len(cells) == 4 and not any(c.get("waiting") for c in cells)  # 2 runs × clean, noisy
    assert numbers("second") == (cells, over_seeds)
    archives = [(tmp_path / f"{stem}_rounds.tar.gz").read_bytes() for stem in ("first", "second")]
    assert archives[0] == archives[1]
    manifest = json.loads((again / "models.json").read_text())
    assert [(m["hand"], m["rep"], m["seed"]) for m in manifest] == [
        ("robotiq-2f85", "bingham2d", 0), ("robotiq-2f85", "bingham2d", 1)]  # fmt: skip


def test_models_from_needs_collate_only_and_a_manifest(tmp_path):
    bad = tmp_path / "models.json"
    bad.write_text("{not json")
    done = _collate("--models-from", bad, "--out", tmp_path)
    assert done.returncode == 2
    assert "--models-from" in done.stderr and "models.json" in done.stderr
    played = subprocess.run(
        [sys.executable, "experiments/robustness.py", "--play-only", "--models-from", str(bad)],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert played.returncode == 2 and "--collate-only" in played.stderr


def test_the_archive_takes_folders_by_their_paths_links_kept_and_names_one_outside(
    tmp_path, monkeypatch
):
    import argparse
    import tarfile

    monkeypatch.syspath_prepend(str(ROOT / "experiments"))
    import robustness

    monkeypatch.chdir(tmp_path)
    for folder in ("out/a/clean", "table/b"):
        (tmp_path / folder).mkdir(parents=True)
        (tmp_path / folder / "rounds.jsonl").write_text("{}\n")
    args = argparse.Namespace(out=Path("out"), baselines=tmp_path / "table", models=[],
                              result=tmp_path / "r")  # fmt: skip
    (tmp_path / "table/c").symlink_to(tmp_path / "elsewhere/c", target_is_directory=True)
    (tmp_path / "elsewhere/c").mkdir(parents=True)
    (tmp_path / "elsewhere/c/rounds.jsonl").write_text("{}\n")
    cells = [{"source": str(tmp_path / "out/a/clean")}, {"source": "table/b"}, {"waiting": "x"},
             {"source": str(tmp_path / "table/c")}]  # fmt: skip
    robustness.write_archive(cells, args)
    with tarfile.open(tmp_path / "r_rounds.tar.gz") as tar:
        names = set(tar.getnames())
    # a linked cell is kept where the link puts it, as the collation read it
    assert {
        "out/a/clean/rounds.jsonl",
        "baselines/b/rounds.jsonl",
        "baselines/c/rounds.jsonl",
    } <= names
    with pytest.raises(ValueError, match=r"elsewhere.* neither --out out nor --baselines"):
        robustness.write_archive([{"source": str(tmp_path / "elsewhere")}], args)
