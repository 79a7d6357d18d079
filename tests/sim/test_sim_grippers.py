"""Gripper specs: resolved once from a name, and a new parallel gripper is one new spec."""

import dataclasses

import numpy as np
import pytest

from symgrasp.names import GRIPPERS
from symgrasp.sim import FRANKA, World, execute_grasp, get_gripper
from symgrasp.sim.collision import hand_boxes, hand_collides
from symgrasp.sim.execute import Outcome, top_grasp
from symgrasp.sim.objects import ObjectSpec, Part
from symgrasp.workspace import TABLE_HEIGHT

WIDE = dataclasses.replace(FRANKA, name="wide-jaw", max_width=0.11, finger_width=0.03)
"""A made-up rigid parallel jaw opening 110 mm: nothing but a spec."""

BOX = ObjectSpec("box", "box", (Part("box", (0.045, 0.02, 0.03), (0, 0, 0.03)),), 0.2, 0.8)
"""9 cm across x: wider than the Franka's 80 mm opening, narrower than the made-up 110 mm."""


def test_every_built_in_name_resolves_to_its_spec():
    assert [get_gripper(name).name for name in GRIPPERS] == list(GRIPPERS)
    assert get_gripper(FRANKA) is FRANKA  # a spec passes through
    with pytest.raises(ValueError, match="franka, robotiq-2f85, got 'shadow-hand'"):
        get_gripper("shadow-hand")


@pytest.mark.parametrize("spec", [get_gripper(n) for n in GRIPPERS] + [WIDE], ids=lambda s: s.name)
def test_the_open_pads_are_max_width_apart(spec):
    boxes = hand_boxes(spec)
    reach = np.einsum(
        "bjk,bk->bj", np.abs(boxes.rotation), boxes.half
    )  # extents along e_x, e_y, e_z
    inner = np.abs(boxes.centre[:, 2]) - reach[:, 2]
    tip = boxes.centre[:, 0] + reach[:, 0]
    for sign in (1, -1):  # each finger's pad is the box at its fingertip
        side = np.flatnonzero((inner > 0) & (np.sign(boxes.centre[:, 2]) == sign))
        pad = side[np.argmax(tip[side])]
        assert inner[pad] == pytest.approx(spec.max_width / 2, abs=2e-3)


def _top_grasp_on_the_box(spec) -> np.ndarray:
    """Close across the box's 9 cm, fingertips 1.5 cm below its top."""
    return top_grasp([0.15, 0.15, TABLE_HEIGHT + 0.06 + 0.015 - spec.tip_beyond_tcp], yaw=0.0)


def test_a_new_parallel_gripper_is_one_spec():
    world = World([BOX], gripper=WIDE)
    world.settle(0.5)
    assert execute_grasp(world, _top_grasp_on_the_box(WIDE)).outcome is Outcome.SUCCESS
    narrow = World([BOX], gripper=FRANKA)
    narrow.settle(0.5)
    assert execute_grasp(narrow, _top_grasp_on_the_box(FRANKA)).outcome is not Outcome.SUCCESS
    points = np.array([[0.15 + 0.045, 0.15, TABLE_HEIGHT + 0.06]])  # the box's top edge
    assert not hand_collides(_top_grasp_on_the_box(WIDE)[None], WIDE, points)[0]
    assert hand_collides(_top_grasp_on_the_box(FRANKA)[None], FRANKA, points)[0]


def test_a_grasp_needs_a_world_with_a_hand():
    with pytest.raises(ValueError, match="hand"):
        execute_grasp(World([BOX]), _top_grasp_on_the_box(FRANKA))
