"""Grasp databases: antipodal geometry, settled widths, friction-limited rejection forces."""

import dataclasses

import numpy as np
import pytest

from symgrasp.data import grasp_db
from symgrasp.data.directions import interpolation_support
from symgrasp.data.grasp_db import (
    GRAVITY,
    DatabaseConfig,
    GraspDatabase,
    OnDemandDatabase,
    antipodal_pairs,
    build_database,
    cached_database,
    randomised_frames,
    rejection_score,
    side_normals,
)
from symgrasp.objects.folder import DATA_ENV
from symgrasp.objects.sets import resolve
from symgrasp.sim import FRANKA, get_gripper
from symgrasp.sim.execute import stepwise_pull_out_forces
from symgrasp.sim.objects import ObjectSpec, Part, surface_samples

HALF = (0.02, 0.03, 0.045)  # 4 × 6 × 9 cm: only the 4 and 6 cm sides fit the 8 cm Franka
FRICTION = 0.5
MASS = 0.2
SQUEEZE = 70.0  # Franka, per pad (docs/sim.md)
CFG = DatabaseConfig(grasps=6, max_candidates=40, surface_points=400, directions=16)


def _box() -> ObjectSpec:
    return ObjectSpec("box", "box", (Part("box", HALF, (0, 0, HALF[2])),), MASS, FRICTION)


@pytest.fixture(scope="module")
def database() -> GraspDatabase:
    return build_database(_box(), FRANKA, CFG, seed=3)


def test_antipodal_pairs_of_a_box_cross_opposite_faces_within_the_friction_cone():
    rng = np.random.default_rng(0)
    points, normals = surface_samples(_box(), 400, rng)
    mid, line = antipodal_pairs(points, normals, FRICTION, 0.08, rng)
    assert len(mid) > 50
    axis = np.argmax(np.abs(line), axis=1)
    assert set(axis.tolist()) <= {0, 1}  # the 9 cm side is wider than the hand
    assert np.all(np.abs(line[np.arange(len(line)), axis]) > np.cos(np.arctan(FRICTION)))
    assert np.all(np.abs(mid - [0, 0, HALF[2]]) <= np.array(HALF) + 1e-9)


def test_approach_enters_through_the_nearest_side_within_the_cone():
    """Closing across x (4 cm), the box's sides are its ±y (6 cm) and ±z (9 cm) faces; a
    midpoint 1 cm below the top face is entered from the top (e_x = −z), one 0.5 cm from the
    +y face from there (e_x = −y), up to the approach cone."""
    rng = np.random.default_rng(1)
    points, normals = surface_samples(_box(), 4000, rng)
    mid = np.array([[0.0, 0.0, 2 * HALF[2] - 0.01], [0.0, HALF[1] - 0.005, HALF[2]]])
    line = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    outward = side_normals(mid, line, points, normals)
    assert np.allclose(outward, [[0, 0, 1], [0, 1, 0]], atol=1e-6)
    cfg = dataclasses.replace(CFG, tilt=0.0, offset=(0.0, 0.0))
    frames = randomised_frames(
        np.repeat(mid, 500, 0), np.repeat(line, 500, 0), np.repeat(outward, 500, 0), cfg, rng
    )
    e_x, e_z = frames[:, :3, 0], frames[:, :3, 2]
    cos_in = np.einsum("ij,ij->i", e_x, -np.repeat(outward, 500, 0))
    assert np.all(cos_in >= np.cos(cfg.approach_cone) - 1e-9)
    assert cos_in.min() < np.cos(0.8 * cfg.approach_cone)  # the cone is used, not just its axis
    assert np.allclose(np.abs(e_z[:, 0]), 1.0)  # closing stays on the contact line (tilt 0)
    assert np.allclose(np.linalg.det(frames[:, :3, :3]), 1.0)


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
    2 μ × squeeze (MuJoCo uses the pair's larger μ: the box's 0.5, fingers 0.1), plus what the
    ramp adds while the box slides to the slip distance: a net force rising at rate r moves a
    mass m by r t³ / 6m, so it has grown by r (6 m slip / r)^(1/3) when the ramp stops."""
    bound = 2 * FRICTION * SQUEEZE
    rate = CFG.score_clip * MASS * GRAVITY / CFG.ramp_time
    overshoot = rate * (6 * MASS * CFG.slip / rate) ** (1 / 3)
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
    assert np.all(out < 1.05 * (bound + overshoot))  # 5 %: soft contacts
    assert np.median(out) > 0.4 * bound
    assert np.all(out < CFG.score_clip * MASS * GRAVITY)  # not clipped: the bound was measured


def test_score_is_the_log_of_the_clipped_force_in_units_of_weight(database):
    weights = np.minimum(database.resisted_force / (MASS * GRAVITY), CFG.score_clip)
    assert np.allclose(database.score, np.log1p(weights) / np.log1p(CFG.score_clip))
    assert np.all((database.score >= 0) & (database.score <= 1))
    weight = MASS * GRAVITY
    assert rejection_score(np.array([0.0, 1e9]), weight, 200.0).tolist() == [0.0, 1.0]
    assert rejection_score(np.array([3 * weight]), weight, 200.0)[0] == pytest.approx(
        np.log(4) / np.log(201)
    )


def test_same_seed_same_database_and_the_cache_is_keyed_by_object(database, tmp_path):
    again = build_database(_box(), FRANKA, CFG, seed=3)
    for field in dataclasses.fields(GraspDatabase):
        assert np.array_equal(getattr(again, field.name), getattr(database, field.name))
    cached_database(_box(), FRANKA, tmp_path, CFG, seed=3)
    assert len(list(tmp_path.glob("*.npz"))) == 1
    loaded = cached_database(_box(), FRANKA, tmp_path, CFG, seed=3)  # from disk
    assert np.array_equal(loaded.T_object_tcp, database.T_object_tcp)
    heavier = dataclasses.replace(_box(), mass=0.3)
    small = dataclasses.replace(CFG, grasps=1, max_candidates=5)
    cached_database(heavier, FRANKA, tmp_path, small, seed=3)
    assert len(list(tmp_path.glob("*.npz"))) == 2


def _assert_same(a: GraspDatabase, b: GraspDatabase) -> None:
    for field in dataclasses.fields(GraspDatabase):
        assert np.array_equal(getattr(a, field.name), getattr(b, field.name)), field.name


def test_the_database_is_the_one_of_ramps_stepped_through_the_world(database, monkeypatch):
    """The fast ramps change no bit of a database, so a cached one (its key unchanged) is
    what this code builds."""
    monkeypatch.setattr(grasp_db, "pull_out_forces", stepwise_pull_out_forces)
    _assert_same(build_database(_box(), FRANKA, CFG, seed=3), database)


def test_scores_measured_on_demand_in_any_order_are_the_databases(database):
    """Each score measured alone, in a shuffled order of (grasp, direction), equals the whole
    database's (ramps measured grasp by grasp): a ramp depends on nothing measured before."""
    lazy = OnDemandDatabase(_box(), FRANKA, CFG, seed=3)
    held = np.flatnonzero(lazy.held)
    assert np.isnan(lazy.score[held]).all() and not np.isnan(lazy.score[~lazy.held]).any()
    pairs = [(g, k) for g in held for k in range(CFG.directions)]
    for i in np.random.default_rng(0).permutation(len(pairs)):
        lazy.measure(*pairs[i])
    for field in ("T_object_tcp", "width", "contact_force", "held", "resisted_force", "score"):
        assert np.array_equal(getattr(lazy, field), getattr(database, field)), field


