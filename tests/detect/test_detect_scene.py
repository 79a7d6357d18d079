"""Detection beyond one cube (`symgrasp.detect.scene`): the whole table and the object asked
for, on rendered scenes of boxes spread over a 1 m × 0.6 m table; a stand-in network where the
grasps' places matter, the shipped model where realism does. The objects' masks are the oracle's:
the pixels whose points lie inside a box's known volume."""

import warnings

import numpy as np
import pytest
from conftest import FixedNet, bingham2d_channels

from symgrasp.detect import GraspDetector, NoGraspWarning
from symgrasp.detect.scene import MERGE_RADIUS, detect_object, detect_table, hand_margin
from symgrasp.perception import CameraIntrinsic, fit_table, look_at
from symgrasp.sim import ROBOTIQ_2F85, World
from symgrasp.sim.objects import flat_box
from symgrasp.sim.render import make_renderer
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE, WORKSPACE_SIZE

R = RESOLUTION
K = CameraIntrinsic().scaled(0.5)  # 320 × 240: ≈ 3.7 mm per pixel on the table
TABLE = (np.array([-0.35, -0.15]), np.array([0.65, 0.45]))  # the 1 m × 0.6 m table [m]
CAMERA = look_at(np.array([0.15, -0.2, 0.95]), np.array([0.15, 0.15, TABLE_HEIGHT]))
HEIGHT = 0.06  # every box's height [m]
BOXES = {  # name: (centre x, y [m], size x, y [m])
    "A": (-0.25, 0.0, 0.05, 0.05),  # far left, B far right: no cube holds both
    "B": (0.55, 0.30, 0.05, 0.07),
    "C": (0.15, 0.15, 0.05, 0.05),  # C and D 4.5 cm apart: one cube
    "D": (0.24, 0.15, 0.04, 0.06),
}


def _world(boxes: dict) -> World:
    objects = [flat_box((sx, sy, HEIGHT), "box", name) for name, (_, _, sx, sy) in boxes.items()]
    poses = np.tile(np.eye(4), (len(objects), 1, 1))
    poses[:, :2, 3] = [(x, y) for x, y, _, _ in boxes.values()] or np.empty((0, 2))
    poses[:, 2, 3] = TABLE_HEIGHT
    return World(objects, poses)


def _points(depth: np.ndarray) -> np.ndarray:
    return (depth[..., None] * K.pixel_rays()) @ CAMERA[:3, :3].T + CAMERA[:3, 3]


def _render(boxes: dict) -> np.ndarray:
    """The depth image of ``boxes`` on the table, nothing seen past the table's edge."""
    depth = make_renderer(K).render(_world(boxes), CAMERA)
    xy = _points(depth)[..., :2]
    return np.where(np.all((xy >= TABLE[0]) & (xy <= TABLE[1]), axis=-1), depth, 0.0)


def _mask(depth: np.ndarray, name: str, tolerance: float = 0.003) -> np.ndarray:
    """The pixels of box ``name``: their points inside its volume, grown by ``tolerance``."""
    x, y, sx, sy = BOXES[name]
    p = _points(depth)
    inside = (np.abs(p[..., 0] - x) <= sx / 2 + tolerance) & (
        np.abs(p[..., 1] - y) <= sy / 2 + tolerance
    )
    return inside & (p[..., 2] > TABLE_HEIGHT + tolerance) & (depth > 0)


def _pixel(point) -> tuple[int, int]:
    """The pixel (u, v) a world point projects to."""
    p = np.linalg.inv(CAMERA) @ np.r_[point, 1.0]
    return round(K.fx * p[0] / p[2] + K.cx), round(K.fy * p[1] / p[2] + K.cy)


def _off(position, name: str) -> float:
    """[m] horizontal distance of ``position`` from box ``name``'s footprint (0 inside)."""
    x, y, sx, sy = BOXES[name]
    gap = np.maximum(np.abs(position[:2] - (x, y)) - (sx / 2, sy / 2), 0.0)
    return float(np.linalg.norm(gap))


