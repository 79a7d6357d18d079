"""`validate_labels` and the card's ``label_validation`` on tiny datasets without and with a
label spread: what each trial executes (the grasps stubbed out: an oracle on the poses),
which trials count as added voxels, the rates and intervals, and one real physics run."""

import json
import shutil
from types import SimpleNamespace

import numpy as np
import pytest

import symgrasp.data.validate as validate
from symgrasp.config import DatabaseConfig, SceneConfig
from symgrasp.data.card import VALIDATION_NOTE, dataset_card
from symgrasp.data.dataset import load_scene, scene_path
from symgrasp.data.generate import generate
from symgrasp.objects.folder import MissingData
from symgrasp.rates import Z95
from symgrasp.sim import FRANKA
from symgrasp.workspace import VOXEL_SIZE

V = VOXEL_SIZE
SCENES = 3


@pytest.fixture(scope="module")
def datasets(tmp_path_factory):
    """Two tiny datasets of the same scenes: labels as the grasps' voxels, and spread."""
    root = tmp_path_factory.mktemp("validate")
    cfg = SceneConfig(object_set="blocks", gripper="franka", pool_size=2,
                      database=DatabaseConfig(grasps=40, directions=8))  # fmt: skip
    generate(root / "plain", cfg, SCENES)
    shutil.copytree(root / "plain" / "db", root / "spread" / "db")  # the databases reused
    spread = SceneConfig(**{**cfg.__dict__, "label_spread": (V, 2 * V, V, V)})
    generate(root / "spread", spread, SCENES)
    return {"plain": (root / "plain", cfg), "spread": (root / "spread", spread)}


def stub_trials(monkeypatch, held):
    """Replace the physics: each world is its scene's object poses, each trial's pose is
    recorded, and it holds when ``held(pose, call)`` (call: 0, 1, … in order)."""
    calls = []

    def execute(world, pose):
        calls.append((world.poses, pose))
        return SimpleNamespace(success=held(pose, len(calls) - 1))

    monkeypatch.setattr(
        validate, "World", lambda objects, poses, gripper: SimpleNamespace(poses=poses)
    )
    monkeypatch.setattr(validate, "execute_grasp", execute)
    return calls


def in_box(points, centre):
    """Which of ``points`` (N, 3) lie in the voxel whose centre is ``centre`` (3,)."""
    return np.all(np.abs(points - centre) <= V / 2 + 1e-9, axis=-1)


@pytest.mark.parametrize("name", ["plain", "spread"])
def test_every_trial_runs_a_labelled_voxels_grasp_at_its_centre(datasets, monkeypatch, name):
    root, cfg = datasets[name]
    records = [load_scene(scene_path(root, i)) for i in range(SCENES)]

    def is_added(poses, pose):
        record = next(r for r in records if np.array_equal(r["object_poses"], poses))
        return not in_box(record["grasp_pose"][:, :3, 3], pose[:3, 3]).any()

    # a labelled grasp holds when its voxel holds no stored grasp's TCP; a random one never
    calls = stub_trials(monkeypatch, lambda pose, call: call % 2 == 0 and is_added(*calls[call]))
    trials = 60
    result = validate.validate_labels(root, cfg, FRANKA, list(range(SCENES)), trials, seed=1)
    assert result.trials == trials and len(calls) == 2 * trials  # labelled, random, …
    seen = np.zeros(SCENES)
    added = 0
    for poses, T in calls[::2]:
        k = next(k for k, r in enumerate(records) if np.array_equal(r["object_poses"], poses))
        r = records[k]
        seen[k] += 1
        centres = (r["voxel_index"] + 0.5) * V
        v = np.flatnonzero(np.all(np.abs(centres - T[:3, 3]) < 1e-9, axis=1))
        assert len(v) == 1  # the TCP is a labelled voxel's centre
        targets = r["voxel_rotations"][v[0]][r["voxel_rotation_mask"][v[0]]]
        assert np.abs(targets - T[:3, :3]).max(axis=(1, 2)).min() < 1e-6  # one of its targets
        added += not in_box(r["grasp_pose"][:, :3, 3], T[:3, 3]).any()
    assert result.added_trials == added
    assert result.labelled_success == pytest.approx(added / trials)
    assert result.random_success == 0.0
    assert result.random_ci95 == pytest.approx((0.0, Z95**2 / (trials + Z95**2)))
    if name == "plain":  # every voxel holds its grasp's TCP
        assert added == 0 and result.added_success is None and result.added_ci95 is None
    else:
        assert added > trials / 2  # a spread of this size adds most of the voxels
        assert result.added_success == 1.0
        assert result.added_ci95 == pytest.approx((added / (added + Z95**2), 1.0))
    # voxels drawn uniformly over all the dataset's: scenes in proportion to their voxels
    share = np.array([len(r["voxel_index"]) for r in records], dtype=float)
    assert np.abs(seen / trials - share / share.sum()).max() < 0.2


def test_the_card_reports_real_trials_of_the_spread_labels(datasets):
    root, _ = datasets["spread"]
    card = dataset_card(root, validate=2)
    saved = json.loads((root / "card.json").read_text())["label_validation"]
    assert saved == json.loads(json.dumps(card["label_validation"]))
    assert saved["trials"] == 2 and saved["about"] == VALIDATION_NOTE
    assert 0 <= saved["labelled_success"] <= 1 and 0 <= saved["random_success"] <= 1
    lo, hi = saved["labelled_ci95"]
    assert 0 <= lo <= saved["labelled_success"] <= hi <= 1
    assert 0 <= saved["added_trials"] <= 2


def test_the_cards_label_coverage_adds_up_to_the_scenes_survival(datasets, monkeypatch):
    """Per family, the placements add up to the objects the scenes hold, and with databases of
    equal size the placement-weighted kept share is the card's grasp survival rate, which is
    computed from the scenes' own grasp totals."""
    root, cfg = datasets["plain"]
    card = dataset_card(root)
    families = card["label_coverage"]["families"]
    placements = np.array([c["placements"] for c in families.values()])
    shares = np.array([c["kept_share"] for c in families.values()])
    assert placements.sum() == round(card["mean_per_scene"]["objects"] * card["scenes"])
    assert ((shares >= 0) & (shares <= 1)).all() and list(shares) == sorted(shares)
    totals = [int(load_scene(scene_path(root, i))["grasps_total"]) for i in range(SCENES)]
    objects = [len(load_scene(scene_path(root, i))["object_pool_index"]) for i in range(SCENES)]
    assert all(t == cfg.database.grasps * n for t, n in zip(totals, objects, strict=True))
    assert placements @ shares / placements.sum() == pytest.approx(card["grasp_survival_rate"])

    def missing(cfg):
        raise MissingData("the object set blocks is not in the data folder")

    monkeypatch.setattr("symgrasp.data.card.scene_pool", missing)
    assert dataset_card(root)["label_coverage"]["unavailable"] == (
        "the object set blocks is not in the data folder"
    )
