"""The grasp server over loopback: start, requests answered as the detector in this process
answers them, malformed requests answered 400 naming the field while the server goes on,
concurrent clients, shutdown (in a thread and as ``symgrasp serve`` stopped by a signal)."""

import base64
import http.client
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from bad_input_cases import CAMERA, INTRINSIC, MODEL, table_depth

from symgrasp.detect import GraspDetector
from symgrasp.perception import default_extrinsic, depth_to_points, fit_table
from symgrasp.perception.camera import CameraIntrinsic
from symgrasp.serve import DETECT_PATH, HEALTH_PATH, PROTOCOL
from symgrasp.serve.client import POSES, GraspClient, ServerError
from symgrasp.serve.protocol import RequestError, decode_array, encode_array
from symgrasp.serve.server import GraspServer
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene

ROOT = Path(__file__).resolve().parents[2]
SMALL = CameraIntrinsic().scaled(0.25)  # 160 × 120: a request of 77 kB


@pytest.fixture(scope="module")
def detector():
    return GraspDetector.from_pretrained(MODEL, device="cpu")


@pytest.fixture(scope="module")
def scene(detector):
    world = pile_scene(object_set("household-test", 5, seed=0), seed=0, gripper=detector.gripper)
    T = default_extrinsic()
    return make_renderer(SMALL).render(world, T), T


@pytest.fixture(scope="module")
def server(detector):
    """A server on a free loopback port, serving on a thread."""
    served = GraspServer(("127.0.0.1", 0), detector, MODEL, log=None)
    thread = threading.Thread(target=served.serve_forever)
    thread.start()
    yield served
    served.shutdown()
    served.server_close()
    thread.join()


def _records(grasps) -> list:
    return [g.record() for g in grasps]


def _served(detection) -> list:
    """The client's grasps as the server's records: every pose an array, back to lists."""
    assert all(isinstance(g[key], np.ndarray) for g in detection.grasps for key in POSES)
    return [{**g, **{key: g[key].tolist() for key in POSES}} for g in detection.grasps]


def test_arrays_travel_exactly_in_both_encodings():
    rng = np.random.default_rng(0)
    for array in (
        rng.random((3, 4)).astype(np.float32),
        rng.random(5),
        np.arange(6, dtype=np.uint16).reshape(2, 3),
    ):
        again = decode_array(
            json.loads(json.dumps(encode_array(array))), "a", ("float32", "float64", "uint16")
        )
        assert again.dtype == array.dtype and np.array_equal(again, array)
    assert np.array_equal(
        decode_array([[1, 2], [3, None]], "a"), [[1, 2], [3, np.nan]], equal_nan=True
    )
    wrong = [
        ({"dtype": "float32", "shape": [2]}, "a lacks data"),
        ({"dtype": "int64", "shape": [1], "data": ""}, "a.dtype must be one of float32, float64"),
        ({"dtype": "float32", "shape": [2], "data": "AAAA"}, "a.data holds 3 bytes; shape"),
        ({"dtype": "float32", "shape": [-1], "data": ""}, "a.shape must be a list of sizes"),
        ({"dtype": "float32", "shape": [1], "data": "!!"}, "a.data is not base64"),
        ([[1, 2], [3]], "a must be nested lists of numbers of one rectangular shape"),
        ("1 2 3", "a must be an array"),
    ]
    for value, said in wrong:
        with pytest.raises(RequestError, match=said):
            decode_array(value, "a")


def test_health_names_the_protocol_model_and_workspace(server, detector):
    reply = GraspClient(server.url).health()
    assert reply["protocol"] == PROTOCOL and reply["model"] == MODEL
    assert reply["gripper"] == detector.gripper.name == "robotiq-2f85"
    assert reply["workspace"] == {"origin": [0.0, 0.0, 0.0], "size": 0.3, "table_height": 0.05}


@pytest.mark.parametrize("encoding", ["base64", "lists"])
def test_a_depth_request_is_answered_as_the_detector_answers_here(
    server, detector, scene, encoding
):
    depth, T = scene
    expected = _records(detector.detect(depth, SMALL, T))
    assert len(expected) >= 2
    client = GraspClient(server.url, encoding=encoding)
    got = client.detect(depth, SMALL.K, T)
    assert _served(got) == expected
    assert got.warnings == [] and {"tsdf", "network", "decode", "server"} <= set(got.timing_ms)
    assert _served(client.detect(depth, SMALL, T, top_k=1)) == expected[:1]
    millimetres = np.round(depth * 1000).astype(np.uint16)
    in_mm = client.detect(millimetres, SMALL.K, T, depth_scale=0.001)
    assert _served(in_mm) == _records(
        detector.detect((millimetres * 0.001).astype(np.float32), SMALL, T)
    )


