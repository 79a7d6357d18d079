"""Grasp databases: antipodal geometry, settled widths, friction-limited rejection forces."""

import dataclasses

import numpy as np
import pytest

from symgrasp.data.grasp_db import (
    GRAVITY,
    DatabaseConfig,
    GraspDatabase,
    antipodal_pairs,
    build_database,
    cached_database,
)
from symgrasp.sim import get_gripper
from symgrasp.sim.objects import ObjectSpec, Part

HALF = (0.02, 0.03, 0.045)  # 4 × 6 × 9 cm: only the 4 and 6 cm sides fit the 8 cm Franka
FRICTION = 0.5
MASS = 0.2
SQUEEZE = 70.0  # Franka, per pad (docs/sim.md)
CFG = DatabaseConfig(grasps=6, max_candidates=40, surface_points=400, directions=16)


def _box() -> ObjectSpec:
    return ObjectSpec("box", "box", (Part("box", HALF, (0, 0, HALF[2])),), MASS, FRICTION)


@pytest.fixture(scope="module")
def database() -> GraspDatabase:
    return build_database(_box(), "franka", CFG, seed=3)


def test_antipodal_pairs_of_a_box_cross_opposite_faces_within_the_friction_cone():
    mid, line = antipodal_pairs(_box(), 0.08, 400, np.random.default_rng(0))
    assert len(mid) > 50
    axis = np.argmax(np.abs(line), axis=1)
    assert set(axis.tolist()) <= {0, 1}  # the 9 cm side is wider than the hand
    assert np.all(np.abs(line[np.arange(len(line)), axis]) > np.cos(np.arctan(FRICTION)))
    assert np.all(np.abs(mid - [0, 0, HALF[2]]) <= np.array(HALF) + 1e-9)


def test_settled_grasps_hold_the_box_across_one_of_its_sides(database):
    held = database.held
    assert held.sum() >= CFG.grasps
    R = database.T_object_tcp[held, :3, :3]
    closing = np.abs(R[:, :, 2])  # closing axis in the object frame
    side = 2 * np.array(HALF)[np.argmax(closing, axis=1)]
    assert np.all(np.isin(np.argmax(closing, axis=1), [0, 1]))
    assert np.allclose(database.width[held], side, atol=0.005)
    assert np.all(database.contact_force[held] > SQUEEZE)  # both pads press


def test_rejection_force_out_of_the_hand_is_friction_limited(database):
    """Pulling the box out along the approach is resisted by pad friction only: at most
    2 μ × squeeze (MuJoCo uses the pair's larger μ: the box's 0.5, fingers 0.1)."""
    bound = 2 * FRICTION * SQUEEZE
    out = []
    for T, force in zip(
        database.T_object_tcp[database.held], database.resisted_force[database.held], strict=True
    ):
        e_x, e_z = T[:3, 0], T[:3, 2]
        # directions that pull the object back out of the hand (−e_x), across the pads
        pulling = (database.directions @ -e_x > 0.8) & (np.abs(database.directions @ e_z) < 0.3)
        out.extend(force[pulling])
    assert len(out) > 0
    out = np.array(out)
    assert np.all(out < 1.3 * bound)
    assert np.median(out) > 0.4 * bound
    assert np.all(out < CFG.score_clip * MASS * GRAVITY)  # not clipped: the bound was measured


def test_score_is_the_clipped_force_in_units_of_weight(database):
    expected = (
        np.minimum(database.resisted_force / (MASS * GRAVITY), CFG.score_clip) / CFG.score_clip
    )
    assert np.allclose(database.score, expected)
    assert np.all((database.score >= 0) & (database.score <= 1))


def test_same_seed_same_database_and_the_cache_is_keyed_by_object(database, tmp_path):
    again = build_database(_box(), "franka", CFG, seed=3)
    for field in dataclasses.fields(GraspDatabase):
        assert np.array_equal(getattr(again, field.name), getattr(database, field.name))
    cached_database(_box(), "franka", tmp_path, CFG, seed=3)
    assert len(list(tmp_path.glob("*.npz"))) == 1
    loaded = cached_database(_box(), "franka", tmp_path, CFG, seed=3)  # from disk
    assert np.array_equal(loaded.T_object_tcp, database.T_object_tcp)
    heavier = dataclasses.replace(_box(), mass=0.3)
    small = dataclasses.replace(CFG, grasps=1, max_candidates=5)
    cached_database(heavier, "franka", tmp_path, small, seed=3)
    assert len(list(tmp_path.glob("*.npz"))) == 2


def test_bad_gripper_lists_the_known_ones():
    with pytest.raises(ValueError, match="franka"):
        build_database(_box(), "shadow-hand", CFG)
    assert get_gripper("franka").max_width == 0.08
