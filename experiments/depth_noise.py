"""Depth noise in the training data (``symgrasp data generate --noise dex``): its cost, what it
does to the TSDF, whether the loader could add it instead, and where the benchmark's views lie
against the training cameras → experiments/results/depth_noise.{json,md}.

    OMP_NUM_THREADS=1 PYTHONPATH=src python experiments/depth_noise.py [--scenes 20]
        [--pool-size 4] [--quick [DIR]]

1. **Cost and effect.** Scenes 0 … ``--scenes`` − 1 of the default `SceneConfig`
   (household-train, Robotiq 2F-85, a pool of ``--pool-size`` objects, the default databases,
   built once and cached under ``--cache``), each made with ``noise`` none and dex in turn
   (which goes first alternates; one scene made before as a warm-up), in one process on one
   thread (`make_scene_record` and the compressed file, what a worker of ``data generate``
   runs): seconds per scene, the scene files' sizes (and what they would be were the noisy
   image stored in place of the rendered one), and the change of the TSDF over the
   voxels either image observed (weight > 0): mean |ΔTSDF|, the share whose sign flips, both
   also in the clean TSDF's truncation band (|TSDF| < 1), and the whole image's scale factor.
2. **Load time.** A scene file stores the rendered depth image (0.1 mm steps, before any
   noise), its intrinsic and its camera, so a loader could add the noise and fuse again.
   Equivalence: the noisy image drawn from the stored one (the scene's own draws), fused,
   against the TSDF ``--noise dex`` stored; cost: reading a training item today against reading the image too,
   the noise and the fusion.
3. **Views.** Each benchmark view's cameras (`symgrasp.benchmark.sensing.Sensor`, VGN's circle
   of 6) against the training cameras (`random_camera`, default `SceneConfig`): distance of the
   eye to the workspace centre, its angle from the vertical through the centre, the angle
   between the optical axis and the line to the centre (0 for every training camera), and the
   share of the workspace's voxel centres above the table inside the image (and of those in
   the 10 cm above the table, where the objects lie); the training cameras' shares over
   10 000 draws.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import time
from pathlib import Path

import numpy as np
import torch
from scripts import best_seconds, command_line, parse_args, run_main, write_result

from symgrasp.benchmark.sensing import Sensor
from symgrasp.config import SceneConfig
from symgrasp.data.dataset import ITEM_KEYS, load_scene, make_item
from symgrasp.data.grasp_db import build_database, database_path, read_cached
from symgrasp.data.scenes import (
    DEPTH_UNIT,
    make_scene_record,
    noise_seed,
    random_camera,
    scene_pool,
)
from symgrasp.perception import CameraIntrinsic, TSDFVolume, add_depth_noise, noisy_depth
from symgrasp.sim.grippers import get_gripper
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE, WORKSPACE_SIZE

BOOTSTRAP = 2000
TRAINING_DRAWS = 10_000
VIEWS = (("fixed", 1), ("side", 1), ("circle", 6), ("random", 6))
LAYER = 0.10
"""[m] The layer above the table the objects of a scene lie in."""


def interval(values: np.ndarray, seed: int = 0) -> list[float]:
    """The mean of ``values`` (one per scene) and its 95 % bootstrap interval over scenes."""
    values = np.asarray(values, dtype=float)
    index = np.random.default_rng(seed).integers(len(values), size=(BOOTSTRAP, len(values)))
    low, high = np.percentile(values[index].mean(axis=1), [2.5, 97.5])
    return [float(values.mean()), float(low), float(high)]


def compressed(record: dict[str, np.ndarray]) -> bytes:
    """``record`` as the bytes of its scene file (what ``data generate``'s worker returns)."""
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **record)
    return buffer.getvalue()


def fuse(depth: np.ndarray, record: dict[str, np.ndarray]) -> TSDFVolume:
    """``depth`` [m] fused from ``record``'s camera."""
    w, h, fx, fy, cx, cy = record["intrinsic"]
    volume = TSDFVolume(resolution=RESOLUTION)
    volume.integrate(depth, CameraIntrinsic(int(w), int(h), fx, fy, cx, cy), record["extrinsic"])
    return volume


def databases(cfg: SceneConfig, hand, pool, cache: Path) -> list:
    """The pool's databases, read from ``cache`` or built and written there."""
    found = []
    for k, obj in enumerate(pool.objects):
        path = database_path(cache, obj, hand, cfg.database, k)
        db = read_cached(path)
        if db is None:
            db = build_database(obj, hand, cfg.database, seed=k)
            db.save(path)
        found.append(db)
    return found


