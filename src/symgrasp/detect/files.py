"""Detection inputs and outputs as files: what ``symgrasp detect`` reads and writes.

Inputs: a depth image (``.npy`` floating-point metres, or ``.png`` 16-bit integers times a
scale, millimetres by default), the intrinsic as JSON (``{"width", "height", "fx", "fy", "cx",
"cy"}`` or a 3×3 matrix, bare or under ``"K"``), the extrinsic ``T_world_camera`` as JSON
(a 4×4 matrix, bare or under ``"T_world_camera"``). Outputs: ``grasps.json``,
``grasps.png`` and the interactive ``grasps.html`` (`symgrasp.detect.show`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import torch
from PIL import Image  # matplotlib's own dependency; keeps 16-bit PNGs exact

from symgrasp.detect.detector import GraspDetector
from symgrasp.detect.grasp import Grasp
from symgrasp.detect.planner import GraspPlanner
from symgrasp.detect.show import save_grasps_html, save_grasps_png
from symgrasp.perception import CameraIntrinsic, TSDFVolume

DRAWN = 20
"""Grasps drawn in the pictures."""

SAMPLED = 5
"""Best grasps whose Bingham closing-axis samples the HTML view shows ..."""

SAMPLES = 30
"""... this many each."""


def load_depth(path: str | Path, png_scale: float = 0.001) -> np.ndarray:
    """A depth image (H, W) [m] from ``.npy`` (floating-point metres) or ``.png`` (one 16-bit
    integer per pixel, times ``png_scale``: millimetres by default). ValueError naming the file
    for any other content: integer, bool or complex arrays, an 8-bit or colour PNG (a picture
    of depth, not depth)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"depth: no file at {path}")
    if path.suffix not in (".npy", ".png"):
        raise ValueError(f"depth must be a .npy or .png file, got {path}")
    try:
        if path.suffix == ".npy":
            raw = _load_npy(path)
        else:
            image = Image.open(path)
            raw = np.asarray(image)
    except (OSError, ValueError, EOFError, TypeError) as err:
        raise ValueError(f"depth: cannot read an image from {path} ({err})") from None
    if path.suffix == ".npy" and not np.issubdtype(raw.dtype, np.floating):
        hint = (
            " (raw sensor units? convert them to metres, or save them as a 16-bit .png and give "
            "its scale)"
            if np.issubdtype(raw.dtype, np.integer)
            else ""
        )
        raise ValueError(
            f"depth {path} holds {raw.dtype} values; a .npy depth image holds floating-point "
            f"metres{hint}"
        )
    if path.suffix == ".png" and not (
        raw.ndim == 2 and np.issubdtype(raw.dtype, np.integer) and raw.dtype.itemsize >= 2
    ):
        raise ValueError(
            f"depth {path} is a PNG of mode {image.mode} ({raw.dtype}, shape {raw.shape}); a "
            "depth PNG holds one 16-bit integer per pixel: an 8-bit or colour PNG is a picture "
            "of depth, not depth"
        )
    if raw.ndim == 3 and raw.shape[-1] == 1:
        raw = raw[..., 0]
    if raw.ndim != 2 or raw.size == 0:
        raise ValueError(
            f"depth must be one (H, W) or (H, W, 1) image of at least one pixel, got shape "
            f"{raw.shape} from {path}"
        )
    scale = 1.0 if path.suffix == ".npy" else png_scale
    return (raw.astype(np.float64) * scale).astype(np.float32)


def _load_npy(path: Path) -> np.ndarray:
    """The array of a ``.npy`` file; ValueError for another content under that name (a
    ``.npz`` archive, a pickle: ``np.load`` reads the bytes, not the name)."""
    loaded = np.load(path)
    if not isinstance(loaded, np.ndarray):  # np.load opened an .npz archive
        loaded.close()
        raise ValueError(
            "it is an .npz archive, not one .npy array (np.savez writes archives; np.save one "
            "array)"
        )
    return loaded


PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
"""PLY's scalar property types (Turk's format, 1994, and its newer names) as numpy's."""

PLY_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}


