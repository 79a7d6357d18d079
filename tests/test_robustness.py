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

from conftest import campaign_steps

ROOT = Path(__file__).resolve().parents[1]
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
    assert len(wanted) == 4 * 2 * 5

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
                "diagnose": True, "pictures": False}  # fmt: skip
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
