"""Physics sanity of grasp trials: each case has an answer known without the simulator."""

import mujoco
import numpy as np
import pytest

from symgrasp.objects.sets import make_scene
from symgrasp.sim import (
    FRANKA,
    ROBOTIQ_2F85,
    World,
    execute_grasp,
    get_gripper,
    large_box,
)
from symgrasp.sim.execute import (
    Outcome,
    pull_out_force,
    pull_out_forces,
    ramp,
    stepwise_pull_out_forces,
    top_grasp,
)
from symgrasp.sim.objects import ObjectSpec, Part
from symgrasp.sim.physics import HAND_GROUP
from symgrasp.workspace import TABLE_HEIGHT

GRIPPERS = ["franka", "robotiq-2f85"]
CENTRE = np.array([0.15, 0.15])


def _box(half: tuple[float, float, float], mass: float = 0.2, friction: float = 0.8):
    return ObjectSpec("box", "box", (Part("box", half, (0, 0, half[2])),), mass, friction)


def _grasp_height(gripper: str, top: float) -> float:
    """TCP height that puts the fingertips 1.5 cm below an object top at ``top`` [m]."""
    return top + 0.015 - get_gripper(gripper).tip_beyond_tcp


def _settled(obj: ObjectSpec, gripper: str) -> World:
    world = World([obj], gripper=get_gripper(gripper))
    world.settle(0.5)
    return world


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_centred_top_grasp_on_a_box_succeeds_and_removes_it(gripper):
    world = _settled(_box((0.025, 0.025, 0.03)), gripper)
    pose = top_grasp(np.r_[CENTRE, _grasp_height(gripper, TABLE_HEIGHT + 0.06)])
    result = execute_grasp(world, pose)
    assert result.outcome is Outcome.SUCCESS
    assert result.object_index == 0
    assert world.objects == []


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_grasp_7cm_beside_the_box_closes_on_nothing(gripper):
    world = _settled(_box((0.025, 0.025, 0.03)), gripper)
    # shifted along e_y (finger width direction): box half-width 2.5 cm + pad half-width ≤ 1.1 cm
    beside = CENTRE + np.array([0.0, 0.07])
    pose = top_grasp(np.r_[beside, _grasp_height(gripper, TABLE_HEIGHT + 0.06)])
    assert execute_grasp(world, pose).outcome is Outcome.NO_CONTACT
    assert len(world.objects) == 1


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_heavy_low_friction_box_slips(gripper):
    # 2 kg needs ≥ 19.6 N of friction; the pair's μ is max(0.02, fingers' 0.1) = 0.1, and the
    # squeeze on a 5 cm box (70 N Franka, 77 N Robotiq per pad) gives at most 15.4 N
    world = _settled(_box((0.025, 0.025, 0.03), mass=2.0, friction=0.02), gripper)
    pose = top_grasp(np.r_[CENTRE, _grasp_height(gripper, TABLE_HEIGHT + 0.06)])
    assert execute_grasp(world, pose).outcome is Outcome.SLIPPED


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_large_box_needs_the_right_yaw(gripper):
    """70 mm wide box: fits across the 80/85 mm opening, but not along its 200 mm length."""
    top = TABLE_HEIGHT + 0.03
    position = np.r_[CENTRE, _grasp_height(gripper, top)]
    world = _settled(large_box(), gripper)
    wrong = execute_grasp(world, top_grasp(position, yaw=np.pi / 2))
    assert wrong.outcome is Outcome.APPROACH_COLLISION
    right = execute_grasp(world, top_grasp(position, yaw=0.0))
    assert right.outcome is Outcome.SUCCESS


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_oblique_side_grasp_on_a_tall_box_succeeds(gripper):
    """Approach along +x tilted 30° down, closing along y: any SE(3) grasp can be executed."""
    world = _settled(_box((0.025, 0.025, 0.06)), gripper)
    tilt = np.deg2rad(30)
    e_x, e_z = np.array([np.cos(tilt), 0.0, -np.sin(tilt)]), np.array([0.0, 1.0, 0.0])
    pose = np.eye(4)
    pose[:3, :3] = np.c_[e_x, np.cross(e_z, e_x), e_z]
    pose[:3, 3] = (*CENTRE, TABLE_HEIGHT + 0.07)
    assert execute_grasp(world, pose).outcome is Outcome.SUCCESS


def _yaw_tolerance(gripper: str, box_width: float) -> float:
    """Largest yaw [rad] at which the open pads' inner corners still clear a box of
    ``box_width`` centred between them (paper Appx. D: 22.6° for the 2F-85 and 70 mm)."""
    spec = get_gripper(gripper)
    half_open, half_pad = spec.max_width / 2, spec.pad_width / 2
    corner = np.hypot(half_open, half_pad)
    return np.arccos(box_width / 2 / corner) - np.arctan2(half_pad, half_open)


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_large_box_yaw_tolerance_matches_the_geometry(gripper):
    tolerance = _yaw_tolerance(gripper, 0.07)
    if gripper == "robotiq-2f85":
        assert np.rad2deg(tolerance) == pytest.approx(22.6, abs=0.2)
    position = np.r_[CENTRE, _grasp_height(gripper, TABLE_HEIGHT + 0.03)]
    margin = np.deg2rad(2.0)
    inside = execute_grasp(_settled(large_box(), gripper), top_grasp(position, tolerance - margin))
    outside = execute_grasp(_settled(large_box(), gripper), top_grasp(position, tolerance + margin))
    assert inside.outcome is Outcome.SUCCESS
    assert outside.outcome is Outcome.APPROACH_COLLISION


