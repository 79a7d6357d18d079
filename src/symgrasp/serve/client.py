"""A small Python client of the grasp server (``symgrasp serve``; docs/serve.md).

It needs only the standard library and numpy (no torch, no MuJoCo), so a robot's program can
import it in its own environment::

    from symgrasp.serve.client import GraspClient

    client = GraspClient("http://127.0.0.1:8642")
    answer = client.detect(depth, K, T_world_camera)        # depth (H, W) [m], K (3, 3)
    best = answer.grasps[0]
    best["T_world_tcp"], best["score"], best["confidence"]   # (4, 4) array, floats
    best["T_world_flange"], best["opening_width"]              # where the robot's flange goes
"""

from __future__ import annotations

import json
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symgrasp.serve.protocol import DEFAULT_PORT, DETECT_PATH, HEALTH_PATH, encode_array

POSES = ("T_world_tcp", "T_world_flange")
"""The poses of a grasp record, read as (4, 4) arrays."""


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
        grasps: best first, each the server's grasp record (docs/serve.md) with its poses
            ``T_world_tcp`` and ``T_world_flange`` as (4, 4) arrays [m]: ``"score"``,
            ``"validity"``, ``"confidence"`` (None for point estimates), ``"voxel"``,
            ``"opening_width"`` and ``"object_width"`` [m], ``"cut"``, ``"fallback"``.
        warnings: the detector's warnings, e.g. why no grasp was found.
        timing_ms: milliseconds per stage (``tsdf``, ``network``, ``decode``) and ``server``,
            from the request's arrival (its body read, decoded, waiting for the lock,
            detected) to its answer.
        T_world_workspace: with ``fit_table``, the fitted workspace cube's pose (4, 4), else
            None.
        workspaces: with ``whole_table``, ``mask``, ``pixel`` or ``box``, the poses (4, 4) of
            the cubes detected in, else empty.
    """

    grasps: list[dict[str, Any]]
    warnings: list[str] = field(default_factory=list)
    timing_ms: dict[str, float] = field(default_factory=dict)
    T_world_workspace: np.ndarray | None = None
    workspaces: list[np.ndarray] = field(default_factory=list)


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
        whole_table: bool = False,
        mask: np.ndarray | None = None,
        pixel: tuple[int, int] | None = None,
        box: tuple[int, int, int, int] | None = None,
        top_k: int | None = None,
    ) -> Detection:
        """Grasps in depth image(s) ``depth`` (H, W) or (V, H, W): metres, or uint16 with
        ``depth_scale`` [m per unit]; ``intrinsic`` a 3×3 matrix, ``{"fx", "fy", "cx",
        "cy"}`` or a `CameraIntrinsic`; ``T_world_camera`` (4, 4) or (V, 4, 4).
        ``fit_table``: find the table and place the workspace on it (one image): grasps in the
        frame of ``T_world_camera`` (whose +z is up), or in the camera's when it is None;
        ``around`` (3,) [m, that frame] centres the workspace. At most one of: ``whole_table``
        (every object group on the table, `symgrasp.detect.detect_table`), ``mask`` (H, W)
        (nonzero: the object's pixels), ``pixel`` (u, v) or ``box`` (u0, v0, u1, v1) (the
        object asked for, `symgrasp.detect.detect_object`). ``top_k``: at most this many
        grasps."""
        depth = np.asarray(depth)
        body: dict[str, Any] = {"depth": self._array(depth), "intrinsic": _intrinsic(intrinsic)}
        if mask is not None:
            body["mask"] = self._array((np.asarray(mask) != 0).astype(np.uint16))
        for name, pixels in (("pixel", pixel), ("box", box)):
            if pixels is not None:  # integers, as the protocol has them
                body[name] = [int(value) for value in pixels]
        optional = {
            "T_world_camera": T_world_camera,
            "depth_scale": depth_scale,
            "fit_table": fit_table or None,
            "around": around,
            "whole_table": whole_table or None,
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
        grasps = [
            {**g, **{key: np.array(g[key]) for key in POSES if g.get(key) is not None}}
            for g in reply["grasps"]
        ]
        pose = reply.get("T_world_workspace")
        return Detection(
            grasps,
            reply["warnings"],
            reply["timing_ms"],
            None if pose is None else np.array(pose),
            [np.array(T) for T in reply.get("workspaces", [])],
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
