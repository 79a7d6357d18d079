"""Every script of benchmarks/ and experiments/ runs in its ``--quick`` mode (seconds, tiny sizes,
the real code paths), so a script that no longer runs fails `make test`; a quick run leaves the
committed results and the docs alone, and its result names the machine and its load; a run without
``--publish`` writes under out/ what it would publish. A script whose downloaded data is missing
stops with one line naming it and exit status 66 (`experiments.scripts.run_main`); its test then
skips with that line (fails under SYMGRASP_REQUIRE_DATA=1), so no list of which script needs which
data is kept here. A script needing an optional extra that is not installed stops likewise with
status 69 and skips."""

import argparse
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.scripts import EX_NOINPUT, EX_UNAVAILABLE, command_line, parse_args, run_main
from symgrasp.objects.folder import DATA_ENV, MissingData
from symgrasp.parallel import TasksFailed

from .conftest import missing_data

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = ("benchmarks", "experiments")
"""What `make bench` times, and the studies, tables, campaigns and real-object measurements."""
RESULTS = {  # script: the result file its quick run writes, and a key that file holds
    "benchmarks/bingham": ("bingham.json", "normalizer"),
    "benchmarks/rotation": ("rotation.json", "runs"),
    "benchmarks/sim": ("sim.json", "results"),
    "benchmarks/data": ("data.json", "scenes"),
    "benchmarks/model": ("model.json", "representations"),
    "benchmarks/detect": ("detect.json", "median_ms"),
    "benchmarks/detect_table": ("detect_table.json", "cells"),
    "benchmarks/serve": ("serve.json", "cells"),
    "benchmarks/grasp_db": ("grasp_db.json", "summary"),
    "benchmarks/scene_labels": ("scene_labels.json", "summary"),
    "benchmarks/objects": ("objects.json", "cells"),
    "experiments/declutter_table": ("declutter.json", "cells"),
    "experiments/validity_sweep": ("validity_sweep.json", "cells"),
    "experiments/decoding": ("decoding.json", "cells"),
    "experiments/operating_points": ("operating_points.json", "chosen"),
    "experiments/validity_calibration": ("validity_calibration.json", "cells"),
    "experiments/eigen_gap": ("eigen_gap.json", "cells"),
    "experiments/yaw_tolerance": ("yaw_tolerance.json", "cells"),
    "experiments/franka_box": ("franka_box.json", "cells"),
    "experiments/scene_physics": ("scene_physics.json", "cells"),
    "experiments/decomposition": ("decomposition.json", "summary"),
    "experiments/decomposition_declutter": ("decomposition_declutter.json", "cells"),
    "experiments/grasp_db": ("grasp_db.json", "cells"),
    "experiments/label_density": ("label_density.json", "cells"),
    "experiments/bad_input": ("bad_input.json", "counts"),
    "experiments/sensor_depth": ("sensor_depth.json", "cells"),
    "experiments/hands": ("hands.json", "cells"),
    "experiments/scale": ("scale.json", "one_million_scenes"),
    "experiments/campaign": ("campaign.json", "steps"),
    "experiments/selection": ("selection.json", "correlations"),
    "experiments/learning_curve": ("learning_curve.json", "cells"),
    "experiments/recipe": ("recipe.json", "verdicts"),
    "experiments/seed_spread": ("seed_spread.json", "pairings"),
    "experiments/peers_table": ("peers_declutter.json", "cells"),
    "experiments/oracle": ("oracle.json", "cells"),
    "experiments/vgn_frame": ("vgn_frame.json", "cells"),
    "experiments/robustness": ("robustness.json", "cells"),
    "experiments/depth_noise": ("depth_noise.json", "summary"),
    "experiments/retrain_ablation": ("retrain_ablation.json", "gaps"),
    "experiments/judge": ("judge_retrained.json", "picks"),
    "experiments/thin_objects": ("thin_objects.json", "cells"),
    "experiments/table_strikes": ("table_strikes.json", "cells"),
    "experiments/slips": ("slips.json", "cells"),
    "experiments/real_scenes": ("real_scenes.json", "cells"),
}
SHARED_MODULES = {
    "experiments/__init__",
    "experiments/common",
    "experiments/scripts",
    "benchmarks/lab",
}
"""Modules of the folders that are not scripts."""


