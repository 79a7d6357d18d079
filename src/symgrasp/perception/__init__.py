"""Perception: pinhole camera, depth rendering of the simulated world, TSDF fusion."""

from symgrasp.perception.camera import (
    CameraIntrinsic,
    default_extrinsic,
    depth_to_points,
    look_at,
)
from symgrasp.perception.noise import add_depth_noise
from symgrasp.perception.render import (
    GLRenderer,
    RaycastRenderer,
    gl_available,
    make_renderer,
)
from symgrasp.perception.tsdf import TSDFVolume

__all__ = [
    "CameraIntrinsic",
    "GLRenderer",
    "RaycastRenderer",
    "TSDFVolume",
    "add_depth_noise",
    "default_extrinsic",
    "depth_to_points",
    "gl_available",
    "look_at",
    "make_renderer",
]
