"""The campaign plans behind Table 1 (benchmarks/campaigns/robust_training.toml, then
table1.toml): read together, they train, select and play every run of the table, the
collation waits for all of them, and the analysis figures are drawn from seed 0 of every
Robotiq representation."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import campaign
import declutter_table

PLANS = Path(__file__).resolve().parents[1] / "benchmarks" / "campaigns"


def test_every_run_of_the_table_is_trained_selected_and_played_before_the_collation():
    steps = {s.name: s for s in campaign.read_plan(
        [PLANS / "robust_training.toml", PLANS / "table1.toml"], Path("/root"))}  # fmt: skip
    runs = [f"{declutter_table.PREFIXES[g]}-{rep}-s{seed}" for g in declutter_table.GRIPPERS
            for rep in declutter_table.REPS for seed in (0, 1, 2)]  # fmt: skip
    assert len(runs) == 24
    for run in runs:
        assert f"--out /root/runs/{run}" in steps[run].run
        assert steps[f"select-{run}"].needs == (run,)
        assert steps[f"cells-{run}"].needs == (f"select-{run}",)
        assert f"cells-{run}" in steps["table1"].needs
    assert "--collate-only" in steps["table1"].run
    for run in runs:  # each run plays its own cells only, and the Robotiq no packed scenes
        gripper = "franka" if "franka" in run else "robotiq-2f85"
        words = steps[f"cells-{run}"].run.split()
        assert words[words.index("--grippers") + 1] == gripper
        assert words[words.index("--seeds") + 1] == run[-1]
        assert ("--field" in words) == (gripper == "robotiq-2f85")


def test_the_figures_come_from_seed_0_of_every_robotiq_representation():
    steps = {s.name: s for s in campaign.read_plan(
        [PLANS / "robust_training.toml", PLANS / "table1.toml"], Path("/root"))}  # fmt: skip
    figures = steps["figures"]
    assert set(figures.needs) == {f"select-final-{rep}-s0" for rep in declutter_table.REPS}
    for rep in declutter_table.REPS:
        assert f"--model {rep}=/root/runs/final-{rep}-s0/best.pt" in figures.run
    assert "distribution --model /root/runs/final-bingham2d-s0/best.pt" in figures.run
    assert figures.run.count("--out /root/results/figures") == 2  # never into docs/


def test_the_threshold_check_reads_seed_0_of_every_cell():
    steps = {s.name: s for s in campaign.read_plan(
        [PLANS / "robust_training.toml", PLANS / "table1.toml"], Path("/root"))}  # fmt: skip
    check = steps["validity-calibration"]
    runs = [f"{declutter_table.PREFIXES[g]}-{rep}-s0" for g in declutter_table.GRIPPERS
            for rep in declutter_table.REPS]  # fmt: skip
    assert set(check.needs) == {f"select-{run}" for run in runs}
    assert all(f"/root/runs/{run}/best.pt" in check.run for run in runs)


def test_every_baseline_cell_is_exported_under_its_name_from_seed_0():
    steps = {s.name: s for s in campaign.read_plan(
        [PLANS / "robust_training.toml", PLANS / "table1.toml"], Path("/root"))}  # fmt: skip
    export = steps["export-baselines"]
    for gripper in declutter_table.GRIPPERS:
        for rep in (r for r in declutter_table.REPS if r != "bingham2d"):
            run = f"{declutter_table.PREFIXES[gripper]}-{rep}-s0"
            assert f"select-{run}" in export.needs
            assert (f"export /root/runs/{run}/best.pt /root/results/models/{rep}-{gripper}.pt"
                    in export.run)  # fmt: skip
