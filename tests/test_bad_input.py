"""Bad input, table-driven: every case ends with a non-zero exit and one line that names the
argument or file (command line), or a ValueError/TypeError with a message (API); never a
traceback, a hang or a silently wrong run. Arguments are checked before any work starts, so
each case takes well under a second."""

from __future__ import annotations

import dataclasses
import json
import shutil
import sys

import numpy as np
import pytest
import torch

from symgrasp import bingham
from symgrasp.cli import main
from symgrasp.config import BenchmarkConfig
from symgrasp.detect.pretrained import shipped_path

SHIPPED = "bingham2d-robotiq-2f85"


@pytest.fixture
def files(tmp_path, wide_jaw):
    return make_files(tmp_path, wide_jaw)


def make_files(tmp_path, wide_jaw):
    """Valid and broken input files in ``tmp_path``, by name, the bad gripper specs made from
    the made-up jaw's file ``wide_jaw`` (also used by benchmarks/bad_input.py, which plays the
    command-line cases as real processes)."""
    spec = wide_jaw.read_text()
    for name, old, new in BAD_SPECS:
        assert old in spec
        (tmp_path / name).write_text(spec.replace(old, new))
    depth = np.full((48, 64), 0.6, dtype=np.float32)
    np.save(tmp_path / "depth.npy", depth)
    np.save(tmp_path / "depth_mm.npy", depth * 1000)
    (tmp_path / "intrinsic.json").write_text(json.dumps({"fx": 50, "fy": 50, "cx": 32, "cy": 24}))
    (tmp_path / "no_fx.json").write_text(json.dumps({"fy": 50, "cx": 32, "cy": 24}))
    (tmp_path / "extrinsic.json").write_text(json.dumps(np.eye(4).tolist()))
    (tmp_path / "garbage.pt").write_bytes(b"not a checkpoint at all")
    whole = shipped_path(SHIPPED).read_bytes()
    (tmp_path / "truncated.pt").write_bytes(whole[: len(whole) // 2])
    (tmp_path / "garbage.npy").write_bytes(b"\x93NUMPY garbage")
    (tmp_path / "a_file").write_text("x")
    (tmp_path / "unrelated").mkdir()
    (tmp_path / "unrelated" / "notes.txt").write_text("mine")
    (tmp_path / "folder").mkdir()
    unfinished = tmp_path / "unfinished"
    (unfinished / "scenes").mkdir(parents=True)
    manifest = {"gripper": "franka", "object_set": "blocks", "k_max": 8, "scene_ids": []}
    (unfinished / "manifest.json").write_text(json.dumps(manifest))
    (unfinished / "scenes" / "scene_000000.npz").write_bytes(b"")
    _urdf_object(tmp_path / "no_mesh", mesh=None)
    _urdf_object(tmp_path / "too_big", mesh=0.4)
    (tmp_path / "bench").mkdir()  # a benchmark folder of the default configuration
    config = json.loads(json.dumps(dataclasses.asdict(BenchmarkConfig())))
    (tmp_path / "bench" / "config.json").write_text(json.dumps(config))
    return tmp_path


def _urdf_object(folder, mesh):
    """A folder holding ``thing.urdf`` whose collision mesh is a cube of side ``mesh`` [m], or
    names a file that is not there (``mesh=None``)."""
    folder.mkdir()
    if mesh is not None:
        corners = np.array(np.meshgrid([0, mesh], [0, mesh], [0, mesh])).reshape(3, -1).T
        faces = "f 1 2 4\nf 5 6 8\nf 1 3 5\nf 2 4 8\n"
        (folder / "thing.obj").write_text(
            "".join(f"v {x} {y} {z}\n" for x, y, z in corners) + faces
        )
    (folder / "thing.urdf").write_text(
        '<robot name="thing"><link name="l"><inertial><mass value="0.2"/></inertial>'
        '<collision><geometry><mesh filename="thing.obj"/></geometry></collision></link></robot>'
    )


def _detect(d, *extra, depth="depth.npy", intrinsic="intrinsic.json", model=SHIPPED):
    return ["detect", "--depth", str(d / depth), "--intrinsic", str(d / intrinsic),
            "--extrinsic", str(d / "extrinsic.json"), "--model", str(model),
            "--out", str(d / "out"), *extra]  # fmt: skip


BAD_SPECS = (
    ("negative.toml", "pad_width = 0.03", "pad_width = -0.03"),
    ("wide_pad.toml", "pad_width = 0.03", "pad_width = 0.08"),
    ("no_force.toml", "grip_force = 80.0", ""),
    ("colour.toml", "grip_force = 80.0", 'grip_force = 80.0\ncolour = "red"'),
)
"""Gripper spec files made from the made-up wide jaw's: (file, text replaced, replacement)."""

CLI = {
    # argument ranges and names, refused by the parser
    "bench --workers 0": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--workers", "0"], "--workers"),
    "bench --backend spark": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--backend", "spark"], "--backend"),
    "data generate --ray-address without --backend ray": (lambda d: ["data", "generate", "--out", str(d / "g"), "--ray-address", "10.0.0.1:6379"], "ray_address"),
    "bench --num-objects 1000": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--num-objects", "1000"], "num_objects"),
    "bench --objects bogus": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--objects", "bogus"], "--objects"),
    "bench --confidence nan": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--confidence", "nan"], "--confidence"),
    "bench --validity 2": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--validity", "2"], "--validity"),
    "bench --seed 2**70": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--seed", str(2**70)], "seed"),
    "bench --rounds 0": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--rounds", "0"], "rounds"),
    "data generate --k-max 0": (lambda d: ["data", "generate", "--out", str(d / "g"), "--k-max", "0"], "k_max"),
    "data generate --seed -1": (lambda d: ["data", "generate", "--out", str(d / "g"), "--seed", "-1"], "--seed"),
    "data generate --scenes 10**12": (lambda d: ["data", "generate", "--out", str(d / "g"), "--scenes", str(10**12)], "--scenes"),
    "data generate --grasps 0": (lambda d: ["data", "generate", "--out", str(d / "g"), "--grasps", "0"], "grasps"),
    "data generate --kinds heap": (lambda d: ["data", "generate", "--out", str(d / "g"), "--kinds", "heap"], "--kinds"),
    "data generate --camera-distance 0.7 0.4": (lambda d: ["data", "generate", "--out", str(d / "g"), "--camera-distance", "0.7", "0.4"], "camera_distance"),
    "train --lr inf": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--lr", "inf"], "lr"),
    "train --epochs 0": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--epochs", "0"], "epochs"),
    "train --nproc 2 --batch-size 3": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--nproc", "2", "--batch-size", "3"], "batch_size 3 must be a multiple of the 2"),
    "train --nproc 0": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--nproc", "0"], "--nproc"),
    "train --widths 0 1 2 3": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--widths", "0", "1", "2", "3"], "widths"),
    "train --schedule step": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--schedule", "step"], "--schedule"),
    "train --schedule onecycle without --warmup": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--schedule", "onecycle"], "warmup in (0, 1)"),
    "train --min-lr with the constant schedule": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--min-lr", "1e-5"], "min_lr"),
    "train --ema 1": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--ema", "1"], "ema"),
    "train --focal-gamma with bce": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--focal-gamma", "3"], "focal_gamma"),
    "train --train-scenes -1": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--train-scenes", "-1"], "train_scenes"),
    "detect --samples-per-voxel 10**6": (lambda d: _detect(d, "--samples-per-voxel", str(10**6)), "--samples-per-voxel"),
    "detect --top-k 0": (lambda d: _detect(d, "--top-k", "0"), "--top-k"),
    "detect --workspace-origin nan": (lambda d: _detect(d, "--workspace-origin", "nan", "0", "0"), "--workspace-origin"),
    "figures percentiles --samples 10**12": (lambda d: ["figures", "percentiles", "--samples", str(10**12), "--out", str(d)], "--samples"),
    "figures distribution --height nan": (lambda d: ["figures", "distribution", "--model", SHIPPED, "--height", "nan", "--out", str(d)], "--height"),
    "sim show --n 1000": (lambda d: ["sim", "show", "--n", "1000", "--out", str(d)], "--n"),
    "demo --num-objects 1000": (lambda d: ["demo", "--num-objects", "1000", "--out", str(d)], "--num-objects"),
    "an unknown command": (lambda d: ["declutter"], "declutter"),
    # files: named in the message
    "bench into an existing benchmark": (lambda d: ["bench", "declutter", "--out", str(d / "bench")], "--resume"),
    "bench --resume of another configuration": (lambda d: ["bench", "declutter", "--out", str(d / "bench"), "--resume", "--rounds", "3"], "rounds differ"),
    "data generate --out ''": (lambda d: ["data", "generate", "--out", ""], "out"),
    "data generate --out a file": (lambda d: ["data", "generate", "--out", str(d / "a_file")], "a_file"),
    "data generate --out unrelated files": (lambda d: ["data", "generate", "--out", str(d / "unrelated")], "not a symgrasp dataset"),
    "data inspect unfinished": (lambda d: ["data", "inspect", str(d / "unfinished")], "unfinished"),
    "data inspect not a dataset": (lambda d: ["data", "inspect", str(d / "folder")], "manifest"),
    "detect intrinsic without fx": (lambda d: _detect(d, intrinsic="no_fx.json"), "no_fx.json"),
    "detect missing depth": (lambda d: _detect(d, depth="nothing.npy"), "nothing.npy"),
    "detect garbage depth": (lambda d: _detect(d, depth="garbage.npy"), "garbage.npy"),
    "detect depth in millimetres": (lambda d: _detect(d, depth="depth_mm.npy"), "metres"),
    "detect garbage checkpoint": (lambda d: _detect(d, model=d / "garbage.pt"), "garbage.pt"),
    "detect truncated checkpoint": (lambda d: _detect(d, model=d / "truncated.pt"), "truncated.pt"),
    "detect unknown model": (lambda d: _detect(d, model="bingham9d-hand"), "bingham9d-hand"),
    "detect --out under a file": (lambda d: [*_detect(d)[:-1], str(d / "a_file" / "out")], "a_file"),
    "detect --out is a file": (lambda d: [*_detect(d)[:-1], str(d / "a_file")], "a_file"),
    "sim show --out is a file": (lambda d: ["sim", "show", "--n", "1", "--out", str(d / "a_file")], "a_file"),
    "export into a folder": (lambda d: ["export", str(shipped_path(SHIPPED)), str(d / "folder")], "folder"),
    "sim show --objects an empty folder": (lambda d: ["sim", "show", "--objects", str(d / "folder"), "--out", str(d / "s")], "holds no .urdf file"),
    "sim show --objects a URDF without its mesh": (lambda d: ["sim", "show", "--objects", str(d / "no_mesh"), "--out", str(d / "s")], "thing.obj"),
    "sim show --objects an object larger than the workspace": (lambda d: ["sim", "show", "--objects", str(d / "too_big"), "--out", str(d / "s")], "larger than the 0.3 m workspace"),
    "sim show --objects an unknown set": (lambda d: ["sim", "show", "--objects", "kitchen", "--out", str(d / "s")], "data folder"),
    "gripper show an unknown name": (lambda d: ["gripper", "show", "shadow-hand"], "shadow-hand"),
    "gripper show a missing spec file": (lambda d: ["gripper", "show", str(d / "nothing.toml")], "nothing.toml"),
    "gripper show a negative size": (lambda d: ["gripper", "show", str(d / "negative.toml")], "negative.toml: pad_width must be in (0, 1] m"),
    "gripper show a pad wider than the palm": (lambda d: ["gripper", "show", str(d / "wide_pad.toml")], "pad_width (0.08 m) is wider than the palm"),
    "gripper show a missing key": (lambda d: ["gripper", "show", str(d / "no_force.toml")], "no_force.toml: missing key grip_force"),
    "gripper show an unknown key": (lambda d: ["gripper", "show", str(d / "colour.toml")], "colour.toml: unknown key colour"),
    "data generate --gripper a bad spec": (lambda d: ["data", "generate", "--out", str(d / "g"), "--gripper", str(d / "negative.toml")], "pad_width"),
    "train --gripper a missing spec file": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--gripper", str(d / "nothing.toml")], "--gripper"),
    "demo --gripper a spec file without --model": (lambda d: ["demo", "--gripper", str(d / "negative.toml"), "--out", str(d)], "--model"),
    "bench --gripper another than the model's": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--gripper", "franka"], "--gripper franka, but --model bingham2d-robotiq-2f85 is robotiq-2f85"),
    "objects inspect a procedural set": (lambda d: ["objects", "inspect", "blocks"], "built in code"),
    "export a garbage checkpoint": (lambda d: ["export", str(d / "garbage.pt"), str(d / "x.pt")], "garbage.pt"),
}  # fmt: skip


RAY_CLI = {
    "--ray-address unreachable": (lambda d: ["data", "generate", "--out", str(d / "g"), "--backend", "ray", "--ray-address", "127.0.0.1:1"], "ray_address 127.0.0.1:1: no Ray cluster answers there"),
    "--ray-address not host:port": (lambda d: ["bench", "declutter", "--out", str(d / "g"), "--backend", "ray", "--ray-address", "headnode"], "ray_address must be host:port"),
    "RAY_ADDRESS unreachable": (lambda d: ["bench", "declutter", "--out", str(d / "g"), "--backend", "ray"], "ray_address 127.0.0.1:1"),
}  # fmt: skip
"""Ray's bad input, where Ray is installed (the extra 'cluster'): one line, nothing written."""


@pytest.mark.parametrize("case", CLI)
def test_command_line(case, files, capsys):
    _refused(CLI[case], files, capsys)


@pytest.mark.parametrize("case", RAY_CLI)
def test_command_line_with_ray(case, files, capsys, monkeypatch):
    pytest.importorskip("ray")
    monkeypatch.setenv("RAY_ADDRESS", "127.0.0.1:1")  # read when --ray-address is not given
    _refused(RAY_CLI[case], files, capsys)
    assert not (files / "g").exists()


def test_backend_ray_without_ray_installed(files, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails as if not installed
    argv = ["data", "generate", "--out", str(files / "g"), "--backend", "ray"]
    _refused((lambda d: argv, "pip install 'symgrasp[cluster]'"), files, capsys)
    assert not (files / "g").exists()


def _refused(case, files, capsys):
    """Run the command of ``case`` = (argv of the files folder, text its message names) and
    check it fails in one line naming that text, leaving no temporary file."""
    argv, named = case
    with pytest.raises(SystemExit) as exit_:
        main(argv(files))
    code = exit_.value.code
    captured = capsys.readouterr()
    message = code if isinstance(code, str) else captured.err.strip()
    assert code not in (0, None), message
    assert "Traceback" not in captured.err + captured.out
    assert len(message.splitlines()) == 1, message
    assert named in message
    assert "error" in message
    assert not list(files.rglob("*.tmp")), "a temporary file was left behind"


def test_detect_with_no_grasp_is_an_answer(files, capsys):
    """An empty table (a flat depth image) is a valid scene: exit 0, zero grasps, pictures."""
    main(_detect(files, "--validity", "1.0"))
    assert "no grasp found" in capsys.readouterr().out
    assert json.loads((files / "out" / "grasps.json").read_text())["grasps"] == []
    assert (files / "out" / "grasps.png").stat().st_size > 0


def test_data_show_writes_the_path_it_prints(tmp_path, capsys):
    from symgrasp.model.synthetic import SyntheticGraspDataset  # noqa: F401  (torch present)

    dataset = tmp_path / "d"
    main(["data", "generate", "--objects", "blocks", "--gripper", "franka", "--pool-size", "1",
          "--grasps", "5", "--directions", "4", "--scenes", "1", "--out", str(dataset)])  # fmt: skip
    capsys.readouterr()
    main(["data", "show", str(dataset), "--out", str(tmp_path / "picture")])
    printed = capsys.readouterr().out.strip()
    assert printed == str(tmp_path / "picture") and (tmp_path / "picture").stat().st_size > 0


# -- the Python API ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def detector():
    from symgrasp.detect import GraspDetector

    return GraspDetector.from_pretrained(SHIPPED, device="cpu")


def _construct(**options):
    from symgrasp.detect import GraspDetector

    return GraspDetector.from_pretrained(SHIPPED, device="cpu", **options)


API = {
    "confidence_threshold=nan": (lambda d: _construct(confidence_threshold=float("nan")), "confidence_threshold"),
    "top_k=2.5": (lambda d: _construct(top_k=2.5), "top_k"),
    "nms_radius=1.5": (lambda d: _construct(nms_radius=1.5), "nms_radius"),
    "samples_per_voxel=2.5": (lambda d: _construct(samples_per_voxel=2.5), "samples_per_voxel"),
    "samples_per_voxel=10**6": (lambda d: _construct(samples_per_voxel=10**6), "samples_per_voxel"),
    "validity_threshold=nan": (lambda d: _construct(validity_threshold=float("nan")), "validity_threshold"),
    "workspace_origin nan": (lambda d: _construct(workspace_origin=(float("nan"), 0, 0)), "workspace_origin"),
    "gripper=bogus": (lambda d: _construct(gripper="bogus"), "bogus"),
    "depth in millimetres": (lambda d: d.detect(np.full((48, 64), 600.0), np.diag([50.0, 50, 1]), np.eye(4)), "metres"),
    "raw uint16 depth": (lambda d: d.detect(np.full((48, 64), 600, np.uint16), np.diag([50.0, 50, 1]), np.eye(4)), "uint16"),
    "NaN intrinsics": (lambda d: d.detect(np.full((48, 64), 0.6), np.diag([np.nan, 50, 1]), np.eye(4)), "fx"),
    "depth (H, W, 2)": (lambda d: d.detect(np.full((48, 64, 2), 0.6), np.diag([50.0, 50, 1]), np.eye(4)), "depth"),
    "extrinsic not rigid": (lambda d: d.detect(np.full((48, 64), 0.6), np.diag([50.0, 50, 1]), 2 * np.eye(4)), "extrinsic"),
    "unknown object set": (lambda d: __import__("symgrasp.sim", fromlist=["x"]).object_set("kitchen", 3), "household-train"),
    "unknown gripper": (lambda d: __import__("symgrasp.sim", fromlist=["x"]).get_gripper("shadow"), "robotiq-2f85"),
    "unknown representation": (lambda d: __import__("symgrasp.rotation", fromlist=["x"]).get("rotmat9d"), "bingham2d"),
    "Bingham A (2, 3)": (lambda d: bingham.Bingham(torch.zeros(2, 3)), "`A` must be"),
    "Bingham NaN A, sampled": (lambda d: bingham.Bingham(torch.full((3, 3), torch.nan)).sample(), "`A` must be finite"),
    "Bingham nll of a non-unit v": (lambda d: bingham.nll(torch.zeros(3, 3), torch.tensor([2.0, 0, 0])), "unit vectors"),
    "Bingham normalizer method": (lambda d: bingham.log_normalizer(torch.zeros(3), method="laplace"), "`method`"),
}  # fmt: skip
"""Bad calls of the API: each raises ValueError or TypeError naming the argument. The Bingham
rows cover its entry points; tests/bingham/ hold the rest of its cases."""


@pytest.mark.parametrize("case", API)
def test_api(case, detector):
    call, named = API[case]
    with pytest.raises((ValueError, TypeError), match=named):
        call(detector)


def test_a_depth_image_with_a_channel_axis_is_one_image(detector):
    K, T = np.diag([50.0, 50, 1]), np.eye(4)
    depth = np.full((48, 64), 0.6, dtype=np.float32)
    flat = detector.fuse(depth, K, T).grid()
    channel = detector.fuse(depth[..., None], K, T).grid()
    assert np.array_equal(flat.cpu().numpy(), channel.cpu().numpy())


def test_a_corrupted_grasp_database_cache_is_recomputed(tmp_path):
    from symgrasp.config import DatabaseConfig
    from symgrasp.data.grasp_db import cached_database, database_key
    from symgrasp.sim import FRANKA, object_set

    obj = object_set("blocks", 1)[0]
    cfg = DatabaseConfig(grasps=3, max_candidates=10, directions=4)
    good = cached_database(obj, FRANKA, tmp_path, cfg)
    path = tmp_path / f"{obj.name}_{FRANKA.name}_{database_key(obj, FRANKA, cfg, 0)}.npz"
    path.write_bytes(b"PK\x03\x04 truncated")
    with pytest.warns(UserWarning, match="recomputing the corrupted grasp database"):
        again = cached_database(obj, FRANKA, tmp_path, cfg)
    np.testing.assert_array_equal(again.T_object_tcp, good.T_object_tcp)
    shutil.rmtree(tmp_path)


def test_training_needs_a_validation_split(tmp_path, capsys):
    dataset = tmp_path / "d"
    main(["data", "generate", "--objects", "blocks", "--gripper", "franka", "--pool-size", "1",
          "--grasps", "5", "--directions", "4", "--scenes", "2", "--out", str(dataset)])  # fmt: skip
    with pytest.raises(SystemExit, match="0 validation scenes"):
        main(["train", "--data", str(dataset), "--gripper", "franka", "--out", str(tmp_path / "r")])
