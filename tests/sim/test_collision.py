"""The swept-hand check tests only the points near each box (a k-d tree): its answer must be the
exact test's over every point, whatever the points' order, and for any number of grasps."""

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from symgrasp.sim import FRANKA, ROBOTIQ_2F85
from symgrasp.sim.collision import (
    ALL_PAIRS,
    BOXES,
    CHUNK,
    SIGNS,
    hand_boxes,
    hand_collides,
    simulated_hand_boxes,
)
from symgrasp.sim.execute import top_grasp
from symgrasp.sim.protocol import PREGRASP_DISTANCE


def _every_point(T, gripper, points, tolerance, sweep):
    """The oracle: every point against each swept box of each grasp, by the segment parameters
    s ∈ [0, sweep] that put it inside the box along each box axis (no search for near points)."""
    boxes = hand_boxes(gripper)
    half = np.maximum(boxes.half - tolerance, 1e-4)
    hit = np.zeros(len(T), dtype=bool)
    for g, pose in enumerate(T):
        p_hand = (points - pose[:3, 3]) @ pose[:3, :3]
        for c, Rb, h in zip(boxes.centre, boxes.rotation, half, strict=True):
            q, u = (p_hand - c) @ Rb, -Rb[0]  # the box moves by s·u in its own frame
            lo, hi = np.zeros(len(q)), np.full(len(q), sweep)
            for a in range(3):
                if abs(u[a]) < 1e-12:
                    hi[np.abs(q[:, a]) >= h[a]] = -1.0
                else:
                    ends = np.sort([(q[:, a] - h[a]) / u[a], (q[:, a] + h[a]) / u[a]], axis=0)
                    lo, hi = np.maximum(lo, ends[0]), np.minimum(hi, ends[1])
            hit[g] |= bool(np.any(lo <= hi))
    return hit


BLOBS = 30
CENTRE = np.array([0.15, 0.15, 1.0])  # [m] high above the table


def _grasps_among_points(gripper, count, seed):
    """``count`` random grasps high above the table among ``BLOBS`` clusters of points (1 cm
    across), placed so that a quarter to a half of the grasps hold a point in a box."""
    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (count, 1, 1))
    T[:, :3, :3] = Rotation.random(count, random_state=seed).as_matrix()
    T[:, :3, 3] = CENTRE + rng.normal(0, 0.2, (count, 3))
    blobs = CENTRE + rng.normal(0, 0.2, (BLOBS, 3))
    points = blobs[rng.integers(BLOBS, size=2000)] + rng.normal(0, 0.01, (2000, 3))
    return T, points.astype(np.float32)


@pytest.mark.parametrize("gripper", [FRANKA, ROBOTIQ_2F85], ids=lambda g: g.name)
@pytest.mark.parametrize(("tolerance", "sweep"), [(0.002, PREGRASP_DISTANCE), (-0.001, 0.0)])
@pytest.mark.parametrize("grasps", [64, 16], ids=["searched", "every-pair"])
def test_the_check_is_the_exact_test_over_every_point(gripper, tolerance, sweep, grasps):
    T, points = _grasps_among_points(gripper, grasps, seed=1)
    assert (len(T) * len(points) > ALL_PAIRS) == (grasps == 64)  # both ways of finding pairs
    expected = _every_point(T, gripper, points.astype(float), tolerance, sweep)
    assert 0.2 < expected.mean() < 0.9  # both answers are exercised
    got = hand_collides(T, gripper, points, tolerance=tolerance, sweep=sweep, table_height=-1)
    assert list(got) == list(expected)


def test_the_answer_does_not_depend_on_the_points_order_or_the_grasps_chunks():
    T, points = _grasps_among_points(ROBOTIQ_2F85, 2 * CHUNK + 7, seed=2)
    whole = hand_collides(T, ROBOTIQ_2F85, points, table_height=-1)
    assert 0.2 < whole.mean() < 0.9
    shuffled = np.random.default_rng(3).permutation(points)
    assert list(hand_collides(T, ROBOTIQ_2F85, shuffled, table_height=-1)) == list(whole)
    one_by_one = [hand_collides(g[None], ROBOTIQ_2F85, points, table_height=-1)[0] for g in T[::9]]
    assert one_by_one == list(whole[::9])


def test_no_grasps_and_no_points():
    T, points = _grasps_among_points(FRANKA, 3, seed=4)
    assert hand_collides(np.zeros((0, 4, 4)), FRANKA, points).shape == (0,)
    assert not hand_collides(T, FRANKA, np.zeros((0, 3)), table_height=-1).any()


def _lowest_corner(T, gripper, grow=0.0):
    """[m] z of the lowest corner, at the grasp or the pre-grasp, of the hand's boxes (grown by
    ``grow``) for each grasp ``T`` (G, 4, 4): the closed form the table rule is read against."""
    boxes = hand_boxes(gripper)
    half = boxes.half + grow
    corners = boxes.centre[:, None] + np.einsum(
        "bij,bcj->bci", boxes.rotation, SIGNS * half[:, None]
    )
    ends = np.concatenate([corners, corners - [PREGRASP_DISTANCE, 0, 0]], axis=1).reshape(-1, 3)
    return (T[:, 2, 3][:, None] + (T[:, 2, :3] @ ends.T)).min(axis=1)


