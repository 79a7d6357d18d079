"""What issue 66 found silent or late that the bad-input tables (tests/bad_input_cases.py) cannot
state as one refused command: a shipped model exported by name, a picture written where its
path says, a multi-process run refused before its ranks start, a planner object's grasps
checked as a function's are, and a point cloud file whose size exactly meets its header."""

import numpy as np
import pytest
import torch

from symgrasp.cli import main
from symgrasp.detect.files import load_points
from symgrasp.detect.planner import Observation
from symgrasp.model.checkpoint import load_checkpoint
from symgrasp.peers.plugin import load_plugin
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.sim import get_gripper


def test_export_takes_a_shipped_models_name(tmp_path, capsys):
    out = tmp_path / "franka.pt"
    main(["export", "bingham2d-franka", str(out)])
    assert capsys.readouterr().out.strip() == str(out)
    assert load_checkpoint(out)["representation"] == "bingham2d"


def test_gripper_show_writes_the_path_it_prints(tmp_path, capsys):
    main(["gripper", "show", "franka", "--out", str(tmp_path / "hand")])  # no .png suffix
    printed = capsys.readouterr().out.strip().rpartition("picture: ")[2]
    assert printed == str(tmp_path / "hand")
    assert (tmp_path / "hand").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["hand"]


@pytest.mark.skipif(torch.cuda.is_available(), reason="a machine with CUDA trains there")
def test_train_on_processes_refuses_a_missing_gpu_before_its_ranks_start(tmp_path, monkeypatch):
    from symgrasp.model import distributed

    def spawned(*args):
        raise AssertionError("ranks were started")

    monkeypatch.setattr(distributed, "launch", spawned)
    argv = ["train", "--data", str(tmp_path), "--out", str(tmp_path / "r"), "--nproc", "2",
            "--batch-size", "2", "--device", "cuda"]  # fmt: skip
    with pytest.raises(SystemExit, match="device 'cuda' asked for, but CUDA is not available"):
        main(argv)
    assert not (tmp_path / "r").exists()


PLANNER_OBJECTS = """
import numpy as np
from symgrasp.detect import Grasp
from symgrasp.sim import get_gripper

class Planner:
    name, version = "mine", "1"

    def __init__(self, pose):
        self.gripper, self.pose = get_gripper("franka"), np.array(pose)

    def plan(self, observation):
        return [Grasp(self.pose, score=0.5)]

good = Planner(TURNED)
bad = Planner(SHEARED)
"""
"""A user's planner objects (`symgrasp.detect.GraspPlanner`), each planning one grasp."""


def test_a_planner_objects_grasps_are_checked(tmp_path, monkeypatch):
    turned = np.eye(4)
    turned[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # rigid: 90° about y
    sheared = turned.copy()
    sheared[0, 1] = 0.1  # no longer orthonormal
    text = PLANNER_OBJECTS.replace("TURNED", str(turned.tolist()))
    (tmp_path / "object_planners.py").write_text(text.replace("SHEARED", str(sheared.tolist())))
    monkeypatch.syspath_prepend(str(tmp_path))
    observation = Observation(
        np.zeros((4, 4), np.float32), CameraIntrinsic(4, 4, 4.0, 4.0, 1.5, 1.5),
        default_extrinsic()[None],
    )  # fmt: skip
    good = load_plugin("object_planners:good")
    assert (good.name, good.version, good.gripper) == ("mine", "1", get_gripper("franka"))
    assert np.array_equal(good.plan(observation)[0].pose, turned)
    with pytest.raises(ValueError, match="planner mine: grasp 0's pose must be T_world_tcp"):
        load_plugin("object_planners:bad").plan(observation)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_a_ply_whose_size_meets_its_header_exactly_is_read(tmp_path, fmt):
    """The size check is tight: the smallest file holding ``count`` vertices (one-digit ASCII
    values, the last line without its newline; 12 bytes a binary vertex) reads, one byte less
    is refused before anything is allocated."""
    points = np.array([[1, 2, 3], [4, 5, 6]], np.float32)
    header = f"ply\nformat {fmt} 1.0\nelement vertex 2\n" + "".join(
        f"property float {axis}\n" for axis in "xyz"
    )
    body = b"1 2 3\n4 5 6" if fmt == "ascii" else points.astype("<f4").tobytes()
    path = tmp_path / "cloud.ply"
    path.write_bytes(f"{header}end_header\n".encode() + body)
    assert np.array_equal(load_points(path), points)
    path.write_bytes(f"{header}end_header\n".encode() + body[:-1])
    with pytest.raises(ValueError, match="ends before its 2 vertices: the"):
        load_points(path)


def test_an_npz_named_npy_is_refused_naming_it(tmp_path):
    with open(tmp_path / "cloud.npy", "wb") as file:
        np.savez(file, points=np.zeros((5, 3)))
    with pytest.raises(ValueError, match=r"cloud\.npy \(it is an \.npz archive"):
        load_points(tmp_path / "cloud.npy")
    np.save(tmp_path / "cloud.npy", np.zeros((5, 3)))  # the same name, one array: read
    assert load_points(tmp_path / "cloud.npy").shape == (5, 3)
