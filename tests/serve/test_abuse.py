"""The grasp server under abuse, over loopback: clients that trickle, flood, hang up or send
bodies built to cost memory, recursion or wrong types. Each is answered or cut within a
bound, the server goes on, and nothing but one log line is printed. Every loop is bounded and
every socket has a short timeout."""

import json
import re
import select
import socket
import threading
import time
import tracemalloc

import numpy as np
import pytest
from bad_input_cases import CAMERA, INTRINSIC, MODEL, table_depth

from symgrasp.detect import GraspDetector
from symgrasp.serve import DETECT_PATH, HEALTH_PATH, protocol
from symgrasp.serve.client import GraspClient, ServerError
from symgrasp.serve.protocol import (
    MAX_DIMS,
    MAX_VALUES,
    RequestError,
    decode_array,
    encode_array,
    parse_request,
)
from symgrasp.serve.server import GraspServer

DEADLINE = 1.0
"""[s] the servers' deadline here (`symgrasp.serve.server.DEADLINE` is 25 s)."""


class Log:
    """A server's log, its lines kept (written from the request threads)."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def write(self, text: str) -> None:
        self.lines.extend(line for line in text.splitlines() if line)

    def flush(self) -> None:
        pass


@pytest.fixture(scope="module")
def detector():
    return GraspDetector.from_pretrained(MODEL, device="cpu")


def _start(detector, **options) -> tuple[GraspServer, threading.Thread]:
    served = GraspServer(("127.0.0.1", 0), detector, MODEL, **options)
    thread = threading.Thread(target=served.serve_forever, kwargs={"poll_interval": 0.05})
    thread.start()
    return served, thread


def _stop(served: GraspServer, thread: threading.Thread) -> float:
    """Stop ``served`` as ``symgrasp serve`` does on a signal; the seconds it took."""
    began = time.monotonic()
    served.shutdown()
    served.server_close()  # joins the request threads
    thread.join(timeout=30)
    return time.monotonic() - began


@pytest.fixture()
def server(detector):
    served, thread = _start(detector, log=Log(), deadline=DEADLINE)
    yield served
    _stop(served, thread)


def _connect(served: GraspServer) -> socket.socket:
    return socket.create_connection(served.server_address[:2], timeout=5)


def _exchange(served: GraspServer, data: bytes) -> tuple[int, dict]:
    """``data`` sent whole on a fresh connection; the answer's status and JSON body."""
    with _connect(served) as connection:
        connection.sendall(data)
        return _answer(connection)


def _answer(connection: socket.socket) -> tuple[int, dict]:
    """The status and JSON body of the answer on ``connection``, read to its end (the server
    closes after its answer)."""
    answer = b""
    while chunk := connection.recv(2**16):
        answer += chunk
    head, _, body = answer.partition(b"\r\n\r\n")
    return int(head.split()[1]), json.loads(body)


def _post(body: bytes, length: str | None = None) -> bytes:
    length = str(len(body)) if length is None else length
    return (
        f"POST {DETECT_PATH} HTTP/1.0\r\nContent-Length: {length}\r\n\r\n".encode("latin-1") + body
    )