def _committed() -> dict[Path, int]:
    """Modification times of the committed results and docs."""
    files = [*(ROOT / "docs").rglob("*")]
    for folder in FOLDERS:
        files += (ROOT / folder / "results").rglob("*")
    return {path: path.stat().st_mtime_ns for path in files if path.is_file()}


def test_every_script_has_a_quick_test():
    scripts = {
        f"{folder}/{path.stem}" for folder in FOLDERS for path in (ROOT / folder).glob("*.py")
    }
    assert scripts - SHARED_MODULES == set(RESULTS)


def test_make_bench_runs_every_script_of_benchmarks_and_nothing_else_and_publishes_nothing():
    makefile = (ROOT / "Makefile").read_text()
    target = re.search(r"^bench:.*\n((?:\t.*\n)+)", makefile, re.M)
    assert target, "the Makefile has no bench target"
    run = set(re.findall(r"\$\(PY\) (\S+)\.py", target.group(1)))
    scripts = {f"benchmarks/{path.stem}" for path in (ROOT / "benchmarks").glob("*.py")}
    assert run == scripts - SHARED_MODULES
    assert "--publish" not in target.group(1)  # its results go under out/, the tree stays as it was


@pytest.mark.data
@pytest.mark.parametrize("script", RESULTS)
def test_quick_run_writes_its_result_and_nothing_committed(script, tmp_path, shared):
    name, key = RESULTS[script]
    before = _committed()
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), DATA_ENV: str(shared)}
    done = subprocess.run(
        [sys.executable, f"{script}.py", "--quick", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True,
    )  # fmt: skip
    if done.returncode == EX_NOINPUT:
        assert len(done.stderr.strip().splitlines()) == 1, done.stderr[-3000:]
        missing_data(f"{script}: {done.stderr.strip()}")
    if done.returncode == EX_UNAVAILABLE:  # `make test` installs the extras; others may not
        assert "pip install 'symgrasp[" in done.stderr and len(done.stderr.splitlines()) == 1
        pytest.skip(f"{script}: {done.stderr.strip()}")
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / name).read_text())
    assert key in result
    assert result["command"].endswith(
        shlex.join(["python", f"{script}.py", "--quick", os.path.relpath(tmp_path, ROOT)])
    )
    load = result["machine"]["load_average_1_5_15min"]
    assert len(load["start"]) == len(load["end"]) == 3
    assert _committed() == before


def test_an_option_without_help_is_refused(monkeypatch):
    parser = argparse.ArgumentParser()
    parser.add_argument("--explained", help="what it is")
    parser.add_argument("--silent")
    monkeypatch.setattr(sys, "argv", ["script"])
    with pytest.raises(ValueError, match="--silent"):
        parse_args(parser, outputs=(), quick={})


def test_the_recorded_command_is_the_one_run(monkeypatch):
    # the script named from the checkout's root, the arguments as given, quoted; an absolute
    # path (a word, an option's or a variable's value, each part of a path list) from the root
    up = "../" * (len(ROOT.parts) - 1)  # from the root to /
    argv = ["--gripper", "franka", "--out", "out/a b", "--data", str(ROOT.parent / "shared"),
            f"--runs={ROOT / 'runs'}", "--url", "http://host/x"]  # fmt: skip
    monkeypatch.setattr(sys, "argv", [str(ROOT / "experiments" / "label_density.py"), *argv])
    assert command_line(f"SYMGRASP_DATA=../shared PYTHONPATH={ROOT / 'src'}:/opt/lib") == (
        f"SYMGRASP_DATA=../shared PYTHONPATH=src:{up}opt/lib python experiments/label_density.py "
        "--gripper franka --out 'out/a b' --data ../shared --runs=runs --url http://host/x"
    )
    monkeypatch.setattr(sys, "argv", ["/elsewhere/my script.py", "--quick"])
    assert command_line("") == f"python '{up}elsewhere/my script.py' --quick"


def _outputs_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser()
    parser.add_argument("--result", default="experiments/results/study", help="a result stem")
    parser.add_argument("--table", default=ROOT / "benchmarks/results/t.json", help="absolute")
    parser.add_argument("--work", type=Path, default="out/work", help="a work folder")
    parser.add_argument("--docs", default="docs/page.md", help="a page edited in place")
    parser.add_argument("--given", default="experiments/results/given", help="set by the user")
    return parser


