"""What a robot reads in the grasp server's answers: the flange pose and opening width of each
grasp, the table fit's time apart, and the shipped JSON Schema (`symgrasp.serve.protocol.SCHEMA`)
that real requests and answers, over the wire, and docs/serve.md's base64 example meet."""

import base64
import http.client
import json
import re
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bad_input_cases import MODEL

from symgrasp.detect import GraspDetector
from symgrasp.detect.grasp import Grasp, T_flange_tcp
from symgrasp.perception import default_extrinsic
from symgrasp.perception.camera import CameraIntrinsic
from symgrasp.serve import DETECT_PATH, HEALTH_PATH
from symgrasp.serve.protocol import SCHEMA, encode_array
from symgrasp.serve.server import FIELDS, GraspServer, answer
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene

ROOT = Path(__file__).resolve().parents[2]
SMALL = CameraIntrinsic().scaled(0.25)  # 160 × 120
STAGES = ("fit_table", "tsdf", "network", "decode")


# -- a validator of the JSON Schema keywords schema.json uses --------------------------------

TYPES = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
    "number": lambda v: isinstance(v, int | float) and not isinstance(v, bool),
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
}
ANNOTATIONS = {"$schema", "$defs", "title", "description"}


def errors(value: Any, schema: dict, root: dict, at: str = "$") -> list[str]:
    """Where ``value`` breaks ``schema`` (a subset of JSON Schema 2020-12, ``$ref`` resolved in
    ``root``); a keyword outside the subset fails the test rather than pass unread."""
    unknown = set(schema) - ANNOTATIONS - set(KEYWORDS)
    assert not unknown, f"{at}: the validator does not know {unknown}"
    found = []
    for keyword, check in KEYWORDS.items():
        if keyword in schema:
            found += check(value, schema[keyword], schema, root, at)
    return found


def _ref(value, ref, schema, root, at):
    assert ref.startswith("#/$defs/"), ref
    return errors(value, root["$defs"][ref.removeprefix("#/$defs/")], root, at)


def _type(value, types, schema, root, at):
    types = [types] if isinstance(types, str) else types
    return [] if any(TYPES[t](value) for t in types) else [f"{at}: not {'/'.join(types)}"]


def _properties(value, properties, schema, root, at):
    if not isinstance(value, dict):
        return []
    return [
        e
        for k, s in properties.items()
        if k in value
        for e in errors(value[k], s, root, f"{at}.{k}")
    ]


def _additional(value, rule, schema, root, at):
    if not isinstance(value, dict):
        return []
    extra = [k for k in value if k not in schema.get("properties", {})]
    if rule is False:
        return [f"{at}: unexpected {k}" for k in extra]
    return [e for k in extra for e in errors(value[k], rule, root, f"{at}.{k}")]


def _required(value, names, schema, root, at):
    if not isinstance(value, dict):
        return []
    return [f"{at}: missing {k}" for k in names if k not in value]


def _items(value, rule, schema, root, at):
    if not isinstance(value, list):
        return []
    return [e for i, v in enumerate(value) for e in errors(v, rule, root, f"{at}[{i}]")]


def _bound(name, fails):
    def check(value, limit, schema, root, at):
        return [f"{at}: {name} {limit}"] if fails(value, limit) else []

    return check


def _any_of(value, options, schema, root, at):
    return [] if any(not errors(value, s, root, at) for s in options) else [f"{at}: no anyOf"]


def _one_of(value, options, schema, root, at):
    matched = sum(not errors(value, s, root, at) for s in options)
    return [] if matched == 1 else [f"{at}: {matched} of oneOf"]


KEYWORDS = {
    "$ref": _ref,
    "type": _type,
    "properties": _properties,
    "additionalProperties": _additional,
    "required": _required,
    "items": _items,
    "minItems": _bound("minItems", lambda v, n: isinstance(v, list) and len(v) < n),
    "maxItems": _bound("maxItems", lambda v, n: isinstance(v, list) and len(v) > n),
    "minimum": _bound("minimum", lambda v, n: TYPES["number"](v) and v < n),
    "maximum": _bound("maximum", lambda v, n: TYPES["number"](v) and v > n),
    "enum": _bound("enum", lambda v, options: v not in options),
    "const": _bound("const", lambda v, c: v != c),
    "anyOf": _any_of,
    "oneOf": _one_of,
}


@pytest.fixture(scope="module")
def schema():
    return json.loads(SCHEMA.read_text())


def valid(value: Any, name: str, schema: dict) -> list[str]:
    return errors(value, {"$ref": f"#/$defs/{name}"}, schema)


# -- the schema ----------------------------------------------------------------------------


