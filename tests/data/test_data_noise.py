"""Depth noise in the training data (`SceneConfig.noise`, ``symgrasp data generate --noise``):
"none" is today's scene to the byte; "dex" is the benchmark's noise on the image the TSDF is
fused from, drawn from the scene alone, and leaves the labels as they were; ``--table-scale``
divides that image by the depth scale read off the table before it is fused."""

import dataclasses
import json
import shutil

import numpy as np
import pytest

from symgrasp.cli import main
from symgrasp.config import DatabaseConfig, SceneConfig
from symgrasp.data.generate import config_from_dict
from symgrasp.data.grasp_db import build_database
from symgrasp.data.scenes import DEPTH_UNIT, make_scene_record, noise_seed, scene_pool
from symgrasp.perception import (
    CameraIntrinsic,
    TSDFVolume,
    add_depth_noise,
    noisy_depth,
    table_depth_scale,
)
from symgrasp.sim import FRANKA
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT

TINY = ["--objects", "blocks", "--gripper", "franka", "--pool-size", "2", "--grasps", "40"]
TINY += ["--directions", "8", "--scenes", "3"]


def _generate(out, *extra):
    main(["data", "generate", *TINY, "--out", str(out), *extra])


def _scene_bytes(root):
    return {p.name: p.read_bytes() for p in sorted((root / "scenes").glob("*.npz"))}


def _hash(root):
    return json.loads((root / "manifest.json").read_text())["dataset_hash"]


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    """A dataset generated without the option."""
    root = tmp_path_factory.mktemp("noise") / "plain"
    _generate(root)
    return root


@pytest.fixture(scope="module")
def tiny():
    """A pool of two blocks with small Franka databases, and the records of scenes 0 and 1
    without noise, with dex noise, and with dex noise divided by the table's depth scale."""
    cfg = SceneConfig(object_set="blocks", gripper="franka", pool_size=2,
                      database=DatabaseConfig(grasps=40, directions=8))  # fmt: skip
    pool = scene_pool(cfg)
    databases = [
        build_database(o, FRANKA, cfg.database, seed=k) for k, o in enumerate(pool.objects)
    ]
    dex = dataclasses.replace(cfg, noise="dex")
    table = dataclasses.replace(dex, table_scale=True)
    records = {
        (noise, i): make_scene_record(i, c, FRANKA, pool, databases, seed=3)
        for noise, c in (("none", cfg), ("dex", dex), ("table", table))
        for i in (0, 1)
    }
    return records


def test_noise_none_is_the_scene_made_without_the_option_to_the_byte(plain, tmp_path):
    other = tmp_path / "none"
    shutil.copytree(plain / "db", other / "db")
    _generate(other, "--noise", "none")
    assert _scene_bytes(other) == _scene_bytes(plain) and _hash(other) == _hash(plain)
    depth = np.ones((4, 4), np.float32)
    assert noisy_depth(depth, "none", 0) is depth  # no draw, no copy


def _fused(record, depth):
    """``depth`` [m] fused from ``record``'s camera: the TSDF (40, 40, 40)."""
    w, h, fx, fy, cx, cy = record["intrinsic"]
    volume = TSDFVolume(resolution=RESOLUTION)
    volume.integrate(depth, CameraIntrinsic(int(w), int(h), fx, fy, cx, cy), record["extrinsic"])
    return volume.grid().numpy()


def _off(record, depth):
    """|TSDF of ``depth`` − ``record``'s stored TSDF| (40, 40, 40)."""
    return np.abs(_fused(record, depth) - record["tsdf"].astype(np.float32))


def test_dex_changes_the_tsdf_alone_not_the_labels(tiny):
    for i in (0, 1):
        clean, noisy = tiny["none", i], tiny["dex", i]
        changed = {k for k in clean if not np.array_equal(clean[k], noisy[k])}
        assert changed == {"tsdf"}  # objects, grasps, labels, camera, rendered image: the same
        assert np.abs(noisy["tsdf"].astype(float) - clean["tsdf"].astype(float)).mean() > 0.01


