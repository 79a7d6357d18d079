"""A declutter round with the shipped model: its bookkeeping, and same seed → same round."""

import json
from collections import Counter

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from symgrasp.benchmark.declutter import NONE_FOUND, first_free, picture_observer, run_round
from symgrasp.benchmark.failures import MODES, STRUCK
from symgrasp.benchmark.runner import round_record
from symgrasp.detect import Grasp, GraspDetector
from symgrasp.objects.sets import resolve
from symgrasp.sim import ROBOTIQ_2F85
from symgrasp.sim.collision import SIGNS, hand_boxes
from symgrasp.sim.execute import Outcome, execute_grasp, top_grasp
from symgrasp.sim.objects import object_set
from symgrasp.sim.world import World
from symgrasp.workspace import TABLE_HEIGHT

HOUSEHOLD = resolve("household-test")


@pytest.fixture(scope="module")
def detector():
    return GraspDetector.from_pretrained("bingham2d-robotiq-2f85", device="cpu")


def test_a_round_is_reproducible_undisturbed_by_diagnosis_and_its_counts_add_up(detector):
    seen = []

    def observer(world, points, candidates, attempt):
        seen.append((len(world.objects), attempt))
        assert points.ndim == 2 and points.shape[1] == 3 and len(points) > 100

    # seed 13: a failure is replayed mid-round, and more attempts follow it
    first = run_round(detector, HOUSEHOLD, 3, seed=13, observer=observer)
    again = run_round(detector, HOUSEHOLD, 3, seed=13, diagnose=False)
    assert [a.outcome for a in first.attempts] == [a.outcome for a in again.attempts]
    for a, b in zip(first.attempts, again.attempts, strict=True):
        assert (a.grasp is None) == (b.grasp is None)
        if a.grasp is not None:
            assert np.allclose(a.grasp.pose, b.grasp.pose)
    assert len(seen) == len(first.attempts) >= 1
    assert first.successes == sum(a.outcome == "success" for a in first.attempts)
    assert first.executed == sum(a.outcome != NONE_FOUND for a in first.attempts)
    for objects_after, attempt in seen:  # a success removes exactly one object
        assert objects_after == attempt.objects_before - attempt.success
    assert 0 <= first.clear_ratio <= 1
    assert all(a.mode is None for a in again.attempts)
    assert any(not a.success for a in first.attempts[:-1])
    families = {spec.family for spec in object_set("household-test", 3, seed=13)}
    for a in first.attempts:
        assert a.mode in MODES and (a.mode == "success") == a.success
        assert (a.mode == NONE_FOUND) == (a.outcome == NONE_FOUND)
        assert (a.target is None) == (a.outcome == NONE_FOUND)
        assert a.target is None or a.target in families
        assert set(a.struck) <= set(STRUCK) and (not a.struck or "collision" in a.outcome)
    assert [a.target for a in first.attempts] == [a.target for a in again.attempts]
    assert [a.struck for a in first.attempts] == [a.struck for a in again.attempts]
    # what was presented and what is left: the lifted objects' families taken out, no more
    assert len(first.presented) == first.objects and set(first.presented) <= families
    lifted = Counter(a.target for a in first.attempts if a.success)
    assert Counter(first.left) == Counter(first.presented) - lifted
    assert (first.presented, first.left) == (again.presented, again.left)
    recorded = json.loads(json.dumps(round_record(first)))["attempts"]  # the executed poses
    for a, r in zip(first.attempts, recorded, strict=True):
        assert (r["pose"] is None) == (a.grasp is None)
        assert a.grasp is None or np.array_equal(np.array(r["pose"]), a.grasp.pose)


def test_pictures_are_drawn_per_attempt(detector, tmp_path):
    record = run_round(
        detector, HOUSEHOLD, 2, seed=3, observer=picture_observer(tmp_path, detector.gripper)
    )
    drawn = sorted(p.name for p in tmp_path.glob("*.png"))
    assert drawn == [f"attempt_{n:02d}.png" for n in range(1, len(record.attempts) + 1)]


def test_bad_round_arguments_are_refused(detector):
    with pytest.raises(ValueError, match="num_objects"):
        run_round(detector, HOUSEHOLD, num_objects=0)