def _until(condition, seconds: float = 5.0) -> bool:
    """Whether ``condition()`` holds within ``seconds`` (polled)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.01)
    return condition()


def _trickle(
    served: GraspServer, head: bytes, trickled: bytes, every: float, cut: list[float]
) -> None:
    """Send ``head`` at once, then ``trickled`` a byte every ``every`` seconds (bounded by
    its length); the time the server cut the connection, if it did, into ``cut``."""
    with _connect(served) as connection:
        try:
            connection.sendall(head)
            for byte in trickled:
                connection.sendall(bytes([byte]))
                time.sleep(every)
        except OSError:  # reset: the server dropped the connection
            cut.append(time.monotonic())
            return
        connection.settimeout(5)
        try:
            connection.recv(2**16)
        except OSError:
            pass
        cut.append(time.monotonic())


def test_trickling_clients_cannot_hold_the_shutdown(detector):
    """A client sending its request line a byte every 0.2 s (it would take 10 s), one sending
    its body so, and one sending nothing: each byte comes well within any socket timeout, yet
    the stop waits no longer than the deadline from their connections' opening."""
    served, thread = _start(detector, log=Log(), deadline=DEADLINE)
    line = f"GET {HEALTH_PATH} HTTP/1.0\r\nX-Padding: {'x' * 10}\r\n\r\n".encode()
    body = b"{" + b" " * 28 + b"}"
    opened = time.monotonic()
    cut: list[float] = []
    clients = [
        threading.Thread(target=_trickle, args=(served, b"", line, 0.2, cut)),
        threading.Thread(
            target=_trickle, args=(served, _post(b"", str(len(body))), body, 0.2, cut)
        ),
        threading.Thread(target=_trickle, args=(served, b"", b"", 0.0, cut)),  # only waits
    ]
    for client in clients:
        client.start()
    assert _until(lambda: served.connections == 3)
    took = _stop(served, thread)
    assert time.monotonic() - opened < DEADLINE + 2.0 and took < DEADLINE + 2.0, took
    for client in clients:
        client.join(timeout=10)
    assert len(cut) == 3 and max(cut) - opened < DEADLINE + 2.0, [t - opened for t in cut]
    assert served.connections == 0


def test_a_body_trickled_past_the_deadline_is_answered_408(server):
    """Its headers whole, its body a byte every 0.1 s: answered 408 when the deadline passes,
    long before the body would have arrived."""
    with _connect(server) as connection:
        connection.sendall(_post(b"", length="100"))
        began = time.monotonic()
        for _ in range(100):  # a byte every 0.1 s: 10 s, would the server wait
            connection.sendall(b" ")
            if select.select([connection], [], [], 0.1)[0]:  # the answer is coming
                break
        answered = time.monotonic() - began
        code, reply = _answer(connection)
    assert code == 408 and answered < DEADLINE + 1.0, (code, answered)
    assert reply["error"] == "the request's 100 bytes did not arrive within 1 s of its connection"


def test_connections_over_the_cap_are_answered_503_at_once_and_the_server_goes_on(detector):
    log = Log()
    served, thread = _start(detector, log=log, deadline=5.0, max_connections=2)
    try:
        holders = [_connect(served), _connect(served)]  # silent: they hold their slots
        assert _until(lambda: served.connections == 2)
        for _ in range(3):
            with _connect(served) as refused:  # nothing sent: the answer comes unasked
                began = time.monotonic()
                answer = refused.recv(2**16)
                assert time.monotonic() - began < 1.0
            assert answer.startswith(b"HTTP/1.0 503"), answer
            assert b"serves 2 connections already" in answer
        with pytest.raises(ServerError, match="answered 503") as error:
            GraspClient(served.url, timeout=5).health()  # a request sent and refused unread
        assert error.value.status == 503
        for holder in holders:
            holder.close()
        assert _until(lambda: served.connections == 0)
        assert GraspClient(served.url, timeout=5).health()["status"] == "ok"
    finally:
        _stop(served, thread)
    assert sum(" 503 " in line for line in log.lines) == 4, log.lines


def test_symgrasp_serve_takes_its_connection_cap(capsys):
    from symgrasp.cli import build_parser

    assert build_parser().parse_args(["serve", "--max-connections", "3"]).max_connections == 3
    with pytest.raises(SystemExit):
        build_parser().parse_args(["serve", "--max-connections", "0"])
    assert "--max-connections: must be an integer in [1, " in capsys.readouterr().err


def _values(value) -> int:
    """The Python objects a parsed JSON document holds, keys included, and one more for each
    empty list or object (the oracle of `parse_request`'s count, which reads their opening
    bracket as a value's start)."""
    if isinstance(value, list):
        return 1 + sum(map(_values, value)) + (not value)
    if isinstance(value, dict):
        return 1 + len(value) + sum(map(_values, value.values())) + (not value)
    return 1