def test_the_validator_refuses_what_the_schema_excludes(schema):
    grasp = Grasp(np.eye(4), 0.5, tcp_offset=0.1, opening_width=0.05, object_width=0.03).record()
    assert valid(grasp, "grasp", schema) == []
    assert valid({k: v for k, v in grasp.items() if k != "T_world_flange"}, "grasp", schema)
    assert valid({**grasp, "width": 0.05}, "grasp", schema)  # a field the schema does not hold
    assert valid({**grasp, "opening_width": "5 cm"}, "grasp", schema)
    assert valid({**grasp, "T_world_flange": np.eye(4)[:3].tolist()}, "grasp", schema)
    request = {"points": [[0.1, 0.1, 0.1]], "viewpoint": [0.5, 0.1, 0.6]}
    assert valid(request, "request", schema) == []
    assert valid({**request, "depth": [[0.5]]}, "request", schema)  # both inputs
    assert valid({**request, "top_k": 0}, "request", schema)
    assert valid({**request, "fit_table": 1}, "request", schema)
    assert valid({**request, "depth_scale": True}, "request", schema)  # true is no number
    assert valid({"viewpoint": [0.5, 0.1, 0.6]}, "request", schema)  # no input


def test_the_schema_names_the_fields_the_server_and_grasps_hold(schema):
    assert set(schema["$defs"]["request"]["properties"]) == FIELDS
    grasp = Grasp(np.eye(4), 0.5).record()
    assert set(schema["$defs"]["grasp"]["properties"]) == set(grasp)
    assert valid(grasp, "grasp", schema) == []  # the nulls of a planner that gives no widths


# -- real answers --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def detector():
    return GraspDetector.from_pretrained(MODEL, device="cpu")


@pytest.fixture(scope="module")
def scene(detector):
    world = pile_scene(object_set("household-test", 5, seed=0), seed=0, gripper=detector.gripper)
    T = default_extrinsic()
    return make_renderer(SMALL).render(world, T), T


def test_a_fit_table_answer_holds_flanges_widths_and_the_fits_time(detector, scene, schema):
    depth, T_base_camera = scene
    millimetres = np.round(depth * 1000).astype(np.uint16)
    request = {
        "depth": encode_array(millimetres),
        "depth_scale": 0.001,
        "intrinsic": {"fx": SMALL.fx, "fy": SMALL.fy, "cx": SMALL.cx, "cy": SMALL.cy},
        "T_world_camera": T_base_camera.tolist(),
        "fit_table": True,
    }
    request = json.loads(json.dumps(request))  # as the wire carries it
    assert valid(request, "request", schema) == []
    reply = json.loads(json.dumps(answer(detector, request), allow_nan=False))
    assert valid(reply, "answer", schema) == []
    timing = reply["timing_ms"]
    assert set(STAGES) <= set(timing) and all(timing[s] > 0 for s in STAGES)
    assert sum(timing[s] for s in STAGES) <= timing["server"]
    assert len(reply["grasps"]) >= 2
    offset, gripper = detector.gripper.tcp_offset, detector.gripper
    for grasp in reply["grasps"]:
        tcp, flange = np.array(grasp["T_world_tcp"]), np.array(grasp["T_world_flange"])
        # in the request's frame: tcp_offset back along the approach, the same axes
        assert np.allclose(flange[:3, 3], tcp[:3, 3] - offset * tcp[:3, 0], atol=2e-6)
        assert np.allclose(flange @ T_flange_tcp(gripper), tcp, atol=2e-6)
        assert 0 < grasp["opening_width"] <= gripper.max_width
        if grasp["object_width"] is not None:
            assert grasp["object_width"] <= grasp["opening_width"]
    without = answer(detector, {**request, "fit_table": False})
    assert "fit_table" not in without["timing_ms"]


def _get(server, method: str, path: str, body: bytes | None = None) -> tuple[int, Any]:
    connection = http.client.HTTPConnection(*server.server_address[:2], timeout=30)
    connection.request(method, path, body, {"Content-Type": "application/json"})
    response = connection.getresponse()
    status, data = response.status, json.loads(response.read())
    connection.close()
    return status, data


def _docs_request() -> dict:
    """The first ``json`` block of docs/serve.md: its base64 request example."""
    text = (ROOT / "docs" / "serve.md").read_text()
    return json.loads(re.search(r"```json\n(.*?)```", text, re.DOTALL).group(1))


def test_the_wire_and_the_docs_example_meet_the_schema(detector, schema):
    served = GraspServer(("127.0.0.1", 0), detector, MODEL, log=None)
    thread = threading.Thread(target=served.serve_forever)
    thread.start()
    try:
        status, health = _get(served, "GET", HEALTH_PATH)
        assert status == 200 and valid(health, "health", schema) == []
        example = _docs_request()
        assert valid(example, "request", schema) == []
        status, reply = _get(served, "POST", DETECT_PATH, json.dumps(example).encode())
        assert status == 200 and valid(reply, "answer", schema) == [], reply
        status, error = _get(served, "POST", DETECT_PATH, b'{"top_K": 3}')
        assert status == 400 and valid(error, "error", schema) == []
    finally:
        served.shutdown()
        served.server_close()
        thread.join()
    # the example's depth decodes to what docs/serve.md says it is
    raw = base64.b64decode(example["depth"]["data"])
    millimetres = np.frombuffer(raw, "<u2").reshape(example["depth"]["shape"])
    assert millimetres.tolist() == [[612, 611, 0], [613, 612, 610]]
