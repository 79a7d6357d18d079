"""The bad input symgrasp refuses, as tables of cases: every command-line case ends with a
non-zero exit and one line that names the argument or file, every API case with a ValueError or
TypeError naming the argument; never a traceback, a hang or a silently wrong run. The inputs that
are valid but give no grasp for a cause they show (`WARNED_CLI`, `WARNED_API`) end with no grasp
and one warning that names the cause (a ``warning:`` line, a `NoGraspWarning`).

Two players read these tables: tests/test_bad_input.py runs each case in-process on every
``make test`` (a guarantee of the library, so the tables live beside it, with the library's
tests; its small depth images and camera serve other tests too), and the lab's bad-input study
runs each command-line case as a real ``symgrasp`` process with a time limit and sorts the
outcomes (clear error, unclear, traceback, silent, hang).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import torch
from PIL import Image

from symgrasp import bingham
from symgrasp.benchmark.runner import local_renderer
from symgrasp.config import BenchmarkConfig, SceneConfig
from symgrasp.detect.pretrained import shipped_path
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.workspace import TABLE_HEIGHT

MODEL = "bingham2d-robotiq-2f85"
"""The shipped model the cases play (and break: a truncated, a corrupted and a NaN copy of its
file)."""

INTRINSIC = CameraIntrinsic(64, 48, 50.0, 50.0, 32.0, 24.0)
"""The small camera of the cases' depth images (``intrinsic.json``)."""

CAMERA = default_extrinsic()
"""``T_world_camera`` of the cases' depth images (``extrinsic.json``): the default view."""

FOOT = 0.3048
"""[m]"""


def table_depth() -> np.ndarray:
    """The depth image (48, 64) [m] `INTRINSIC` takes of the empty table (the plane
    ``z = TABLE_HEIGHT``) from `CAMERA`; 0 where a ray misses it."""
    rays = INTRINSIC.pixel_rays() @ CAMERA[:3, :3].T  # world directions, camera z = 1
    depth = (TABLE_HEIGHT - CAMERA[2, 3]) / rays[..., 2]
    return np.where(depth > 0, depth, 0.0).astype(np.float32)


def table_cloud() -> np.ndarray:
    """The world points (N, 3) [m] of `table_depth`: the empty table as a point cloud."""
    rays = INTRINSIC.pixel_rays() @ CAMERA[:3, :3].T
    depth = table_depth()
    return (CAMERA[:3, 3] + depth[..., None] * rays)[depth > 0]