def test_the_tsdf_is_the_benchmarks_noise_on_the_stored_image_from_the_scenes_own_seed(tiny):
    """Fusing `noisy_depth` of the stored (rendered) image, drawn from `noise_seed` of the
    scene, gives the stored TSDF; the other scene's draws, or none, do not."""
    for i in (0, 1):
        clean, noisy = tiny["none", i], tiny["dex", i]
        image = clean["depth"] * DEPTH_UNIT
        same = _off(noisy, noisy_depth(image, "dex", noise_seed(3, i)))
        # float16 storage; the image's 0.1 mm steps move a few voxels across the truncation
        # band's far edge (observed at −1, or unobserved at 1)
        assert np.median(same) < 1e-3 and (same > 0.01).mean() < 5e-4
        assert (_off(clean, image) > 0.01).mean() < 5e-4  # none: the image as rendered
        for other in (noise_seed(3, 1 - i), noise_seed(4, i)):
            assert (_off(noisy, noisy_depth(image, "dex", other)) > 0.01).mean() > 0.05
        assert (_off(noisy, image) > 0.01).mean() > 0.05
        assert np.array_equal(
            add_depth_noise(image, noise_seed(3, i)), noisy_depth(image, "dex", noise_seed(3, i))
        )  # the benchmark's dex model at its defaults


def test_table_scale_fuses_the_noisy_image_over_its_tables_depth_scale(tiny):
    """The same scene as dex but for the TSDF, which is the stored image's noise divided by
    the factor `table_depth_scale` reads off it: not the uncalibrated one."""
    for i in (0, 1):
        noisy, table = tiny["dex", i], tiny["table", i]
        changed = {k for k in noisy if not np.array_equal(noisy[k], table[k])}
        assert changed == {"tsdf"}
        seen = noisy_depth(table["depth"] * DEPTH_UNIT, "dex", noise_seed(3, i))
        w, h, fx, fy, cx, cy = table["intrinsic"]
        intrinsic = CameraIntrinsic(int(w), int(h), fx, fy, cx, cy)
        g = table_depth_scale(seen, intrinsic, table["extrinsic"], TABLE_HEIGHT)
        assert abs(g - 1) > 1e-3  # this scene's draw does scale the image
        same = _off(table, seen / g)
        assert np.median(same) < 1e-3 and (same > 0.01).mean() < 5e-4
        assert (_off(table, seen) > 0.01).mean() > 0.01


def test_table_scale_without_a_noise_is_refused_in_one_line(tmp_path):
    with pytest.raises(ValueError, match="table_scale needs a depth noise"):
        SceneConfig(table_scale=True)
    with pytest.raises(SystemExit) as refused:
        _generate(tmp_path / "t", "--table-scale")
    message = str(refused.value.code)
    assert "table_scale needs a depth noise" in message and "\n" not in message


def test_dex_datasets_are_the_same_bytes_with_two_workers_and_after_resume(plain, tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    for root in (one, two):
        shutil.copytree(plain / "db", root / "db")
    _generate(one, "--noise", "dex")
    _generate(two, "--noise", "dex", "--workers", "2")
    assert _scene_bytes(one) == _scene_bytes(two)
    assert _hash(one) != _hash(plain)
    (two / "scenes" / "scene_000001.npz").unlink()  # interrupted
    _generate(two, "--noise", "dex", "--resume")
    assert _scene_bytes(one) == _scene_bytes(two) and _hash(two) == _hash(one)
    assert json.loads((one / "manifest.json").read_text())["config"]["noise"] == "dex"


def test_resume_with_another_noise_is_refused_in_one_line(plain, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(plain, other)
    with pytest.raises(SystemExit) as refused:
        _generate(other, "--noise", "dex", "--resume")
    message = str(refused.value.code)
    assert "noise: 'none' recorded, 'dex' given" in message and "\n" not in message
    assert _scene_bytes(other) == _scene_bytes(plain)


def test_an_unknown_noise_is_refused_by_name(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["data", "generate", "--out", str(tmp_path / "g"), "--noise", "gaussian"])
    assert "--noise" in capsys.readouterr().err
    with pytest.raises(ValueError, match="noise must be one of"):
        SceneConfig(noise="gaussian")
    with pytest.raises(ValueError, match="noise must be one of"):
        noisy_depth(np.ones((4, 4)), "gaussian", 0)


def test_the_card_shows_the_noise_and_a_manifest_from_before_reads_as_none(plain, tmp_path):
    config = json.loads((plain / "manifest.json").read_text())["config"]
    del config["noise"], config["table_scale"]  # a dataset made before the options
    assert config_from_dict(config).noise == "none"
    assert config_from_dict(config).table_scale is False
    main(["data", "inspect", str(plain), "--validate", "0"])
    card = json.loads((plain / "card.json").read_text())
    assert card["noise"] == "none" and card["table_scale"] is False
