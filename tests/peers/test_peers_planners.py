"""The planner interface: every kind of planner resolved from its name, a user's planner
defined in a test file played through ``symgrasp bench declutter --planner`` and the API, and
what a results folder records of it."""

import json
from pathlib import Path

import numpy as np
import pytest

from symgrasp.benchmark.declutter import run_round
from symgrasp.cli import main
from symgrasp.detect import GraspDetector, GraspPlanner, Observation
from symgrasp.model.checkpoint import file_sha256
from symgrasp.objects.sets import resolve
from symgrasp.peers.planners import load_planner, planner_kind, planner_version
from symgrasp.peers.plugin import FunctionPlanner, is_plugin_name
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.sim import get_gripper
from symgrasp.workspace import TABLE_HEIGHT

PLUGIN = "tests.peers.plugin_planner:top_down"
SOURCE = Path(__file__).with_name("plugin_planner.py")
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _from_the_checkout(monkeypatch):
    """Names of test modules resolve from the checkout's root, as from a user's folder."""
    monkeypatch.chdir(ROOT)
    monkeypatch.syspath_prepend(str(ROOT))


def test_names_select_their_kind_of_planner():
    assert planner_kind("bingham2d-franka") == "model"
    assert planner_kind("runs/x/best.pt") == "model"
    assert planner_kind("vgn") == "vgn"
    assert planner_kind(PLUGIN) == "plugin"
    assert not is_plugin_name("C:weights.pt") or not Path("C:weights.pt").exists()
    assert not is_plugin_name("module:not an identifier")


def test_the_shipped_detector_is_a_planner_whose_version_is_its_files_hash():
    detector = load_planner("bingham2d-franka")
    assert isinstance(detector, GraspDetector) and isinstance(detector, GraspPlanner)
    assert detector.name == "bingham2d-franka"
    assert detector.version == planner_version("bingham2d-franka")
    from symgrasp.detect.pretrained import shipped_path

    assert detector.version == file_sha256(shipped_path("bingham2d-franka"))
    with pytest.raises(ValueError, match="trained for the 'franka' gripper, not 'robotiq-2f85'"):
        load_planner("bingham2d-franka", "robotiq-2f85")


def test_a_detector_plans_what_it_detects():
    detector = load_planner("bingham2d-franka")
    depth = np.full((480, 640), 0.7, np.float32)
    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    planned = detector.plan(Observation(depth, intrinsic, T))
    detected = detector.detect(depth, intrinsic, T)
    assert [g.score for g in planned] == [g.score for g in detected]


def test_a_function_becomes_a_planner_for_the_hand_named():
    planner = load_planner(PLUGIN, "franka")
    assert isinstance(planner, FunctionPlanner) and isinstance(planner, GraspPlanner)
    assert planner.gripper == get_gripper("franka") and planner.name == PLUGIN
    assert planner.version == file_sha256(SOURCE) == planner_version(PLUGIN, "franka")
    with pytest.raises(ValueError, match="is a function: name the hand"):
        load_planner(PLUGIN)
    with pytest.raises(ValueError, match="is a int: expected a function"):
        load_planner("tests.peers.plugin_planner:not_a_planner", "franka")
    with pytest.raises(ValueError, match="has no 'missing'"):
        load_planner("tests.peers.plugin_planner:missing", "franka")
    with pytest.raises(ValueError, match="cannot import no_such_package"):
        load_planner("no_such_package.module:plan", "franka")
    with pytest.raises(ValueError, match="takes no detector options"):
        load_planner(PLUGIN, "franka", validity_threshold=0.5)


def test_a_user_planner_plays_a_round_through_the_api():
    planner = load_planner(PLUGIN, "franka")
    record = run_round(planner, resolve("large-box"), 1, seed=0, diagnose=False)
    assert record.objects == 1 and record.attempts
    grasp = record.attempts[0].grasp
    assert grasp is not None and grasp.pose[2, 3] > TABLE_HEIGHT  # aimed at the box's top
    assert record.attempts[0].outcome != "none_found"


def test_a_user_planner_plays_through_bench_declutter_and_is_recorded(tmp_path, capsys):
    out = tmp_path / "bench"
    argv = ["bench", "declutter", "--planner", PLUGIN, "--gripper", "franka",
            "--objects", "large-box", "--num-objects", "1", "--rounds", "2", "--no-diagnose",
            "--out", str(out)]  # fmt: skip
    main(argv)
    assert f"| {PLUGIN} | large-box | 2 |" in capsys.readouterr().out
    config = json.loads((out / "config.json").read_text())
    assert config["model"] == PLUGIN and config["options"] == [["gripper", "franka"]]
    assert (out / "model.sha256").read_text().strip() == file_sha256(SOURCE)
    rounds = [json.loads(line) for line in (out / "rounds.jsonl").read_text().splitlines()]
    assert [r["seed"] for r in rounds] == [0, 1] and all("error" not in r for r in rounds)
    main([*argv, "--resume"])  # a finished benchmark of the same planner and source: reused


def test_bench_refuses_a_detectors_thresholds_for_another_planner(tmp_path):
    with pytest.raises(SystemExit, match=r"--validity.*takes none of them"):
        main(["bench", "declutter", "--planner", PLUGIN, "--gripper", "franka",
              "--validity", "0.5", "--out", str(tmp_path / "b")])  # fmt: skip
    with pytest.raises(SystemExit, match="is a function: name the hand"):
        main(["bench", "declutter", "--planner", PLUGIN, "--objects", "large-box",
              "--out", str(tmp_path / "c")])  # fmt: skip
