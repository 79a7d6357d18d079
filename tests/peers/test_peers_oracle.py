"""The oracle planner: the scene's training labels read from the simulator, checked against the
databases it reads (closed form), MuJoCo's own contacts and the benchmark that plays it."""

import json

import numpy as np
import pytest

from symgrasp.cli import main
from symgrasp.config import TRAINING_DATABASE, DatabaseConfig, PlannerOptions
from symgrasp.data.grasp_db import build_database
from symgrasp.detect import GraspPlanner, Observation
from symgrasp.names import ORACLE_GRIPPER, planner_kind
from symgrasp.objects.sets import make_scene
from symgrasp.peers.oracle import KEEP, OraclePlanner
from symgrasp.peers.planners import load_planner, planner_version
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.sim import get_gripper
from symgrasp.workspace import WORKSPACE_SIZE

TINY = {"grasps": 20, "directions": 4}
"""Databases small enough for a unit test (seconds per object)."""


@pytest.fixture(scope="module")
def scene():
    """A pile of three blocks, the oracle of tiny databases for the Robotiq hand and its plan."""
    oracle = OraclePlanner(get_gripper("robotiq-2f85"), **TINY)
    world = make_scene("pile", "blocks", 3, 0, gripper=oracle.gripper)
    intrinsic = CameraIntrinsic()
    depth = np.zeros((intrinsic.height, intrinsic.width), np.float32)
    grasps = oracle.plan(Observation(depth, intrinsic, default_extrinsic(), world))
    return oracle, world, grasps


def test_the_oracles_grasps_are_database_grasps_moved_by_the_poses_best_first(scene):
    oracle, world, grasps = scene
    assert grasps, "three blocks on a table leave some grasp free"
    poses = world.object_poses()
    databases = [oracle.database_of(obj) for obj in world.objects]
    assert all(len(db) >= TINY["grasps"] and db.score.shape[1] == 4 for db in databases)
    for grasp in grasps:
        # closed form: one object's held database grasp, T_object_tcp = T_world_object⁻¹ · T_world_tcp
        matches = [
            np.flatnonzero(
                np.isclose(np.linalg.inv(T_wo) @ grasp.pose, db.T_object_tcp, atol=1e-9).all(
                    axis=(1, 2)
                )
                & db.held
            )
            for T_wo, db in zip(poses, databases, strict=True)
        ]
        assert sum(len(m) for m in matches) == 1
        i = next(i for i, m in enumerate(matches) if len(m))
        # its score along world gravity: between the scores of the directions it was read at
        read = databases[i].score[matches[i][0]]
        assert np.isfinite(read).sum() in (1, 3)  # measured only where read
        assert np.nanmin(read) - 1e-9 <= grasp.score <= np.nanmax(read) + 1e-9
        assert np.all((grasp.position >= 0) & (grasp.position < WORKSPACE_SIZE))
    scores = [g.score for g in grasps]
    assert scores == sorted(scores, reverse=True)


def test_the_oracles_grasps_leave_the_open_hand_free_by_mujocos_contacts(scene):
    """Oracle: MuJoCo's collision detection on the hand's full model at each grasp."""
    _, world, grasps = scene
    state = world.snapshot()
    hits = []
    for grasp in grasps:
        world.set_hand_pose(grasp.pose)
        hits.append(world.hand_in_collision())
    world.restore(state)
    assert np.mean(hits) <= 0.05  # the labels keep 1 mm clearance; grazing contacts at most


def test_the_oracle_scores_only_what_it_reads_the_scores_of_the_whole_database(scene):
    """Oracle: `build_database` of each object, every score measured. The oracle's databases
    measure a grasp's scores only once it survives a collision check, and only along the
    directions its gravity reads: what it measured equals the whole database bit for bit."""
    oracle, world, _ = scene
    measured = total = 0
    for obj in world.objects:
        lazy = oracle.database_of(obj)
        whole = build_database(obj, oracle.gripper, oracle.database, oracle.seed)
        known = ~np.isnan(lazy.score)
        assert np.array_equal(lazy.T_object_tcp, whole.T_object_tcp)
        assert np.array_equal(lazy.score[known], whole.score[known])
        measured += known[lazy.held].sum()
        total += whole.score[whole.held].size
    assert 0 < measured < total / 2  # a part, not all


