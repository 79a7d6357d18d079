"""Failure modes against physics cases whose answer is known without the simulator."""

import numpy as np
import pytest

from symgrasp.benchmark.failures import (
    MODES,
    STRUCK,
    aimed_object,
    failure_mode,
    struck,
    turned_about_approach,
)
from symgrasp.sim import ROBOTIQ_2F85, World, execute_grasp, large_box
from symgrasp.sim.execute import Outcome, top_grasp
from symgrasp.sim.objects import ObjectSpec, Part
from symgrasp.workspace import TABLE_HEIGHT

GRIPPER = ROBOTIQ_2F85
CENTRE = np.array([0.15, 0.15])


def _box(half, mass=0.2, friction=0.8):
    return ObjectSpec("box", "box", (Part("box", half, (0, 0, half[2])),), mass, friction)


def _height(top):
    """TCP height that puts the fingertips 1.5 cm below an object top at ``top`` [m]."""
    return top + 0.015 - GRIPPER.tip_beyond_tcp


def _failed_trial(obj, pose):
    """A settled world with ``obj``, the snapshot before the trial of ``pose``, its outcome."""
    world = World([obj], gripper=GRIPPER)
    world.settle(0.5)
    before = world.snapshot()
    outcome = execute_grasp(world, pose).outcome
    return world, before, outcome


def test_turning_about_the_approach_keeps_position_and_approach_and_turns_the_closing_axis():
    T = top_grasp(np.array([0.1, 0.2, 0.3]), yaw=0.4)
    turned = turned_about_approach(T, 0.5)
    assert np.allclose(turned[:3, 3], T[:3, 3]) and np.allclose(turned[:3, 0], T[:3, 0])
    # right-handed about e_x = world −z: the world yaw goes 0.4 → 0.4 − 0.5
    assert np.allclose(turned[:3, 2], [np.cos(-0.1), np.sin(-0.1), 0.0])
    assert np.allclose(turned[:3, :3] @ turned[:3, :3].T, np.eye(3))


def test_closing_along_the_large_boxs_length_is_a_wrong_yaw_and_the_world_is_kept():
    position = np.r_[CENTRE, _height(TABLE_HEIGHT + 0.03)]
    pose = top_grasp(position, yaw=np.pi / 2)  # along the 200 mm length: cannot fit
    world, before, outcome = _failed_trial(large_box(), pose)
    assert outcome is Outcome.APPROACH_COLLISION
    left = world.object_poses()
    assert failure_mode(world, before, pose, outcome) == "wrong_yaw"  # 90° turn fits
    assert np.array_equal(world.object_poses(), left)  # back where the failed trial left it


def test_closing_beside_the_box_is_a_wrong_approach_whatever_the_yaw():
    beside = np.r_[CENTRE + np.array([0.0, 0.09]), _height(TABLE_HEIGHT + 0.06)]
    world, before, outcome = _failed_trial(_box((0.025, 0.025, 0.03)), top_grasp(beside))
    assert outcome is Outcome.NO_CONTACT
    assert failure_mode(world, before, top_grasp(beside), outcome) == "wrong_approach"


def test_a_heavy_slippery_box_slips_whatever_the_yaw():
    pose = top_grasp(np.r_[CENTRE, _height(TABLE_HEIGHT + 0.06)])
    world, before, outcome = _failed_trial(_box((0.025, 0.025, 0.03), 2.0, 0.02), pose)
    assert outcome is Outcome.SLIPPED
    assert failure_mode(world, before, pose, outcome) == "slip"


def test_a_pregrasp_under_the_table_is_a_collision_whatever_the_yaw():
    pose = top_grasp(np.r_[CENTRE, TABLE_HEIGHT + 0.05])
    pose[:3, :3] = pose[:3, :3] @ np.diag([-1.0, 1.0, -1.0])  # approach upwards from below
    world, before, outcome = _failed_trial(_box((0.025, 0.025, 0.03)), pose)
    assert outcome is Outcome.PREGRASP_COLLISION
    assert failure_mode(world, before, pose, outcome) == "collision"


