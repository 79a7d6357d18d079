"""The grasp server: one detector held in a process, answering HTTP + JSON requests
(`symgrasp.serve.protocol`; docs/serve.md).

`answer` turns a request's JSON into the detector's call and its grasps into the answer (no
HTTP in it); `GraspServer` is the standard library's threading HTTP server around it. Each
request is read and decoded on its own thread, the detection itself runs under one lock: the
detector keeps per-call state (``timing``) and a second forward pass at the same time would
only share the same cores, so serialising them costs no throughput and keeps each request's
latency its own. A bad request is answered 400 with ``{"error": ...}`` naming the field, an
unexpected failure 500, and the server goes on.
"""

from __future__ import annotations

import json
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Callable
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import numpy as np

from symgrasp.detect import Grasp, GraspDetector
from symgrasp.detect.files import intrinsic_from_json
from symgrasp.perception import CameraIntrinsic, fit_table
from symgrasp.perception.camera import is_rigid
from symgrasp.perception.points import FRAMES
from symgrasp.serve.protocol import (
    DETECT_PATH,
    HEALTH_PATH,
    MAX_BODY,
    PROTOCOL,
    RequestError,
    decode_array,
    optional_choice,
    optional_flag,
    optional_integer,
    optional_number,
)
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

REQUEST_TIMEOUT = 60.0
"""[s] a client that sends nothing for this long is dropped (a stalled client never blocks
the server's shutdown for longer)."""

FIELDS = {
    "depth", "depth_scale", "points", "intrinsic", "T_world_camera", "viewpoint", "frame",
    "fit_table", "around", "top_k",
}  # fmt: skip
"""The fields a detect request may hold; any other is refused (a misspelt option would
otherwise be ignored silently)."""


def health(detector: GraspDetector, model: str) -> dict[str, Any]:
    """What ``GET /v1/health`` answers: the protocol, the model and the workspace it sees."""
    return {
        "status": "ok",
        "protocol": PROTOCOL,
        "model": model,
        "representation": detector.representation.name,
        "gripper": detector.gripper.name,
        "workspace": {
            "origin": detector.origin.tolist(),
            "size": WORKSPACE_SIZE,
            "table_height": TABLE_HEIGHT,
        },
        "top_k": detector.top_k,
    }


def answer(
    detector: GraspDetector,
    body: Any,
    lock: threading.Lock | None = None,
    start: float | None = None,
) -> dict[str, Any]:
    """The answer to a detect request ``body`` (parsed JSON): the grasps best first, the
    detector's stage timing and the server's (from ``start``, `time.perf_counter` when the
    request arrived; default now), the warnings it gave, and with ``fit_table`` the fitted
    workspace's pose. `RequestError` (or ValueError from the detector, which names its
    argument) for a request that cannot be answered. ``lock``: held around the detection."""
    start = time.perf_counter() if start is None else start
    if not isinstance(body, dict):
        raise RequestError(f"the request must be a JSON object, got {type(body).__name__}")
    unknown = sorted(set(body) - FIELDS)
    if unknown:
        raise RequestError(
            f"unknown field {', '.join(unknown)}; a detect request holds {', '.join(sorted(FIELDS))}"
        )
    if ("depth" in body) == ("points" in body):
        raise RequestError("give depth or points, exactly one")
    top_k = optional_integer(body, "top_k", 1, 10**6)
    parse = _depth_call if "depth" in body else _points_call
    call, T_frame_world, extra = parse(body, detector)
    # catch_warnings changes the process's filters: inside the lock, one request at a time
    with lock or threading.Lock(), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        grasps = call()
        timing = dict(detector.timing)
    if T_frame_world is not None:
        grasps = [grasp.transformed(T_frame_world) for grasp in grasps]
    return {
        "grasps": [grasp.record() for grasp in grasps[:top_k]],
        "warnings": [str(warning.message) for warning in caught],
        "timing_ms": {**timing, "server": 1e3 * (time.perf_counter() - start)},
        **extra,
    }


Call = Callable[[], list[Grasp]]
"""A detection, ready to run under the lock."""

Parsed = tuple[Call, np.ndarray | None, dict[str, Any]]
"""A request's detection, the pose taking its grasps to the request's frame (None: they are in
it), and what else the answer holds."""


