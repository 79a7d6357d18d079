"""The planner interface: what the declutter benchmark asks of any grasp detector.

A planner sees what a robot sees, an `Observation` (depth images, the camera's intrinsic, the
cameras' poses), and answers with ranked `Grasp` s in symgrasp's grasp frame (``T_world_tcp``
with [e_x approach, e_y, e_z closing], docs/conventions.md) for its hand, ``gripper``; ``name``
and ``version`` say which planner played in a benchmark's record. `GraspDetector` (the
paper's detector), VGN's network (`symgrasp.peers.vgn`) and a user's function
(`symgrasp.peers.plugin`) meet it; VGN's own evaluation takes a planning callable the same way
(``clutter_removal.run(grasp_plan_fn)``, Breyer et al., CoRL 2020).

Nothing here loads the simulator: ``Observation.world`` is whatever the caller hands over (the
benchmark's `symgrasp.sim.world.World`, None on a robot). A planner that reads it knows more
than a camera shows: an oracle, not a detector.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from symgrasp.detect.grasp import Grasp
from symgrasp.perception import CameraIntrinsic, depth_to_points
from symgrasp.sim.grippers import GripperSpec


@dataclass(frozen=True)
class Observation:
    """What a planner is given before each grasp.

    Attributes:
        depth: (V, H, W) float32 depth images [m], 0 where nothing was seen (an (H, W) image
            is taken as one view).
        intrinsic: the cameras' pinhole parameters (all views share them).
        T_world_camera: (V, 4, 4) camera poses, OpenCV axes (x right, y down, z forward).
        world: the simulator's state when the benchmark plays (its ``World``), else None.
    """

    depth: np.ndarray
    intrinsic: CameraIntrinsic
    T_world_camera: np.ndarray
    world: Any = None

    def __post_init__(self) -> None:
        depth = np.asarray(self.depth, dtype=np.float32)
        depth = depth.reshape(-1, *depth.shape[-2:]) if depth.ndim >= 2 else depth
        T = np.asarray(self.T_world_camera, dtype=float).reshape(-1, 4, 4)
        if depth.ndim != 3 or depth.shape[1:] != (self.intrinsic.height, self.intrinsic.width):
            raise ValueError(
                f"depth must be (V, {self.intrinsic.height}, {self.intrinsic.width}) as the "
                f"intrinsic says, got shape {np.shape(self.depth)}"
            )
        if len(T) != len(depth):
            raise ValueError(
                f"T_world_camera must be one (4, 4) pose per depth image ({len(depth)}), got "
                f"shape {np.shape(self.T_world_camera)}"
            )
        object.__setattr__(self, "depth", depth)
        object.__setattr__(self, "T_world_camera", T)

    def points(self, crop: bool = True) -> np.ndarray:
        """The world points (N, 3) [m] of every view's valid pixels (`depth_to_points`; with
        ``crop``, those inside the workspace cube from the world origin)."""
        return np.concatenate(
            [
                depth_to_points(d, self.intrinsic, T, crop=crop)
                for d, T in zip(self.depth, self.T_world_camera, strict=True)
            ]
        )


@runtime_checkable
class GraspPlanner(Protocol):
    """Anything the declutter benchmark can play (module docstring)."""

    gripper: GripperSpec
    """The hand its grasps are for; the benchmark simulates this hand."""
    name: str
    """What played, as a benchmark records it (a model name, ``vgn``, ``module:function``)."""
    version: str
    """Which version of it played: the SHA-256 of its weights or source."""

    def plan(self, observation: Observation) -> Sequence[Grasp]:
        """Grasps for ``observation``, best first (the benchmark tries them in this order and
        executes the first whose approach misses the observed scene)."""
        ...
