"""Depth images of a :class:`~symgrasp.sim.world.World`: MuJoCo's OpenGL renderer where a
GL backend works, otherwise a CPU ray cast (``mujoco.mj_multiRay``), chosen automatically.

Both see the same geoms (the table and the objects; never the hand or the pile walls) and
return the same depth convention (:mod:`symgrasp.perception.camera`).
"""

from __future__ import annotations

import functools
from typing import Protocol

import mujoco
import numpy as np

from symgrasp.perception.camera import CameraIntrinsic
from symgrasp.sim.physics import HAND_GROUP, HIDDEN_GROUP
from symgrasp.sim.world import World

VISIBLE_GROUPS = np.array([1, 1, 0, 0, 1, 1], dtype=np.uint8)
"""Geom groups a camera sees: not the hand (2) nor hidden geoms (3: table plane, walls)."""
assert VISIBLE_GROUPS[HAND_GROUP] == VISIBLE_GROUPS[HIDDEN_GROUP] == 0

SCENE_MARGIN = 64
"""Scene geoms a GL renderer holds beyond its model's geoms, sites and tendons."""
ROOMY_SCENE = 10_000
"""Scene geoms of a renderer whose tight scene filled up (``mujoco.Renderer``'s default)."""

MAX_DEPTH = 3.0
"""Farthest surface reported [m]; anything beyond reads as 0 (no return)."""


class DepthRenderer(Protocol):
    """Renders depth images; ``name`` says which backend it is."""

    name: str

    def render(self, world: World, T_world_camera: np.ndarray) -> np.ndarray:
        """Depth image (height, width) float32 [m], 0 where nothing is seen."""
        ...


def _check_extrinsic(T: np.ndarray) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4):
        raise ValueError(f"T_world_camera must be a 4×4 transform, got shape {T.shape}")
    return T


class RaycastRenderer:
    """CPU fallback: one MuJoCo ray per pixel (exact for primitives, ~20 ms per 640×480)."""

    name = "raycast"

    def __init__(self, intrinsic: CameraIntrinsic | None = None) -> None:
        self.intrinsic = intrinsic = intrinsic or CameraIntrinsic()
        self._rays = intrinsic.pixel_rays().reshape(-1, 3)

    def render(self, world: World, T_world_camera: np.ndarray) -> np.ndarray:
        T = _check_extrinsic(T_world_camera)
        # rays with z = 1 in the camera frame: the hit distance in units of the ray *is* depth
        vec = np.ascontiguousarray(self._rays @ T[:3, :3].T).reshape(-1)
        n = len(self._rays)
        geom = np.zeros(n, dtype=np.int32)
        dist = np.zeros(n)
        mujoco.mj_multiRay(
            world.model,
            world.data,
            T[:3, 3].copy(),
            vec,
            VISIBLE_GROUPS,
            1,
            -1,
            geom,
            dist,
            None,
            n,
            MAX_DEPTH,
        )
        depth = np.where(geom >= 0, dist, 0.0)
        return depth.reshape(self.intrinsic.height, self.intrinsic.width).astype(np.float32)