def _depth_call(body: dict[str, Any], detector: GraspDetector) -> Parsed:
    raw = decode_array(body["depth"], "depth", ("float32", "float64", "uint16"))
    scale = optional_number(body, "depth_scale", 1e-9, 1e3)
    integers = np.issubdtype(raw.dtype, np.integer)
    listed = isinstance(body["depth"], list)  # numbers in units when depth_scale is given
    if (integers and scale is None) or (not integers and not listed and scale is not None):
        raise RequestError(
            "depth_scale (metres per unit) goes with uint16 depth (or nested lists in units) "
            f"and float depth is metres; got {raw.dtype} depth and depth_scale {scale}"
        )
    depth = (raw * scale).astype(np.float32) if scale is not None else raw
    if depth.ndim not in (2, 3):
        raise RequestError(f"depth must be (H, W) or (V, H, W), got shape {depth.shape}")
    if "intrinsic" not in body:
        raise RequestError("intrinsic is missing: a depth request needs its camera's")
    intrinsic = intrinsic_from_json(body["intrinsic"], depth.shape[-2:], "intrinsic")
    T = _optional_array(body, "T_world_camera")
    for field in ("points", "viewpoint", "frame"):
        if field in body:
            raise RequestError(f"{field} goes with points, not with depth")
    if optional_flag(body, "fit_table"):
        return _table_call(body, detector, depth, intrinsic, T)
    if "around" in body:
        raise RequestError("around goes with fit_table")
    if T is None:
        raise RequestError("T_world_camera is missing (or ask for fit_table)")
    return (lambda: detector.detect(depth, intrinsic, T)), None, {}