def tsdf_change(clean: dict, noisy: dict, image: np.ndarray) -> dict[str, float]:
    """How the dex scene's TSDF differs from the clean one's (module docstring, 1); ``image``:
    the noisy image [m] it was fused from."""
    a, b = clean["tsdf"].astype(np.float32), noisy["tsdf"].astype(np.float32)
    seen = (fuse(clean["depth"] * DEPTH_UNIT, clean).weight > 0).numpy()
    seen |= (fuse(image, noisy).weight > 0).numpy()
    band = seen & (np.abs(a) < 1)
    flips = np.sign(a) != np.sign(b)
    pixels = clean["depth"] > 0
    return {
        "observed_voxels": int(seen.sum()),
        "mean_abs_change": float(np.abs(a - b)[seen].mean()),
        "sign_flips": float(flips[seen].mean()),
        "band_voxels": int(band.sum()),
        "band_mean_abs_change": float(np.abs(a - b)[band].mean()),
        "band_sign_flips": float(flips[band].mean()),
        "scale_factor": float(np.median(image[pixels] / (clean["depth"][pixels] * DEPTH_UNIT))),
    }


def load_time(clean: dict, noisy: dict, image: np.ndarray, folder: Path) -> dict:
    """The load-time path against the stored dex TSDF, and its costs (module docstring, 2);
    ``image``: the noisy image [m] drawn from the stored clean one, as a loader would."""
    off = np.abs(fuse(image, clean).grid().numpy() - noisy["tsdf"].astype(np.float32))
    path = folder / f"scene_{int(clean['scene_id']):06d}.npz"
    path.write_bytes(compressed(clean))

    def item() -> None:
        r = load_scene(path, ITEM_KEYS)
        make_item(r["tsdf"], r["voxel_index"], r["voxel_score"], r["voxel_rotations"],
                  r["voxel_rotation_mask"], r["voxel_width"])  # fmt: skip

    stored = clean["depth"] * DEPTH_UNIT
    return {
        "voxels_off_by_more_than_0.01": int((off > 0.01).sum()),
        "median_abs_difference": float(np.median(off)),
        "max_abs_difference_elsewhere": float(off[off <= 0.01].max()),
        "ms_item_today": 1e3 * best_seconds(item, 5),
        "ms_read_image": 1e3
        * best_seconds(lambda: load_scene(path, ("depth", "intrinsic", "extrinsic")), 5),
        "ms_noise_with_field": 1e3
        * best_seconds(lambda: add_depth_noise(stored, 0, field_probability=1.0), 5),
        "ms_fuse": 1e3 * best_seconds(lambda: fuse(image, clean).grid(), 5),
    }


def view_geometry(T: np.ndarray, intrinsic: CameraIntrinsic, centres: np.ndarray) -> dict:
    """Where camera ``T`` (``T_world_camera``) sits against the workspace centre, and the share
    of ``centres`` (N, 3) its image holds, and of those within `LAYER` of the table (module
    docstring, 3)."""
    centre = np.full(3, WORKSPACE_SIZE / 2)
    eye, axis = T[:3, 3], T[:3, 2]
    offset = eye - centre
    distance = float(np.linalg.norm(offset))
    to_centre = -offset / distance
    local = (centres - eye) @ T[:3, :3]
    z = local[:, 2]
    u = intrinsic.fx * local[:, 0] / z + intrinsic.cx
    v = intrinsic.fy * local[:, 1] / z + intrinsic.cy
    inside = (z > 0) & (u >= -0.5) & (u < intrinsic.width - 0.5)
    inside &= (v >= -0.5) & (v < intrinsic.height - 0.5)
    return {
        "distance_m": distance,
        "polar_deg": float(np.degrees(np.arccos(offset[2] / distance))),
        "off_axis_deg": float(np.degrees(np.arccos(np.clip(axis @ to_centre, -1, 1)))),
        "in_image": float(inside.mean()),
        "layer_in_image": float(inside[centres[:, 2] < TABLE_HEIGHT + LAYER].mean()),
    }


