"""The planner interface: every kind of planner resolved from its name, a user's planner
defined in a test file played through ``symgrasp bench declutter --planner`` and the API, and
what a results folder records of it."""

import json
from pathlib import Path

import numpy as np
import pytest

from symgrasp.benchmark.declutter import run_round
from symgrasp.cli import main
from symgrasp.config import PlannerOptions
from symgrasp.detect import GraspDetector, GraspPlanner, Observation
from symgrasp.digest import file_sha256
from symgrasp.names import is_plugin_name, planner_kind
from symgrasp.objects.sets import resolve
from symgrasp.peers.planners import load_planner, planner_version
from symgrasp.peers.plugin import FunctionPlanner
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
        load_planner("bingham2d-franka", PlannerOptions(gripper="robotiq-2f85"))


def test_a_detector_plans_what_it_detects():
    detector = load_planner("bingham2d-franka")
    depth = np.full((480, 640), 0.7, np.float32)
    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    planned = detector.plan(Observation(depth, intrinsic, T))
    detected = detector.detect(depth, intrinsic, T)
    assert [g.score for g in planned] == [g.score for g in detected]


def test_a_function_becomes_a_planner_for_the_hand_named():
    franka = PlannerOptions(gripper="franka")
    planner = load_planner(PLUGIN, franka)
    assert isinstance(planner, FunctionPlanner) and isinstance(planner, GraspPlanner)
    assert planner.gripper == get_gripper("franka") and planner.name == PLUGIN
    assert planner.version == file_sha256(SOURCE) == planner_version(PLUGIN, franka)
    with pytest.raises(ValueError, match="is a function: name the hand"):
        load_planner(PLUGIN)
    with pytest.raises(ValueError, match="is a int: expected a function"):
        load_planner("tests.peers.plugin_planner:not_a_planner", franka)
    with pytest.raises(ValueError, match="has no 'missing'"):
        load_planner("tests.peers.plugin_planner:missing", franka)
    with pytest.raises(ValueError, match="cannot import no_such_package"):
        load_planner("no_such_package.module:plan", franka)
    with pytest.raises(ValueError, match="takes no validity_threshold, fallbacks"):
        load_planner(PLUGIN, PlannerOptions(gripper="franka", validity_threshold=0.5, fallbacks=2))


def test_a_user_planner_plays_a_round_through_the_api():
    planner = load_planner(PLUGIN, PlannerOptions(gripper="franka"))
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


def _depth_files(folder: Path) -> list[str]:
    """A rendered pile of household-train objects as `symgrasp detect`'s input files."""
    from symgrasp.objects.sets import make_scene
    from symgrasp.sim.render import make_renderer

    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    world = make_scene("pile", "household-train", 5, 0, get_gripper("franka"))
    np.save(folder / "depth.npy", make_renderer(intrinsic).render(world, T))
    (folder / "K.json").write_text(json.dumps({"fx": 540, "fy": 540, "cx": 320, "cy": 240}))
    (folder / "T.json").write_text(json.dumps(T.tolist()))
    return ["--depth", str(folder / "depth.npy"), "--intrinsic", str(folder / "K.json"),
            "--extrinsic", str(folder / "T.json")]  # fmt: skip


def test_detect_runs_vgn_from_the_data_folder(vgn_weights, monkeypatch, tmp_path):
    from symgrasp.objects.folder import DATA_ENV
    from symgrasp.peers.vgn import WEIGHTS

    monkeypatch.setenv(DATA_ENV, str(vgn_weights))
    inputs = _depth_files(tmp_path)
    main(["detect", "--model", "vgn", *inputs, "--out", str(tmp_path / "out")])
    found = json.loads((tmp_path / "out" / "grasps.json").read_text())
    assert found["planner"] == "vgn" and found["gripper"] == "franka"
    assert found["version"] == file_sha256(vgn_weights / WEIGHTS)
    assert found["grasps"] and found["grasps"][0]["validity"] is None
    assert (tmp_path / "out" / "grasps.png").stat().st_size > 0
    with pytest.raises(SystemExit, match="takes no --validity"):
        main(
            ["detect", "--model", "vgn", *inputs, "--validity", "0.5", "--out", str(tmp_path / "v")]
        )


def test_without_vgns_weights_detect_and_bench_stop_with_one_line_and_status_66(
    monkeypatch, tmp_path, capsys
):
    from symgrasp.objects.folder import DATA_ENV, EX_NOINPUT

    monkeypatch.setenv(DATA_ENV, str(tmp_path / "no-data"))
    inputs = _depth_files(tmp_path)
    for argv in (["detect", "--model", "vgn", *inputs, "--out", str(tmp_path / "d")],
                 ["bench", "declutter", "--model", "vgn", "--objects", "large-box",
                  "--out", str(tmp_path / "b")]):  # fmt: skip
        with pytest.raises(SystemExit) as exit_:
            main(argv)
        err = capsys.readouterr().err.strip()
        assert exit_.value.code == EX_NOINPUT and len(err.splitlines()) == 1
        assert "VGN's weights are not in the data folder" in err and "peers/vgn/vgn_conv.pth" in err


@pytest.mark.parametrize(
    "bad, named",
    [({"validity_threshold": 1.5}, "validity_threshold"), ({"fallbacks": -1}, "fallbacks"),
     ({"offset": (0.05, 0.01)}, "offset"), ({"workspace_origin": (0.0, 0.0)}, "workspace_origin"),
     ({"gripper": ""}, "gripper"), ({"approach_check": "yes"}, "approach_check")],
)  # fmt: skip
def test_bad_planner_options_are_refused_naming_the_option(bad, named):
    with pytest.raises(ValueError, match=f"^{named}"):
        PlannerOptions(**bad)


def test_a_planner_refuses_options_of_another_kind():
    with pytest.raises(ValueError, match="planner vgn takes no grasps"):
        load_planner("vgn", PlannerOptions(grasps=10))