def _table_call(
    body: dict[str, Any],
    detector: GraspDetector,
    depth: np.ndarray,
    intrinsic: CameraIntrinsic,
    T: np.ndarray | None,
) -> Parsed:
    """The detection on the table fitted in ``depth`` (one view), its grasps taken to the
    frame of ``T`` (``T_world_camera``, whose +z is taken for up), else to the camera's."""
    if depth.ndim == 3 and len(depth) != 1:
        raise RequestError(f"fit_table takes one depth image, got {len(depth)}")
    if T is not None and (T.shape != (4, 4) or not is_rigid(T)):
        raise RequestError(
            f"T_world_camera of fit_table must be one rigid (4, 4) transform, got shape {T.shape}"
        )
    T_frame_camera = np.eye(4) if T is None else T
    around = None
    if "around" in body:
        point = decode_array(body["around"], "around")
        if point.shape != (3,):
            raise RequestError(f"around must be 3 numbers [m], got shape {point.shape}")
        around = (point - T_frame_camera[:3, 3]) @ T_frame_camera[:3, :3]
    image = np.nan_to_num(depth.reshape(depth.shape[-2:]), nan=0.0, posinf=0.0, neginf=0.0)
    up = None if T is None else T[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    fit = fit_table(image, intrinsic, around=around, up=up)
    # the detector's world is the fitted cube moved to its workspace origin
    T_world_camera = _shift(detector.origin) @ fit.T_workspace_camera
    T_frame_workspace = T_frame_camera @ fit.T_camera_workspace
    return (
        lambda: detector.detect(depth, intrinsic, T_world_camera),
        T_frame_workspace @ _shift(-detector.origin),
        {"T_world_workspace": T_frame_workspace.tolist(), "table_centred_on": fit.centred_on},
    )


def _points_call(body: dict[str, Any], detector: GraspDetector) -> Parsed:
    points = decode_array(body["points"], "points")
    T = _optional_array(body, "T_world_camera")
    viewpoint = _optional_array(body, "viewpoint")
    intrinsic = None
    if "intrinsic" in body:
        shape = points.shape[:2] if points.ndim == 3 else None
        intrinsic = intrinsic_from_json(body["intrinsic"], shape, "intrinsic")
    frame = optional_choice(body, "frame", FRAMES)
    for field in ("depth_scale", "fit_table", "around"):
        if field in body:
            raise RequestError(f"{field} goes with depth, not with points")

    def call() -> list[Grasp]:
        return detector.detect_points(
            points, T, viewpoint=viewpoint, intrinsic=intrinsic, frame=frame
        )

    return call, None, {}


def _optional_array(body: dict[str, Any], field: str) -> np.ndarray | None:
    return decode_array(body[field], field) if body.get(field) is not None else None


def _shift(offset: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = offset
    return T


class GraspServer(ThreadingHTTPServer):
    """An HTTP server answering `HEALTH_PATH` (GET) and `DETECT_PATH` (POST) with
    ``detector``, one request per connection, each on its own thread; `shutdown` stops it
    and `server_close` waits for the requests in flight.

    Args:
        address: ``(host, port)``; port 0 picks a free one (`url` says which).
        detector: the detector every request uses.
        model: the model's name, for the health answer.
        log: where one line per request goes (None: nowhere).
    """

    daemon_threads = False  # server_close joins the request threads: requests in flight end
    block_on_close = True

    def __init__(
        self,
        address: tuple[str, int],
        detector: GraspDetector,
        model: str,
        log: Any = sys.stderr,
    ) -> None:
        super().__init__(address, _Handler)
        self.detector, self.model, self.log = detector, model, log
        self.lock = threading.Lock()
        self.answered = 0
        self._count = threading.Lock()

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        return f"http://{host}:{port}"

    def count(self) -> None:
        with self._count:
            self.answered += 1


class _Handler(BaseHTTPRequestHandler):
    server: GraspServer
    protocol_version = "HTTP/1.0"  # one request per connection: nothing idles at shutdown
    timeout = REQUEST_TIMEOUT
    server_version = f"symgrasp-serve/{PROTOCOL}"

    def do_GET(self) -> None:
        start = time.perf_counter()
        if self.path != HEALTH_PATH:
            self._reply(HTTPStatus.NOT_FOUND, {"error": _unknown_path(self.path, "GET")}, start)
            return
        self._reply(HTTPStatus.OK, health(self.server.detector, self.server.model), start)

    def do_POST(self) -> None:
        start = time.perf_counter()
        if self.path != DETECT_PATH:
            self._reply(HTTPStatus.NOT_FOUND, {"error": _unknown_path(self.path, "POST")}, start)
            return
        try:
            body = self._body()
            reply = answer(self.server.detector, body, self.server.lock, start)
        except ValueError as error:  # RequestError, and the detector's argument errors
            self._reply(HTTPStatus.BAD_REQUEST, {"error": str(error)}, start)
            return
        except _BodyError as error:
            self._reply(error.status, {"error": str(error)}, start)
            return
        except Exception as error:  # a bug or an exhausted device: say so, keep serving
            traceback.print_exc(file=sys.stderr)
            message = f"internal error: {type(error).__name__}: {error}"
            self._reply(HTTPStatus.INTERNAL_SERVER_ERROR, {"error": message}, start)
            return
        self._reply(HTTPStatus.OK, reply, start, f"{len(reply['grasps'])} grasps")

    def _body(self) -> Any:
        """The request's JSON body; `_BodyError` for a missing or oversized length, and
        `RequestError` for bytes that are not JSON."""
        length = self.headers.get("Content-Length")
        if length is None:
            raise _BodyError(HTTPStatus.LENGTH_REQUIRED, "Content-Length is missing")
        if not length.isdigit():
            raise _BodyError(HTTPStatus.BAD_REQUEST, f"Content-Length is not a size: {length!r}")
        if int(length) > MAX_BODY:
            raise _BodyError(
                HTTPStatus.REQUEST_ENTITY_TOO_LARGE,
                f"the request has {int(length)} bytes, over the {MAX_BODY} accepted",
            )
        try:
            data = self.rfile.read(int(length))
        except TimeoutError:
            raise _BodyError(
                HTTPStatus.REQUEST_TIMEOUT,
                f"the request's {length} bytes did not arrive within {REQUEST_TIMEOUT:g} s",
            ) from None
        try:
            return json.loads(data)
        except (UnicodeDecodeError, json.JSONDecodeError) as error:
            raise RequestError(f"the request is not JSON: {error}") from None

    def _reply(
        self,
        status: HTTPStatus,
        payload: dict[str, Any],
        start: float | None = None,
        note: str = "",
    ) -> None:
        try:
            data = json.dumps(payload, allow_nan=False).encode()
        except ValueError as error:  # NaN or inf, which JSON has no words for
            status = HTTPStatus.INTERNAL_SERVER_ERROR
            data = json.dumps(
                {"error": f"internal error: the answer is not JSON ({error})"}
            ).encode()
        # counted and logged before the answer leaves: a client holding its answer finds its
        # request in the count and the log (after, a client's next request, answered by
        # another thread, could be logged first)
        self.server.count()
        if self.server.log is not None:
            took = "" if start is None else f" {1e3 * (time.perf_counter() - start):.1f} ms"
            detail = note or payload.get("error", "")
            request = f"{self.command} {getattr(self, 'path', '')}"  # unset: a bad request line
            print(f"{request} {status.value}{took} {detail}".rstrip(),
                  file=self.server.log, flush=True)  # fmt: skip
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def send_error(self, code: int, message: str | None = None, explain: str | None = None) -> None:
        """http.server's own errors (a malformed request line, an unsupported method) as JSON,
        as every other answer."""
        status = HTTPStatus(code)
        self.close_connection = True
        self._reply(status, {"error": message or status.phrase})

    def log_request(self, code: int | str = "-", size: int | str = "-") -> None:
        """`_reply` logs each answer once, with its time."""


class _BodyError(Exception):
    """A request body refused before it is read: its HTTP status and why."""

    def __init__(self, status: HTTPStatus, message: str) -> None:
        super().__init__(message)
        self.status = status


def _unknown_path(path: str, method: str) -> str:
    return f"no {method} {path}: this server answers GET {HEALTH_PATH} and POST {DETECT_PATH}"