def test_a_point_cloud_request_is_answered_as_detect_points(server, detector, scene):
    depth, T = scene
    cloud = depth_to_points(depth, SMALL, T, crop=False).astype(np.float32)
    got = GraspClient(server.url).detect_points(cloud, viewpoint=T[:3, 3])
    assert _served(got) == _records(detector.detect_points(cloud, viewpoint=T[:3, 3]))
    with_camera = GraspClient(server.url).detect_points(cloud, T, intrinsic=SMALL)
    assert _served(with_camera) == _records(detector.detect(depth, SMALL, T))


def test_fit_table_answers_in_the_requests_frame(server, detector, scene):
    depth, T = scene
    fit = fit_table(depth, SMALL, up=T[:3, :3].T @ [0.0, 0.0, 1.0])
    here = detector.detect(depth, SMALL, fit.T_workspace_camera)
    client = GraspClient(server.url)
    in_world = client.detect(depth, SMALL.K, T, fit_table=True)
    moved = [g.transformed(T @ fit.T_camera_workspace) for g in here]
    assert _served(in_world) == _records(moved)
    assert np.allclose(in_world.T_world_workspace, T @ fit.T_camera_workspace)
    in_camera = client.detect(depth, SMALL.K, fit_table=True)
    assert len(in_camera.grasps) == len(here)
    assert np.allclose(
        T @ in_camera.grasps[0]["T_world_tcp"], in_world.grasps[0]["T_world_tcp"], atol=1e-3
    )


def test_a_request_with_no_grasp_carries_the_warning(server):
    far = np.stack([table_depth() / 0.3048])  # feet read as metres
    got = GraspClient(server.url).detect(far, INTRINSIC.K, CAMERA[None])
    assert got.grasps == [] and "none of the" in got.warnings[0]


def _post(server, path: str, body: bytes, headers: dict | None = None) -> tuple[int, dict]:
    connection = http.client.HTTPConnection(*server.server_address[:2], timeout=30)
    connection.request("POST", path, body, headers or {})
    response = connection.getresponse()
    status, data = response.status, json.loads(response.read())
    connection.close()
    return status, data


def _request(**fields) -> bytes:
    depth = table_depth()
    body = {
        "depth": depth.tolist(),
        "intrinsic": INTRINSIC.K.tolist(),
        "T_world_camera": CAMERA.tolist(),
    }
    body.update(fields)
    return json.dumps({k: v for k, v in body.items() if v is not None}).encode()


MALFORMED = {
    "not JSON": (b"{depth: 1", 400, "the request is not JSON"),
    "a list": (b"[1, 2]", 400, "must be a JSON object"),
    "a misspelt field": (_request(top_K=3), 400, "unknown field top_K"),
    "no input": (json.dumps({"intrinsic": [[1, 0, 0]]}).encode(), 400, "give depth or points, exactly one"),
    "depth and points": (_request(points=[[0, 0, 1]]), 400, "give depth or points, exactly one"),
    "no intrinsic": (_request(intrinsic=None), 400, "intrinsic is missing"),
    "no pose": (_request(T_world_camera=None), 400, "T_world_camera is missing"),
    "a 3×4 pose": (_request(T_world_camera=np.eye(4)[:3].tolist()), 400, r"extrinsic must be T_world_camera \(4, 4\)"),
    "a scaled pose": (_request(T_world_camera=(2 * CAMERA).tolist()), 400, "not a rigid transform"),
    "depth of one row": (_request(depth=[1.0, 2.0]), 400, r"depth must be \(H, W\) or \(V, H, W\)"),
    "integer depth without scale": (_request(depth={"dtype": "uint16", "shape": [1, 1], "data": "AAA="}), 400, "depth_scale"),
    "an intrinsic without fy": (_request(intrinsic={"fx": 1, "cx": 1, "cy": 1}), 400, "intrinsic: expected"),
    "top_k 0": (_request(top_k=0), 400, r"top_k must be an integer in \[1, "),
    "a text fit_table": (_request(fit_table="yes"), 400, "fit_table must be true or false"),
    "fit_table with a scaled pose": (_request(fit_table=True, T_world_camera=(2 * CAMERA).tolist()), 400, "one rigid"),
    "around without fit_table": (_request(around=[0, 0, 0]), 400, "around goes with fit_table"),
    "a viewpoint with depth": (_request(viewpoint=[1, 0, 1]), 400, "viewpoint goes with points"),
    "points in no frame": (json.dumps({"points": [[0, 0, 1]], "T_world_camera": CAMERA.tolist(), "frame": "base"}).encode(), 400, "frame must be one of world, camera"),
    "points with no pose": (json.dumps({"points": [[0, 0, 1]]}).encode(), 400, "T_world_camera or its viewpoint"),
}  # fmt: skip


