"""The grasp server's whole-table and object requests (``whole_table``, ``mask``, ``pixel``,
``box``): answered as `symgrasp.detect.scene` answers here, in the request's frame, and refused
naming the field when malformed."""

import json
import threading

import numpy as np
import pytest

from symgrasp.detect import GraspDetector
from symgrasp.detect.scene import detect_object, detect_table
from symgrasp.perception import CameraIntrinsic, TableWarning, fit_table, look_at
from symgrasp.serve.client import POSES, GraspClient, ServerError
from symgrasp.serve.protocol import encode_array
from symgrasp.serve.server import GraspServer, answer
from symgrasp.sim import World
from symgrasp.sim.objects import flat_box
from symgrasp.sim.render import make_renderer
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

K = CameraIntrinsic().scaled(0.5)
CAMERA = look_at(np.array([0.15, -0.2, 0.95]), np.array([0.15, 0.15, TABLE_HEIGHT]))
BOXES = {"left": (-0.2, 0.1), "right": (0.5, 0.2)}  # [m] 70 cm apart: two cubes
SIZE = (0.05, 0.05, 0.06)


@pytest.fixture(scope="module")
def detector():
    return GraspDetector.from_pretrained("bingham2d-robotiq-2f85", device="cpu")


def depth_of_boxes() -> np.ndarray:
    objects = [flat_box(SIZE, "box", name) for name in BOXES]
    poses = np.tile(np.eye(4), (len(objects), 1, 1))
    poses[:, :2, 3] = list(BOXES.values())
    poses[:, 2, 3] = TABLE_HEIGHT
    return make_renderer(K).render(World(objects, poses), CAMERA)


@pytest.fixture(scope="module")
def depth():
    return depth_of_boxes()


def _left_mask(depth) -> np.ndarray:
    """The left box's pixels: their points inside its volume (the oracle's mask)."""
    points = (depth[..., None] * K.pixel_rays()) @ CAMERA[:3, :3].T + CAMERA[:3, 3]
    x, y = BOXES["left"]
    inside = (np.abs(points[..., 0] - x) <= 0.028) & (np.abs(points[..., 1] - y) <= 0.028)
    return inside & (points[..., 2] > TABLE_HEIGHT + 0.003) & (depth > 0)


def _body(depth, **fields) -> dict:
    """A request as JSON carries it (parsed again: what the server reads)."""
    body = {
        "depth": encode_array(depth),
        "intrinsic": K.K.tolist(),
        "T_world_camera": CAMERA.tolist(),
    }
    body.update(fields)
    return json.loads(json.dumps({k: v for k, v in body.items() if v is not None}))


def _records(grasps) -> list:
    return [g.record() for g in grasps]


def test_a_whole_table_request_is_answered_as_detect_table_answers_here(detector, depth):
    reply = answer(detector, _body(depth, whole_table=True))
    found = detect_table(detector, depth, K, CAMERA)
    assert reply["grasps"] == _records(found.grasps) and reply["grasps"]
    assert len(reply["workspaces"]) == len(found.origins) == 2
    for pose, origin in zip(reply["workspaces"], found.origins, strict=True):
        assert np.allclose(np.array(pose)[:3, 3], origin) and np.allclose(
            np.array(pose)[:3, :3], np.eye(3)
        )
    assert {"objects", "network", "select", "server"} <= set(reply["timing_ms"])
    assert answer(detector, _body(depth, whole_table=False))["grasps"] == _records(
        detector.detect(depth, K, CAMERA)
    )


def test_a_whole_table_on_the_fitted_table_answers_in_the_requests_frame(detector, depth):
    """With fit_table the grasps come in the frame of T_world_camera: near the known frame's
    (the fitted cubes turn with the fitted frame, so voxel centres move by up to a voxel)."""
    reply = answer(detector, _body(depth, whole_table=True, fit_table=True))
    known = detect_table(detector, depth, K, CAMERA).grasps
    assert len(reply["workspaces"]) == 2
    for cube in reply["workspaces"]:
        centre = np.array(cube) @ [WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2, TABLE_HEIGHT, 1.0]
        assert min(np.linalg.norm(centre[:2] - xy) for xy in BOXES.values()) < 0.01
        assert abs(centre[2] - TABLE_HEIGHT) < 0.003
    for grasp in reply["grasps"][:3]:
        position = np.array(grasp["T_world_tcp"])[:3, 3]
        assert min(np.linalg.norm(g.position - position) for g in known) < 0.02


def test_an_object_asked_for_by_mask_pixel_or_box_is_answered_as_detect_object(detector, depth):
    mask = _left_mask(depth)
    expected = _records(detect_object(detector, depth, K, CAMERA, mask=mask).grasps)
    assert expected
    for encoded in (mask.astype(int).tolist(), encode_array(mask.astype(np.uint16))):
        assert answer(detector, _body(depth, mask=encoded))["grasps"] == expected
    rows, cols = np.nonzero(mask)
    u, v = int(np.median(cols)), int(np.median(rows))
    pixel = answer(detector, _body(depth, pixel=[u, v]))
    assert pixel["grasps"] == _records(
        detect_object(detector, depth, K, CAMERA, pixel=(u, v)).grasps
    )
    box = [int(cols.min()), int(rows.min()), int(cols.max()), int(rows.max())]
    reply = answer(detector, _body(depth, box=box))
    assert reply["grasps"] == _records(
        detect_object(detector, depth, K, CAMERA, box=tuple(box)).grasps
    )
    assert len(reply["workspaces"]) == 1