def load_points(path: str | Path) -> np.ndarray:
    """A point cloud [m] from ``.npy`` (floats, (N, 3) or organised (H, W, 3); NaN rows are
    missing points) or ``.ply`` (the x, y, z of its vertices, the first element; ASCII or
    binary), as float64 (N, 3) or (H, W, 3). ValueError naming the file otherwise."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"points: no file at {path}")
    if path.suffix not in (".npy", ".ply"):
        raise ValueError(f"points must be a .npy or .ply file, got {path}")
    try:
        cloud = _load_npy(path) if path.suffix == ".npy" else _read_ply(path)
    except (OSError, ValueError, EOFError, TypeError, IndexError) as err:  # a broken file
        raise ValueError(f"points: cannot read a point cloud from {path} ({err})") from None
    if (
        not np.issubdtype(cloud.dtype, np.floating)
        or cloud.ndim not in (2, 3)
        or cloud.shape[-1] != 3
    ):
        raise ValueError(
            f"points {path} holds {cloud.dtype} of shape {cloud.shape}; a point cloud is "
            "floating-point metres of shape (N, 3) or organised (H, W, 3)"
        )
    return cloud.astype(np.float64)


def _read_ply(path: Path) -> np.ndarray:
    """The (N, 3) vertex positions of a PLY file (ValueError for what it cannot read)."""
    with open(path, "rb") as file:
        if file.readline().strip() != b"ply":
            raise ValueError("not a PLY file (no 'ply' first line)")
        fmt, elements = None, []
        while True:
            line = file.readline()
            if not line:
                raise ValueError("the header has no end_header")
            words = line.decode("ascii").split()
            if not words or words[0] in ("comment", "obj_info"):
                continue
            if words[0] == "end_header":
                break
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                elements.append((words[1], int(words[2]), []))
            elif words[0] == "property" and elements:
                if words[1] == "list":
                    elements[-1][2].append((words[-1], None))
                else:
                    elements[-1][2].append((words[2], words[1]))
        if fmt not in PLY_FORMATS:
            raise ValueError(f"format {fmt!r} is not one of {', '.join(PLY_FORMATS)}")
        if not elements or elements[0][0] != "vertex":
            raise ValueError("its first element must be vertex")
        _, count, properties = elements[0]
        names = [name for name, _ in properties]
        if not {"x", "y", "z"} <= set(names) or any(kind is None for _, kind in properties):
            raise ValueError(
                f"its vertices must have scalar properties x, y, z, got {', '.join(names)}"
            )
        dtype = None if fmt == "ascii" else _vertex_dtype(properties, PLY_FORMATS[fmt])
        # checked before anything is allocated: a vertex takes at least this many of the file's
        # bytes (an ASCII line: n one-digit values, n − 1 spaces and a newline, which the last
        # line may lack)
        least = 2 * len(names) if dtype is None else dtype.itemsize
        left = path.stat().st_size - file.tell()
        most = (left + (dtype is None)) // least
        if not 0 <= count <= most:
            raise ValueError(
                f"the file ends before its {count} vertices: the {left} bytes after its header "
                f"hold at most {most}"
            )
        if fmt == "ascii":
            rows = [file.readline().split() for _ in range(count)]
            if any(len(row) < len(names) for row in rows):
                raise ValueError(f"fewer than {count} vertex lines of {len(names)} values")
            table = np.array([r[: len(names)] for r in rows], dtype=np.float64).reshape(count, -1)
            return table[:, [names.index(axis) for axis in "xyz"]]
        vertices = np.frombuffer(file.read(dtype.itemsize * count), dtype=dtype)
        return np.stack([vertices[axis].astype(np.float64) for axis in "xyz"], axis=1)


def _vertex_dtype(properties: list[tuple[str, str]], order: str) -> np.dtype:
    """The numpy record of a binary PLY vertex of ``properties`` (name, PLY type) in byte
    ``order`` ("<" or ">"); ValueError for a type PLY does not name."""
    unknown = sorted({kind for _, kind in properties} - set(PLY_TYPES))
    if unknown:
        raise ValueError(f"unknown property type {', '.join(unknown)}")
    return np.dtype([(name, order + PLY_TYPES[kind]) for name, kind in properties])


def _load_json(path: str | Path, what: str) -> Any:
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ValueError(f"{what}: cannot read JSON from {path}: {error}") from error


def load_intrinsic(path: str | Path, shape: tuple[int, int] | None) -> CameraIntrinsic:
    """The camera intrinsic of images of ``shape`` (H, W) from a JSON file (None: the file
    must say the size)."""
    return intrinsic_from_json(_load_json(path, "intrinsic"), shape, f"intrinsic {path}")


def intrinsic_from_json(data: Any, shape: tuple[int, int] | None, what: str) -> CameraIntrinsic:
    """The camera intrinsic in JSON data ``data``: ``{"fx", "fy", "cx", "cy"[, "width",
    "height"]}`` or a 3×3 matrix, bare or under ``"K"``, of images of ``shape`` (H, W) (None:
    the size must be in ``data``). ValueError starting with ``what`` otherwise."""
    expected = (
        'expected {"fx", "fy", "cx", "cy"[, "width", "height"]} or a 3×3 matrix (bare or under "K")'
    )
    try:
        if isinstance(data, dict) and "K" not in data:
            size = shape or (data["height"], data["width"])
            values = {"width": data.get("width", size[1]), "height": data.get("height", size[0]),
                      **{k: data[k] for k in ("fx", "fy", "cx", "cy")}}  # fmt: skip
            return CameraIntrinsic(**values)
        if shape is None:
            raise ValueError("a 3×3 matrix does not say the image size: give width and height")
        K = np.asarray(data["K"] if isinstance(data, dict) else data, dtype=float)
        return CameraIntrinsic.from_matrix(K, shape[1], shape[0])
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{what}: {expected}; {type(err).__name__}: {err}") from None


def load_extrinsic(path: str | Path) -> np.ndarray:
    """``T_world_camera`` (4, 4) from a JSON file (checked for rigidity by the detector)."""
    data = _load_json(path, "extrinsic")
    try:
        T = np.asarray(data["T_world_camera"] if isinstance(data, dict) else data, dtype=float)
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(
            f'extrinsic {path}: expected a 4×4 matrix (bare or under "T_world_camera"); '
            f"{type(err).__name__}: {err}"
        ) from None
    if T.shape != (4, 4):
        raise ValueError(f"extrinsic {path}: expected a 4×4 matrix, got shape {T.shape}")
    return T


def write_detection(
    out: str | Path,
    planner: GraspPlanner,
    volume: TSDFVolume,
    grasps: list[Grasp],
    points: np.ndarray | None = None,
) -> dict[str, Path]:
    """Write ``grasps.json``, ``grasps.png`` and ``grasps.html`` for ``grasps`` that
    ``planner`` (a `GraspDetector` or any `GraspPlanner`) found in the scene fused into
    ``volume``, drawn over ``points`` (N, 3) (the depth image's, `depth_to_points`; default:
    the volume's surface points); the HTML view shows closing-axis samples of the best
    voxels when the model predicts a distribution."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    representation = getattr(getattr(planner, "representation", None), "name", None)
    meta = {
        "planner": planner.name,
        "version": planner.version,
        "representation": representation,
        "gripper": planner.gripper.name,
        "timing_ms": getattr(planner, "timing", {}),
        "grasps": [g.record() for g in grasps],
    }
    paths = {"json": out / "grasps.json", "png": out / "grasps.png", "html": out / "grasps.html"}
    paths["json"].write_text(json.dumps(meta, indent=1))
    if points is None:
        points = volume.point_cloud().cpu().numpy()
    shown = grasps[:DRAWN]
    poses = np.array([g.pose for g in shown]).reshape(-1, 4, 4)
    scores = np.array([g.score for g in shown])
    title = f"{len(grasps)} grasps ({representation or planner.name}, {planner.gripper.name})"
    best = 0 if grasps else None
    png = paths["png"]
    save_grasps_png(png, points, poses, scores, planner.gripper, title=title, highlight=best)
    samples = (
        _closing_samples(planner, volume, shown) if isinstance(planner, GraspDetector) else None
    )
    save_grasps_html(paths["html"], points, poses, scores, planner.gripper, samples, title)
    return paths


def _closing_samples(
    detector: GraspDetector, volume: TSDFVolume, grasps: list[Grasp]
) -> dict[int, np.ndarray] | None:
    """Closing-axis samples (SAMPLES, 3) of the best `SAMPLED` grasps' voxels."""
    if not detector.representation.has_distribution or not grasps:
        return None
    rotation = detector.predict(volume.grid())["rotation"]
    voxels = [g.voxel for g in grasps[:SAMPLED]]
    pred = torch.stack([rotation[v] for v in voxels]).double()
    generator = torch.Generator(pred.device).manual_seed(detector.seed)
    samples = detector.representation.sample(pred, SAMPLES, generator)[..., 2]
    return {i: s.cpu().numpy() for i, s in enumerate(samples)}


def save_png_depth(path: str | Path, depth: np.ndarray, png_scale: float = 0.001) -> Path:
    """Write a depth image [m] as a 16-bit PNG of ``depth / png_scale`` (for tests and users)."""
    values = np.clip(np.round(np.nan_to_num(depth) / png_scale), 0, 65535).astype(np.uint16)
    Image.fromarray(values).save(path)
    return Path(path)
