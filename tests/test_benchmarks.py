"""Every script in benchmarks/ runs in its ``--quick`` mode (seconds, tiny sizes, the real code
paths), so a benchmark that no longer runs fails `make test`; a quick run leaves the
committed results and the docs alone, and its result names the machine and its load."""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RESULTS = {  # script: the result file its quick run writes, and a key that file holds
    "bingham": ("bingham.json", "normalizer"),
    "rotation": ("rotation.json", "runs"),
    "sim": ("sim.json", "results"),
    "data": ("data.json", "scenes"),
    "model": ("model.json", "representations"),
    "detect": ("detect.json", "median_ms"),
    "declutter_table": ("declutter.json", "cells"),
    "validity_sweep": ("validity_sweep.json", "cells"),
    "validity_calibration": ("validity_calibration.json", "cells"),
    "eigen_gap": ("eigen_gap.json", "cells"),
    "yaw_tolerance": ("yaw_tolerance.json", "cells"),
    "seed_check": ("seed_check.json", "paired_lead"),
    "scene_physics": ("scene_physics.json", "cells"),
    "decomposition": ("decomposition.json", "summary"),
    "grasp_db": ("grasp_db.json", "cells"),
    "bad_input": ("bad_input.json", "counts"),
    "hands": ("hands.json", "cells"),
    "scale": ("scale.json", "one_million_scenes"),
    "campaign": ("campaign.json", "steps"),
    "selection": ("selection.json", "correlations"),
    "learning_curve": ("learning_curve.json", "cells"),
    "recipe": ("recipe.json", "verdicts"),
    "seed_spread": ("seed_spread.json", "pairings"),
}
NEEDS_VGN = {"scene_physics", "grasp_db"}  # reads VGN's meshes from the data folder
NEEDS_REFERENCE = {"hands"}  # reads MuJoCo Menagerie's hands (conftest's `menagerie`)


def _committed() -> dict[Path, int]:
    """Modification times of the committed results and docs."""
    files = [*(ROOT / "benchmarks" / "results").iterdir(), *(ROOT / "docs").rglob("*")]
    return {path: path.stat().st_mtime_ns for path in files if path.is_file()}


def test_every_benchmark_script_has_a_quick_test():
    scripts = {path.stem for path in (ROOT / "benchmarks").glob("*.py")} - {"common"}
    assert scripts == set(RESULTS)


@pytest.mark.parametrize("script", RESULTS)
def test_quick_run_writes_its_result_and_nothing_committed(script, tmp_path, request):
    name, key = RESULTS[script]
    before = _committed()
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    if script in NEEDS_REFERENCE:
        request.getfixturevalue("menagerie")
    if script in NEEDS_VGN:
        env["SYMGRASP_DATA"] = str(request.getfixturevalue("vgn_data"))
    done = subprocess.run(
        [sys.executable, f"benchmarks/{script}.py", "--quick", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / name).read_text())
    assert key in result
    load = result["machine"]["load_average_1_5_15min"]
    assert len(load["start"]) == len(load["end"]) == 3
    assert _committed() == before


def test_an_option_without_help_is_refused(monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    from common import parse_args

    parser = argparse.ArgumentParser()
    parser.add_argument("--explained", help="what it is")
    parser.add_argument("--silent")
    monkeypatch.setattr(sys, "argv", ["script"])
    with pytest.raises(ValueError, match="--silent"):
        parse_args(parser, outputs=(), quick={})


def test_sim_runs_without_pythonpath(tmp_path):
    # `make bench` sets no PYTHONPATH (the package is installed); sim.py used to raise a
    # KeyError then. This checkout's src goes on sys.path from inside instead.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    bootstrap = (
        f"import runpy, sys; sys.path[:0] = [{str(ROOT / 'src')!r}, {str(ROOT / 'benchmarks')!r}]; "
        "sys.argv.pop(0); runpy.run_path(sys.argv[0], run_name='__main__')"
    )
    done = subprocess.run(
        [sys.executable, "-c", bootstrap, "benchmarks/sim.py", "--quick", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    assert "PYTHONPATH" not in json.loads((tmp_path / "sim.json").read_text())["command"]
