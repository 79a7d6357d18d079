"""The grasp server: one detector held in a process, answering HTTP + JSON requests
(`symgrasp.serve.protocol`; docs/serve.md).

`answer` turns a request's JSON into the detector's call and its grasps into the answer (no
HTTP in it); `GraspServer` is the standard library's threading HTTP server around it. Each
request is read and decoded on its own thread, the detection itself runs under one lock: the
detector keeps per-call state (``timing``) and a second forward pass at the same time would
only share the same cores, so serialising them costs no throughput and keeps each request's
latency its own. A bad request is answered 400 with ``{"error": ...}`` naming the field, an
unexpected failure 500, and the server goes on.

No client holds it: each connection must deliver its request within `DEADLINE` of its opening
and take its answer within `DEADLINE` of its sending, however it paces its bytes; connections
beyond ``max_connections`` are answered 503 at once; a body's JSON values are counted before it
is parsed (`symgrasp.serve.protocol.parse_request`); a client that hangs up costs a log line.
"""

from __future__ import annotations

import functools
import io
import json
import socket
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Callable
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any, NamedTuple

import numpy as np

from symgrasp.detect import Grasp, GraspDetector
from symgrasp.detect.files import intrinsic_from_json
from symgrasp.detect.scene import SceneDetection, detect_object, detect_table
from symgrasp.perception import CameraIntrinsic, fit_table
from symgrasp.perception.camera import is_rigid
from symgrasp.perception.points import FRAMES
from symgrasp.serve import MAX_CONNECTIONS
from symgrasp.serve.protocol import (
    DETECT_PATH,
    HEALTH_PATH,
    MAX_BODY,
    PROTOCOL,
    RequestError,
    decode_array,
    is_number,
    optional_choice,
    optional_flag,
    optional_integer,
    optional_number,
    parse_request,
    shown,
)
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

DEADLINE = 25.0
"""[s] how long a client may take to send its whole request (from the connection's opening) and,
apart, to take its whole answer (from its sending); past it the connection is dropped, however
slowly its bytes trickle. A stop therefore waits at most 2 × DEADLINE for the requests in flight,
plus the detections queued then."""

