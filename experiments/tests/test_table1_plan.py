"""The campaign plans behind Table 1 (experiments/campaigns/robust_training.toml, then
table1.toml): read together (``campaign.py show``), they train, select and play every run that
experiments/declutter_table.py waits for before it can collate the table, the collation waits
for all of them, and the analysis figures are drawn from seed 0 of every Robotiq
representation."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from .conftest import campaign_steps

ROOT = Path(__file__).resolve().parents[2]
PLANS = ROOT / "experiments" / "campaigns"
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}


@pytest.fixture(scope="module")
def steps():
    """The plan's steps by name, ``{root}`` being /root."""
    return campaign_steps(str(PLANS / "robust_training.toml"), str(PLANS / "table1.toml"))


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The training runs the table waits for, as the script names them when none is there
    (its default grid: every gripper, representation and seed): ``{run: (gripper, rep,
    seed)}``."""
    tmp = tmp_path_factory.mktemp("table")
    page = tmp / "page.md"
    page.write_text("<!-- declutter-table: begin -->\n<!-- declutter-table: end -->\n")
    done = subprocess.run(
        [sys.executable, "experiments/declutter_table.py", "--collate-only",
         "--runs", str(tmp / "runs"), "--out", str(tmp / "cells"), "--result", str(tmp / "table"),
         "--figure", str(tmp / "figure.png"), "--docs", str(page),
         "--archive", str(tmp / "rounds.tar.gz")],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp / "table.json").read_text())
    by_length = sorted(result["prefixes"].items(), key=lambda item: -len(item[1]))
    waiting = {}
    for entry in result["waiting"]:
        run = entry.removesuffix(" (not selected)")
        gripper, prefix = next((g, p) for g, p in by_length if run.startswith(f"{p}-"))
        rep, seed = run[len(prefix) + 1 :].rsplit("-s", 1)
        waiting[run] = (gripper, rep, int(seed))
    return waiting


def test_every_run_of_the_table_is_trained_selected_and_played_before_the_collation(steps, runs):
    assert len(runs) == 24  # 2 grippers, 4 representations, 3 seeds
    for run, (gripper, _, seed) in runs.items():
        assert f"--out /root/runs/{run}" in steps[run]["run"]
        assert steps[f"select-{run}"]["needs"] == [run]
        assert steps[f"cells-{run}"]["needs"] == [f"select-{run}"]
        assert f"cells-{run}" in steps["table1"]["needs"]
        # each run plays its own cells only, and the Robotiq no packed scenes
        words = steps[f"cells-{run}"]["run"].split()
        assert words[words.index("--grippers") + 1] == gripper
        assert words[words.index("--seeds") + 1] == str(seed)
        assert ("--field" in words) == (gripper == "robotiq-2f85")
    assert "--collate-only" in steps["table1"]["run"]


def test_the_figures_come_from_seed_0_of_every_robotiq_representation(steps, runs):
    figures = steps["figures"]
    robotiq = {
        run: rep for run, (g, rep, seed) in runs.items() if g == "robotiq-2f85" and seed == 0
    }
    assert set(figures["needs"]) == {f"select-{run}" for run in robotiq}
    for run, rep in robotiq.items():
        assert f"--model {rep}=/root/runs/{run}/best.pt" in figures["run"]
    assert "distribution --model /root/runs/final-bingham2d-s0/best.pt" in figures["run"]
    assert figures["run"].count("--out /root/results/figures") == 2  # never into docs/


def test_the_threshold_check_reads_seed_0_of_every_cell(steps, runs):
    check = steps["validity-calibration"]
    first = [run for run, (_, _, seed) in runs.items() if seed == 0]
    assert len(first) == 8
    assert set(check["needs"]) == {f"select-{run}" for run in first}
    assert all(f"/root/runs/{run}/best.pt" in check["run"] for run in first)


def test_every_baseline_cell_is_exported_under_its_name_from_seed_0(steps, runs):
    export = steps["export-baselines"]
    for run, (gripper, rep, seed) in runs.items():
        if seed == 0 and rep != "bingham2d":
            assert f"select-{run}" in export["needs"]
            assert (
                f"export /root/runs/{run}/best.pt /root/results/models/{rep}-{gripper}.pt"
                in (export["run"])
            )