def _robotiq_closed_on(obj: ObjectSpec, depth: float) -> float:
    """Curl angle [rad] of the left pad after the Robotiq closes on a free-floating ``obj``
    whose origin lies ``depth`` metres past the TCP toward the palm (no gravity)."""
    T = np.eye(4)
    T[:3, 3] = (0.15, 0.15, 0.25)
    world = World([obj], T[None], gripper=ROBOTIQ_2F85)
    world.set_gravity(np.zeros(3))
    world.set_hand_pose(top_grasp(T[:3, 3] + (0.0, 0.0, -depth)))
    world.actuate(close=True)
    assert world.objects_in_hand() == [0]
    return float(world.data.qpos[world.model.joint("hand_curl_left").qposadr[0]])


def test_robotiq_pads_stay_parallel_in_a_pinch_and_curl_when_the_proximal_link_is_blocked():
    pinched = ObjectSpec("b", "box", (Part("box", (0.025, 0.02, 0.02)),), 0.2, 0.8)
    assert abs(_robotiq_closed_on(pinched, depth=0.0)) < 0.01
    # a 5 cm plate near the palm stops the proximal links; the pads wrap in below it
    plate = ObjectSpec("p", "box", (Part("box", (0.025, 0.03, 0.006)),), 0.5, 0.8)
    assert _robotiq_closed_on(plate, depth=0.025) > 0.15


def _held_ball(depth: float) -> tuple[World, np.ndarray]:
    """A free-floating ball (r = 3 cm, μ = 0.3, no gravity) closed on by the Robotiq with the
    TCP ``depth`` metres past the ball centre along the approach direction."""
    ball = ObjectSpec("ball", "sphere", (Part("sphere", (0.03,)),), 0.2, 0.3)
    T = np.eye(4)
    T[:3, 3] = (0.15, 0.15, 0.25)
    world = World([ball], T[None], gripper=ROBOTIQ_2F85)
    world.set_gravity(np.zeros(3))
    pose = top_grasp(T[:3, 3] + (0.0, 0.0, -depth))
    world.set_hand_pose(pose)
    world.actuate(close=True)
    return world, pose


def test_robotiq_power_grasp_resists_more_pull_out_than_a_pinch():
    """Fingertip pinch: pads on the ball's far half, held by friction alone. Power grasp:
    ball against the proximal links, pads curled around it (enveloping)."""
    pinch_world, pose = _held_ball(depth=-0.01)
    power_world, _ = _held_ball(depth=0.015)
    assert pinch_world.objects_in_hand() == [0]
    assert power_world.objects_in_hand() == [0]
    curl = power_world.model.joint("hand_curl_left").qposadr[0]
    assert power_world.data.qpos[curl] > 0.03  # the pad curled in
    out = pose[:3, 0]  # pulling along e_x, away from the palm
    pinch = pull_out_force(pinch_world, 0, out)
    power = pull_out_force(power_world, 0, out)
    assert power > 1.3 * pinch


def test_grasp_trials_are_deterministic():
    results = []
    for _ in range(2):
        world = _settled(_box((0.02, 0.03, 0.03)), "robotiq-2f85")
        pose = top_grasp(
            np.r_[CENTRE + 0.004, _grasp_height("robotiq-2f85", TABLE_HEIGHT + 0.06)], yaw=0.3
        )
        execute_grasp(world, pose, remove=False)
        results.append(world.object_poses())
    np.testing.assert_array_equal(results[0], results[1])


def test_bad_grasp_pose_is_rejected():
    world = _settled(_box((0.02, 0.02, 0.02)), "franka")
    with pytest.raises(ValueError, match="grasp_pose"):
        execute_grasp(world, np.eye(3))