@pytest.mark.parametrize("gripper", [FRANKA, ROBOTIQ_2F85], ids=lambda g: g.name)
def test_a_top_down_grasp_keeps_its_table_clearance_in_closed_form(gripper):
    """Straight down, the boxes' lowest corner is the fingertips' reach r below the TCP: with
    ``table_tolerance`` −c the hand is free exactly from TCP height r + 2c (boxes grown by c,
    kept c above the table); the default rule's +2 mm lets it 4 mm into the table."""
    reach = -_lowest_corner(top_grasp(np.zeros(3))[None], gripper)[0]  # the grasp's own
    table = 0.05
    for tolerance, threshold in ((-0.001, reach + 0.002), (0.002, reach - 0.004)):
        for dz, free in ((-1e-4, False), (1e-4, True)):
            T = top_grasp(np.array([0.1, 0.1, table + threshold + dz]))[None]
            hit = hand_collides(T, gripper, np.zeros((0, 3)), table_tolerance=tolerance)
            assert bool(hit[0]) is not free, (tolerance, dz)


def test_the_table_rule_bounds_how_deep_a_tilted_hand_may_reach():
    """For any rotation, a hand free under ``table_tolerance`` −c keeps its true boxes at least
    2c above the table, and one whose boxes stay (1 + √3)·c above it is free; the default +2 mm
    let tilted boxes sink below the table by more than 2 mm (the rule before 2026-11-27)."""
    c, table = 0.001, 0.05
    rng = np.random.default_rng(5)
    T = np.tile(np.eye(4), (400, 1, 1))
    T[:, :3, :3] = Rotation.random(400, random_state=5).as_matrix()
    T[:, :2, 3] = 0.15
    T[:, 2, 3] = 0.0
    T[:, 2, 3] = table - _lowest_corner(T, ROBOTIQ_2F85) + rng.uniform(-0.006, 0.006, 400)
    lowest = _lowest_corner(T, ROBOTIQ_2F85) - table
    free = ~hand_collides(T, ROBOTIQ_2F85, np.zeros((0, 3)), table_tolerance=-c)
    assert 0.2 < free.mean() < 0.8
    assert np.all(lowest[free] >= 2 * c - 1e-9)
    assert np.all(free[lowest >= (1 + np.sqrt(3)) * c + 1e-9])
    lenient = ~hand_collides(T, ROBOTIQ_2F85, np.zeros((0, 3)))
    assert lowest[lenient].min() < -0.003


def test_the_table_rule_defaults_to_the_points_tolerance():
    T = np.tile(top_grasp(np.array([0.1, 0.1, 0.0])), (41, 1, 1))
    T[:, 2, 3] = np.linspace(0.05, 0.09, 41)
    for tolerance in (0.002, -0.001):
        same = hand_collides(T, ROBOTIQ_2F85, np.zeros((0, 3)), tolerance=tolerance)
        given = hand_collides(
            T, ROBOTIQ_2F85, np.zeros((0, 3)), tolerance=tolerance, table_tolerance=tolerance
        )
        assert list(same) == list(given) and 0 < same.mean() < 1


@pytest.mark.parametrize("gripper", [FRANKA, ROBOTIQ_2F85], ids=lambda g: g.name)
def test_the_stored_boxes_are_the_simulated_hands(gripper):
    """The stored boxes stand for the simulated hand's (its model at the open configuration):
    after a change to a hand, its spec or the code that builds it, `store_hand_boxes` writes
    them again."""
    stored, simulated = hand_boxes(gripper), simulated_hand_boxes(gripper)
    for key in BOXES:
        np.testing.assert_allclose(getattr(stored, key), getattr(simulated, key), rtol=0,
                                   atol=1e-12, err_msg=f"{gripper.name} {key}: run "
                                   "symgrasp.sim.collision.store_hand_boxes()")  # fmt: skip


def test_a_hand_other_than_the_stored_ones_is_simulated():
    wider = dataclasses.replace(ROBOTIQ_2F85, pad_width=ROBOTIQ_2F85.pad_width + 0.004)
    boxes = hand_boxes(wider)
    pads = np.flatnonzero(np.isclose(boxes.half, wider.pad_width / 2).any(axis=1))
    assert len(pads) >= 2  # the pads' boxes are the wider spec's, not the stored hand's
    assert not np.isclose(hand_boxes(ROBOTIQ_2F85).half, wider.pad_width / 2).any()


def test_the_approach_check_of_a_built_in_hand_loads_no_simulator():
    """A robot's detector with the approach check on needs the hand's boxes, not MuJoCo."""
    code = (
        "import sys, numpy as np\n"
        "import symgrasp.detect\n"
        "from symgrasp.sim import ROBOTIQ_2F85\n"
        "from symgrasp.sim.collision import hand_collides\n"
        "T = np.eye(4); T[2, 3] = 0.2\n"
        "hits = hand_collides(T[None], ROBOTIQ_2F85, np.zeros((1, 3)))\n"
        "assert hits.tolist() == [False], hits\n"
        "assert 'mujoco' not in sys.modules, 'MuJoCo was loaded'\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
