"""Depth noise in the training data (`SceneConfig.noise`, ``symgrasp data generate --noise``):
"none" is today's scene to the byte; "dex" is the benchmark's noise on the image the TSDF is
fused from, drawn from the scene alone, and leaves the labels as they were."""

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
from symgrasp.perception import CameraIntrinsic, TSDFVolume, add_depth_noise, noisy_depth
from symgrasp.sim import FRANKA
from symgrasp.workspace import RESOLUTION

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
    without noise and with dex noise."""
    cfg = SceneConfig(object_set="blocks", gripper="franka", pool_size=2,
                      database=DatabaseConfig(grasps=40, directions=8))  # fmt: skip
    pool = scene_pool(cfg)
    databases = [
        build_database(o, FRANKA, cfg.database, seed=k) for k, o in enumerate(pool.objects)
    ]
    dex = dataclasses.replace(cfg, noise="dex")
    records = {
        (noise, i): make_scene_record(i, c, FRANKA, pool, databases, seed=3)
        for noise, c in (("none", cfg), ("dex", dex))
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


def test_dex_changes_the_image_and_the_tsdf_not_the_labels(tiny):
    for i in (0, 1):
        clean, noisy = tiny["none", i], tiny["dex", i]
        changed = {k for k in clean if not np.array_equal(clean[k], noisy[k])}
        assert changed == {"tsdf", "depth"}  # objects, grasps, labels, camera: the same
        assert np.abs(noisy["tsdf"].astype(float) - clean["tsdf"].astype(float)).mean() > 0.01


def test_the_stored_depth_is_the_benchmarks_noise_and_what_the_tsdf_was_fused_from(tiny):
    for i in (0, 1):
        clean, noisy = tiny["none", i], tiny["dex", i]
        # the benchmark's function on the clean image, from the scene's own seed (the clean
        # image is stored rounded to 0.1 mm: the noisy one agrees to that rounding)
        expected = add_depth_noise(clean["depth"] * DEPTH_UNIT, noise_seed(3, i))
        assert np.abs(noisy["depth"] * DEPTH_UNIT - expected).max() < 1.5 * DEPTH_UNIT
        assert np.array_equal(noisy["depth"] == 0, clean["depth"] == 0)  # holes stay holes
        w, h, fx, fy, cx, cy = noisy["intrinsic"]
        volume = TSDFVolume(resolution=RESOLUTION)
        volume.integrate(noisy["depth"] * DEPTH_UNIT, CameraIntrinsic(int(w), int(h), fx, fy,
                         cx, cy), noisy["extrinsic"])  # fmt: skip
        off = np.abs(volume.grid().numpy() - noisy["tsdf"].astype(np.float32))
        # float16 storage; the 0.1 mm rounding moves a few voxels across the band's far edge
        # (observed at −1, or unobserved at 1)
        assert np.median(off) < 1e-3 and (off > 0.01).mean() < 5e-4


def test_each_scene_draws_its_own_noise_from_its_seed(tiny):
    """The whole-image scale factor, read back as the median ratio of noisy to clean depth,
    is the first draw of the scene's noise stream and differs between scenes."""
    factors = []
    for i in (0, 1):
        clean, noisy = (tiny[n, i]["depth"].astype(float) for n in ("none", "dex"))
        seen = clean > 0
        first = np.random.default_rng(noise_seed(3, i)).gamma(1000.0, 1e-3)
        ratio = np.median(noisy[seen] / clean[seen])
        assert ratio == pytest.approx(first, abs=2e-3)  # the field's share is 5 mm at most 1 %
        factors.append(first)
    assert abs(factors[0] - factors[1]) > 1e-4
    assert noise_seed(3, 0) != noise_seed(3, 1) != noise_seed(4, 1)


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
    del config["noise"]  # a dataset made before the option
    assert config_from_dict(config).noise == "none"
    main(["data", "inspect", str(plain), "--validate", "0"])
    assert json.loads((plain / "card.json").read_text())["noise"] == "none"
