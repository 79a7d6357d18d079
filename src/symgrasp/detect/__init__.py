"""Grasp detection for robots: depth images in, ranked 6-DoF grasps out.

from symgrasp.detect import GraspDetector
detector = GraspDetector.from_pretrained("bingham2d-robotiq-2f85")
grasps = detector.detect(depth, intrinsic, T_world_camera)   # best first
waypoints = grasps[0].approach_trajectory()                   # pre-grasp, grasp, lift

Any detector the benchmark plays meets `GraspPlanner` (`symgrasp.detect.planner`): an
`Observation` in, ranked grasps out.
"""

from symgrasp.detect.detector import GraspDetector, NoGraspWarning
from symgrasp.detect.grasp import Grasp
from symgrasp.detect.planner import GraspPlanner, Observation
from symgrasp.detect.pretrained import PRETRAINED, export_model, export_torchscript

__all__ = [
    "PRETRAINED",
    "Grasp",
    "GraspDetector",
    "GraspPlanner",
    "NoGraspWarning",
    "Observation",
    "export_model",
    "export_torchscript",
]
