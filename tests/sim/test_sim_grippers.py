"""Gripper specs: spec files, resolved once from a name, a file or a stored record, checked
whole; a new parallel gripper is one new file."""

import json

import numpy as np
import pytest

from symgrasp.names import GRIPPERS
from symgrasp.sim import FRANKA, ROBOTIQ_2F85, World, execute_grasp, get_gripper, load_gripper
from symgrasp.sim.collision import hand_boxes, hand_collides
from symgrasp.sim.execute import Outcome, top_grasp
from symgrasp.sim.grippers import SPEC_FOLDER, GripperSpec
from symgrasp.sim.objects import ObjectSpec, Part
from symgrasp.workspace import TABLE_HEIGHT

BOX = ObjectSpec("box", "box", (Part("box", (0.045, 0.02, 0.03), (0, 0, 0.03)),), 0.2, 0.8)
"""9 cm across x: wider than the Franka's 80 mm opening, narrower than the made-up 110 mm."""


@pytest.fixture(scope="module")
def wide(wide_jaw) -> GripperSpec:
    return get_gripper(str(wide_jaw))


@pytest.fixture(params=[*GRIPPERS, "wide-jaw"])
def spec(request, wide) -> GripperSpec:
    return wide if request.param == "wide-jaw" else get_gripper(request.param)


