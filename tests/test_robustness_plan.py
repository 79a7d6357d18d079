"""The campaign plan behind the robustness table (experiments/campaigns/robustness.toml): read as
the driver reads it (``campaign.py show``), it plays every cell and condition that
experiments/robustness.py collates by default, each in a step of one core of its own after the
Table 1 rounds are unpacked, and collates once all of them are done."""

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}


def test_the_plan_plays_every_cell_the_table_waits_for_once_and_collates_after_them(tmp_path):
    shown = subprocess.run(
        [sys.executable, "experiments/campaign.py", "show",
         "experiments/campaigns/robustness.toml", "--root", "/root"],
        cwd=ROOT, env=ENV, capture_output=True, text=True,
    )  # fmt: skip
    assert shown.returncode == 0, shown.stderr
    steps = {s["name"]: s for s in map(json.loads, shown.stdout.splitlines())}
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