MALFORMED = {
    "a number for whole_table": ({"whole_table": 1}, "whole_table must be true or false"),
    "a text mask": ({"mask": "left"}, "mask must be an array"),
    "a mask of 2s": ({"mask": [[2]]}, r"mask must have the depth image's shape"),
    "a pixel of floats": ({"pixel": [1.5, 2]}, r"pixel must be 2 integer pixels \(u, v\)"),
    "a pixel of booleans": ({"pixel": [True, 2]}, "pixel must be 2 integer pixels"),
    "a pixel as text": ({"pixel": "10 20"}, "pixel must be 2 integer pixels"),
    "a box of three": ({"box": [0, 0, 5]}, r"box must be 4 integer pixels \(u0, v0, u1, v1\)"),
    "a pixel off the image": ({"pixel": [320, 0]}, r"pixel must be \(u, v\): integer pixels, u in \[0, 320\)"),
    "a mask and a pixel": ({"mask": [[1]], "pixel": [1, 1]}, r"at most one of whole_table, mask, pixel and box, got \['mask', 'pixel'\]"),
    "the whole table and a box": ({"whole_table": True, "box": [0, 0, 1, 1]}, "at most one of whole_table"),
}  # fmt: skip


@pytest.mark.parametrize("case", MALFORMED)
def test_a_malformed_scene_request_is_refused_naming_the_field(detector, depth, case):
    fields, message = MALFORMED[case]
    with pytest.raises(ValueError, match=message):
        answer(detector, _body(depth, **fields))


def test_scene_fields_go_with_one_depth_image(detector, depth):
    with pytest.raises(ValueError, match="pixel selects in one depth image, got 2"):
        answer(
            detector,
            _body(np.stack([depth, depth]), pixel=[1, 1], T_world_camera=[CAMERA.tolist()] * 2),
        )
    points = {"points": [[0.0, 0.0, 0.1]], "T_world_camera": CAMERA.tolist()}
    for field, value in (
        ("whole_table", True),
        ("mask", [[1]]),
        ("pixel", [1, 1]),
        ("box", [0, 0, 1, 1]),
    ):
        with pytest.raises(ValueError, match=f"{field} goes with depth, not with points"):
            answer(detector, {**points, field: value})


def test_the_table_fits_doubt_reaches_the_answer(detector):
    """A wall 6 cm in front of the camera's foot hides most of the table: the plane fitted holds
    13 % of the points, under `MIN_TABLE_SHARE`; the answer says so in its warnings, as
    `fit_table` says it to the process (`TableFit.warning`, one message)."""
    wall = flat_box((2.0, 0.02, 1.6), "box", "wall")
    pose = np.eye(4)
    pose[:3, 3] = (0.15, -0.14, TABLE_HEIGHT)
    walled = make_renderer(K).render(World([wall], pose[None]), CAMERA)
    with pytest.warns(TableWarning) as caught:
        fit = fit_table(walled, K, up=CAMERA[:3, :3].T @ [0.0, 0.0, 1.0])
    assert fit.doubts and str(caught[0].message) == fit.warning
    with pytest.warns(TableWarning):
        reply = answer(detector, _body(walled, fit_table=True))
    assert fit.warning in reply["warnings"] and "no dominant plane" in fit.warning
    clear = answer(detector, _body(depth_of_boxes(), fit_table=True))
    assert not any(message.startswith("fit_table:") for message in clear["warnings"])


def test_the_client_asks_for_the_whole_table_and_an_object(detector, depth):
    """`GraspClient.detect`'s ``whole_table``, ``mask``, ``pixel`` and ``box`` over loopback
    answer as `answer` does here: the same grasps (poses as arrays) and cube poses."""
    server = GraspServer(("127.0.0.1", 0), detector, "stand-in", log=None)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        client = GraspClient(server.url)
        mask = _left_mask(depth)
        v, u = np.argwhere(mask).mean(0).round().astype(int)
        asked = {
            "whole_table": ({"whole_table": True}, {"whole_table": True}),
            "mask": ({"mask": mask}, {"mask": encode_array(mask.astype(np.uint16))}),
            "pixel": ({"pixel": (u, v)}, {"pixel": [int(u), int(v)]}),
            "box": ({"box": (u - 5, v - 5, u + 5, v + 5)}, {"box": [int(u - 5), int(v - 5), int(u + 5), int(v + 5)]}),
        }  # fmt: skip
        for name, (arguments, fields) in asked.items():
            got = client.detect(depth, K.K, CAMERA, **arguments)
            expected = answer(detector, _body(depth, **fields))
            assert got.grasps, name
            for grasp, record in zip(got.grasps, expected["grasps"], strict=True):
                assert all(isinstance(grasp[key], np.ndarray) for key in POSES)
                assert {**grasp, **{key: grasp[key].tolist() for key in POSES}} == record
            assert [T.tolist() for T in got.workspaces] == expected["workspaces"]
        with pytest.raises(ServerError, match="at most one of whole_table, mask, pixel and box"):
            client.detect(depth, K.K, CAMERA, whole_table=True, pixel=(u, v))
    finally:
        server.shutdown()
        server.server_close()