def _toml(data: dict) -> str:
    """``data`` (a spec's keys, one level of tables) as TOML text: JSON values are TOML's."""
    lines = [f"{k} = {json.dumps(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for table, values in ((k, v) for k, v in data.items() if isinstance(v, dict)):
        lines += [f"[{table}]", *(f"{k} = {json.dumps(v)}" for k, v in values.items())]
    return "\n".join(lines) + "\n"


def test_every_built_in_name_resolves_to_its_shipped_spec_file():
    assert sorted(p.stem for p in SPEC_FOLDER.glob("*.toml")) == sorted(GRIPPERS)
    for name in GRIPPERS:
        assert get_gripper(name) == load_gripper(SPEC_FOLDER / f"{name}.toml")
        assert get_gripper(name).name == name
    assert (FRANKA.kind, ROBOTIQ_2F85.kind) == ("rigid", "underactuated")
    with pytest.raises(ValueError, match="got GripperSpec"):  # resolved once, not again
        get_gripper(FRANKA)
    with pytest.raises(
        ValueError, match=r"franka, robotiq-2f85 or a \.toml spec file, got 'shadow'"
    ):
        get_gripper("shadow")


def test_a_spec_is_its_record(spec, tmp_path):
    """What models and datasets store (JSON) and a file written from it give the same hand."""
    record = json.loads(json.dumps(spec.to_dict()))
    assert get_gripper(record) == spec
    (tmp_path / "again.toml").write_text(_toml(record))
    again = load_gripper(tmp_path / "again.toml")
    assert again == spec and again.hand_xml() == spec.hand_xml()


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


def test_the_hand_of_a_spec_file_closes_and_its_boxes_follow(wide):
    world = World([], gripper=wide)
    assert world.finger_opening() == pytest.approx(0.11, abs=1e-4)
    open_boxes = world.hand_boxes()
    world.actuate(close=True)
    assert world.finger_opening() < 1e-3
    names, closed = world.hand_box_names(), world.hand_boxes()
    assert names == ["hand_palm", "hand_pad_left", "hand_pad_right"]
    pads = [names.index("hand_pad_left"), names.index("hand_pad_right")]
    assert np.abs(closed[0][pads, 2]) == pytest.approx([0.005] * 2, abs=1e-3)  # touching
    np.testing.assert_allclose(closed[0][0], open_boxes[0][0], atol=1e-6)  # the palm stays


def _top_grasp_on_the_box(spec) -> np.ndarray:
    """Close across the box's 9 cm, fingertips 1.5 cm below its top."""
    return top_grasp([0.15, 0.15, TABLE_HEIGHT + 0.06 + 0.015 - spec.tip_beyond_tcp], yaw=0.0)


def test_a_new_parallel_gripper_is_one_spec_file(wide):
    world = World([BOX], gripper=wide)
    world.settle(0.5)
    assert execute_grasp(world, _top_grasp_on_the_box(wide)).outcome is Outcome.SUCCESS
    narrow = World([BOX], gripper=FRANKA)
    narrow.settle(0.5)
    assert execute_grasp(narrow, _top_grasp_on_the_box(FRANKA)).outcome is not Outcome.SUCCESS
    points = np.array([[0.15 + 0.045, 0.15, TABLE_HEIGHT + 0.06]])  # the box's top edge
    assert not hand_collides(_top_grasp_on_the_box(wide)[None], wide, points)[0]
    assert hand_collides(_top_grasp_on_the_box(FRANKA)[None], FRANKA, points)[0]


def test_a_grasp_needs_a_world_with_a_hand():
    with pytest.raises(ValueError, match="hand"):
        execute_grasp(World([BOX]), _top_grasp_on_the_box(FRANKA))


def _set(key, value, base=None):
    """A change of a spec's record: ``key`` (``table.key`` inside a table) set to ``value``, or
    removed when ``value`` is None; on the wide jaw's record, or on ``base``'s."""

    def change(record):
        record = json.loads(json.dumps(base.to_dict())) if base else record
        table, _, name = key.rpartition(".")
        where = record[table] if table else record
        if value is None:
            del where[name]
        else:
            where[name] = value
        return record

    return change


BAD = {
    "a negative size": (_set("pad_width", -0.03), "pad_width must be in (0, 1] m, got -0.03"),
    "a zero palm side": (_set("palm_size", [0.05, 0, 0.16]), "palm_size[1] must be in (0, 1] m"),
    "three palm sizes wanted": (_set("palm_size", [0.05, 0.07]), "palm_size must be 3 lengths"),
    "a pad wider than the palm": (_set("pad_width", 0.08), "pad_width (0.08 m) is wider than the palm (palm_size[1] = 0.07 m)"),
    "an opening wider than the palm": (_set("max_width", 0.15), "max_width (0.15 m) does not fit the palm"),
    "millimetres for metres": (_set("max_width", 110), "max_width must be in (0, 1] m, got 110"),
    "a missing key": (_set("grip_force", None), "missing key grip_force (squeeze of each finger"),
    "a missing kind": (_set("kind", None), "missing key kind (how the hand is built: rigid or underactuated)"),
    "a missing finger key": (_set("fingers.depth", None), "missing key fingers.depth"),
    "an unknown key": (_set("pad_widht", 0.03), "unknown key pad_widht; did you mean pad_width?"),
    "another kind's finger key": (_set("fingers.link_length", 0.05), "unknown key fingers.link_length"),
    "a string for a number": (_set("max_width", "0.11"), "max_width must be a number [m], got '0.11'"),
    "a boolean for a number": (_set("close_time", True), "close_time must be a number [s], got True"),
    "an unknown kind": (_set("kind", "robotiq"), "kind must be 'rigid' or 'underactuated', got 'robotiq'"),
    "fingers not a table": (_set("fingers", 3), "fingers must be a table"),
    "a name with a slash": (_set("name", "my/jaw"), "name must be 1 to 64 letters"),
    "the TCP behind the palm": (_set("fingers.tip_beyond_tcp", 0.07), "fingers.tip_beyond_tcp (0.07 m) must be less than fingers.depth"),
    "a link too short to open": (_set("fingers.link_length", 0.02, ROBOTIQ_2F85), "fingers.link_length (0.02 m) cannot open the pads"),
    "a negative curl ratio": (_set("fingers.curl_ratio", -0.2, ROBOTIQ_2F85), "fingers.curl_ratio must be in (0, 10], got -0.2"),
}  # fmt: skip
"""Bad spec files: a change of the wide jaw's record (or a built-in's) and what the error says
after the file's name."""


@pytest.mark.parametrize("case", BAD)
def test_a_bad_spec_file_is_refused_naming_the_file_and_key(case, wide, tmp_path):
    change, message = BAD[case]
    path = tmp_path / "bad.toml"
    path.write_text(_toml(change(json.loads(json.dumps(wide.to_dict())))))
    with pytest.raises(ValueError) as error:
        get_gripper(str(path))
    assert str(error.value).startswith(f"{path}: ")
    assert message in str(error.value)


def test_a_spec_file_that_is_not_toml_is_refused(tmp_path):
    (tmp_path / "broken.toml").write_text("max_width = = 3\n")
    with pytest.raises(ValueError, match=r"broken\.toml: not a TOML file"):
        load_gripper(tmp_path / "broken.toml")


def test_a_spec_file_may_not_take_a_built_in_name_with_other_dimensions(wide, tmp_path):
    record = {**wide.to_dict(), "name": "franka"}
    (tmp_path / "franka.toml").write_text(_toml(record))
    with pytest.raises(ValueError, match="'franka' is a built-in gripper's"):
        get_gripper(str(tmp_path / "franka.toml"))
    (tmp_path / "same.toml").write_text(_toml(FRANKA.to_dict()))
    assert get_gripper(str(tmp_path / "same.toml")) == FRANKA  # a copy of the built-in is it


def test_every_key_of_both_kinds_is_documented():
    """docs/sim.md's tables name every key of a spec file, top level and [fingers]."""
    from pathlib import Path

    docs = (Path(__file__).parents[2] / "docs" / "sim.md").read_text(encoding="utf-8")
    for spec in (FRANKA, ROBOTIQ_2F85):
        top = spec.to_dict()
        fingers = top.pop("fingers")
        for key in [*top, *fingers]:
            assert f"| `{key}` |" in docs, key
    assert "`[fingers]` of a `rigid` hand" in docs and "`[fingers]` of an `underactuated`" in docs