def test_the_values_of_a_body_are_counted_before_it_is_parsed(monkeypatch):
    rng = np.random.default_rng(0)

    def document(depth: int):
        kind = rng.integers(0 if depth < 4 else 2, 4)
        if kind == 0:
            return [document(depth + 1) for _ in range(rng.integers(0, 4))]
        if kind == 1:
            return {f"k{i}": document(depth + 1) for i in range(rng.integers(0, 4))}
        return [1.5, None, True, "text"][rng.integers(0, 4)]

    for _ in range(50):
        data = json.dumps(document(0)).encode()
        count = _values(json.loads(data))
        monkeypatch.setattr(protocol, "MAX_VALUES", count)
        parse_request(data)  # exactly at the limit: parsed
        monkeypatch.setattr(protocol, "MAX_VALUES", count - 1)
        with pytest.raises(RequestError, match=f"holds up to {count} JSON values, over the"):
            parse_request(data)


def test_oversized_bodies_are_refused_before_they_cost_memory():
    """A nested list of `MAX_VALUES` + 1 zeros (67 MB of pointers once parsed) and a base64
    array whose text is far off its shape: refused with next to no memory allocated."""
    lists = b'{"points": [' + b"0," * MAX_VALUES + b"0]}"
    encoded = {"dtype": "float32", "shape": [2, 3], "data": "AAAA" * 2**20}  # 3 MiB, not 24 B
    tracemalloc.start()
    try:
        with pytest.raises(RequestError, match=f"over the {MAX_VALUES} accepted"):
            parse_request(lists)
        with pytest.raises(RequestError, match=r"data holds 3145728 bytes; shape \[2, 3\]"):
            decode_array(encoded, "depth")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 2**16, peak


def _detect(**fields) -> bytes:
    body = {
        "depth": table_depth().tolist(),
        "intrinsic": INTRINSIC.K.tolist(),
        "T_world_camera": CAMERA.tolist(),
    }
    body.update(fields)
    return json.dumps(body).encode()