FIELDS = {
    "depth", "depth_scale", "points", "intrinsic", "T_world_camera", "viewpoint", "frame",
    "fit_table", "around", "top_k", "whole_table", "mask", "pixel", "box",
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
    """The answer to a detect request ``body`` (parsed JSON): the grasps best first (each with
    its flange pose and opening width, `Grasp.record`), the warnings it gave, the timing [ms]
    of the table fit (``fit_table``, with ``fit_table``), of the detector's stages and of the
    server's whole answer (``server``, from ``start``, `time.perf_counter` when the request
    arrived; default now), and with ``fit_table`` the fitted workspace's pose. `RequestError`
    (or ValueError from the detector, which names its argument) for a request that cannot be
    answered. ``lock``: held around the detection."""
    start = time.perf_counter() if start is None else start
    if not isinstance(body, dict):
        raise RequestError(f"the request must be a JSON object, got {type(body).__name__}")
    unknown = sorted(set(body) - FIELDS)
    if unknown:
        raise RequestError(
            f"unknown field {', '.join(name[:40] for name in unknown[:3])}"
            f"{' …' if len(unknown) > 3 else ''}; a detect request holds {', '.join(sorted(FIELDS))}"
        )
    if ("depth" in body) == ("points" in body):
        raise RequestError("give depth or points, exactly one")
    top_k = optional_integer(body, "top_k", 1, 10**6)
    parse = _depth_call if "depth" in body else _points_call
    parsed = parse(body, detector)
    # catch_warnings changes the process's filters: inside the lock, one request at a time
    with lock or threading.Lock(), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        grasps = parsed.call()
        timing = dict(detector.timing)
    if parsed.T_frame_world is not None:
        grasps = [grasp.transformed(parsed.T_frame_world) for grasp in grasps]
    return {
        "grasps": [grasp.record() for grasp in grasps[:top_k]],
        "warnings": [*parsed.warnings, *(str(warning.message) for warning in caught)],
        "timing_ms": {**parsed.stages, **timing, "server": 1e3 * (time.perf_counter() - start)},
        **parsed.extra,
    }


Call = Callable[[], list[Grasp]]
"""A detection, ready to run under the lock."""


class Parsed(NamedTuple):
    """A request read: its detection, ready to run under the lock."""

    call: Call
    T_frame_world: np.ndarray | None
    """The pose taking its grasps to the request's frame (None: they are in it)."""
    extra: dict[str, Any]
    """What else the answer holds."""
    stages: dict[str, float]
    """The stages run while the request was read, [ms] by name (``fit_table``)."""
    warnings: tuple[str, ...] = ()
    """What those stages doubted (the table fit's `TableWarning`), for the answer's warnings:
    their own warnings go to the process, whose filters only the lock's holder may change."""


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
    intrinsic = _intrinsic(body["intrinsic"], depth.shape[-2:])
    T = _optional_array(body, "T_world_camera")
    for field in ("points", "viewpoint", "frame"):
        if field in body:
            raise RequestError(f"{field} goes with points, not with depth")
    scene = _scene(body, depth.shape)
    if optional_flag(body, "fit_table"):
        return _table_call(body, detector, depth, intrinsic, T, scene)
    if "around" in body:
        raise RequestError("around goes with fit_table")
    if T is None:
        raise RequestError("T_world_camera is missing (or ask for fit_table)")
    extra: dict[str, Any] = {}
    return Parsed(_detection(scene, detector, depth, intrinsic, T, None, extra), None, extra, {})


Scene = Callable[..., SceneDetection]
"""`detect_table`, or `detect_object` with its selection: called as ``(detector, depth,
intrinsic, T_world_camera)``."""


def _scene(body: dict[str, Any], shape: tuple[int, ...]) -> Scene | None:
    """The scene detection the request's ``whole_table``, ``mask``, ``pixel`` or ``box`` (at
    most one) asks of depth images of ``shape``, or None; their values' ranges are
    `detect_object`'s to check (ValueError naming the field)."""
    whole = optional_flag(body, "whole_table")
    given = [field for field in ("mask", "pixel", "box") if body.get(field) is not None]
    if whole + len(given) > 1:
        asked = (["whole_table"] if whole else []) + given
        raise RequestError(f"give at most one of whole_table, mask, pixel and box, got {asked}")
    if whole:
        return detect_table
    if not given:
        return None
    field = given[0]
    if len(shape) == 3 and shape[0] != 1:
        raise RequestError(f"{field} selects in one depth image, got {shape[0]}")
    if field == "mask":
        mask = decode_array(body["mask"], "mask", ("float32", "float64", "uint16"))
        return functools.partial(detect_object, mask=mask)
    value, count = body[field], {"pixel": 2, "box": 4}[field]
    if not (
        isinstance(value, list)
        and len(value) == count
        and all(isinstance(x, int) and not isinstance(x, bool) for x in value)
    ):
        names = "(u, v)" if count == 2 else "(u0, v0, u1, v1)"
        raise RequestError(f"{field} must be {count} integer pixels {names}, got {shown(value)}")
    return functools.partial(detect_object, **{field: tuple(value)})


def _detection(
    scene: Scene | None,
    detector: GraspDetector,
    depth: np.ndarray,
    intrinsic: CameraIntrinsic,
    T_world_camera: np.ndarray,
    T_frame_world: np.ndarray | None,
    extra: dict[str, Any],
) -> Call:
    """The detection a depth request asks for: ``detector.detect``, or the ``scene``'s (`_scene`),
    which adds its cubes' poses in the answer's frame (``T_frame_world`` of the world's; None:
    the same) to ``extra`` as ``workspaces``, once it has run."""
    if scene is None:
        return lambda: detector.detect(depth, intrinsic, T_world_camera)

    def call() -> list[Grasp]:
        found = scene(detector, depth, intrinsic, T_world_camera)
        T = np.eye(4) if T_frame_world is None else T_frame_world
        extra["workspaces"] = [(T @ _shift(origin)).tolist() for origin in found.origins]
        return found.grasps

    return call


def _table_call(
    body: dict[str, Any],
    detector: GraspDetector,
    depth: np.ndarray,
    intrinsic: CameraIntrinsic,
    T: np.ndarray | None,
    scene: Scene | None,
) -> Parsed:
    """The detection (``scene``'s, if any: `_detection`) on the table fitted in ``depth`` (one
    view), its grasps taken to the frame of ``T`` (``T_world_camera``, whose +z is taken for
    up), else to the camera's."""
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
    fit_start = time.perf_counter()
    fit = fit_table(image, intrinsic, around=around, up=up)
    fit_ms = 1e3 * (time.perf_counter() - fit_start)
    # the detector's world is the fitted cube moved to its workspace origin
    T_world_camera = _shift(detector.origin) @ fit.T_workspace_camera
    T_frame_workspace = T_frame_camera @ fit.T_camera_workspace
    T_frame_world = T_frame_workspace @ _shift(-detector.origin)
    extra = {"T_world_workspace": T_frame_workspace.tolist(), "table_centred_on": fit.centred_on}
    return Parsed(
        _detection(scene, detector, depth, intrinsic, T_world_camera, T_frame_world, extra),
        T_frame_world,
        extra,
        {"fit_table": fit_ms},
        (fit.warning,) if fit.doubts else (),
    )


def _points_call(body: dict[str, Any], detector: GraspDetector) -> Parsed:
    points = decode_array(body["points"], "points")
    T = _optional_array(body, "T_world_camera")
    viewpoint = _optional_array(body, "viewpoint")
    intrinsic = None
    if "intrinsic" in body:
        shape = points.shape[:2] if points.ndim == 3 else None
        intrinsic = _intrinsic(body["intrinsic"], shape)
    frame = optional_choice(body, "frame", FRAMES)
    for field in ("depth_scale", "fit_table", "around", "whole_table", "mask", "pixel", "box"):
        if field in body:
            raise RequestError(f"{field} goes with depth, not with points")

    def call() -> list[Grasp]:
        return detector.detect_points(
            points, T, viewpoint=viewpoint, intrinsic=intrinsic, frame=frame
        )

    return Parsed(call, None, {}, {})


def _intrinsic(value: Any, shape: tuple[int, int] | None) -> CameraIntrinsic:
    """The request's ``intrinsic`` for images of ``shape`` (H, W), its numbers checked as
    numbers first (`intrinsic_from_json` would read ``true`` as 1 and ``"500"`` as 500)."""
    if isinstance(value, dict):
        value = dict(value)
        for key, number in value.items():
            if key == "K":
                value[key] = decode_array(number, "intrinsic.K")
            elif not is_number(number):
                raise RequestError(f"intrinsic.{key} must be a number, got {shown(number)}")
    elif isinstance(value, list):
        value = decode_array(value, "intrinsic")
    return intrinsic_from_json(value, shape, "intrinsic")


def _optional_array(body: dict[str, Any], field: str) -> np.ndarray | None:
    return decode_array(body[field], field) if body.get(field) is not None else None


def _shift(offset: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = offset
    return T


class GraspServer(ThreadingHTTPServer):
    """An HTTP server answering `HEALTH_PATH` (GET) and `DETECT_PATH` (POST) with
    ``detector``, one request per connection, each on its own thread; `shutdown` stops it
    and `server_close` waits for the requests in flight (each bounded by ``deadline``).

    Args:
        address: ``(host, port)``; port 0 picks a free one (`url` says which).
        detector: the detector every request uses.
        model: the model's name, for the health answer.
        log: where one line per request goes (None: nowhere).
        max_connections: connections served at once; one more is answered 503 at once,
            unread.
        deadline: [s] `DEADLINE`, how long a client may take to send its request and,
            apart, to take its answer.
    """

    daemon_threads = False  # server_close joins the request threads: requests in flight end
    block_on_close = True

    def __init__(
        self,
        address: tuple[str, int],
        detector: GraspDetector,
        model: str,
        log: Any = sys.stderr,
        max_connections: int = MAX_CONNECTIONS,
        deadline: float = DEADLINE,
    ) -> None:
        if not (isinstance(max_connections, int) and max_connections >= 1):
            raise ValueError(f"max_connections must be an integer ≥ 1, got {max_connections!r}")
        if not deadline > 0:
            raise ValueError(f"deadline must be > 0 seconds, got {deadline!r}")
        super().__init__(address, _Handler)
        self.detector, self.model, self.log = detector, model, log
        self.max_connections, self.deadline = max_connections, deadline
        self.lock = threading.Lock()
        self.answered = 0
        self.connections = 0  # open, being served
        self._count = threading.Lock()

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        return f"http://{host}:{port}"

    def count(self) -> None:
        with self._count:
            self.answered += 1

    def note(self, line: str) -> None:
        """``line`` to the log, if any."""
        if self.log is not None:
            print(line, file=self.log, flush=True)

    def process_request(self, request: socket.socket, client_address: Any) -> None:
        """Serve the connection on a thread of its own, or refuse it when `max_connections`
        are served already."""
        with self._count:
            full = self.connections >= self.max_connections
            self.connections += not full
        if full:
            self._refuse(request)
        else:
            super().process_request(request, client_address)

    def process_request_thread(self, request: socket.socket, client_address: Any) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            with self._count:
                self.connections -= 1

    def _refuse(self, request: socket.socket) -> None:
        """Answer 503 on the accepting thread, without reading the request or waiting for the
        client: a fresh connection's send buffer takes the few bytes at once."""
        status = HTTPStatus.SERVICE_UNAVAILABLE
        message = f"the server serves {self.max_connections} connections already; try again"
        data = json.dumps({"error": message}).encode()
        head = (f"HTTP/1.0 {status.value} {status.phrase}\r\nContent-Type: application/json\r\n"
                f"Content-Length: {len(data)}\r\nRetry-After: 1\r\n\r\n")  # fmt: skip
        self.count()
        self.note(f"- {status.value} {message}")
        try:
            request.setblocking(False)
            request.send(head.encode() + data)
            request.recv(2**16)  # what the client sent already: closed unread, it would reset
        except OSError:  # nothing sent yet (BlockingIOError), or the client gone
            pass
        self.shutdown_request(request)


class _DeadlineStream(io.RawIOBase):
    """A connection's socket whose reads and writes fail (TimeoutError) once ``deadline``
    (`time.monotonic`) has passed: a socket's own timeout restarts with every byte, and a
    client sending one byte at a time would hold the connection for ever."""

    def __init__(self, connection: socket.socket, deadline: float) -> None:
        self.connection, self.deadline = connection, deadline

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        self._time_left()
        return self.connection.recv_into(buffer)

    def write(self, data: Any) -> int:
        self._time_left()
        self.connection.sendall(data)  # the timeout bounds the whole of it
        return len(data)

    def _time_left(self) -> None:
        left = self.deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError("the connection's deadline passed")
        self.connection.settimeout(left)


class _Handler(BaseHTTPRequestHandler):
    server: GraspServer
    protocol_version = "HTTP/1.0"  # one request per connection: nothing idles at shutdown
    server_version = f"symgrasp-serve/{PROTOCOL}"

    def setup(self) -> None:
        """The connection's streams, read until `DEADLINE` after its opening (a request's
        line, headers and body) and written until `DEADLINE` after its answer starts."""
        self.connection = self.request
        self.stream = _DeadlineStream(self.connection, time.monotonic() + self.server.deadline)
        self.rfile = io.BufferedReader(self.stream)
        self.wfile = self.stream

    def handle(self) -> None:
        try:
            super().handle()
        except ConnectionError as error:  # BrokenPipe, ConnectionReset: the client left
            request = f"{getattr(self, 'command', None) or ''} {getattr(self, 'path', '')}".strip()
            self.server.note(f"{request or '-'} the client hung up ({type(error).__name__})")

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
        except _BodyError as error:
            self._reply(error.status, {"error": str(error)}, start)
            return
        try:
            reply = answer(self.server.detector, body, self.server.lock, start)
        except ValueError as error:  # RequestError, and the detector's argument errors
            self._reply(HTTPStatus.BAD_REQUEST, {"error": str(error)}, start)
            return
        except Exception as error:  # a bug or an exhausted device: say so, keep serving
            traceback.print_exc(file=sys.stderr)
            message = f"internal error: {type(error).__name__}: {error}"
            self._reply(HTTPStatus.INTERNAL_SERVER_ERROR, {"error": message}, start)
            return
        self._reply(HTTPStatus.OK, reply, start, f"{len(reply['grasps'])} grasps")

    def _body(self) -> Any:
        """The request's JSON body; `_BodyError` for a missing, malformed or oversized length,
        a body that does not arrive whole in time, and one that is not JSON or too large to
        parse."""
        length = self.headers.get("Content-Length")
        if length is None:
            raise _BodyError(HTTPStatus.LENGTH_REQUIRED, "Content-Length is missing")
        if not (length.isascii() and length.isdigit()):  # "²".isdigit(), "٣" reads as 3
            raise _BodyError(
                HTTPStatus.BAD_REQUEST,
                f"Content-Length must be a size in bytes (digits 0-9), got {shown(length)}",
            )
        digits = length.lstrip("0") or "0"
        size = int(digits) if len(digits) < 19 else MAX_BODY + 1  # int() refuses 4301 digits
        if size > MAX_BODY:
            raise _BodyError(
                HTTPStatus.REQUEST_ENTITY_TOO_LARGE,
                f"the request's Content-Length {shown(digits)} is over the {MAX_BODY} bytes "
                "accepted",
            )
        data = bytearray()  # grown as bytes arrive, not allocated as claimed
        try:
            while len(data) < size and (chunk := self.rfile.read1(min(size - len(data), 2**20))):
                data += chunk
        except TimeoutError:
            raise _BodyError(
                HTTPStatus.REQUEST_TIMEOUT,
                f"the request's {size} bytes did not arrive within {self.server.deadline:g} s "
                "of its connection",
            ) from None
        if len(data) < size:
            raise _BodyError(
                HTTPStatus.BAD_REQUEST,
                f"the request ended after {len(data)} of its {size} bytes (Content-Length)",
            )
        try:
            return parse_request(data)
        except RequestError as error:
            raise _BodyError(HTTPStatus.BAD_REQUEST, str(error)) from None

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
        took = "" if start is None else f" {1e3 * (time.perf_counter() - start):.1f} ms"
        detail = note or payload.get("error", "")
        request = f"{self.command} {getattr(self, 'path', '')}"  # unset: a bad request line
        self.server.note(f"{request} {status.value}{took} {detail}".rstrip())
        self.stream.deadline = time.monotonic() + self.server.deadline
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

    def log_message(self, format: str, *args: Any) -> None:
        """http.server's own lines (a request line that did not arrive in time) as one line of
        the server's log."""
        self.server.note(f"- {format % args}")


class _BodyError(Exception):
    """A request body refused: its HTTP status and why."""

    def __init__(self, status: HTTPStatus, message: str) -> None:
        super().__init__(message)
        self.status = status


def _unknown_path(path: str, method: str) -> str:
    return f"no {method} {path}: this server answers GET {HEALTH_PATH} and POST {DETECT_PATH}"
