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
            raw = np.load(path)
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
    if raw.ndim != 2:
        raise ValueError(
            f"depth must be one (H, W) or (H, W, 1) image, got shape {raw.shape} from {path}"
        )
    scale = 1.0 if path.suffix == ".npy" else png_scale
    return (raw.astype(np.float64) * scale).astype(np.float32)


def _load_json(path: str | Path, what: str) -> Any:
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ValueError(f"{what}: cannot read JSON from {path}: {error}") from error


def load_intrinsic(path: str | Path, shape: tuple[int, int]) -> CameraIntrinsic:
    """The camera intrinsic of images of ``shape`` (H, W) from a JSON file."""
    data = _load_json(path, "intrinsic")
    try:
        if isinstance(data, dict) and "K" not in data:
            return CameraIntrinsic(
                int(data.get("width", shape[1])),
                int(data.get("height", shape[0])),
                *(float(data[k]) for k in ("fx", "fy", "cx", "cy")),
            )
        K = np.asarray(data["K"] if isinstance(data, dict) else data, dtype=float)
        if K.shape != (3, 3):
            raise ValueError(f"a 3×3 matrix is needed, got shape {K.shape}")
        return CameraIntrinsic(shape[1], shape[0], K[0, 0], K[1, 1], K[0, 2], K[1, 2])
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(
            f'intrinsic {path}: expected {{"fx", "fy", "cx", "cy"[, "width", "height"]}} or a '
            f'3×3 matrix (bare or under "K"); {type(err).__name__}: {err}'
        ) from None


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


def grasp_record(grasp: Grasp) -> dict[str, Any]:
    """A grasp as plain JSON data."""
    return {
        "T_world_tcp": np.round(grasp.pose, 6).tolist(),
        "score": round(grasp.score, 4),
        "validity": None if grasp.validity is None else round(grasp.validity, 4),
        "confidence": None if grasp.confidence is None else round(grasp.confidence, 2),
        "voxel": None if grasp.voxel is None else list(grasp.voxel),
    }


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
        "grasps": [grasp_record(g) for g in grasps],
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