def test_a_success_needs_no_replay_and_modes_cover_the_outcomes():
    world = World([_box((0.025, 0.025, 0.03))], gripper=GRIPPER)
    assert failure_mode(world, world.snapshot(), np.eye(4), Outcome.SUCCESS) == "success"
    assert {"wrong_yaw", "wrong_approach", "collision", "slip", "none_found"} <= set(MODES)


def test_a_snapshot_replays_a_trial_bit_for_bit_and_is_refused_after_a_rebuild():
    world = World([_box((0.025, 0.025, 0.03)), _box((0.02, 0.02, 0.02))], gripper=GRIPPER)
    world.settle(0.3)
    snapshot = world.snapshot()
    world.step(0.2)
    first = world.object_poses()
    world.restore(snapshot)
    world.step(0.2)
    assert np.array_equal(world.object_poses(), first)
    world.remove_object(1)
    with pytest.raises(ValueError, match="snapshot"):
        world.restore(snapshot)


def test_a_grasp_is_aimed_at_the_nearest_surface_not_the_nearest_centre():
    long, cube = _box((0.10, 0.02, 0.02)), _box((0.02, 0.02, 0.02))
    poses = np.tile(np.eye(4), (2, 1, 1))
    poses[:, :3, 3] = [[0.10, 0.15, TABLE_HEIGHT], [0.27, 0.15, TABLE_HEIGHT]]
    world = World([long, cube], poses)
    # 1.5 cm beyond the long box's end (its centre 11.5 cm away), 3.5 cm from the cube's side
    near_end = top_grasp(np.array([0.215, 0.15, TABLE_HEIGHT + 0.02]))
    assert aimed_object(world, near_end) == 0
    assert aimed_object(world, top_grasp(np.array([0.245, 0.15, TABLE_HEIGHT + 0.02]))) == 1
    turned = poses.copy()  # the long box turned 90° about z: its end no longer there
    turned[0, :3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    assert aimed_object(World([long, cube], turned), near_end) == 1
    assert aimed_object(World([]), near_end) is None


def test_what_a_collision_struck_is_read_from_the_touched_indices():
    assert struck((-1, 0, 2), 0) == STRUCK == ("table", "target", "neighbour")
    assert struck((2, 1), 1) == ("target", "neighbour") and struck((3,), None) == ("neighbour",)
    assert struck((), 0) == ()


def test_a_collision_names_the_target_a_neighbour_or_the_table_as_the_physics_touched():
    target = _box((0.025, 0.025, 0.03))
    poses = np.tile(np.eye(4), (2, 1, 1))
    poses[:, :3, 3] = [[*CENTRE, TABLE_HEIGHT], [CENTRE[0] + 0.065, CENTRE[1], TABLE_HEIGHT]]
    # Closing along x over the target: the open finger at +42.5 mm comes down on the 40 mm
    # neighbour standing 15 mm beside it.
    pose = top_grasp(np.r_[CENTRE, _height(TABLE_HEIGHT + 0.06)])
    world = World([target, _box((0.02, 0.02, 0.04))], poses, gripper=GRIPPER)
    world.settle(0.5)
    aimed = aimed_object(world, pose)
    result = execute_grasp(world, pose)
    assert (result.outcome, aimed) == (Outcome.APPROACH_COLLISION, 0)
    assert struck(result.touched, aimed) == ("neighbour",)
    along = top_grasp(np.r_[CENTRE, _height(TABLE_HEIGHT + 0.03)], yaw=np.pi / 2)
    world = World([large_box()], gripper=GRIPPER)  # closing along its 200 mm: onto its top
    world.settle(0.5)
    result = execute_grasp(world, along)
    assert result.outcome is Outcome.APPROACH_COLLISION
    assert struck(result.touched, aimed_object(world, along)) == ("target",)
    into_the_table = top_grasp(np.r_[CENTRE, TABLE_HEIGHT - 0.02])
    result = execute_grasp(World([], gripper=GRIPPER), into_the_table)
    assert (result.outcome, result.touched) == (Outcome.APPROACH_COLLISION, (-1,))
    assert struck(result.touched, None) == ("table",)
