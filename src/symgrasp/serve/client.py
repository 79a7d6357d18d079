"""A small Python client of the grasp server (``symgrasp serve``; docs/serve.md).

It needs only the standard library and numpy (no torch, no MuJoCo), so a robot's program can
import it in its own environment::

    from symgrasp.serve.client import GraspClient

    client = GraspClient("http://127.0.0.1:8642")
    answer = client.detect(depth, K, T_world_camera)        # depth (H, W) [m], K (3, 3)
    best = answer.grasps[0]
    best["T_world_tcp"], best["score"], best["confidence"]   # (4, 4) array, floats
"""

from __future__ import annotations

import json
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symgrasp.serve.protocol import DEFAULT_PORT, DETECT_PATH, HEALTH_PATH, encode_array


class ServerError(RuntimeError):
    """The server refused a request or failed: ``status`` (HTTP; 400 a bad request, whose
    ``message`` names the field) and ``message``."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(f"grasp server answered {status}: {message}")
        self.status, self.message = status, message


@dataclass
class Detection:
    """A detect answer.

    Attributes:
        grasps: best first, each ``{"T_world_tcp": (4, 4) array [m], "score", "validity",
            "confidence" (None for point estimates), "voxel"}``.
        warnings: the detector's warnings, e.g. why no grasp was found.
        timing_ms: milliseconds per stage (``tsdf``, ``network``, ``decode``) and ``server``,
            from the request's arrival (its body read, decoded, waiting for the lock,
            detected) to its answer.
        T_world_workspace: with ``fit_table``, the fitted workspace cube's pose (4, 4), else
            None.
    """

    grasps: list[dict[str, Any]]
    warnings: list[str] = field(default_factory=list)
    timing_ms: dict[str, float] = field(default_factory=dict)
    T_world_workspace: np.ndarray | None = None


class GraspClient:
    """Requests to the grasp server at ``url``; arrays travel as base64 (``encoding="base64"``)
    or as nested lists (``"lists"``: readable, larger, slower). ``timeout`` [s] per request."""

    def __init__(
        self,
        url: str = f"http://127.0.0.1:{DEFAULT_PORT}",
        timeout: float = 30.0,
        encoding: str = "base64",
    ) -> None:
        if encoding not in ("base64", "lists"):
            raise ValueError(f"encoding must be 'base64' or 'lists', got {encoding!r}")
        self.url, self.timeout, self.encoding = url.rstrip("/"), timeout, encoding

    def health(self) -> dict[str, Any]:
        """The server's protocol, model, gripper and workspace."""
        return self._request(HEALTH_PATH, None)

    def detect(
        self,
        depth: np.ndarray,
        intrinsic: np.ndarray | dict[str, float],
        T_world_camera: np.ndarray | None = None,
        *,
        depth_scale: float | None = None,
        fit_table: bool = False,
        around: np.ndarray | None = None,
        top_k: int | None = None,
    ) -> Detection:
        """Grasps in depth image(s) ``depth`` (H, W) or (V, H, W): metres, or uint16 with
        ``depth_scale`` [m per unit]; ``intrinsic`` a 3×3 matrix, ``{"fx", "fy", "cx",
        "cy"}`` or a `CameraIntrinsic`; ``T_world_camera`` (4, 4) or (V, 4, 4). ``fit_table``: find the table and
        place the workspace on it (one image): grasps in the frame of ``T_world_camera``
        (whose +z is up), or in the camera's when it is None; ``around`` (3,) [m, that frame]
        centres the workspace. ``top_k``: at most this many grasps."""
        depth = np.asarray(depth)
        body: dict[str, Any] = {"depth": self._array(depth), "intrinsic": _intrinsic(intrinsic)}
        optional = {
            "T_world_camera": T_world_camera,
            "depth_scale": depth_scale,
            "fit_table": fit_table or None,
            "around": around,
            "top_k": top_k,
        }
        return self._detect(body, optional)

    def detect_points(
        self,
        points: np.ndarray,
        T_world_camera: np.ndarray | None = None,
        *,
        viewpoint: np.ndarray | None = None,
        intrinsic: np.ndarray | dict[str, float] | None = None,
        frame: str = "world",
        top_k: int | None = None,
    ) -> Detection:
        """Grasps in a point cloud ``points`` (N, 3) or (H, W, 3) [m] seen from
        ``T_world_camera`` or ``viewpoint`` (exactly one); ``intrinsic``: the sensor's
        (a dict with width and height for an unorganised cloud), or a virtual camera;
        ``frame``: ``"world"`` or ``"camera"``. As `GraspDetector.detect_points`."""
        body: dict[str, Any] = {"points": self._array(np.asarray(points, dtype=np.float32))}
        optional = {
            "T_world_camera": T_world_camera,
            "viewpoint": viewpoint,
            "intrinsic": None if intrinsic is None else _intrinsic(intrinsic),
            "frame": None if frame == "world" else frame,
            "top_k": top_k,
        }
        return self._detect(body, optional)

    def _detect(self, body: dict[str, Any], optional: dict[str, Any]) -> Detection:
        for name, value in optional.items():
            if value is None:
                continue
            body[name] = self._array(np.asarray(value, dtype=float)) if _is_array(value) else value
        reply = self._request(DETECT_PATH, body)
        grasps = [{**g, "T_world_tcp": np.array(g["T_world_tcp"])} for g in reply["grasps"]]
        pose = reply.get("T_world_workspace")
        return Detection(
            grasps, reply["warnings"], reply["timing_ms"], None if pose is None else np.array(pose)
        )

    def _array(self, array: np.ndarray) -> Any:
        if self.encoding == "base64":
            return encode_array(array)
        if array.dtype.kind == "f":  # JSON has no NaN: null is a missing value
            return np.where(np.isfinite(array), array, None).tolist()
        return array.tolist()

    def _request(self, path: str, body: dict[str, Any] | None) -> dict[str, Any]:
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(
            self.url + path, data=data, headers={"Content-Type": "application/json"}
        )
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                return json.loads(response.read())
        except urllib.error.HTTPError as error:
            try:
                message = json.loads(error.read()).get("error", error.reason)
            except (json.JSONDecodeError, AttributeError):
                message = str(error.reason)
            raise ServerError(error.code, message) from None


def _is_array(value: Any) -> bool:
    return isinstance(value, np.ndarray | list | tuple)


def _intrinsic(intrinsic: Any) -> Any:
    """The intrinsic as the protocol has it: a dict as it is, a `CameraIntrinsic` as its dict
    (with the image size), a 3×3 matrix as nested lists."""
    if isinstance(intrinsic, dict):
        return intrinsic
    keys = ("fx", "fy", "cx", "cy", "width", "height")
    if all(hasattr(intrinsic, key) for key in keys):
        return {key: getattr(intrinsic, key) for key in keys}
    return np.asarray(intrinsic, dtype=float).tolist()
