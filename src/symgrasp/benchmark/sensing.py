"""What the declutter benchmark's cameras see before each attempt: where they look from and the
noise of their images (`Sensor`, `BenchmarkConfig`'s ``view``, ``views`` and ``noise``).

The views (`symgrasp.names.VIEWS`), in the workspace frame of VGN's and symgrasp's worlds (the
cube [0, 0.30]³ m, the table top at z = 0.05 m):

- ``fixed``: symgrasp's one camera (`symgrasp.perception.camera.default_extrinsic`): 0.71 m
  from the workspace centre, 45° below horizontal;
- ``side``: GIGA's one side view (Jiang et al., RSS 2021: "a fixed side view", r = 2l,
  θ = π/3; ``UT-Austin-RPL/GIGA`` ``src/vgn/simulation.py``, ``acquire_tsdf`` with
  ``sideview``): 0.6 m from (0.15, 0.15, 0.10) m, 30° below horizontal, from −y (φ = −π/2);
- ``circle``: VGN's views (Breyer et al., CoRL 2020; ``ethz-asl/vgn`` ``acquire_tsdf``, 6 of
  them by default): ``views`` cameras 0.6 m from (0.15, 0.15, 0) m, 60° below horizontal
  (θ = π/6), at azimuths 2πk / ``views`` from +x;
- ``random``: ``views`` cameras drawn each attempt as the training data's are
  (`symgrasp.data.scenes.random_camera` with `SceneConfig`'s defaults, which the shipped models'
  datasets were made with): 0.45 to 0.7 m from the workspace centre, 0.1 rad to 60° from the
  vertical, any azimuth.

Every random draw (a random view's camera, an image's noise) comes from a generator of its own,
seeded by (what it draws, the round's seed, the attempt's index in the round, the view's index):
a round's attempt shows every planner the same images, and a view's camera or noise does not
depend on how many views there are or whether the other is drawn.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from symgrasp.config import SceneConfig, check_sensing
from symgrasp.data.scenes import random_camera
from symgrasp.detect.planner import Observation
from symgrasp.perception import CameraIntrinsic, default_extrinsic, noisy_depth
from symgrasp.perception.camera import orbit_extrinsic
from symgrasp.perception.table import table_scaled
from symgrasp.sim.render import DepthRenderer
from symgrasp.sim.world import World
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

SIDE_TARGET = (WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 3)
"""[m] What GIGA's side view looks at: the workspace's middle, a third of its height up."""
CIRCLE_TARGET = (WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2, 0.0)
"""[m] What VGN's views look at: the middle of the workspace's floor (below the table top)."""
FIELD_DISTANCE = 2 * WORKSPACE_SIZE
"""[m] GIGA's and VGN's cameras' distance from what they look at: twice the workspace's size."""
SIDE_POLAR, SIDE_AZIMUTH = np.pi / 3, -np.pi / 2
"""GIGA's side view: 60° from the vertical (30° below horizontal), from the −y side."""
CIRCLE_POLAR = np.pi / 6
"""VGN's views: 30° from the vertical (60° below horizontal)."""
CAMERA, NOISE = 0, 1
"""What a generator draws, the first number of its seed (module docstring)."""


def draw_seed(what: int, seed: int, attempt: int, view: int) -> tuple[int, int, int, int]:
    """The seed of one draw (`numpy.random.default_rng`'s): ``what`` (`CAMERA` or `NOISE`) for
    view ``view`` of attempt ``attempt`` of the round of seed ``seed``."""
    return (what, seed, attempt, view)


@dataclass(frozen=True)
class Sensor:
    """The cameras of the benchmark (module docstring): ``views`` images per attempt from
    ``view``, each with ``noise`` (`symgrasp.names.NOISES`, read by
    `symgrasp.perception.noise.noisy_depth`: ``"dex"`` is `add_depth_noise` at its defaults),
    taken by ``intrinsic``.
    ValueError naming the argument for an unknown name or a number of views the view does not
    take (`symgrasp.config.check_sensing`)."""

    noise: str = "none"
    view: str = "fixed"
    views: int = 1
    intrinsic: CameraIntrinsic = field(default_factory=CameraIntrinsic)
    table_scale: bool = False
    """Divide each image by the depth scale read off the table (`table_scaled`), as a
    robot that knows its table calibrates its sensor: what the planner and the collision
    check are given."""

    def __post_init__(self) -> None:
        check_sensing(self.noise, self.view, self.views)

    def cameras(self, seed: int, attempt: int) -> np.ndarray:
        """``T_world_camera`` (V, 4, 4) of attempt ``attempt`` of the round of seed ``seed``."""
        if self.view == "fixed":
            return default_extrinsic()[None]
        if self.view == "side":
            return orbit_extrinsic(SIDE_TARGET, FIELD_DISTANCE, SIDE_POLAR, SIDE_AZIMUTH)[None]
        if self.view == "circle":
            azimuths = 2 * np.pi * np.arange(self.views) / self.views
            return np.stack(
                [orbit_extrinsic(CIRCLE_TARGET, FIELD_DISTANCE, CIRCLE_POLAR, a) for a in azimuths]
            )
        training = SceneConfig()
        return np.stack(
            [
                random_camera(training, np.random.default_rng(draw_seed(CAMERA, seed, attempt, v)))
                for v in range(self.views)
            ]
        )

    def observe(
        self, renderer: DepthRenderer, world: World, seed: int, attempt: int
    ) -> Observation:
        """What the planner is given before attempt ``attempt`` of the round of seed ``seed``:
        ``world`` rendered by ``renderer`` from each camera, with its noise."""
        cameras = self.cameras(seed, attempt)
        depth = np.stack(
            [
                noisy_depth(
                    renderer.render(world, T), self.noise, draw_seed(NOISE, seed, attempt, v)
                )
                for v, T in enumerate(cameras)
            ]
        )
        if self.table_scale:
            depth = table_scaled(depth, self.intrinsic, cameras, TABLE_HEIGHT)
        return Observation(depth, self.intrinsic, cameras, world)