@pytest.mark.parametrize("case", MALFORMED)
def test_a_malformed_request_is_answered_400_naming_the_field_and_the_server_goes_on(server, case):
    body, status, said = MALFORMED[case]
    code, reply = _post(server, DETECT_PATH, body, {"Content-Type": "application/json"})
    assert code == status and set(reply) == {"error"}, reply
    assert re.search(said, reply["error"]), reply["error"]
    assert GraspClient(server.url).health()["status"] == "ok"  # still serving


def test_wrong_paths_methods_and_lengths_are_answered_in_json(server):
    assert _post(server, "/v1/nothing", b"{}")[0] == 404
    connection = http.client.HTTPConnection(*server.server_address[:2], timeout=30)
    connection.putrequest("POST", DETECT_PATH)
    connection.endheaders()  # no Content-Length
    response = connection.getresponse()
    assert response.status == 411 and "Content-Length" in json.loads(response.read())["error"]
    connection.close()
    for method, status in (("PUT", 501), ("GET", 404)):
        connection = http.client.HTTPConnection(*server.server_address[:2], timeout=30)
        connection.request(method, DETECT_PATH)
        response = connection.getresponse()
        assert response.status == status and "error" in json.loads(response.read())
        connection.close()
    with socket.create_connection(server.server_address[:2], timeout=30) as raw:
        raw.sendall(b"garbage\r\n\r\n")  # not even a request line
        assert b"Bad request syntax" in raw.recv(4096)
    huge = {"Content-Length": str(2**40)}
    assert _post(server, DETECT_PATH, b"", huge)[0] == 413
    with pytest.raises(ServerError, match="answered 400: give depth or points") as error:
        GraspClient(server.url)._request(DETECT_PATH, {})
    assert error.value.status == 400


def test_concurrent_clients_each_get_their_own_answer(server, detector, scene):
    """Eight clients at once, half of them sending the pile, half an empty table (no grasp):
    each gets the answer to its own request."""
    depth, T = scene
    empty = table_depth()
    expected = {"pile": _records(detector.detect(depth, SMALL, T)), "table": []}
    answers: dict[int, tuple[str, list]] = {}

    def ask(index: int) -> None:
        client = GraspClient(server.url)
        if index % 2:
            answers[index] = ("table", _served(client.detect(empty, INTRINSIC.K, CAMERA)))
        else:
            answers[index] = ("pile", _served(client.detect(depth, SMALL.K, T)))

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    assert len(answers) == 8
    for kind, got in answers.values():
        assert got == expected[kind]


@pytest.mark.parametrize("module, loaded", [("client", ["numpy"]), ("server", ["numpy", "torch"])])
def test_the_client_needs_neither_torch_nor_mujoco_and_the_server_no_mujoco(module, loaded):
    code = (f"import sys, symgrasp.serve.{module}; "
            "print(' '.join(m for m in ('numpy', 'torch', 'mujoco') if m in sys.modules))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == loaded


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGINT])
def test_symgrasp_serve_answers_and_stops_cleanly_on_a_signal(stop, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "OMP_NUM_THREADS": "1"}
    process = subprocess.Popen(
        [sys.executable, "-m", "symgrasp", "serve", "--port", "0", "--model", MODEL, "--device", "cpu"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
    )  # fmt: skip
    try:
        first = process.stdout.readline()
        assert first.startswith("listening on http://127.0.0.1:"), first + process.stderr.read()
        url = first.split()[2]
        client = GraspClient(url)
        assert client.health()["model"] == MODEL
        assert client.detect(table_depth(), INTRINSIC.K, CAMERA).grasps == []
        with pytest.raises(ServerError):
            client._request(DETECT_PATH, {"depth": "nothing"})
        process.send_signal(stop)
        out, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, err
    assert f"{stop.name}: stopped after 3 requests" in out
    # one log line per request, in order: a request is logged before its answer leaves (on a
    # loaded machine the bad request's line once came before the detection's, logged after)
    lines = [line for line in err.strip().splitlines() if line.startswith(("GET ", "POST "))]
    assert len(lines) == 3, err
    assert lines[0].startswith(f"GET {HEALTH_PATH} 200"), err
    assert lines[1].startswith(f"POST {DETECT_PATH} 200"), err
    assert lines[2].startswith(f"POST {DETECT_PATH} 400"), err
    assert "depth must be an array" in lines[2]


def test_base64_is_standard_base64():
    """The encoded form other languages produce: standard alphabet, padding, little-endian."""
    data = np.array([1.0, -2.5], dtype="<f4").tobytes()
    value = {"dtype": "float32", "shape": [2], "data": base64.standard_b64encode(data).decode()}
    assert decode_array(value, "a").tolist() == [1.0, -2.5]


def test_a_port_already_taken_is_one_line_naming_it():
    from symgrasp.cli import main

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(
            SystemExit, match=f"cannot listen on 127.0.0.1:{port}: Address already in use"
        ):
            main(["serve", "--port", str(port), "--device", "cpu"])