@pytest.mark.parametrize(("depth", "free"), [(-0.003, False), (0.003, True)])
def test_first_free_keeps_the_labels_table_clearance_and_the_physics_agrees(depth, free):
    """A grasp tilted 27° whose open hand reaches ``depth`` [m] below (−) or above the table, on
    an empty table: `first_free` passes it only with the labels' clearance kept (the rule before
    2026-11-27, ``table_clearance`` −0.002, passed both), and the physics stops the sunk one on
    its way in as an approach collision, while the other closes on nothing."""
    T = top_grasp(np.array([0.15, 0.15, 0.0]))
    T[:3, :3] = Rotation.from_euler("x", 27, degrees=True).as_matrix() @ T[:3, :3]
    boxes = hand_boxes(ROBOTIQ_2F85)
    corners = boxes.centre[:, None] + np.einsum(
        "bij,bcj->bci", boxes.rotation, SIGNS * boxes.half[:, None]
    )
    T[2, 3] = TABLE_HEIGHT - (T[2, :3] @ corners.reshape(-1, 3).T).min() + depth
    grasp = Grasp(T, score=1.0)
    chosen, rejected = first_free([grasp], ROBOTIQ_2F85, np.zeros((0, 3)))
    assert (chosen is grasp, rejected) == ((True, 0) if free else (False, 1))
    assert first_free([grasp], ROBOTIQ_2F85, np.zeros((0, 3)), table_clearance=-0.002)[0] is grasp
    result = execute_grasp(World([], gripper=ROBOTIQ_2F85), T)
    assert result.outcome is (Outcome.NO_CONTACT if free else Outcome.APPROACH_COLLISION)
    assert result.touched == (() if free else (-1,))  # the table


@pytest.mark.parametrize(
    ("depth", "clearance", "free"),
    [(0.0015, -0.002, True), (0.0015, -0.001, False), (0.0015, 0.0, False),
     (-0.0005, 0.0, True), (-0.0005, 0.001, False)],
)  # fmt: skip
def test_first_free_keeps_the_surface_clearance_from_the_observed_points(depth, clearance, free):
    """One observed point ``depth`` [m] inside (−: outside) the outer face of a fingertip of
    the open hand, high above the table: it passes when the clearance asked for lets it."""
    T = top_grasp(np.array([0.15, 0.15, TABLE_HEIGHT + 0.15]))
    boxes = hand_boxes(ROBOTIQ_2F85)
    tip = int(np.argmax(boxes.centre[:, 2]))  # the fingertip on +e_z, nothing beyond it
    axis = int(np.argmin(boxes.half[tip]))  # its pad's normal
    assert np.delete(boxes.half[tip], axis).min() > 0.0015  # so no other face is nearer
    in_box = np.zeros(3)
    in_box[axis] = boxes.half[tip][axis] - depth
    point = T[:3, :3] @ (boxes.centre[tip] + boxes.rotation[tip] @ in_box) + T[:3, 3]
    grasp = Grasp(T, score=1.0)
    chosen, rejected = first_free([grasp], ROBOTIQ_2F85, point[None], surface_clearance=clearance)
    assert (chosen is grasp, rejected) == ((True, 0) if free else (False, 1))


class _Listed:
    """A planner that proposes a grasp whose TCP lies under the table, then a free one high
    above the objects: which one runs is the protocol's."""

    gripper, name, version = ROBOTIQ_2F85, "listed", "0"

    def plan(self, observation):
        under = top_grasp(np.array([0.15, 0.15, TABLE_HEIGHT - 0.02]))
        above = top_grasp(np.array([0.15, 0.15, TABLE_HEIGHT + 0.25]))
        return [Grasp(under, 1.0), Grasp(above, 0.5)]


def test_the_protocol_decides_whether_the_approach_is_checked_before_execution():
    checked = run_round(_Listed(), HOUSEHOLD, 1, seed=0, max_attempts=1, diagnose=False)
    (attempt,) = checked.attempts
    assert attempt.rejected == 1 and attempt.grasp.score == 0.5
    paper = run_round(_Listed(), HOUSEHOLD, 1, seed=0, max_attempts=1, diagnose=False,
                      protocol="paper")  # fmt: skip
    (attempt,) = paper.attempts
    assert attempt.rejected == 0 and attempt.grasp.score == 1.0 and not attempt.success
    with pytest.raises(ValueError, match="protocol must be one of"):
        run_round(_Listed(), HOUSEHOLD, 1, protocol="vgn")
