"""A declutter round with the shipped model: its bookkeeping, and same seed → same round."""

from collections import Counter

import numpy as np
import pytest

from symgrasp.benchmark.declutter import NONE_FOUND, picture_observer, run_round
from symgrasp.benchmark.failures import MODES
from symgrasp.detect import GraspDetector
from symgrasp.objects.sets import resolve
from symgrasp.sim.objects import object_set

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
    assert [a.target for a in first.attempts] == [a.target for a in again.attempts]
    # what was presented and what is left: the lifted objects' families taken out, no more
    assert len(first.presented) == first.objects and set(first.presented) <= families
    lifted = Counter(a.target for a in first.attempts if a.success)
    assert Counter(first.left) == Counter(first.presented) - lifted
    assert (first.presented, first.left) == (again.presented, again.left)


def test_pictures_are_drawn_per_attempt(detector, tmp_path):
    record = run_round(
        detector, HOUSEHOLD, 2, seed=3, observer=picture_observer(tmp_path, detector.gripper)
    )
    drawn = sorted(p.name for p in tmp_path.glob("*.png"))
    assert drawn == [f"attempt_{n:02d}.png" for n in range(1, len(record.attempts) + 1)]


def test_bad_round_arguments_are_refused(detector):
    with pytest.raises(ValueError, match="num_objects"):
        run_round(detector, HOUSEHOLD, num_objects=0)