@pytest.fixture(scope="module")
def depth():
    return _render(BOXES)


# -- a stand-in network: the same grasps in every cube -----------------------------------

TOP_DOWN = np.c_[[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]  # e_x down, closing along x
GRASP_Z = int((TABLE_HEIGHT + HEIGHT - 0.01) / VOXEL_SIZE)  # the TCP 1 cm below a box's top
CENTRE = (R // 2, R // 2, GRASP_Z)


def _same_grasps_net(voxels: dict) -> FixedNet:
    """A grasp at each voxel of ``voxels`` {(i, j, k): score}, top-down, closing along world x,
    whatever the TSDF."""
    channels = bingham2d_channels(TOP_DOWN)
    return FixedNet("bingham2d", {v: (score, 0.95, channels) for v, score in voxels.items()})


def _fixed(voxels: dict, **options) -> GraspDetector:
    return GraspDetector(_same_grasps_net(voxels), ROBOTIQ_2F85, device="cpu", **options)


def test_one_cube_per_group_of_objects_each_grasp_on_its_objects(depth):
    """A and B lie 85 cm apart, C and D 4.5 cm: three cubes, each centred on its objects' box
    (the stand-in's centre voxel there), in the detector's world frame."""
    found = detect_table(_fixed({CENTRE: 0.9}), depth, K, CAMERA)
    assert len(found.origins) == 3 and sorted(found.workspace) == [0, 1, 2]
    assert np.allclose(found.origins[:, 2], 0.0)
    half = VOXEL_SIZE / 2  # the centre voxel's centre lies half a voxel past the cube's centre
    centres = found.origins[:, :2] + WORKSPACE_SIZE / 2 + half
    expected = {"A": (-0.25, 0.0), "B": (0.55, 0.30), "CD": (0.1925, 0.15)}
    for name, xy in expected.items():
        assert np.min(np.linalg.norm(centres - xy, axis=1)) < 0.01, name
    assert len(found.grasps) == 3
    for grasp in found.grasps:
        # over A, over B, or between C and D: its pads reach both
        assert (
            min(_off(grasp.position, "A"), _off(grasp.position, "B")) == 0.0
            or max(_off(grasp.position, "C"), _off(grasp.position, "D")) < 0.045
        )
        assert np.allclose(grasp.pose[:3, :3] @ grasp.pose[:3, :3].T, np.eye(3), atol=1e-6)
    timing = found.timing
    assert {"objects", "tsdf", "network", "decode", "select", "total"} <= set(timing)
    assert timing["total"] >= timing["network"] > 0


@pytest.mark.parametrize(("span", "cubes"), [(0.18, 1), (0.225, 2), (0.70, 2)])
def test_two_groups_share_a_cube_where_both_fit_its_core_whole(span, cubes):
    """Two 4 cm boxes whose far sides lie ``span`` apart: one cube where the span fits its core
    (the cube less the open hand's half span each side: 30 − 2 × 4.85 = 20.3 cm for the
    2F-85), whichever grouping; two where it does not, each centred on its box, so that every
    box keeps the hand's margin in its cube."""
    core = WORKSPACE_SIZE - 2 * hand_margin(ROBOTIQ_2F85)
    assert core == pytest.approx(0.203)
    x = 0.15 - span / 2 + 0.02  # the boxes' centres, symmetric about x = 0.15
    boxes = {"left": (x, 0.15, 0.04, 0.04), "right": (x + span - 0.04, 0.15, 0.04, 0.04)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoGraspWarning)  # the stand-in's grasp may hold nothing
        found = detect_table(_fixed({CENTRE: 0.9}), _render(boxes), K, CAMERA)
    assert len(found.origins) == cubes
    centres = np.sort(found.origins[:, 0]) + WORKSPACE_SIZE / 2
    expected = [0.15] if cubes == 1 else [x, x + span - 0.04]
    assert np.allclose(centres, expected, atol=0.01)
    margin = (WORKSPACE_SIZE - core) / 2
    low, high = found.origins[:, 0] + margin, found.origins[:, 0] + WORKSPACE_SIZE - margin
    for bx, *_ in boxes.values():  # whole in a cube's core, to the pixels' 4 mm
        assert np.any((low <= bx - 0.02 + 0.004) & (bx + 0.02 <= high + 0.004))


def test_grasps_that_close_on_no_object_of_their_cube_are_dropped(depth):
    """A voxel 12 cm off every cube's centre lies over bare table in each cube: its grasps hold
    no object point; only the centre voxel's remain."""
    off = (CENTRE[0] - 16, CENTRE[1], GRASP_Z)
    found = detect_table(_fixed({CENTRE: 0.5, off: 0.9}), depth, K, CAMERA)
    assert len(found.grasps) == 3
    with pytest.warns(NoGraspWarning, match="none of the 3 grasps of the cubes closes on"):
        assert detect_table(_fixed({off: 0.9}), depth, K, CAMERA).grasps == []


def test_grasps_of_two_cubes_within_the_merge_radius_count_once():
    """A 42 cm box, cut into three cubes (each holds a piece of it, so a grasp anywhere on it is
    each cube's). A second voxel one cube-step off the centre puts each cube's grasp on the next
    cube's: the worse of two (another cube's, within `MERGE_RADIUS`) is dropped; within 0 m both
    stay, within a metre only the best grasp's cube is left (a cube's own grasps stay: its
    non-maximum suppression has spoken)."""
    image = _render({"long": (0.15, 0.15, 0.42, 0.05)})
    origins = detect_table(_fixed({CENTRE: 0.9}), image, K, CAMERA).origins
    assert len(origins) == 3 and np.ptp(origins[:, 1]) < 1e-3
    step = round(float(np.median(np.diff(np.sort(origins[:, 0])))) / VOXEL_SIZE)
    detector = _fixed({CENTRE: 0.9, (CENTRE[0] + step, CENTRE[1], GRASP_Z): 0.5})
    every = detect_table(detector, image, K, CAMERA, merge_radius=0.0)
    assert sorted(g.score for g in every.grasps) == pytest.approx([0.5, 0.5, 0.9, 0.9, 0.9])
    merged = detect_table(detector, image, K, CAMERA)
    assert [g.score for g in merged.grasps] == pytest.approx([0.9, 0.9, 0.9])
    one = detect_table(detector, image, K, CAMERA, merge_radius=1.0)
    assert [g.score for g in one.grasps] == pytest.approx([0.9, 0.5])
    assert len(set(one.workspace)) == 1
    assert MERGE_RADIUS == pytest.approx(2 * VOXEL_SIZE)


def test_a_row_wider_than_a_core_is_cut_into_cubes_that_overlap_by_the_hands_span():
    """A 45 cm long box: more than one cube's core (the cube less the open hand's half span on
    each side); its cubes overlap by at least the open hand's span, so that whatever the hand
    closes across lies whole in one of them, and together they cover it."""
    long = {"long": (0.15, 0.15, 0.45, 0.05)}
    found = detect_table(_fixed({CENTRE: 0.9}), _render(long), K, CAMERA)
    xs = np.sort(found.origins[:, 0])
    margin = hand_margin(ROBOTIQ_2F85)
    assert margin == pytest.approx(0.085 / 2 + 0.006)  # the Robotiq 2F-85's open pads
    assert len(xs) >= 3 and np.all(WORKSPACE_SIZE - np.diff(xs) >= 2 * margin - 1e-9)
    assert (
        xs[0] + margin <= 0.15 - 0.225 + 0.01
        and xs[-1] + WORKSPACE_SIZE - margin >= 0.15 + 0.225 - 0.01
    )


def test_the_detectors_depth_correction_is_applied_once_before_the_objects_are_found(depth):
    """A sensor reading 5 % deep, with ``depth_scale`` 1.05: the same cubes as the true depth
    (without the correction the table would lie 5 cm low and no object would stand on it)."""
    truth = detect_table(_fixed({CENTRE: 0.9}), depth, K, CAMERA)
    scaled = detect_table(_fixed({CENTRE: 0.9}, depth_scale=1.05), depth * 1.05, K, CAMERA)
    assert np.allclose(np.sort(scaled.origins, axis=0), np.sort(truth.origins, axis=0), atol=1e-3)


def test_the_fitted_table_gives_the_same_cubes_as_the_known_one(depth):
    """With the table fitted in the image (no extrinsic), the grasps in the fitted frame, taken
    to the world, are those the known world frame gives, within the voxel grid's turn (the
    fitted cube's x points at the camera: the centre voxel's half-voxel offset turns with it)
    and the fit's error."""
    fit = fit_table(depth, K, up=CAMERA[:3, :3].T @ [0.0, 0.0, 1.0])
    fitted = detect_table(_fixed({CENTRE: 0.9}), depth, K, fit.T_workspace_camera)
    T_world_fitted = CAMERA @ fit.T_camera_workspace
    known = detect_table(_fixed({CENTRE: 0.9}), depth, K, CAMERA)
    for grasp in fitted.grasps:
        position = grasp.transformed(T_world_fitted).position
        assert np.min(np.linalg.norm([g.position - position for g in known.grasps], axis=1)) < 0.015


def test_an_empty_table_gives_no_grasp_and_says_where_it_looked():
    with pytest.warns(NoGraspWarning, match="no object stands on the table"):
        found = detect_table(_fixed({CENTRE: 0.9}), _render({}), K, CAMERA)
    assert found.grasps == [] and found.origins.shape == (0, 3)


def test_a_mask_centres_the_cube_on_its_object_and_keeps_its_grasps_only(depth):
    """C's mask: the cube centred on C's points; the stand-in's grasp over C kept, its grasp
    over D (12 voxels along x, 9 cm) dropped, though both lie in the cube."""
    on_d = (CENTRE[0] + 12, CENTRE[1], GRASP_Z)
    detector = _fixed({CENTRE: 0.5, on_d: 0.9})
    found = detect_object(detector, depth, K, CAMERA, mask=_mask(depth, "C"))
    centre = found.origins[0, :2] + WORKSPACE_SIZE / 2
    assert np.linalg.norm(centre - BOXES["C"][:2]) < 0.015
    assert len(found.grasps) == 1 and _off(found.grasps[0].position, "C") == 0.0
    plain = _fixed({CENTRE: 0.5, on_d: 0.9}, workspace_origin=tuple(found.origins[0]))
    assert {_nearest(g.position) for g in plain.detect(depth, K, CAMERA)} == {"C", "D"}


def _nearest(position) -> str:
    return min(BOXES, key=lambda name: _off(position, name))


def test_a_pixel_and_a_box_select_what_the_mask_selects(depth):
    mask = _mask(depth, "C")
    by_mask = detect_object(_fixed({CENTRE: 0.9}), depth, K, CAMERA, mask=mask)
    x, y, sx, sy = BOXES["C"]
    top = TABLE_HEIGHT + HEIGHT
    by_pixel = detect_object(_fixed({CENTRE: 0.9}), depth, K, CAMERA, pixel=_pixel((x, y, top)))
    corners = [
        _pixel((x + a * sx / 2, y + b * sy / 2, z))
        for a in (-1, 1)
        for b in (-1, 1)
        for z in (TABLE_HEIGHT, top)
    ]
    u, v = np.array(corners).T
    box = (int(u.min()) - 2, int(v.min()) - 2, int(u.max()) + 2, int(v.max()) + 2)
    by_box = detect_object(_fixed({CENTRE: 0.9}), depth, K, CAMERA, box=box)
    for found in (by_pixel, by_box):
        assert np.allclose(found.origins, by_mask.origins, atol=0.005)
    assert (
        detect_object(
            _fixed({CENTRE: 0.9}), depth, K, CAMERA, mask=mask.astype(np.uint8)
        ).origins.tolist()
        == by_mask.origins.tolist()
    )


BAD_SELECTIONS = {
    "none": ({}, "exactly one of mask, pixel and box"),
    "two": ({"pixel": (1, 1), "box": (0, 0, 2, 2)}, "exactly one of mask, pixel and box"),
    "a mask of another shape": ({"mask": np.ones((2, 2), bool)}, r"mask must have the depth image's shape \(240, 320\)"),
    "a mask of 2s": ({"mask": np.full((240, 320), 2)}, "mask must hold booleans or 0 and 1"),
    "an empty mask": ({"mask": np.zeros((240, 320), bool)}, "selects no depth point standing"),
    "a pixel off the image": ({"pixel": (320, 0)}, r"pixel must be \(u, v\): integer pixels, u in \[0, 320\)"),
    "a pixel of floats": ({"pixel": (1.5, 2.0)}, "integer pixels"),
    "a pixel on the table": ({"pixel": (232, 147)}, r"pixel \(u, v\) = \(232, 147\) sees the table"),
    "a pixel past the table": ({"pixel": (160, 235)}, r"pixel \(u, v\) = \(160, 235\) sees no depth"),
    "a box of three": ({"box": (0, 0, 5)}, r"box must be \(u0, v0, u1, v1\)"),
    "a box inside out": ({"box": (10, 10, 5, 20)}, "u0 ≤ u1 and v0 ≤ v1"),
    "a box on bare table": ({"box": (220, 140, 240, 150)}, r"the box \(220, 140, 240, 150\) selects no depth point"),
}  # fmt: skip


@pytest.mark.parametrize("case", BAD_SELECTIONS)
def test_a_bad_selection_is_refused_naming_it(depth, case):
    selection, message = BAD_SELECTIONS[case]
    with pytest.raises(ValueError, match=message):
        detect_object(_fixed({CENTRE: 0.9}), depth, K, CAMERA, **selection)


def test_an_object_is_selected_in_one_image_and_merge_radius_is_checked(depth):
    with pytest.raises(ValueError, match="select in one depth image, got 2"):
        detect_object(
            _fixed({CENTRE: 0.9}),
            np.stack([depth, depth]),
            K,
            np.stack([CAMERA, CAMERA]),
            pixel=(1, 1),
        )
    with pytest.raises(ValueError, match="merge_radius must be ≥ 0 m"):
        detect_table(_fixed({CENTRE: 0.9}), depth, K, CAMERA, merge_radius=float("nan"))


# -- the shipped model ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def shipped():
    # the library's defaults: the grasps these scenes were checked with, above the threshold
    return GraspDetector.from_pretrained(
        "bingham2d-robotiq-2f85", device="cpu", operating_point=False
    )


def test_the_whole_table_finds_objects_that_no_one_cube_holds(shipped, depth):
    """A and B lie 80 cm apart: the whole table gives grasps on both, the detector's own cube
    at the origin neither."""
    found = detect_table(shipped, depth, K, CAMERA)
    near = {name: [g for g in found.grasps if _off(g.position, name) < 0.02] for name in BOXES}
    assert near["A"] and near["B"], {name: len(g) for name, g in near.items()}
    scores = [g.score for g in found.grasps]
    assert scores == sorted(scores, reverse=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoGraspWarning)
        one = shipped.detect(depth, K, CAMERA)
    assert not [g for g in one if min(_off(g.position, n) for n in "AB") < 0.05]


def test_the_object_asked_for_gets_grasps_on_it_alone(shipped, depth):
    """C asked for by its mask: every grasp kept lies on C (its TCP over C's footprint, within
    the 7.5 mm voxel), nearer C than D; the same cube without the selection has grasps on D."""
    found = detect_object(shipped, depth, K, CAMERA, mask=_mask(depth, "C"))
    assert found.grasps
    for grasp in found.grasps:
        assert _off(grasp.position, "C") <= VOXEL_SIZE and _nearest(grasp.position) == "C"
    cube = GraspDetector.from_pretrained(
        "bingham2d-robotiq-2f85",
        device="cpu",
        workspace_origin=tuple(found.origins[0]),
        operating_point=False,
    )
    assert "D" in {_nearest(g.position) for g in cube.detect(depth, K, CAMERA)}


# -- the command line ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def files(tmp_path_factory, depth):
    """The scene's depth image, camera and pose as `symgrasp detect` reads them; C's mask."""
    import json

    from PIL import Image

    folder = tmp_path_factory.mktemp("scene")
    np.save(folder / "depth.npy", depth)
    keys = ("fx", "fy", "cx", "cy", "width", "height")
    (folder / "k.json").write_text(json.dumps({key: getattr(K, key) for key in keys}))
    (folder / "t.json").write_text(json.dumps(CAMERA.tolist()))
    Image.fromarray(_mask(depth, "C").astype(np.uint8) * 255).save(folder / "c.png")
    return folder


def _cli(files, out: str, *extra: str) -> list:
    import json

    from symgrasp.cli import main

    inputs = ["--depth", "depth.npy", "--intrinsic", "k.json", "--extrinsic", "t.json"]
    main(
        [
            "detect",
            *(str(files / a) if a.endswith(("npy", "json", "png")) else a for a in inputs),
            *extra,
            "--no-operating-point",  # as the `shipped` fixture
            "--out",
            str(files / out),
        ]
    )
    return json.loads((files / out / "grasps.json").read_text())["grasps"]


def test_symgrasp_detect_answers_as_the_api(shipped, depth, files):
    assert _cli(files, "table", "--whole-table") == [
        g.record() for g in detect_table(shipped, depth, K, CAMERA).grasps
    ]
    asked = [
        g.record() for g in detect_object(shipped, depth, K, CAMERA, mask=_mask(depth, "C")).grasps
    ]
    assert _cli(files, "mask", "--mask", str(files / "c.png")) == asked
    u, v = _pixel((*BOXES["C"][:2], TABLE_HEIGHT + HEIGHT))
    by_pixel = detect_object(shipped, depth, K, CAMERA, pixel=(u, v)).grasps
    assert _cli(files, "pixel", "--pixel", str(u), str(v)) == [g.record() for g in by_pixel]
    fitted = _cli(files, "fitted", "--whole-table", "--fit-table")  # in --extrinsic's frame
    fit = fit_table(depth, K, up=CAMERA[:3, :3].T @ [0.0, 0.0, 1.0])
    on_fit = detect_table(shipped, depth, K, fit.T_workspace_camera).grasps
    assert len(fitted) == len(on_fit) > 0
    for grasp, expected in zip(fitted, on_fit, strict=True):
        pose = expected.transformed(CAMERA @ fit.T_camera_workspace).pose
        assert np.allclose(grasp["T_world_tcp"], pose, atol=2e-6)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--whole-table", "--model", "vgn"], "--whole-table needs a symgrasp model"),
        (["--mask", "t.json"], "--mask must be a .npy or .png file"),
        (["--box", "10", "10", "5", "20"], "u0 ≤ u1 and v0 ≤ v1"),
    ],
)
def test_symgrasp_detect_refuses_a_bad_scene_option_in_one_line(files, extra, message):
    extra = [str(files / a) if a.endswith("json") else a for a in extra]
    with pytest.raises(SystemExit, match=message):
        _cli(files, "bad", *extra)