def test_successful_grasp_in_a_scene_removes_only_the_lifted_object():
    world = make_scene("packed", "blocks", n=4, seed=0, gripper=FRANKA)
    before = world.object_poses()
    target = 1
    T = before[target]
    half = np.asarray(world.objects[target].parts[0].size)  # blocks are ≤ 6 cm wide
    top = T[2, 3] + 2 * half[2]
    yaw = np.arctan2(T[1, 0], T[0, 0])  # close across the block's local x
    pose = top_grasp(np.r_[T[:2, 3], _grasp_height("franka", top)], yaw)
    result = execute_grasp(world, pose)
    assert result.outcome is Outcome.SUCCESS and result.object_index == target
    others = np.delete(before, target, axis=0)
    assert len(world.objects) == len(before) - 1
    np.testing.assert_allclose(world.object_poses()[:, :3, 3], others[:, :3, 3], atol=2e-3)


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_flipped_grasp_is_the_same_grasp(gripper):
    """R · diag(1, −1, −1) swaps the fingers of a symmetric hand: same outcome, same lift."""
    pose = top_grasp(np.r_[CENTRE + 0.005, _grasp_height(gripper, TABLE_HEIGHT + 0.06)], 0.4)
    flipped = pose.copy()
    flipped[:3, :3] = pose[:3, :3] @ np.diag([1.0, -1.0, -1.0])
    lifted = []
    for T in (pose, flipped):
        world = _settled(_box((0.02, 0.03, 0.03)), gripper)
        assert execute_grasp(world, T, remove=False).outcome is Outcome.SUCCESS
        lifted.append(world.object_positions()[0])
    np.testing.assert_allclose(lifted[0], lifted[1], atol=2e-3)


def _held_box(gripper: str) -> World:
    """A 4 × 6 × 9 cm box of 0.2 kg floating without gravity, squeezed across its 4 cm side."""
    half = (0.02, 0.03, 0.045)
    T = np.eye(4)
    T[:3, 3] = (0.15, 0.15, 0.6)
    world = World([_box(half, friction=0.5)], T[None], gripper=get_gripper(gripper))
    world.set_gravity(np.zeros(3))
    world.set_hand_pose(top_grasp(T[:3, 3] + (0.0, 0.0, half[2])))
    world.actuate(close=True)
    assert world.objects_in_hand() == [0]
    return world


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_pull_out_forces_equal_the_ramp_stepped_through_the_world(gripper):
    """Bit for bit, ramps that slip and ramps that hold to the end alike; the world is left as
    it was."""
    world = _held_box(gripper)
    directions = np.random.default_rng(0).normal(size=(12, 3))
    before = world.snapshot()
    fast = pull_out_forces(world, 0, directions, max_force=100.0, rate=1000.0, slip=0.005)
    assert np.array_equal(world.snapshot().state, before.state)
    reference = stepwise_pull_out_forces(world, 0, directions, 100.0, 1000.0, 0.005)
    assert np.array_equal(fast, reference)
    assert 0 < np.sum(fast == 100.0) < len(fast)  # both endings were compared
    single = pull_out_force(world, 0, directions[1], max_force=100.0, rate=1000.0, slip=0.005)
    assert single == fast[1]


def test_a_ramp_adds_its_step_until_it_reaches_the_maximum():
    forces = ramp(1.0, 0.3)
    total, expected = 0.0, []
    for _ in range(4):
        total += 0.3
        expected.append(total)
    assert forces.tolist() == expected  # summed step by step: 0.8999… before 1.2
    assert forces[-2] < 1.0 <= forces[-1]
    assert len(ramp(300.0, 2.0)) == 150
    with pytest.raises(ValueError, match="positive"):
        ramp(1.0, 0.0)


def test_pushing_refuses_bad_arguments_and_leaves_no_force_behind():
    world = _held_box("franka")
    assert world.push_until_slip(0, np.full((5, 3), 0.1), slip=0.005) is None
    assert not world.data.xfrc_applied.any()
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        world.push_until_slip(0, np.zeros(3), slip=0.005)
    with pytest.raises(ValueError, match="index"):
        world.push_until_slip(1, np.zeros((5, 3)), slip=0.005)
    with pytest.raises(ValueError, match="non-zero"):
        pull_out_forces(world, 0, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="gripper"):
        World([_box((0.02, 0.02, 0.02))]).push_until_slip(0, np.zeros((5, 3)), slip=0.005)


def _hand_force_by_contact(world: World) -> float:
    """The normal forces of the contacts with one geom in the hand, summed in contact order."""
    hand, wrench, total = world.model.geom_group == HAND_GROUP, np.zeros(6), 0.0
    for i in range(world.data.ncon):
        c = world.data.contact[i]
        if hand[c.geom1] != hand[c.geom2]:
            mujoco.mj_contactForce(world.model, world.data, i, wrench)
            total += wrench[0]
    return total


@pytest.mark.parametrize("gripper", GRIPPERS)
def test_a_guarded_move_onto_a_wide_box_stops_on_the_force_the_box_puts_on_the_hand(gripper):
    world = _settled(_box((0.07, 0.07, 0.03), mass=1.0), gripper)
    world.move_hand(top_grasp(np.r_[CENTRE, TABLE_HEIGHT + 0.25]), 0.5)
    assert world.hand_contact_force() == 0.0 and world.hand_touches() == []
    assert not world.hand_in_collision()
    # the fingertips 2 cm into the top of a box wider than the open hand
    into = top_grasp(np.r_[CENTRE, TABLE_HEIGHT + 0.04 - get_gripper(gripper).tip_beyond_tcp])
    assert world.move_hand(into, 1.0, stop_force=20.0) == float("inf")
    assert world.hand_contact_force() == _hand_force_by_contact(world) > 20.0
    assert world.hand_in_collision() and world.hand_touches() == world.objects_in_hand() == [0]
