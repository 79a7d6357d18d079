"""What a robot needs of each grasp beyond its pose: the opening width measured between the
fingers (`symgrasp.detect.width`) against boxes whose widths are known in closed form, and the
wrist flange's pose from each hand's ``tcp_offset`` (`symgrasp.detect.grasp`)."""

import json
import re

import numpy as np
import pytest

from symgrasp.detect import GraspDetector
from symgrasp.detect.grasp import Grasp, T_flange_tcp
from symgrasp.detect.width import OPENING_MARGIN, TABLE_BAND, with_widths
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.perception.noise import noisy_depth
from symgrasp.sim.grippers import FRANKA, ROBOTIQ_2F85, SPEC_FOLDER, get_gripper
from symgrasp.workspace import TABLE_HEIGHT

SMALL = CameraIntrinsic().scaled(0.5)  # 320 × 240
CAMERA = default_extrinsic()
CENTRE = np.array([0.15, 0.15])
TOP_DOWN = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
"""[e_x e_y e_z]: approach straight down, closing along world x."""


def _turn(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _box_surface(half: np.ndarray, yaw: float = 0.0, step: float = 0.001) -> np.ndarray:
    """Points (N, 3) [m] every ``step`` on the faces of a box of half-extents ``half`` standing
    on the table at `CENTRE`, turned by ``yaw`` about z (its edges included)."""
    axes = [np.linspace(-h, h, round(2 * h / step) + 1) for h in half]
    faces = []
    for normal in range(3):
        a, b = (axis for axis in range(3) if axis != normal)
        u, v = np.meshgrid(axes[a], axes[b], indexing="ij")
        for side in (-half[normal], half[normal]):
            face = np.zeros((u.size, 3))
            face[:, normal], face[:, a], face[:, b] = side, u.ravel(), v.ravel()
            faces.append(face)
    centre = np.array([*CENTRE, TABLE_HEIGHT + half[2]])
    return np.concatenate(faces) @ _turn(yaw).T + centre


def _box_depth(half: np.ndarray, yaw: float) -> np.ndarray:
    """The depth image [m] `SMALL` takes from `CAMERA` of the box of `_box_surface` on the
    table plane, ray-cast in closed form (slabs in the box's frame)."""
    rays = SMALL.pixel_rays() @ CAMERA[:3, :3].T  # world directions whose camera z is 1
    table = (TABLE_HEIGHT - CAMERA[2, 3]) / rays[..., 2]
    centre = np.array([*CENTRE, TABLE_HEIGHT + half[2]])
    local, eye = rays @ _turn(yaw), (CAMERA[:3, 3] - centre) @ _turn(yaw)
    with np.errstate(divide="ignore", invalid="ignore"):
        near, far = (-half - eye) / local, (half - eye) / local
    enter = np.nanmax(np.minimum(near, far), axis=-1)
    leave = np.nanmin(np.maximum(near, far), axis=-1)
    box = np.where((enter <= leave) & (enter > 0), enter, np.inf)
    return np.minimum(np.where(table > 0, table, np.inf), box).astype(np.float32)


def _top_down(shift: float, depth_below_top: float, top: float) -> Grasp:
    """A grasp straight down over `CENTRE` moved ``shift`` [m] along x, its TCP
    ``depth_below_top`` under the height ``top`` [m]."""
    pose = np.eye(4)
    pose[:3, :3] = TOP_DOWN
    pose[:3, 3] = [CENTRE[0] + shift, CENTRE[1], top - depth_below_top]
    return Grasp(pose, score=0.5, voxel=(1, 2, 3))


def _widths(grasp: Grasp, seen: np.ndarray, inside: np.ndarray | None = None) -> Grasp:
    return with_widths([grasp], ROBOTIQ_2F85, seen, TABLE_HEIGHT, inside)[0]


def test_the_opening_clears_the_farther_side_of_a_box_between_the_fingers():
    half = np.array([0.02, 0.03, 0.04])  # 4 cm across the fingers
    box, top = _box_surface(half), TABLE_HEIGHT + 2 * half[2]
    for shift in (0.0, 0.01, -0.01):
        grasp = _widths(_top_down(shift, 0.01, top), box)
        assert grasp.object_width == pytest.approx(2 * half[0], abs=1e-9)
        # each finger starts outside the box's farther face, by half the margin
        need = 2 * (half[0] + abs(shift)) + OPENING_MARGIN
        assert grasp.opening_width == pytest.approx(need, abs=1e-9)
        assert (grasp.score, grasp.voxel, grasp.tcp_offset) == (0.5, (1, 2, 3), 0.145)
    wide = _widths(_top_down(0.03, 0.01, top), box)
    assert wide.opening_width == ROBOTIQ_2F85.max_width  # 2 · 5 cm + margin: capped
    empty = _widths(_top_down(0.0, 0.01, top), np.empty((0, 3)))
    assert (empty.opening_width, empty.object_width) == (ROBOTIQ_2F85.max_width, None)


def test_the_seen_side_measures_the_object_and_what_lies_behind_it_opens_the_hand():
    half = np.array([0.02, 0.03, 0.04])
    box, top = _box_surface(half), TABLE_HEIGHT + 2 * half[2]
    near = np.isclose(box[:, 0], CENTRE[0] - half[0])  # the face at x = −2 cm, seen
    grasp = _widths(_top_down(0.0, 0.01, top), box[near], box[~near])
    assert grasp.object_width == pytest.approx(0.0, abs=1e-9)  # one plane across e_z
    assert grasp.opening_width == pytest.approx(2 * half[0] + OPENING_MARGIN, abs=1e-9)


def test_only_points_between_the_fingers_count():
    half = np.array([0.02, 0.03, 0.04])
    box, top = _box_surface(half), TABLE_HEIGHT + 2 * half[2]
    grasp = _top_down(0.0, 0.01, top)
    alone = _widths(grasp, box)
    wide = np.linspace(-0.06, 0.06, 61)  # along x: would open the hand fully if counted
    x, z = (a.ravel() for a in np.meshgrid(wide, np.linspace(top - 0.2, top + 0.2, 101)))
    beside = np.stack([CENTRE[0] + x, np.full(x.size, CENTRE[1] + 0.012), z], axis=1)
    tip = grasp.position[2] - ROBOTIQ_2F85.tip_beyond_tcp  # the fingertips' height
    past = np.stack([CENTRE[0] + wide, np.full(wide.size, CENTRE[1]), np.full(wide.size, tip)], 1)
    # beside the pads along e_y (they span ±11 mm), 1 mm past the fingertips
    for extra in (beside, past - [0, 0, 0.001]):
        got = _widths(grasp, np.concatenate([box, extra]))
        assert (got.opening_width, got.object_width) == (alone.opening_width, alone.object_width)
    inside = _widths(grasp, np.concatenate([box, past + np.array([0, 0, 0.001])]))
    assert inside.opening_width == ROBOTIQ_2F85.max_width
    # the table band, under a low grasp whose fingertips reach below the table top
    low = _top_down(0.0, 0.0, TABLE_HEIGHT + 0.015)
    for height, counted in ((TABLE_BAND - 0.001, False), (TABLE_BAND + 0.001, True)):
        table = past * [1, 1, 0] + [0, 0, TABLE_HEIGHT + height]
        got = _widths(low, table)
        assert got.opening_width == ROBOTIQ_2F85.max_width
        assert (got.object_width is not None) == counted


def test_widths_do_not_depend_on_where_the_scene_stands_on_the_table():
    half = np.array([0.025, 0.02, 0.03])
    box, top = _box_surface(half, yaw=0.3), TABLE_HEIGHT + 2 * half[2]
    grasps = [_top_down(s, d, top) for s, d in ((0.004, 0.01), (-0.006, 0.02))]
    R, t = _turn(1.1), np.array([0.03, -0.02, 0.0])
    move = np.eye(4)
    move[:3, :3], move[:3, 3] = R, t
    here = with_widths(grasps, FRANKA, box, TABLE_HEIGHT)
    moved_points = box @ R.T + t
    there = with_widths([g.transformed(move) for g in grasps], FRANKA, moved_points, TABLE_HEIGHT)
    for a, b in zip(here, there, strict=True):
        assert a.opening_width == pytest.approx(b.opening_width, abs=1e-9)
        assert a.object_width == pytest.approx(b.object_width, abs=1e-9)


def _box_clearances(detector, boxes, noise=None):
    """Per-finger clearance [m] of each detected grasp's opening from the true box (its need
    read off the analytic surface, in the scene the camera saw: a depth scale error moves the
    box along the rays), and its seen width minus the true one; grasps whose true need is over
    the hand's ``max_width`` left out."""
    clearances, widths = [], []
    for seed, (half, yaw) in enumerate(boxes):
        depth, truth = _box_depth(half, yaw), _box_surface(half, yaw)
        depth = np.where(np.isfinite(depth), depth, 0)  # rays that miss the table
        if noise:
            noisy = noisy_depth(depth, noise, seed).astype(np.float32)
            seen = (depth > 0) & (noisy > 0)
            scale = np.median(noisy[seen] / depth[seen])
            truth = CAMERA[:3, 3] + scale * (truth - CAMERA[:3, 3])
            depth = noisy
        grasps = detector.detect(depth, SMALL, CAMERA)
        assert grasps, f"no grasp on box {seed}"
        true = with_widths(grasps, detector.gripper, truth, TABLE_HEIGHT)
        for grasp, exact in zip(grasps, true, strict=True):
            assert grasp.tcp_offset == detector.gripper.tcp_offset
            assert 0 < grasp.opening_width <= detector.gripper.max_width
            if exact.opening_width < detector.gripper.max_width:
                need = exact.opening_width - OPENING_MARGIN
                clearances.append((grasp.opening_width - need) / 2)
            if grasp.object_width is not None:
                widths.append(grasp.object_width - exact.object_width)
    return np.array(clearances), np.array(widths)


def _boxes(count, seed=0):
    rng = np.random.default_rng(seed)
    return [
        (rng.uniform([0.01, 0.01, 0.015], [0.035, 0.045, 0.06]), rng.uniform(0, np.pi))
        for _ in range(count)
    ]


def test_the_detectors_opening_clears_rendered_boxes():
    # the grasps above the validity threshold, the study's (the card's forced ones come closer)
    detector = GraspDetector.from_pretrained(
        "bingham2d-robotiq-2f85", device="cpu", operating_point=False
    )
    clearances, widths = _box_clearances(detector, _boxes(4))
    assert len(clearances) >= 3
    assert clearances.min() >= 0.003  # the true box, unseen back included, clears each finger
    assert widths.max() <= 0.01  # a single view sees at most the object's width (+ TSDF error)


@pytest.mark.slow
@pytest.mark.parametrize("noise", [None, "dex"])
def test_the_opening_clears_rendered_boxes_for_both_hands(noise):
    """The study docs/detect.md quotes: 20 boxes a hand, without and with the field's noise."""
    clearances, widths = [], []
    for hand in ("robotiq-2f85", "franka"):
        detector = GraspDetector.from_pretrained(f"bingham2d-{hand}", device="cpu")
        hand_clearances, hand_widths = _box_clearances(detector, _boxes(20), noise)
        clearances.append(hand_clearances)
        widths.append(hand_widths)
    clearances, widths = np.concatenate(clearances), np.concatenate(widths)
    print(
        f"noise {noise}: {len(clearances)} grasps; clearance per finger min "
        f"{1e3 * clearances.min():.1f} mm, 5 % {1e3 * np.percentile(clearances, 5):.1f} mm, "
        f"median {1e3 * np.median(clearances):.1f} mm; seen − true width median "
        f"{1e3 * np.median(widths):.1f} mm, max {1e3 * widths.max():.1f} mm"
    )
    assert clearances.min() >= 0  # no finger meets the true box
    assert np.percentile(clearances, 5) >= 0.003


@pytest.mark.parametrize("gripper", [FRANKA, ROBOTIQ_2F85], ids=lambda g: g.name)
def test_the_flange_stands_tcp_offset_behind_the_tcp_of_each_built_in_hand(gripper):
    text = (SPEC_FOLDER / f"{gripper.name}.toml").read_text()
    offset = float(re.search(r"^tcp_offset = ([0-9.]+)", text, re.MULTILINE).group(1))
    T = T_flange_tcp(gripper)
    assert np.array_equal(T[:3, :3], np.eye(3)) and np.allclose(T[:3, 3], [offset, 0, 0])
    pose = np.eye(4)
    pose[:3, :3] = _turn(0.4) @ TOP_DOWN
    pose[:3, 3] = [0.1, 0.2, 0.3]
    grasp = Grasp(pose, 0.5, tcp_offset=gripper.tcp_offset)
    flange = grasp.flange_pose()
    assert np.allclose(flange[:3, :3], pose[:3, :3])
    assert np.allclose(flange[:3, 3], pose[:3, 3] - offset * grasp.approach)
    assert np.allclose(flange @ T, pose)  # T_world_flange · T_flange_tcp = T_world_tcp
    move = np.eye(4)
    move[:3, :3], move[:3, 3] = _turn(-0.7), [0.5, 0.0, -0.1]
    assert np.allclose(grasp.transformed(move).flange_pose(), move @ flange)


def test_a_spec_files_tcp_offset_places_its_flange(tmp_path):
    text = (SPEC_FOLDER / "franka.toml").read_text()
    path = tmp_path / "long-wrist.toml"
    path.write_text(text.replace('name = "franka"', 'name = "long-wrist"').replace("0.1034", "0.2"))
    assert np.allclose(T_flange_tcp(get_gripper(path))[:3, 3], [0.2, 0, 0])


def test_the_record_holds_the_flange_and_widths_or_null():
    pose = np.eye(4)
    pose[:3, 3] = [0.1, 0.2, 0.3]
    bare = Grasp(pose, 0.5).record()
    assert (bare["T_world_flange"], bare["opening_width"], bare["object_width"]) == (None,) * 3
    with pytest.raises(ValueError, match="tcp_offset"):
        Grasp(pose, 0.5).flange_pose()
    full = Grasp(pose, 0.5, opening_width=0.0612345678, object_width=0.04, tcp_offset=0.1)
    record = json.loads(json.dumps(full.record(), allow_nan=False))
    assert record["opening_width"] == 0.061235 and record["object_width"] == 0.04
    assert np.allclose(record["T_world_flange"], full.flange_pose())
    assert np.allclose(np.array(record["T_world_flange"])[:3, 3], [0.0, 0.2, 0.3])