@pytest.mark.parametrize("publish", [False, True])
def test_outputs_go_under_out_unless_published(publish, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the scripts' paths are from where they run, the checkout
    Path("docs").mkdir()
    Path("docs/page.md").write_text("before <!-- begin --> text <!-- end --> after\n")
    argv = ["script", "--given", "mine", *["--publish"] * publish]
    monkeypatch.setattr(sys, "argv", argv)
    args = parse_args(_outputs_parser(), outputs=("result", "table", "work", "docs", "given"),
                      quick={}, pages=("docs",))  # fmt: skip
    written = {dest: str(getattr(args, dest)) for dest in ("result", "table", "work", "docs")}
    if publish:
        assert written == {"result": "experiments/results/study",
                           "table": str(ROOT / "benchmarks/results/t.json"),
                           "work": "out/work", "docs": "docs/page.md"}  # fmt: skip
        assert not Path("out").exists()
    else:
        assert written == {"result": "out/experiments/results/study",
                           "table": "out/benchmarks/results/t.json",
                           "work": "out/work", "docs": "out/docs/page.md"}  # fmt: skip
        assert Path("out/docs/page.md").read_text() == Path("docs/page.md").read_text()
        assert Path("out/experiments/results").is_dir() and not Path("out/work").exists()
    assert args.given == "mine"


def test_quick_mode_moves_every_output_into_its_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", ["script", "--quick", "q"])
    args = parse_args(_outputs_parser(), outputs=("result", "table", "work"), quick={})
    assert (args.result, args.table, args.work) == (
        Path("q/study"),
        Path("q/t.json"),
        Path("q/work"),
    )


def test_quick_mode_never_publishes(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["script", "--quick", str(tmp_path), "--publish"])
    with pytest.raises(SystemExit):
        parse_args(_outputs_parser(), outputs=("result",), quick={})
    assert "--quick never publishes; drop --publish" in capsys.readouterr().err


def test_a_run_without_publish_writes_under_out_and_nothing_committed(tmp_path):
    before = _committed()
    done = subprocess.run(
        [sys.executable, ROOT / "benchmarks/rotation.py", "--batch", "64", "--repeats", "1"],
        cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT / "src")}, capture_output=True,
        text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / "out/benchmarks/results/rotation.json").read_text())
    assert result["command"] == "python benchmarks/rotation.py --batch 64 --repeats 1"
    assert result["environment"]["PYTHONPATH"] == "src"
    assert _committed() == before


@pytest.mark.parametrize(
    "error, status",
    [(MissingData("object set vgn-pile-train is not in the data folder"), EX_NOINPUT),
     (TasksFailed("every one of the 2 rounds in out failed"), 1),
     (ModuleNotFoundError("backend 'ray' needs Ray: pip install 'symgrasp[cluster]'"), EX_UNAVAILABLE)],
)  # fmt: skip
def test_missing_data_extras_or_failed_tasks_stop_a_script_with_one_line(error, status, capsys):
    def main():
        raise error

    with pytest.raises(SystemExit) as stop:
        run_main(main)
    assert stop.value.code == status
    assert capsys.readouterr().err == f"error: {error}\n"


def test_a_module_an_import_itself_misses_keeps_its_traceback():
    def main():
        import symgrasp_no_such_module  # noqa: F401

    with pytest.raises(ModuleNotFoundError, match="symgrasp_no_such_module"):
        run_main(main)


def test_sim_runs_without_pythonpath(tmp_path):
    # `make bench` sets no PYTHONPATH (the package is installed); sim.py used to raise a
    # KeyError then. This checkout's src goes on sys.path from inside instead, after the
    # script's folder as `python benchmarks/sim.py` puts it.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    bootstrap = (
        f"import runpy, sys; sys.path[:0] = [{str(ROOT / 'benchmarks')!r}, {str(ROOT / 'src')!r}]; "
        "sys.argv.pop(0); runpy.run_path(sys.argv[0], run_name='__main__')"
    )
    done = subprocess.run(
        [sys.executable, "-c", bootstrap, "benchmarks/sim.py", "--quick", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    assert "PYTHONPATH" not in json.loads((tmp_path / "sim.json").read_text())["command"]
