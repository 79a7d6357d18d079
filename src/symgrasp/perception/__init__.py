"""Perception on the robot's side: pinhole camera, depth noise, TSDF fusion, point clouds as
depth images.

Nothing here knows the simulator: depth images of the simulated world come from
`symgrasp.sim.render`.
"""

from symgrasp.perception.camera import (
    CameraIntrinsic,
    default_extrinsic,
    depth_to_points,
    look_at,
    orbit_extrinsic,
)
from symgrasp.perception.noise import add_depth_noise, noisy_depth
from symgrasp.perception.points import fill_holes, points_view
from symgrasp.perception.table import TableFit, TableWarning, fit_table, table_depth_scale
from symgrasp.perception.tsdf import TSDFVolume, surface_points

__all__ = [
    "CameraIntrinsic",
    "TSDFVolume",
    "TableFit",
    "TableWarning",
    "add_depth_noise",
    "default_extrinsic",
    "depth_to_points",
    "fill_holes",
    "fit_table",
    "look_at",
    "noisy_depth",
    "orbit_extrinsic",
    "points_view",
    "surface_points",
    "table_depth_scale",
]