def test_score_along_measures_only_the_rows_and_directions_it_reads(database):
    lazy = OnDemandDatabase(_box(), FRANKA, CFG, seed=3)
    up = np.array([0.3, -0.2, 1.0])  # between directions: three are read
    rows = np.array([0, 2])
    along = lazy.score_along(up, rows)
    expected = database.score_along(up)
    assert np.array_equal(along[rows], expected[rows])
    assert np.isnan(np.delete(along, rows)).all()
    measured = ~np.isnan(lazy.score[lazy.held])
    assert measured.sum() == 3 * len(rows)
    assert set(np.flatnonzero(measured.any(axis=0))) == set(
        interpolation_support(lazy.directions, up)
    )
    on_one = lazy.directions[5]  # on a stored direction: that one alone
    assert np.array_equal(lazy.score_along(on_one, rows)[rows], database.score[lazy.held][rows, 5])


@pytest.mark.parametrize("gripper", ["franka", "robotiq-2f85"])
def test_so_is_a_database_on_a_vgn_mesh(gripper, vgn_data, monkeypatch):
    monkeypatch.setenv(DATA_ENV, str(vgn_data))
    obj = resolve("vgn-pile-train,vgn-packed-train").pool(2, 0)[1]
    assert len(obj.parts) == 3  # a mesh of several convex parts
    hand, cfg = get_gripper(gripper), DatabaseConfig(grasps=3, surface_points=400, directions=8)
    fast = build_database(obj, hand, cfg, seed=1)
    lazy = OnDemandDatabase(obj, hand, cfg, seed=1)
    for k in (5, 0, 7, 2, 1, 6, 3, 4):  # direction by direction, out of order
        lazy.measure(np.flatnonzero(lazy.held)[::-1], [k])
    assert np.array_equal(lazy.score, fast.score)
    monkeypatch.setattr(grasp_db, "pull_out_forces", stepwise_pull_out_forces)
    _assert_same(build_database(obj, hand, cfg, seed=1), fast)
    assert fast.held.sum() == 3 and 0 < fast.score[fast.held].mean() < 1


def test_bad_gripper_lists_the_known_ones():
    with pytest.raises(
        ValueError, match=r"franka, robotiq-2f85 or a \.toml spec file, got 'shadow"
    ):
        get_gripper("shadow-hand")
    assert get_gripper("franka").max_width == 0.08