class GLRenderer:
    """MuJoCo's OpenGL renderer with the pinhole camera imposed on the scene's GL camera.

    A depth image needs neither multisampling nor a shadow map, so its GL contexts are made
    without them (``pictures=False``, the default): on a software GL (llvmpipe) they made the
    first image of each rebuilt world 4× costlier (125.9 against 31.0 ms), a fifth of a
    declutter round, for the same depth (dataset hashes and benchmark rounds compared,
    `docs/sim.md`). ``pictures=True`` keeps the model's settings, for colour pictures."""

    name = "gl"

    def __init__(self, intrinsic: CameraIntrinsic | None = None, pictures: bool = False) -> None:
        self.intrinsic = intrinsic or CameraIntrinsic()
        self.pictures = pictures
        self._renderer: mujoco.Renderer | None = None
        self._model: mujoco.MjModel | None = None
        self._option = mujoco.MjvOption()
        self._option.geomgroup[:] = VISIBLE_GROUPS

    def _renderer_for(self, model: mujoco.MjModel, roomy: bool = False) -> mujoco.Renderer:
        """The renderer of ``model`` (worlds rebuild their model when objects change). Its scene
        holds the model's geoms, sites and tendons and ``SCENE_MARGIN`` more, not
        ``mujoco.Renderer``'s 10 000 (allocating those took a third of each rebuild's
        renderer); ``roomy`` asks for the 10 000 after a scene filled up."""
        if self._model is not model or roomy:
            if self._renderer is not None:
                self._renderer.close()
            tight = model.ngeom + model.nsite + model.ntendon + SCENE_MARGIN
            quality = model.vis.quality
            saved = quality.offsamples, quality.shadowsize
            if not self.pictures:  # the context reads them once, when it is made
                quality.offsamples, quality.shadowsize = 0, 0
            try:
                self._renderer = mujoco.Renderer(model, self.intrinsic.height, self.intrinsic.width,
                                                 max_geom=ROOMY_SCENE if roomy else tight)  # fmt: skip
            finally:
                quality.offsamples, quality.shadowsize = saved
            self._renderer.enable_depth_rendering()
            self._model = model
        return self._renderer

    def render(self, world: World, T_world_camera: np.ndarray) -> np.ndarray:
        depth = self._render(world, T_world_camera, depth=True)
        depth[depth > MAX_DEPTH] = 0.0
        return depth.astype(np.float32)

    def render_color(self, world: World, T_world_camera: np.ndarray) -> np.ndarray:
        """Colour image (height, width, 3) uint8 from the same camera."""
        return self._render(world, T_world_camera, depth=False)

    def _render(self, world: World, T_world_camera: np.ndarray, depth: bool) -> np.ndarray:
        T = _check_extrinsic(T_world_camera)
        renderer = self._renderer_for(world.model)
        renderer.update_scene(world.data, scene_option=self._option)
        if renderer.scene.ngeom >= renderer.scene.maxgeom:  # full: geoms may have been dropped
            renderer = self._renderer_for(world.model, roomy=True)
            renderer.update_scene(world.data, scene_option=self._option)
        if depth:
            renderer.enable_depth_rendering()
        else:
            renderer.disable_depth_rendering()
        k = self.intrinsic
        for cam in renderer.scene.camera:
            near = cam.frustum_near
            cam.pos[:] = T[:3, 3]
            cam.forward[:] = T[:3, 2]
            cam.up[:] = -T[:3, 1]
            # image edges are half a pixel beyond the outermost pixel centres
            left, right = -(k.cx + 0.5) / k.fx * near, (k.width - 0.5 - k.cx) / k.fx * near
            cam.frustum_center = (left + right) / 2
            # mjr_render reads frustum_width as the *half* width (the test against the ray
            # caster catches a full width: the image then sees twice as wide)
            cam.frustum_width = (right - left) / 2
            cam.frustum_top = (k.cy + 0.5) / k.fy * near
            cam.frustum_bottom = -(k.height - 0.5 - k.cy) / k.fy * near
        return renderer.render()


@functools.cache
def gl_available() -> bool:
    """Whether MuJoCo can open an OpenGL context here (:mod:`symgrasp.gl_backend` picks
    the backend before mujoco is imported)."""
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    try:
        mujoco.Renderer(model, 8, 8).close()
    except Exception:  # any backend failure (missing library, no device) means "no GL"
        return False
    return True


def make_renderer(intrinsic: CameraIntrinsic | None = None, backend: str = "auto") -> DepthRenderer:
    """A depth renderer: ``"gl"``, ``"raycast"``, or ``"auto"`` (GL if it works here)."""
    if backend not in ("auto", "gl", "raycast"):
        raise ValueError(f"backend must be 'auto', 'gl' or 'raycast', got {backend!r}")
    if backend == "gl" or (backend == "auto" and gl_available()):
        if not gl_available():
            raise ValueError("backend 'gl' was requested but no OpenGL context can be created")
        return GLRenderer(intrinsic)
    return RaycastRenderer(intrinsic)