K = {"fx": 50.0, "fy": 50.0, "cx": 32.0, "cy": 24.0}
ABUSE = {
    "JSON nested 100 000 deep": (b"[" * 100_000 + b"]" * 100_000, 400, "nests its JSON too deep"),
    "objects nested 100 000 deep": (b'{"a":' * 100_000 + b"1" + b"}" * 100_000, 400, "too deep"),
    "lists nested past MAX_DIMS": (_detect(depth=json.loads("[" * 500 + "1" + "]" * 500)), 400, f"depth must have at most {MAX_DIMS} dimensions"),
    "a shape past MAX_DIMS": (_detect(depth={"dtype": "float32", "shape": [1] * 9, "data": "AAAAAA=="}), 400, "depth.shape must be a list of sizes"),
    "too many values": (b"[" + b"0," * MAX_VALUES + b"0]", 400, "JSON values, over the"),
    "true as depth": (_detect(depth=[[True, 0.5], [0.5, 0.5]]), 400, "depth must be nested lists of numbers.*got true/false"),
    "a string as depth": (_detect(depth=[["0.5", 0.5]]), 400, "depth must be nested lists of numbers.*got strings"),
    "a ragged depth": (_detect(depth=[[0.5, 0.5], [0.5]]), 400, "depth must be .* one rectangular shape; its lists at depth 2"),
    "lists mixed with numbers": (_detect(depth=[[0.5], 0.5]), 400, "depth must be .* mix lists and numbers"),
    "an integer beyond float64": (_detect(depth=[[10**400]]), 400, "depth holds a number beyond float64"),
    "NaN as a number": (_detect().replace(b'"T_world_camera"', b'"depth_scale": NaN, "T_world_camera"'), 400, "NaN is no JSON number"),
    "fx true": (_detect(intrinsic={**K, "fx": True}), 400, "intrinsic.fx must be a number, got True"),
    "fx a string": (_detect(intrinsic={**K, "fx": "50"}), 400, "intrinsic.fx must be a number, got '50'"),
    "a matrix of strings": (_detect(intrinsic=[["50", 0, 32], [0, 50, 24], [0, 0, 1]]), 400, "intrinsic must be nested lists of numbers"),
    "a pose holding true": (_detect(T_world_camera=[[True] * 4] * 4), 400, "T_world_camera must be nested lists of numbers.*true/false"),
    "around holding a string": (_detect(fit_table=True, around=["0", 0, 0]), 400, "around must be nested lists of numbers.*strings"),
    "top_k true": (_detect(top_k=True), 400, "top_k must be an integer in .*, got True"),
    "depth_scale a string": (_detect(depth_scale="0.001"), 400, "depth_scale must be a number"),
    "a long unknown field": (_detect(**{"x" * 10_000: 1}), 400, "unknown field x{40};"),
    "Content-Length ²": (None, 400, r"Content-Length must be a size in bytes \(digits 0-9\), got '²'"),
    "Content-Length 1²": (None, 400, "Content-Length must be a size in bytes"),
    "Content-Length of 5000 digits": (None, 413, r"Content-Length '9+\.\.\.9+' is over the 268435456 bytes accepted"),
    "Content-Length with leading zeros": (None, 400, "give depth or points, exactly one"),
    "a body shorter than its length": (None, 400, "the request ended after 2 of its 10 bytes"),
}  # fmt: skip
HEADERS = {
    "Content-Length ²": _post(b"{}", length="²"),
    "Content-Length 1²": _post(b"{}", length="1²"),
    "Content-Length with leading zeros": _post(b"{}", length="0" * 4999 + "2"),
    "Content-Length of 5000 digits": _post(b"{}", length="9" * 5000),
    "a body shorter than its length": _post(b"{}", length="10"),
}


@pytest.mark.parametrize("case", ABUSE)
def test_an_abusive_body_is_answered_in_json_naming_what_is_wrong(server, case, capfd):
    body, status, said = ABUSE[case]
    data = HEADERS[case] if body is None else _post(body)
    if case == "a body shorter than its length":
        with _connect(server) as connection:  # the rest never comes: the client stops sending
            connection.sendall(data)
            connection.shutdown(socket.SHUT_WR)
            code, reply = _answer(connection)
    else:
        code, reply = _exchange(server, data)
    assert code == status and set(reply) == {"error"}, reply
    assert len(reply["error"]) < 500 and re.search(said, reply["error"]), reply
    assert GraspClient(server.url, timeout=5).health()["status"] == "ok"  # still serving
    assert "Traceback" not in capfd.readouterr().err


def test_clients_that_hang_up_early_cost_one_log_line_and_no_traceback(server, capfd):
    """A client that resets its connection mid-body, and one that resets it before reading
    its answer (a detection that runs): at most one line each beyond the request's own, no
    traceback; the server goes on."""
    reset = (socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")
    whole = _post(json.dumps({
        "depth": encode_array(table_depth()), "intrinsic": K, "T_world_camera": CAMERA.tolist()
    }).encode())  # fmt: skip
    for data in (_post(b'{"', length="1000"), whole):
        before = len(server.log.lines)
        with _connect(server) as connection:
            connection.setsockopt(*reset)  # close sends RST, as a killed client's kernel does
            connection.sendall(data)
            time.sleep(0.05)
        assert _until(lambda: server.connections == 0)
        new = server.log.lines[before:]
        assert 1 <= len(new) <= 2 and all("Traceback" not in line for line in new), new
        if data is not whole:  # reset mid-body: the read fails, nothing was answered
            assert new == [f"POST {DETECT_PATH} the client hung up (ConnectionResetError)"]
        assert GraspClient(server.url, timeout=5).health()["status"] == "ok"
    assert "Traceback" not in capfd.readouterr().err