def make_files(folder: Path, wide_jaw: Path) -> Path:
    """Valid and broken input files in the folder ``folder``, by name, that the `CLI` cases
    name; the bad gripper specs are made from the spec file ``wide_jaw`` (the tests' made-up
    110 mm jaw, tests/wide-jaw.toml, whose lines `BAD_SPECS` replaces)."""
    spec = wide_jaw.read_text()
    (folder / "wide_jaw.toml").write_text(spec)
    for name, old, new in BAD_SPECS:
        assert old in spec
        (folder / name).write_text(spec.replace(old, new))
    depth = table_depth()
    np.save(folder / "depth.npy", depth)
    np.save(folder / "depth_mm.npy", depth * 1000)
    np.save(folder / "depth_feet.npy", depth / FOOT)
    np.save(folder / "depth_bool.npy", depth > 0)
    np.save(folder / "depth_complex.npy", depth.astype(np.complex64))
    for name, unit in (("depth_cm.png", 0.01), ("depth_tenth_mm.png", 1e-4)):
        Image.fromarray(np.round(depth / unit).astype(np.uint16)).save(folder / name)
    picture = np.round(255 * depth / depth.max()).astype(np.uint8)  # a visualisation
    Image.fromarray(picture).save(folder / "depth_8bit.png")
    K = INTRINSIC
    (folder / "intrinsic.json").write_text(
        json.dumps({"fx": K.fx, "fy": K.fy, "cx": K.cx, "cy": K.cy})
    )
    (folder / "no_fx.json").write_text(json.dumps({"fy": K.fy, "cx": K.cx, "cy": K.cy}))
    (folder / "extrinsic.json").write_text(json.dumps(CAMERA.tolist()))
    (folder / "inverted.json").write_text(json.dumps(np.linalg.inv(CAMERA).tolist()))
    (folder / "garbage.pt").write_bytes(b"not a checkpoint at all")
    whole = shipped_path(MODEL).read_bytes()
    (folder / "truncated.pt").write_bytes(whole[: len(whole) // 2])
    flipped = bytearray(whole)
    flipped[len(whole) // 2] ^= 0x01  # one bit of one weight: still a finite number
    (folder / "corrupted.pt").write_bytes(bytes(flipped))
    state = torch.load(shipped_path(MODEL), weights_only=True)
    first = next(tensor for tensor in state["model"].values() if tensor.is_floating_point())
    first.view(-1)[0] = torch.nan  # one weight of a diverged run
    torch.save(state, folder / "nan.pt")
    state["model"][next(iter(state["model"]))] = torch.zeros(1)  # a tensor of another shape
    torch.save(state, folder / "misshapen.pt")
    del state["model"]  # a checkpoint without its network (hand-made, or a script's)
    torch.save(state, folder / "no_network.pt")
    (folder / "garbage.npy").write_bytes(b"\x93NUMPY garbage")
    np.save(folder / "cloud.npy", table_cloud())
    np.save(folder / "pairs.npy", table_cloud()[:, :2])
    (folder / "faces.ply").write_text("ply\nformat ascii 1.0\nelement face 0\nend_header\n")
    for fmt in ("ascii", "binary_little_endian"):  # a header claiming 10⁹ vertices, one given
        header = f"ply\nformat {fmt} 1.0\nelement vertex {10**9}\n" + "".join(
            f"property float {axis}\n" for axis in "xyz"
        )
        body = b"0 0 0\n" if fmt == "ascii" else np.zeros(3, "<f4").tobytes()
        (folder / f"huge_{fmt}.ply").write_bytes(f"{header}end_header\n".encode() + body)
    with open(folder / "archive.npy", "wb") as file:  # np.savez under a .npy name
        np.savez(file, depth=depth)
    np.save(folder / "empty.npy", np.zeros((0, 0), np.float32))
    K_true = {"fx": True, "fy": INTRINSIC.fy, "cx": INTRINSIC.cx, "cy": INTRINSIC.cy}
    (folder / "fx_true.json").write_text(json.dumps(K_true))
    (folder / "a_file").write_text("x")
    (folder / "unrelated").mkdir()
    (folder / "unrelated" / "notes.txt").write_text("mine")
    (folder / "folder").mkdir()
    unfinished = folder / "unfinished"
    (unfinished / "scenes").mkdir(parents=True)
    manifest = {"gripper": "franka", "object_set": "blocks", "k_max": 8, "scene_ids": []}
    (unfinished / "manifest.json").write_text(json.dumps(manifest))
    (unfinished / "scenes" / "scene_000000.npz").write_bytes(b"")
    _dataset(folder / "swapped", files=(0, 0))  # scene 0's file copied as scene 1's
    _dataset(folder / "misshapen", files=(0, 1), tsdf=(39, 40, 40))
    _urdf_object(folder / "no_mesh", mesh=None)
    _urdf_object(folder / "too_big", mesh=0.4)
    _urdf_object(folder / "escaping", mesh=0.05, name="../../../x")
    _urdf_object(folder / "face_out_of_range", mesh=0.05, faces="f 1 2 4\nf 5 6 99\n")
    _urdf_object(folder / "face_text", mesh=0.05, faces="f 1 2 4\nf one two three\n")
    _urdf_object(folder / "bad_scale", mesh=0.05, scale="0.1 0.1")
    _urdf_object(folder / "one_broken", mesh=0.05)  # thing.urdf, then a file it does not have
    (folder / "one_broken" / "zz_broken.urdf").write_text(
        (folder / "one_broken" / "thing.urdf").read_text().replace("thing.obj", "gone.obj")
    )
    for name, text in PLUGINS.items():
        (folder / f"{name}.py").write_text(text)
    (folder / "mine").mkdir()  # a user's own files, named as a benchmark's are
    (folder / "mine" / "results.md").write_text("my notes")
    (folder / "mine" / "model.sha256").write_text("my hash")
    (folder / "bench").mkdir()  # a benchmark folder of the default configuration
    config = BenchmarkConfig().record()
    (folder / "bench" / "config.json").write_text(json.dumps(config))
    for name, text in (("manifest_list", "[]"), ("manifest_torn", '{"gripper": "fr')):
        (folder / name / "scenes").mkdir(parents=True)
        (folder / name / "manifest.json").write_text(text)
    _dataset(folder / "manifest_keyless", files=(0,))
    keyless = json.loads((folder / "manifest_keyless" / "manifest.json").read_text())
    del keyless["k_max"]
    (folder / "manifest_keyless" / "manifest.json").write_text(json.dumps(keyless))
    _dataset(folder / "ids_text", files=(0, 1), scene_ids="0-1")  # hand-edited manifests
    _dataset(folder / "ids_strings", files=(0, 1), scene_ids=["0", "1"])
    _dataset(folder / "ids_twice", files=(0, 1), scene_ids=[0, 1, 1])
    _dataset(folder / "k_max_word", files=(0,), k_max="eight")
    scene = SceneConfig()  # a dataset begun with the default configuration, no scene yet
    config_word = {**dataclasses.asdict(scene), "k_max": "eight"}
    _dataset(folder / "config_word", files=(0,), seed=0, config=config_word)
    (folder / "dataset" / "scenes").mkdir(parents=True)
    begun = {"gripper": scene.gripper, "object_set": scene.object_set, "k_max": scene.k_max,
             "scene_ids": [], "seed": 0, "config": dataclasses.asdict(scene)}  # fmt: skip
    (folder / "dataset" / "manifest.json").write_text(json.dumps(begun))
    (folder / "bench_rendered").mkdir()  # a round rendered as no round played here would be
    (folder / "bench_rendered" / "config.json").write_text(json.dumps(config))
    other = "raycast" if local_renderer() == "gl" else "gl"
    (folder / "bench_rendered" / "rounds.jsonl").write_text(
        json.dumps({"seed": 0, "renderer": other}) + "\n"
    )
    (folder / "bench_list").mkdir()
    (folder / "bench_list" / "config.json").write_text("[]")
    (folder / "bench_torn").mkdir()  # rounds.jsonl torn in the middle (hand-edited, merged)
    (folder / "bench_torn" / "config.json").write_text(json.dumps(config))
    (folder / "bench_torn" / "rounds.jsonl").write_text(
        '{"seed": 0}\n{"seed": 1, "gr\n{"seed": 2}\n'
    )
    return folder


def _dataset(folder, files, tsdf=(40, 40, 40), **manifest):
    """A dataset folder of scenes 0, 1, … whose files hold the scenes ``files`` (an empty
    scene each: a TSDF of shape ``tsdf``, no valid voxel); ``manifest`` replaces fields of
    its manifest."""
    (folder / "scenes").mkdir(parents=True)
    made = {"gripper": "franka", "object_set": "blocks", "k_max": 8}
    ids = [*range(len(files))]
    (folder / "manifest.json").write_text(json.dumps({**made, "scene_ids": ids, **manifest}))
    for i, held in enumerate(files):
        np.savez_compressed(
            folder / "scenes" / f"scene_{i:06d}.npz", scene_id=np.int64(held),
            tsdf=np.zeros(tsdf, np.float32), voxel_index=np.zeros((0, 3), np.int64),
            voxel_score=np.zeros(0, np.float32), voxel_width=np.zeros(0, np.float32),
            voxel_rotations=np.zeros((0, 8, 3, 3), np.float32),
            voxel_rotation_mask=np.zeros((0, 8), bool),
        )  # fmt: skip


def _urdf_object(
    folder, mesh, name="thing", faces="f 1 2 4\nf 5 6 8\nf 1 3 5\nf 2 4 8\n", scale=""
):
    """A folder holding ``thing.urdf``, the robot ``name``, whose collision mesh is a cube of
    side ``mesh`` [m] (its vertices, then the lines ``faces``) scaled by the attribute
    ``scale`` (none when empty), or names a file that is not there (``mesh=None``)."""
    folder.mkdir()
    if mesh is not None:
        corners = np.array(np.meshgrid([0, mesh], [0, mesh], [0, mesh])).reshape(3, -1).T
        (folder / "thing.obj").write_text(
            "".join(f"v {x} {y} {z}\n" for x, y, z in corners) + faces
        )
    scaled = f' scale="{scale}"' if scale else ""
    (folder / "thing.urdf").write_text(
        f'<robot name="{name}"><link name="l"><inertial><mass value="0.2"/></inertial>'
        f'<collision><geometry><mesh filename="thing.obj"{scaled}/></geometry></collision>'
        "</link></robot>"
    )


PLUGINS = {
    "plugin_raising": 'raise RuntimeError("no camera driver")\n',
    "plugin_syntax": "def plan(observation) return []\n",
    "plugin_planners": (
        "import numpy as np\n"
        "from symgrasp.detect import Grasp\n\n"
        "def nothing(observation):\n    return None\n\n"
        "def scaled(observation):\n    return [Grasp(2 * np.eye(4), score=1.0)]\n\n"
        "def nan_score(observation):\n"
        "    pose = np.eye(4)\n    pose[:3, 3] = 0.15\n"
        "    return [Grasp(pose, score=float('nan'))]\n"
    ),
}
"""A user's planner modules (`make_files` writes them as ``NAME.py``, imported from the folder
they are played in): one that raises on import, one that does not parse, and functions that
return None, a pose that is not rigid and a NaN score."""


def detect_argv(
    d,
    *extra,
    depth="depth.npy",
    intrinsic="intrinsic.json",
    extrinsic="extrinsic.json",
    model=MODEL,
):
    """``symgrasp detect``'s argv on the files of `make_files` in ``d``, with ``extra``."""
    return ["detect", "--depth", str(d / depth), "--intrinsic", str(d / intrinsic),
            "--extrinsic", str(d / extrinsic), "--model", str(model),
            "--out", str(d / "out"), *extra]  # fmt: skip


BAD_SPECS = (
    ("negative.toml", "pad_width = 0.03", "pad_width = -0.03"),
    ("wide_pad.toml", "pad_width = 0.03", "pad_width = 0.08"),
    ("no_force.toml", "grip_force = 80.0", ""),
    ("colour.toml", "grip_force = 80.0", 'grip_force = 80.0\ncolour = "red"'),
)
"""Gripper spec files made from the made-up wide jaw's: (file, text replaced, replacement)."""

ARGUMENTS = {  # case: (argv of the `make_files` folder, text the one-line message names)
    "bench --workers 0": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--workers", "0"], "--workers"),
    "bench --backend spark": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--backend", "spark"], "--backend"),
    "data generate --ray-address without --backend ray": (lambda d: ["data", "generate", "--out", str(d / "g"), "--ray-address", "10.0.0.1:6379"], "ray_address"),
    "bench --num-objects 1000": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--num-objects", "1000"], "num_objects"),
    "bench --objects bogus": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--objects", "bogus"], "--objects"),
    "bench --confidence nan": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--confidence", "nan"], "--confidence"),
    "bench --validity 2": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--validity", "2"], "--validity"),
    "bench --seed 2**70": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--seed", str(2**70)], "seed"),
    "bench --rounds 0": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--rounds", "0"], "rounds"),
    "bench --noise gaussian": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--noise", "gaussian"], "--noise"),
    "bench --views 0": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--view", "circle", "--views", "0"], "--views"),
    "bench --view side --views 6": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--view", "side", "--views", "6"], "views must be 1 with view 'side'"),
    "data generate --k-max 0": (lambda d: ["data", "generate", "--out", str(d / "g"), "--k-max", "0"], "k_max"),
    "data generate --seed -1": (lambda d: ["data", "generate", "--out", str(d / "g"), "--seed", "-1"], "--seed"),
    "data generate --scenes 10**12": (lambda d: ["data", "generate", "--out", str(d / "g"), "--scenes", str(10**12)], "--scenes"),
    "data generate --grasps 0": (lambda d: ["data", "generate", "--out", str(d / "g"), "--grasps", "0"], "grasps"),
    "data generate --kinds heap": (lambda d: ["data", "generate", "--out", str(d / "g"), "--kinds", "heap"], "--kinds"),
    "data generate --camera-distance 0.7 0.4": (lambda d: ["data", "generate", "--out", str(d / "g"), "--camera-distance", "0.7", "0.4"], "camera_distance"),
    "data generate --noise gaussian": (lambda d: ["data", "generate", "--out", str(d / "g"), "--noise", "gaussian"], "--noise"),
    "bench --decomposition vhacd64": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--decomposition", "vhacd64"], "--decomposition"),
    "objects inspect --decomposition v-hacd": (lambda d: ["objects", "inspect", str(d), "--decomposition", "v-hacd"], "--decomposition"),
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
    "detect --samples-per-voxel 10**6": (lambda d: detect_argv(d, "--samples-per-voxel", str(10**6)), "--samples-per-voxel"),
    "detect --top-k 0": (lambda d: detect_argv(d, "--top-k", "0"), "--top-k"),
    "detect --fill-holes -1": (lambda d: detect_argv(d, "--fill-holes", "-1"), "--fill-holes"),
    "detect --depth and --points": (lambda d: detect_argv(d, "--points", str(d / "cloud.npy")), "not allowed with argument --depth"),
    "serve --port 70000": (lambda d: ["serve", "--port", "70000"], "--port"),
    "detect --workspace-origin nan": (lambda d: detect_argv(d, "--workspace-origin", "nan", "0", "0"), "--workspace-origin"),
    "figures percentiles --samples 10**12": (lambda d: ["figures", "percentiles", "--samples", str(10**12), "--out", str(d / "pictures")], "--samples"),
    "figures distribution --height nan": (lambda d: ["figures", "distribution", "--model", MODEL, "--height", "nan", "--out", str(d / "pictures")], "--height"),
    "sim show --n 1000": (lambda d: ["sim", "show", "--n", "1000", "--out", str(d / "pictures")], "--n"),
    "demo --num-objects 1000": (lambda d: ["demo", "--num-objects", "1000", "--out", str(d / "pictures")], "--num-objects"),
    "an unknown command": (lambda d: ["declutter"], "declutter"),
    "data generate --out ''": (lambda d: ["data", "generate", "--out", ""], "--out"),
    "data generate --out ' '": (lambda d: ["data", "generate", "--out", " "], "--out"),
    "bench --out ''": (lambda d: ["bench", "declutter", "--out", ""], "--out"),
    "demo --out ''": (lambda d: ["demo", "--out", ""], "--out"),
    "sim show --out ''": (lambda d: ["sim", "show", "--out", ""], "--out"),
    "train --out ' '": (lambda d: ["train", "--data", str(d), "--out", " "], "--out"),
    "data generate --out a file": (lambda d: ["data", "generate", "--out", str(d / "a_file")], "a_file"),
    "detect missing depth": (lambda d: detect_argv(d, depth="nothing.npy"), "nothing.npy"),
    "detect unknown model": (lambda d: detect_argv(d, model="bingham9d-hand"), "bingham9d-hand"),
    "detect --out under a file": (lambda d: [*detect_argv(d)[:-1], str(d / "a_file" / "out")], "a_file"),
    "detect --out is a file": (lambda d: [*detect_argv(d)[:-1], str(d / "a_file")], "a_file"),
    "sim show --out is a file": (lambda d: ["sim", "show", "--n", "1", "--out", str(d / "a_file")], "a_file"),
    "export into a folder": (lambda d: ["export", str(shipped_path(MODEL)), str(d / "folder")], "folder"),
    "export --torchscript an unknown model": (lambda d: ["export", "bingham9d-hand", str(d / "x.pt"), "--torchscript"], "bingham9d-hand"),
    "detect --model vgn --optimize": (lambda d: detect_argv(d, "--optimize", model="vgn"), "--optimize"),
    "sim show --objects an unknown set": (lambda d: ["sim", "show", "--objects", "kitchen", "--out", str(d / "s")], "data folder"),
    "sim show --objects good, (an empty part)": (lambda d: ["sim", "show", "--objects", f"{d / 'too_big'},", "--out", str(d / "s")], "--objects"),
    "sim show --objects ''": (lambda d: ["sim", "show", "--objects", "", "--out", str(d / "s")], "--objects"),
    "gripper show an unknown name": (lambda d: ["gripper", "show", "shadow-hand"], "shadow-hand"),
    "gripper show a missing spec file": (lambda d: ["gripper", "show", str(d / "nothing.toml")], "nothing.toml"),
    "gripper show a negative size": (lambda d: ["gripper", "show", str(d / "negative.toml")], "negative.toml: pad_width must be in (0, 1] m"),
    "gripper show a pad wider than the palm": (lambda d: ["gripper", "show", str(d / "wide_pad.toml")], "pad_width (0.08 m) is wider than the palm"),
    "gripper show a missing key": (lambda d: ["gripper", "show", str(d / "no_force.toml")], "no_force.toml: missing key grip_force"),
    "gripper show an unknown key": (lambda d: ["gripper", "show", str(d / "colour.toml")], "colour.toml: unknown key colour"),
    "data generate --gripper a bad spec": (lambda d: ["data", "generate", "--out", str(d / "g"), "--gripper", str(d / "negative.toml")], "pad_width"),
    "train --gripper a missing spec file": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--gripper", str(d / "nothing.toml")], "--gripper"),
    "demo --gripper a spec file without --model": (lambda d: ["demo", "--gripper", str(d / "wide_jaw.toml"), "--out", str(d / "pictures")], "--model"),
    "objects inspect a procedural set": (lambda d: ["objects", "inspect", "blocks"], "built in code"),
    "detect --points without a pose": (lambda d: ["detect", "--points", str(d / "cloud.npy"), "--out", str(d / "out")], "--points needs --extrinsic or --viewpoint"),
    "serve an unknown model": (lambda d: ["serve", "--port", "0", "--model", "bingham9d-hand"], "bingham9d-hand"),
    "detect --device tpu": (lambda d: detect_argv(d, "--device", "tpu"), "--device"),
    "detect --device ''": (lambda d: detect_argv(d, "--device", ""), "--device"),
    "serve --device mps": (lambda d: ["serve", "--port", "0", "--device", "mps"], "--device"),
    "select --device tpu": (lambda d: ["select", str(d), "--by", "val_loss", "--device", "tpu"], "--device"),
    "train --device mps": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--device", "mps"], "device must be 'auto', 'cpu' or 'cuda[:N]', got 'mps'"),
    "select --by bogus": (lambda d: ["select", str(d), "--by", "bogus"], "--by"),
    "figures continuity --model of no file": (lambda d: ["figures", "continuity", "--model", f"a={d / 'nothing.pt'}", "--out", str(d / "pictures")], "nothing.pt"),
    "figures continuity --model without a label": (lambda d: ["figures", "continuity", "--model", MODEL, "--out", str(d / "pictures")], "LABEL=MODEL"),
    "train with every loss weight 0": (lambda d: ["train", "--data", str(d), "--out", str(d / "r"), "--weight-validity", "0", "--weight-score", "0", "--weight-rotation", "0"], "all 0"),
}  # fmt: skip
"""Bad arguments: values out of range or of no known name, options that contradict each other,
paths that are blank, missing or of the wrong kind, gripper spec files (plain data). Each is
refused before the command imports torch, MuJoCo, trimesh or matplotlib, so in well under a
second (tests/test_bad_input.py plays them with those imports blocked)."""

FILES = {  # case: (argv of the `make_files` folder, text the one-line message names)
    "bench into an existing benchmark": (lambda d: ["bench", "declutter", "--out", str(d / "bench")], "--resume"),
    "bench --resume a config.json that is []": (lambda d: ["bench", "declutter", "--out", str(d / "bench_list"), "--resume"], "config.json is not a valid benchmark configuration: expected a JSON object"),
    "bench --resume a rounds.jsonl torn in the middle": (lambda d: ["bench", "declutter", "--out", str(d / "bench_torn"), "--resume", "--no-operating-point"], "rounds.jsonl line 2 is not a valid round record"),
    "bench --resume of another configuration": (lambda d: ["bench", "declutter", "--out", str(d / "bench"), "--resume", "--rounds", "3", "--no-operating-point"], "rounds differ"),
    "bench --resume with another depth noise": (lambda d: ["bench", "declutter", "--out", str(d / "bench"), "--resume", "--noise", "dex", "--no-operating-point"], "noise differ"),
    "bench --resume with another decomposition": (lambda d: ["bench", "declutter", "--out", str(d / "bench"), "--resume", "--decomposition", "coacd", "--no-operating-point"], "decomposition differ"),
    "bench --out a folder of the user's results.md": (lambda d: ["bench", "declutter", "--out", str(d / "mine")], "holds files that are not a benchmark (model.sha256, results.md)"),
    "train --out unrelated files": (lambda d: ["train", "--data", str(d), "--out", str(d / "unrelated")], "not a training run (notes.txt)"),
    "demo --out unrelated files": (lambda d: ["demo", "--out", str(d / "unrelated")], "not pictures"),
    "data generate --objects a URDF whose name leaves the folder": (lambda d: ["data", "generate", "--objects", str(d / "escaping"), "--out", str(d / "g")], "thing.urdf: the robot's name must be one file name"),
    "data generate --out unrelated files": (lambda d: ["data", "generate", "--out", str(d / "unrelated")], "not a symgrasp dataset"),
    "data inspect a manifest that is []": (lambda d: ["data", "inspect", str(d / "manifest_list")], "manifest.json is not a valid dataset manifest: expected a JSON object"),
    "data inspect a torn manifest": (lambda d: ["data", "inspect", str(d / "manifest_torn")], "manifest.json is not a valid dataset manifest: not JSON"),
    "train on a manifest without k_max": (lambda d: ["train", "--data", str(d / "manifest_keyless"), "--out", str(d / "r")], "manifest.json is not a valid dataset manifest: it lacks the key 'k_max'"),
    "data generate --resume on a manifest that is []": (lambda d: ["data", "generate", "--out", str(d / "manifest_list"), "--resume"], "manifest.json is not a valid dataset manifest"),
    "data generate --resume with another depth noise": (lambda d: ["data", "generate", "--out", str(d / "dataset"), "--resume", "--noise", "dex"], "noise: 'none' recorded, 'dex' given"),
    "data generate --resume with another decomposition": (lambda d: ["data", "generate", "--out", str(d / "dataset"), "--resume", "--decomposition", "coacd"], "decomposition: 'vhacd-32' recorded, 'coacd' given"),
    "data inspect unfinished": (lambda d: ["data", "inspect", str(d / "unfinished")], "unfinished"),
    "data relabel unfinished": (lambda d: ["data", "relabel", str(d / "unfinished"), "--out", str(d / "g")], "unfinished dataset"),
    "data relabel not a dataset": (lambda d: ["data", "relabel", str(d / "folder"), "--out", str(d / "g")], "src must be a dataset folder"),
    "data relabel a manifest that is []": (lambda d: ["data", "relabel", str(d / "manifest_list"), "--out", str(d / "g")], "manifest.json is not a valid dataset manifest"),
    "data relabel a dataset without a spread": (lambda d: ["data", "relabel", str(d / "dataset"), "--out", str(d / "g")], "has no label spread"),
    "data relabel into its own folder": (lambda d: ["data", "relabel", str(d / "dataset"), "--out", str(d / "dataset")], "another folder than src"),
    "data inspect not a dataset": (lambda d: ["data", "inspect", str(d / "folder")], "manifest"),
    "data inspect a scene file copied under another id": (lambda d: ["data", "inspect", str(d / "swapped")], "scene_000001.npz holds scene 0, not 1"),
    "data inspect a TSDF of 39 × 40 × 40": (lambda d: ["data", "inspect", str(d / "misshapen")], "tsdf has shape (39, 40, 40)"),
    "train on a scene file copied under another id": (lambda d: ["train", "--data", str(d / "swapped"), "--out", str(d / "r")], "scene_000001.npz holds scene 0, not 1"),
    "train on a TSDF of 39 × 40 × 40": (lambda d: ["train", "--data", str(d / "misshapen"), "--out", str(d / "r")], "tsdf has shape (39, 40, 40)"),
    "detect intrinsic without fx": (lambda d: detect_argv(d, intrinsic="no_fx.json"), "no_fx.json"),
    "detect --points a text file": (lambda d: ["detect", "--points", str(d / "a_file"), "--viewpoint", "1", "0", "1", "--out", str(d / "out")], "must be a .npy or .ply file"),
    "detect --points of (N, 2)": (lambda d: ["detect", "--points", str(d / "pairs.npy"), "--viewpoint", "1", "0", "1", "--out", str(d / "out")], "pairs.npy holds float64 of shape"),
    "detect --points a PLY without vertices": (lambda d: ["detect", "--points", str(d / "faces.ply"), "--viewpoint", "1", "0", "1", "--out", str(d / "out")], "faces.ply"),
    "detect garbage depth": (lambda d: detect_argv(d, depth="garbage.npy"), "garbage.npy"),
    "detect depth in millimetres": (lambda d: detect_argv(d, depth="depth_mm.npy"), "metres"),
    "detect bool depth": (lambda d: detect_argv(d, depth="depth_bool.npy"), "depth_bool.npy holds bool"),
    "detect complex depth": (lambda d: detect_argv(d, depth="depth_complex.npy"), "depth_complex.npy holds complex64"),
    "detect an 8-bit PNG (a picture of depth)": (lambda d: detect_argv(d, depth="depth_8bit.png"), "depth_8bit.png is a PNG of mode L"),
    "detect a checkpoint with NaN weights": (lambda d: detect_argv(d, model=d / "nan.pt"), "nan.pt holds non-finite weights"),
    "detect a checkpoint with a flipped bit": (lambda d: detect_argv(d, model=d / "corrupted.pt"), "corrupted.pt is not a readable symgrasp checkpoint"),
    "detect garbage checkpoint": (lambda d: detect_argv(d, model=d / "garbage.pt"), "garbage.pt"),
    "detect truncated checkpoint": (lambda d: detect_argv(d, model=d / "truncated.pt"), "truncated.pt"),
    "sim show --objects an empty folder": (lambda d: ["sim", "show", "--objects", str(d / "folder"), "--out", str(d / "s")], "holds no .urdf file"),
    "sim show --objects a URDF without its mesh": (lambda d: ["sim", "show", "--objects", str(d / "no_mesh"), "--out", str(d / "s")], "thing.obj"),
    "sim show --objects an object larger than the workspace": (lambda d: ["sim", "show", "--objects", str(d / "too_big"), "--out", str(d / "s")], "larger than the 0.3 m workspace"),
    "sim show --objects an OBJ face out of range": (lambda d: ["sim", "show", "--objects", str(d / "face_out_of_range"), "--out", str(d / "s")], "thing.obj: a face names vertex 99, out of range: the file holds 8 vertices"),
    "sim show --objects an OBJ face of words": (lambda d: ["sim", "show", "--objects", str(d / "face_text"), "--out", str(d / "s")], "thing.obj:10: a face needs vertex numbers"),
    "sim show --objects a URDF scale of two numbers": (lambda d: ["sim", "show", "--objects", str(d / "bad_scale"), "--out", str(d / "s")], "thing.urdf: the mesh's scale must be three positive numbers"),
    "bench --gripper another than the model's": (lambda d: ["bench", "declutter", "--out", str(d / "b"), "--gripper", "franka"], "--gripper franka, but --model bingham2d-robotiq-2f85 is robotiq-2f85"),
    "export a checkpoint without its network": (lambda d: ["export", str(d / "no_network.pt"), str(d / "x.pt")], "no_network.pt lacks 'model'"),
    "detect --model a checkpoint without its network": (lambda d: detect_argv(d, model=d / "no_network.pt"), "no_network.pt lacks 'model'"),
    "export a garbage checkpoint": (lambda d: ["export", str(d / "garbage.pt"), str(d / "x.pt")], "garbage.pt"),
    "detect --points a PLY header claiming 10**9 ASCII vertices": (lambda d: ["detect", "--points", str(d / "huge_ascii.ply"), "--viewpoint", "1", "0", "1", "--out", str(d / "out")], "huge_ascii.ply (the file ends before its 1000000000 vertices"),
    "detect --points a PLY header claiming 10**9 binary vertices": (lambda d: ["detect", "--points", str(d / "huge_binary_little_endian.ply"), "--viewpoint", "1", "0", "1", "--out", str(d / "out")], "the file ends before its 1000000000 vertices"),
    "detect --depth an .npz named .npy": (lambda d: detect_argv(d, depth="archive.npy"), "archive.npy (it is an .npz archive"),
    "detect --points an .npz named .npy": (lambda d: ["detect", "--points", str(d / "archive.npy"), "--viewpoint", "1", "0", "1", "--out", str(d / "out")], "archive.npy (it is an .npz archive"),
    "detect an empty depth image": (lambda d: detect_argv(d, depth="empty.npy"), "empty.npy"),
    "detect intrinsic fx: true": (lambda d: detect_argv(d, intrinsic="fx_true.json"), "fx must be a number"),
    "detect a checkpoint with a tensor of another shape": (lambda d: detect_argv(d, model=d / "misshapen.pt"), "misshapen.pt's weights do not fit its network"),
    "bench a checkpoint with a tensor of another shape": (lambda d: ["bench", "declutter", "--model", str(d / "misshapen.pt"), "--out", str(d / "b")], "misshapen.pt's weights do not fit its network"),
    "bench --objects a folder with one broken object": (lambda d: ["bench", "declutter", "--objects", str(d / "one_broken"), "--out", str(d / "b")], "gone.obj"),
    "train on a manifest whose scene_ids are a string": (lambda d: ["train", "--data", str(d / "ids_text"), "--out", str(d / "r")], "ids_text/manifest.json is not a valid dataset manifest: scene_ids must be a list of integers ≥ 0, got \"0-1\""),
    "data inspect a manifest whose scene_ids are strings": (lambda d: ["data", "inspect", str(d / "ids_strings")], "ids_strings/manifest.json is not a valid dataset manifest: scene_ids must be a list of integers"),
    "data inspect a manifest listing a scene twice": (lambda d: ["data", "inspect", str(d / "ids_twice")], "ids_twice/manifest.json is not a valid dataset manifest: scene_ids must name each scene once, got 1 more than once"),
    "train on a manifest whose k_max is a word": (lambda d: ["train", "--data", str(d / "k_max_word"), "--out", str(d / "r")], "k_max_word/manifest.json is not a valid dataset manifest: k_max must be an integer ≥ 1, got \"eight\""),
    "data relabel a manifest whose config's k_max is a word": (lambda d: ["data", "relabel", str(d / "config_word"), "--out", str(d / "g")], "config_word/manifest.json is not a valid dataset manifest: its config: k_max must be an integer"),
    "bench --resume rounds of another renderer": (lambda d: ["bench", "declutter", "--out", str(d / "bench_rendered"), "--resume", "--no-operating-point"], "the rounds played now would differ"),
}  # fmt: skip
"""Files whose contents are wrong (a checkpoint, a dataset, a benchmark folder, a depth image, a
mesh): refused when the command reads them, with the library it reads them by, naming the file."""

PLANNERS = {  # case: (argv of the `make_files` folder, played in it, text the message names)
    "detect --planner a module that raises": (lambda d: detect_argv(d, "--gripper", "franka", model="plugin_raising:plan"), "importing plugin_raising raised RuntimeError: no camera driver (plugin_raising.py:1)"),
    "bench --planner a module that raises": (lambda d: ["bench", "declutter", "--planner", "plugin_raising:plan", "--gripper", "franka", "--out", str(d / "b")], "importing plugin_raising raised RuntimeError"),
    "detect --planner a module that does not parse": (lambda d: detect_argv(d, "--gripper", "franka", model="plugin_syntax:plan"), "plugin_syntax.py:1"),
    "bench --planner a module that does not parse": (lambda d: ["bench", "declutter", "--planner", "plugin_syntax:plan", "--gripper", "franka", "--out", str(d / "b")], "raised SyntaxError"),
    "detect --planner a missing module": (lambda d: detect_argv(d, "--gripper", "franka", model="plugin_missing:plan"), "cannot import plugin_missing"),
    "detect --planner returning None": (lambda d: detect_argv(d, "--gripper", "franka", model="plugin_planners:nothing"), "must return a sequence of symgrasp.detect.Grasp"),
    "detect --planner returning a pose that is not rigid": (lambda d: detect_argv(d, "--gripper", "franka", model="plugin_planners:scaled"), "grasp 0's pose must be T_world_tcp, a rigid 4×4 transform"),
    "detect --planner returning a NaN score": (lambda d: detect_argv(d, "--gripper", "franka", model="plugin_planners:nan_score"), "grasp 0's score must be a finite number, got nan"),
}  # fmt: skip
"""A user's planner (`PLUGINS`): imported, and its grasps checked, by `symgrasp.peers.plugin`,
each refused naming the planner (and where its module failed), nothing written. Played with the
`make_files` folder as the current folder, where the command line imports planners from."""
CLI = {**ARGUMENTS, **FILES, **PLANNERS}
"""Every command-line case (played in the `make_files` folder: `PLANNERS` import from it)."""


def _construct(**options):
    return _pretrained(MODEL, **options)


def _pretrained(name, **options):
    from symgrasp.detect import GraspDetector

    return GraspDetector.from_pretrained(name, device="cpu", **options)


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
    "bool depth": (lambda d: d.detect(table_depth() > 0, INTRINSIC, CAMERA), "bool"),
    "complex depth": (lambda d: d.detect(table_depth().astype(np.complex64), INTRINSIC, CAMERA), "complex64"),
    "tsdf NaN": (lambda d: d.detect_tsdf(np.full((40, 40, 40), np.nan)), "tsdf must be finite"),
    "tsdf 1e30": (lambda d: d.detect_tsdf(np.full((40, 40, 40), 1e30)), "within [-1, 1]"),
    "tsdf a string": (lambda d: d.detect_tsdf("abc"), "tsdf must be a (40, 40, 40) array or tensor of numbers, got str"),
    "intrinsic a dict": (lambda d: d.detect(table_depth(), {"fx": 50.0, "fy": 50.0, "cx": 32.0, "cy": 24.0}, CAMERA), "intrinsic must be a CameraIntrinsic or 3×3 matrix, got a dict"),
    "depth (H, W, 3)": (lambda d: d.detect(np.full((48, 64, 3), 0.6), INTRINSIC, CAMERA), "depth of shape (48, 64, 3) looks like a colour image or an organised point cloud"),
    "bounds NaN": (lambda d: _construct(bounds=(np.full(3, np.nan), np.ones(3))), "bounds"),
    "bounds outside the workspace": (lambda d: _construct(bounds=(np.full(3, 5.0), np.full(3, 6.0))), "bounds"),
    "extrinsic not rigid": (lambda d: d.detect(np.full((48, 64), 0.6), np.diag([50.0, 50, 1]), 2 * np.eye(4)), "extrinsic"),
    "fill_holes=-1": (lambda d: _construct(fill_holes=-1), "fill_holes"),
    "optimize='yes'": (lambda d: _construct(optimize="yes"), "optimize"),
    "detect_points with a pose and a viewpoint": (lambda d: d.detect_points(table_cloud(), CAMERA, viewpoint=(1, 0, 1)), "exactly one"),
    "detect_points of (N, 2)": (lambda d: d.detect_points(table_cloud()[:, :2], CAMERA), "points must be"),
    "detect_points frame='base'": (lambda d: d.detect_points(table_cloud(), CAMERA, frame="base"), "frame must be one of"),
    "fit_table of an empty image": (lambda d: __import__("symgrasp.perception", fromlist=["x"]).fit_table(np.zeros((48, 64)), INTRINSIC), "needs seen depth pixels"),
    "objects 'a,' (an empty part)": (lambda d: __import__("symgrasp.objects.sets", fromlist=["x"]).resolve("household-train,"), "empty name"),
    "objects ''": (lambda d: __import__("symgrasp.objects.sets", fromlist=["x"]).resolve(""), "empty name"),
    "objects decomposition='v-hacd'": (lambda d: __import__("symgrasp.objects.sets", fromlist=["x"]).resolve("household-train", decomposition="v-hacd"), "decomposition must be one of vhacd-32, vhacd, coacd, coacd-fast, got 'v-hacd'"),
    "unknown object set": (lambda d: __import__("symgrasp.sim", fromlist=["x"]).object_set("kitchen", 3), "household-train"),
    "unknown gripper": (lambda d: __import__("symgrasp.sim", fromlist=["x"]).get_gripper("shadow"), "robotiq-2f85"),
    "unknown representation": (lambda d: __import__("symgrasp.rotation", fromlist=["x"]).get("rotmat9d"), "bingham2d"),
    "Bingham A (2, 3)": (lambda d: bingham.Bingham(torch.zeros(2, 3)), "`A` must be"),
    "Bingham NaN A, sampled": (lambda d: bingham.Bingham(torch.full((3, 3), torch.nan)).sample(), "`A` must be finite"),
    "Bingham nll of a non-unit v": (lambda d: bingham.nll(torch.zeros(3, 3), torch.tensor([2.0, 0, 0])), "unit vectors"),
    "Bingham normalizer method": (lambda d: bingham.log_normalizer(torch.zeros(3), method="laplace"), "`method`"),
    "from_pretrained(None)": (lambda d: _pretrained(None), "model must be a shipped model's name or a checkpoint path, got None"),
    "from_pretrained(123)": (lambda d: _pretrained(123), "got 123"),
    "CameraIntrinsic fx=True": (lambda d: CameraIntrinsic(64, 48, True, 50.0, 32.0, 24.0), "fx must be a number"),
    "CameraIntrinsic width 64.5": (lambda d: CameraIntrinsic(64.5, 48, 50.0, 50.0, 32.0, 24.0), "width must be an integer"),
}  # fmt: skip
"""Bad calls of the API, each ``case: (call of a detector of `MODEL`, text its message names)``:
each raises ValueError or TypeError naming the argument. The Bingham rows cover its entry
points; tests/bingham/ holds the rest of its cases."""

WARNED_CLI = {  # case: (argv of the `make_files` folder, text the warning line names)
    "detect depth in feet": (lambda d: detect_argv(d, depth="depth_feet.npy"), "none of the 3072 depth points lies inside the workspace"),
    "detect the extrinsic inverted (T_camera_world)": (lambda d: detect_argv(d, extrinsic="inverted.json"), "lies inside the workspace"),
    "detect --workspace-origin 100 m away": (lambda d: detect_argv(d, "--workspace-origin", "100", "0", "0"), "cube from (100, 0, 0)"),
    "detect a 16-bit PNG in centimetres": (lambda d: detect_argv(d, depth="depth_cm.png"), "implausibly near"),
    "detect a 16-bit PNG in tenths of a millimetre": (lambda d: detect_argv(d, depth="depth_tenth_mm.png"), "lies inside the workspace"),
}  # fmt: skip
"""Valid command lines that give no grasp for a cause their input shows: each exits 0 with an
empty grasp list and one ``warning:`` line on stderr that names the cause."""


def _nan_network():
    from symgrasp.detect import GraspDetector
    from symgrasp.model.network import GraspNet, NetworkConfig
    from symgrasp.sim import ROBOTIQ_2F85

    net = GraspNet(NetworkConfig())
    with torch.no_grad():
        next(net.parameters()).fill_(torch.nan)
    return GraspDetector(net, ROBOTIQ_2F85, device="cpu")


WARNED_API = {
    "depth in feet": (lambda d: d.detect(table_depth() / FOOT, INTRINSIC, CAMERA), "lies inside the workspace"),
    "the extrinsic inverted (T_camera_world)": (lambda d: d.detect(table_depth(), INTRINSIC, np.linalg.inv(CAMERA)), "lies inside the workspace"),
    "workspace_origin 100 m away": (lambda d: _construct(workspace_origin=(100, 0, 0)).detect(table_depth(), INTRINSIC, CAMERA), "cube from (100, 0, 0)"),
    "depth in centimetres as metres": (lambda d: d.detect(table_depth() * 0.1, INTRINSIC, CAMERA), "implausibly near"),
    "no valid depth pixel": (lambda d: d.detect(np.full((48, 64), np.nan), INTRINSIC, CAMERA), "no valid pixel"),
    "a network with NaN weights": (lambda d: _nan_network().detect(table_depth(), INTRINSIC, CAMERA), "network's output is NaN"),
    "a TSDF that shows nothing": (lambda d: d.detect_tsdf(np.ones((40, 40, 40))), "TSDF shows nothing"),
    "a camera-frame cloud read as the world's": (lambda d: d.detect_points((table_cloud() - CAMERA[:3, 3]) @ CAMERA[:3, :3], CAMERA), "frame"),
}  # fmt: skip
"""Valid calls that give no grasp for a cause their input shows, each ``case: (call of a detector
of `MODEL`, text the warning names)``: each returns [] with one `NoGraspWarning` naming it."""