def views() -> dict:
    """The benchmark's views and the training cameras (module docstring, 3)."""
    intrinsic = CameraIntrinsic()
    index = np.stack(np.meshgrid(*[np.arange(RESOLUTION)] * 3, indexing="ij"), -1).reshape(-1, 3)
    centres = (index + 0.5) * VOXEL_SIZE
    centres = centres[centres[:, 2] >= TABLE_HEIGHT]
    training = SceneConfig()
    drawn = [
        view_geometry(random_camera(training, np.random.default_rng(i)), intrinsic, centres)
        for i in range(TRAINING_DRAWS)
    ]
    shares = np.array([d["in_image"] for d in drawn])
    layer = np.array([d["layer_in_image"] for d in drawn])
    result = {
        "training": {
            "camera_distance_m": list(training.camera_distance),
            "camera_polar_deg": [float(np.degrees(a)) for a in training.camera_polar],
            "off_axis_deg": max(d["off_axis_deg"] for d in drawn),
            "in_image_min_p1_median": [
                float(shares.min()),
                float(np.percentile(shares, 1)),
                float(np.median(shares)),
            ],
            "layer_in_image_min_p1_median": [
                float(layer.min()),
                float(np.percentile(layer, 1)),
                float(np.median(layer)),
            ],
        },
        "benchmark": {},
    }
    for view, n in VIEWS:
        cameras = Sensor(view=view, views=n).cameras(seed=0, attempt=0)
        result["benchmark"][view] = [view_geometry(T, intrinsic, centres) for T in cameras]
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=20, help="scenes (default: 20)")
    parser.add_argument("--pool-size", type=int, default=4, help="objects in the pool (default: 4)")
    parser.add_argument(
        "--cache",
        type=Path,
        default=Path("out/depth_noise/db"),
        help="where the pool's grasp databases are cached (default: out/depth_noise/db)",
    )
    parser.add_argument(
        "--result",
        default="experiments/results/depth_noise",
        metavar="STEM",
        help="where the result goes: STEM.json and STEM.md (default: "
        "experiments/results/depth_noise)",
    )
    args = parse_args(
        parser,
        outputs=("result",),
        quick={"scenes": 2, "pool_size": 1},
        also="databases of 20 grasps and 4 directions",
    )
    torch.set_num_threads(1)
    cfg = SceneConfig(pool_size=args.pool_size)
    if args.quick:
        cfg = dataclasses.replace(
            cfg, database=dataclasses.replace(cfg.database, grasps=20, directions=4)
        )
        args.cache = args.quick / "depth_noise_db"
    dex = dataclasses.replace(cfg, noise="dex")
    hand = get_gripper(cfg.gripper)
    pool = scene_pool(cfg)
    dbs = databases(cfg, hand, pool, args.cache)

    seed, cells = 0, []
    folder = args.cache.parent / "depth_noise_files"
    folder.mkdir(parents=True, exist_ok=True)
    make_scene_record(args.scenes, cfg, hand, pool, dbs, seed)  # warm-up, not timed
    for scene_id in range(args.scenes):
        seconds, records, sizes = {}, {}, {}
        order = (("none", cfg), ("dex", dex))
        for name, c in order if scene_id % 2 == 0 else order[::-1]:  # neither always first
            start = time.perf_counter()
            records[name] = make_scene_record(scene_id, c, hand, pool, dbs, seed)
            sizes[name] = len(compressed(records[name]))  # what a worker returns
            seconds[name] = time.perf_counter() - start
        clean, noisy = records["none"], records["dex"]
        image = noisy_depth(clean["depth"] * DEPTH_UNIT, "dex", noise_seed(seed, scene_id))
        stored = compressed({**noisy, "depth": np.round(image / DEPTH_UNIT).astype(np.uint16)})
        cells.append(
            {
                "scene": scene_id,
                "seconds_none": seconds["none"],
                "seconds_dex": seconds["dex"],
                "kb_none": sizes["none"] / 1e3,
                "kb_dex": sizes["dex"] / 1e3,
                "kb_dex_noisy_image_stored": len(stored) / 1e3,
                **tsdf_change(clean, noisy, image),
                "load_time": load_time(clean, noisy, image, folder),
            }
        )
    column = {k: np.array([c[k] for c in cells]) for k in cells[0] if k != "load_time"}
    load = {k: np.array([c["load_time"][k] for c in cells]) for k in cells[0]["load_time"]}
    summary = {
        "seconds_per_scene_none": interval(column["seconds_none"]),
        "seconds_per_scene_dex": interval(column["seconds_dex"]),
        "seconds_dex_minus_none": interval(column["seconds_dex"] - column["seconds_none"]),
        "kb_per_scene_none": interval(column["kb_none"]),
        "kb_per_scene_dex": interval(column["kb_dex"]),
        "kb_per_scene_dex_noisy_image_stored": interval(column["kb_dex_noisy_image_stored"]),
        **{
            k: interval(column[k])
            for k in ("mean_abs_change", "sign_flips", "band_mean_abs_change", "band_sign_flips")
        },
        "observed_voxels": float(column["observed_voxels"].mean()),
        "band_voxels": float(column["band_voxels"].mean()),
        "scale_factor_sd": float(column["scale_factor"].std()),
        "load_time": {
            "voxels_off_by_more_than_0.01_max": int(load["voxels_off_by_more_than_0.01"].max()),
            "median_abs_difference_max": float(load["median_abs_difference"].max()),
            "max_abs_difference_elsewhere": float(load["max_abs_difference_elsewhere"].max()),
            **{k: float(np.median(load[k])) for k in load if k.startswith("ms_")},
        },
    }
    geometry = views()

    def ci(v: list[float], digits: int = 3) -> str:
        return f"{v[0]:.{digits}f} [{v[1]:.{digits}f}, {v[2]:.{digits}f}]"

    def quantiles(v: list[float]) -> str:
        return f"min {v[0]:.0%}, 1st percentile {v[1]:.0%}, median {v[2]:.0%}"

    lt = summary["load_time"]
    rows = [
        f"{args.scenes} scenes of the default SceneConfig (pool of {args.pool_size}), one thread\n",
        "| quantity | none | dex |",
        "|---|---|---|",
        f"| seconds per scene | {ci(summary['seconds_per_scene_none'])} | "
        f"{ci(summary['seconds_per_scene_dex'])} |",
        f"| dex − none, seconds per scene (paired) | | {ci(summary['seconds_dex_minus_none'])} |",
        f"| scene file [kB] | {ci(summary['kb_per_scene_none'], digits=1)} | "
        f"{ci(summary['kb_per_scene_dex'], digits=1)} |",
        "| scene file [kB] were the noisy image stored in place of the rendered one | | "
        f"{ci(summary['kb_per_scene_dex_noisy_image_stored'], digits=1)} |",
        f"| mean abs TSDF change, observed voxels ({summary['observed_voxels']:.0f}) | | "
        f"{ci(summary['mean_abs_change'])} |",
        f"| share of observed voxels whose sign flips | | {ci(summary['sign_flips'])} |",
        f"| mean abs TSDF change, clean truncation band ({summary['band_voxels']:.0f}) | | "
        f"{ci(summary['band_mean_abs_change'])} |",
        f"| share of band voxels whose sign flips | | {ci(summary['band_sign_flips'])} |",
        f"| SD of the image's scale factor over scenes | | {summary['scale_factor_sd']:.4f} |",
        "",
        "Load time (noise added to the stored rendered image, fused again), against the stored dex "
        f"TSDF: at most {lt['voxels_off_by_more_than_0.01_max']} voxels of 64 000 off by more "
        f"than 0.01, the others within {lt['max_abs_difference_elsewhere']:.4f}; per item "
        f"(median ms): today {lt['ms_item_today']:.1f}, reading the image "
        f"{lt['ms_read_image']:.1f}, noise {lt['ms_noise_with_field']:.1f} (with its field, half "
        f"the draws), fusion {lt['ms_fuse']:.1f}",
        "",
        "| cameras | distance [m] | from vertical [°] | off axis [°] | workspace in image | "
        f"its lowest {LAYER * 100:.0f} cm above the table in image |",
        "|---|---|---|---|---|---|",
    ]
    t = geometry["training"]
    rows.append(
        f"| training | {t['camera_distance_m'][0]:.2f}–{t['camera_distance_m'][1]:.2f} | "
        f"{t['camera_polar_deg'][0]:.1f}–{t['camera_polar_deg'][1]:.1f} | "
        f"{t['off_axis_deg']:.1f} | {quantiles(t['in_image_min_p1_median'])} | "
        f"{quantiles(t['layer_in_image_min_p1_median'])} |"
    )
    for view, cameras in geometry["benchmark"].items():
        c = cameras if view != "random" else cameras[:1]
        for k, cam in enumerate(c):
            name = view if len(c) == 1 else f"{view} {k}"
            rows.append(
                f"| {name} | {cam['distance_m']:.3f} | {cam['polar_deg']:.1f} | "
                f"{cam['off_axis_deg']:.1f} | {cam['in_image']:.0%} | "
                f"{cam['layer_in_image']:.0%} |"
            )
    table = "\n".join(rows) + "\n"
    print(table, end="")
    write_result(
        args.result,
        "depth noise in the training data: cost, TSDF change, load-time equivalence, views",
        command_line("OMP_NUM_THREADS=1 PYTHONPATH=src"),
        cells,
        table,
        summary=summary,
        views=geometry,
    )


if __name__ == "__main__":
    run_main(main)