def test_the_oracle_keeps_the_databases_it_read_last():
    oracle = OraclePlanner(grasps=2, directions=4)
    objects = [
        make_scene("pile", "blocks", 1, seed, gripper=oracle.gripper).objects[0]
        for seed in range(KEEP + 1)
    ]
    first = oracle.database_of(objects[0])
    assert oracle.database_of(objects[0]) is first  # closed once
    for obj in objects[1:]:
        oracle.database_of(obj)
    assert oracle.database_of(objects[0]) is not first  # the oldest was let go


def test_the_oracle_refuses_to_plan_without_a_world():
    oracle = OraclePlanner(get_gripper("franka"), **TINY)
    intrinsic = CameraIntrinsic()
    depth = np.zeros((intrinsic.height, intrinsic.width), np.float32)
    with pytest.raises(ValueError, match="reads the simulator's state"):
        oracle.plan(Observation(depth, intrinsic, default_extrinsic()))


def test_detect_refuses_the_oracle_on_depth_images(tmp_path):
    intrinsic = CameraIntrinsic()
    np.save(tmp_path / "depth.npy", np.zeros((intrinsic.height, intrinsic.width), np.float32))
    (tmp_path / "K.json").write_text(json.dumps({"fx": 540, "fy": 540, "cx": 320, "cy": 240}))
    (tmp_path / "T.json").write_text(json.dumps(default_extrinsic().tolist()))
    with pytest.raises(SystemExit, match="plays only in symgrasp bench declutter"):
        main(["detect", "--model", "oracle", "--depth", str(tmp_path / "depth.npy"),
              "--intrinsic", str(tmp_path / "K.json"), "--extrinsic", str(tmp_path / "T.json"),
              "--out", str(tmp_path / "out")])  # fmt: skip


def test_the_oracle_is_named_and_versioned_by_its_databases():
    assert planner_kind("oracle") == "oracle"
    oracle = load_planner("oracle")
    assert isinstance(oracle, GraspPlanner)
    assert oracle.gripper == get_gripper(ORACLE_GRIPPER) and oracle.database == TRAINING_DATABASE
    small = load_planner("oracle", PlannerOptions(gripper="franka", grasps=40))
    assert small.gripper == get_gripper("franka")
    assert small.database == DatabaseConfig(grasps=40, directions=TRAINING_DATABASE.directions)
    assert small.version != oracle.version
    assert planner_version("oracle", PlannerOptions(grasps=40)) == small.version
    tips = load_planner("oracle", PlannerOptions(gripper="franka", grasps=40, offset=(-0.03, 0.03)))
    assert tips.database == DatabaseConfig(
        grasps=40, directions=TRAINING_DATABASE.directions, offset=(-0.03, 0.03)
    )
    assert tips.version not in (small.version, oracle.version)
    with pytest.raises(ValueError, match="offset"):
        PlannerOptions(gripper="franka", offset=(-0.5, 0.03))
    with pytest.raises(ValueError, match="planner oracle takes no validity_threshold"):
        load_planner("oracle", PlannerOptions(validity_threshold=0.5))


def test_the_oracle_plays_a_round_through_bench_declutter(tmp_path, capsys):
    out = tmp_path / "bench"
    argv = ["bench", "declutter", "--model", "oracle", "--gripper", "robotiq-2f85",
            "--objects", "blocks", "--num-objects", "2", "--rounds", "1", "--no-diagnose",
            "--oracle-grasps", "20", "--oracle-directions", "4", "--oracle-offset", "-0.02", "0.03",
            "--out", str(out)]  # fmt: skip
    main(argv)
    assert "| oracle | blocks | 1 |" in capsys.readouterr().out
    config = json.loads((out / "config.json").read_text())
    assert config["options"] == [["gripper", "robotiq-2f85"], ["grasps", 20], ["directions", 4],
                                 ["offset", [-0.02, 0.03]]]  # fmt: skip
    assert (out / "model.sha256").read_text().strip() == planner_version(
        "oracle", PlannerOptions(**TINY, offset=(-0.02, 0.03))
    )
    (record,) = [json.loads(line) for line in (out / "rounds.jsonl").read_text().splitlines()]
    assert "error" not in record and record["attempts"]
    with pytest.raises(SystemExit, match="another configuration"):
        main([*argv[:-9], "--oracle-grasps", "7", "--oracle-directions", "4",
              "--out", str(out), "--resume"])  # fmt: skip


def test_bench_refuses_the_oracles_options_for_another_planner(tmp_path):
    with pytest.raises(SystemExit, match="--oracle-\\* options are the oracle's"):
        main(["bench", "declutter", "--model", "vgn", "--oracle-grasps", "10",
              "--out", str(tmp_path / "b")])  # fmt: skip
