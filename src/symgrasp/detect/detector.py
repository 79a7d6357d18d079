"""`GraspDetector`: depth images in, ranked 6-DoF grasps out.

The pipeline of the paper's detector (Sec. 3.3 and 4.3): fuse the depth images into the 40³
TSDF of the workspace, run the network once, keep voxels whose validity passes a threshold,
decode a rotation per voxel (for ``bingham2d``: e_z the mode of B(A), Eq. 6,
then Gram–Schmidt keeping e_x), drop grasps whose Bingham confidence (λ₃ − λ₂) + (λ₃ − λ₁)
is below the threshold (15 in the paper), suppress non-maxima of the score, and sort by the
gravity-rejection score. With ``samples_per_voxel`` the closing axis is instead drawn from
B(A) several times per voxel (the paper's third decoding mode, Sec. 3.3). With ``fallbacks``
each voxel's grasp is followed by other rotations of the same voxel, most probable first (draws
of B(A) that keep e_x), tried when its approach is refused: one voxel's 2D Bingham holds every
closing axis the grasp tolerates. With ``validity_floor`` the voxels below the validity
threshold but above the floor follow all those above it (GIGA's forced decoding), so that a
scene whose voxels all fall short of the threshold still gets its best grasps.
The steps after the network are `symgrasp.model.ranking.rank_voxels`, which the validation's
top-k metrics share.

No grasp is a valid answer (an empty table); when the input or the network's output shows why
there is none (no depth point inside the workspace, an implausible depth range, a TSDF with no
surface, a non-finite output), the detector says which with a `NoGraspWarning`.
"""

from __future__ import annotations

import hashlib
import math
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch

from symgrasp.config import (
    DEFAULT_VALIDITY,
    SEED_MAX,
    SURFACE_CLEARANCE,
    TABLE_CLEARANCE,
    check_range,
)
from symgrasp.detect.grasp import Grasp
from symgrasp.detect.limits import check_cut_objects, mark_cut, raised_points
from symgrasp.detect.planner import Observation
from symgrasp.detect.pretrained import resolve_model, shipped_operating_point
from symgrasp.detect.width import measured_widths
from symgrasp.device import resolve_device
from symgrasp.digest import file_sha256
from symgrasp.model import torchscript
from symgrasp.model.checkpoint import load_model, trained_gripper
from symgrasp.model.network import GraspNet
from symgrasp.model.ranking import DEFAULT_NMS_RADIUS, Ranked, rank_voxels
from symgrasp.perception import CameraIntrinsic, TSDFVolume, depth_to_points, surface_points
from symgrasp.perception.camera import is_rigid
from symgrasp.perception.points import DEFAULT_PIXEL_SIZE, fill_holes, points_view
from symgrasp.perception.table import MAX_SCALE_ERROR, table_scaled
from symgrasp.sim.grippers import GripperSpec, same_name_note
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE, WORKSPACE_SIZE

Tensor = torch.Tensor


MAX_SAMPLES_PER_VOXEL = 1000
"""Most closing axes drawn per voxel (each is one grasp)."""

MAX_FILL_HOLES = 64
"""Most pixels ``fill_holes`` reaches into a hole from its edge."""

MAX_MEDIAN_DEPTH = 10.0
"""[m] a depth image whose median is farther than this is taken for one in other units."""

MIN_MEDIAN_DEPTH = 0.1
"""[m] a depth image whose median is nearer than this is implausible for a depth camera that
sees the 30 cm workspace (the nearest-measuring ones start at about 7 cm; training's cameras
stand `SceneConfig.camera_distance` from its centre, about half a metre): when it gives no
grasp, the warning asks for its units."""

TSDF_TOLERANCE = 1e-4
"""How far a TSDF value may stray outside [-1, 1] (float rounding of the fused average)."""


class NoGraspWarning(UserWarning):
    """A detection found no grasp and its input or the network's output shows why (the message
    names the cause and what to check). ``warnings.simplefilter("ignore", NoGraspWarning)``
    silences it; ``"error"`` turns it into an exception."""


class GraspDetector:
    """A trained `GraspNet` with its decoding options.

    Args:
        model: the network (any representation).
        gripper: the gripper the network was trained for (`symgrasp.sim.get_gripper` resolves
            a built-in's name or a spec file).
        validity_threshold: keep voxels whose validity probability is at least this.
        confidence_threshold: keep grasps whose confidence is at least this. None: the
            representation's `~symgrasp.rotation.Representation.default_confidence` (15 for
            ``bingham2d``, the paper's value; none for the others); 0 keeps every grasp (a
            Bingham confidence, a sum of eigenvalue gaps, is never negative). A positive
            threshold needs a representation with a confidence.
        nms_radius: a kept voxel must have the highest score within this many voxels
            (a (2r+1)³ neighbourhood); 0 turns non-maximum suppression off.
        top_k: return at most this many grasps (None: all).
        bounds: world-frame box ``(lo (3,), hi (3,))`` [m] the TCP must lie in (None: all;
            ±inf leaves an axis open); it must hold a voxel centre of the workspace.
        samples_per_voxel: 0 decodes the mode; n ≥ 1 draws n closing axes per voxel from the
            predicted distribution (Bingham representations only).
        fallbacks: after each voxel's grasp, this many other rotations of the same voxel, most
            plausible first (`symgrasp.rotation.Representation.fallbacks`: draws of the
            predicted distribution ordered by density, e_x kept for ``bingham2d``; for a point
            estimate the control a user would try, the yaw turned about e_x in steps of
            180°/(fallbacks + 1)), each marked by `Grasp.fallback`. Whoever checks the
            approach in the ranked order (``approach_check``, the benchmark's `first_free`)
            tries them before the next voxel; with ``approach_check`` each voxel gives at most
            one grasp, its first free one, and a voxel whose own grasp is free costs no more
            checks. 0 (default): none. Not with ``samples_per_voxel``.
        validity_floor: forced decoding (GIGA's): the voxels whose validity lies in
            [validity_floor, validity_threshold) are ranked too, all after the voxels that pass
            the threshold (thresholds, NMS and sort applied within each tier), so that a scene
            whose voxels all fall short of the threshold still gets grasps, and a checker that
            refuses every grasp above the threshold moves on to them. None (default): no
            forced decoding.
        workspace_origin: world position [m] of the workspace cube's corner; the table top is
            expected 5 cm above it, as in training (docs/sim.md).
        fill_holes: fill the holes of every depth image up to this many pixels from their edge
            with the farthest seen neighbour before fusion (`symgrasp.perception.fill_holes`:
            the missing pixels a real sensor leaves at object edges); 0 fuses the images as
            they are.
        table_scale: divide every depth image by the depth scale that puts the table plane
            where the workspace says it is, 5 cm above ``workspace_origin`` with z up
            (`symgrasp.perception.table_depth_scale`): undoes a sensor's depth scale error
            (the ``dex`` noise's Gamma factor, SD 3.2 %), which moves the whole scene along
            the camera's rays. Needs the table in view; off by default (the images are fused
            as they are).
        depth_scale: divide every depth image by this known factor (the sensor's depth over
            the true depth, e.g. `symgrasp.perception.table_depth_scale` read once off a
            calibration image of the table): ``table_scale``'s correction for a sensor whose
            scale error stays put, at the price of one division per image instead of reading
            the table in each. Within ``1 ± MAX_SCALE_ERROR`` (a factor of 1000 is a unit,
            not a scale error: `load_depth`'s ``png_scale`` reads millimetres); not with
            ``table_scale``. None (default): no division.
        approach_check: return only the grasps whose open hand, swept from the pre-grasp,
            keeps the declutter benchmark's clearances from the fused surface and from the
            table (`symgrasp.benchmark.declutter.first_free`'s check, 1 mm each: the grasp the
            benchmark executes is the first such grasp), in their ranked order. Off by default
            (every grasp the network ranks); on, a built-in hand's boxes are read from their
            stored copy, loading no simulator, and another hand's are built in MuJoCo at the
            first detection (`symgrasp.sim.collision.hand_boxes`). `detect_tsdf` checks
            against the given grid's surface.
        cut_objects: what to do with the grasps whose hand, approaching from the pre-grasp or
            closed, meets depth points above the workspace's top or past its sides, or the
            space up to `symgrasp.detect.limits.SHADOW` behind them along their camera's rays
            (the unseen back of an object the cube cuts, whose cut reads as an edge): ``"flag"``
            (default) sets their `Grasp.cut` and keeps the ranking, ``"remove"`` leaves them
            out, each with one `CutObjectWarning` naming how many; ``"ignore"`` does not look.
            Timed as the ``cut`` stage. The default changes no grasp (the benchmark's rounds
            stay as recorded); a robot that executes the first grasp unread wants
            ``"remove"``. `detect_tsdf` has no depth points to check.
        seed: seed of ``samples_per_voxel``'s draws.
        optimize: run the network as a frozen TorchScript graph made for inference
            (`symgrasp.model.torchscript.optimize`: oneDNN convolutions on channels-last
            tensors on the CPU): ≈ 0.4× the eager forward time on the 2-core CPU
            (`benchmarks/detect.py`), outputs equal to eager's up to float rounding (≈ 1e-5),
            so a grasp whose score ties another's may swap places with it. Off by default:
            the benchmark's recorded rounds are eager's to the bit. Tracing takes ≈ 1 s.
        device: ``"auto"``, ``"cpu"``, ``"cuda"``, … where TSDF and network run.
        info: the checkpoint's metadata (shown by `repr`, kept for model cards).
        name: what a benchmark records as the planner (`from_pretrained`: the name or path
            it was given; default: representation and gripper).
        version: the SHA-256 of the checkpoint file (`from_pretrained`; default: of the
            weights, computed when first asked).
    """

    def __init__(
        self,
        model: GraspNet,
        gripper: GripperSpec,
        *,
        validity_threshold: float = DEFAULT_VALIDITY,
        confidence_threshold: float | None = None,
        nms_radius: int = DEFAULT_NMS_RADIUS,
        top_k: int | None = None,
        bounds: tuple[np.ndarray, np.ndarray] | None = None,
        samples_per_voxel: int = 0,
        fallbacks: int = 0,
        validity_floor: float | None = None,
        workspace_origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
        fill_holes: int = 0,
        table_scale: bool = False,
        depth_scale: float | None = None,
        approach_check: bool = False,
        cut_objects: str = "flag",
        seed: int = 0,
        optimize: bool = False,
        device: str | torch.device = "auto",
        info: dict[str, Any] | None = None,
        name: str | None = None,
        version: str | None = None,
    ) -> None:
        self.representation = model.representation
        check_range("validity_threshold", validity_threshold, 0.0, 1.0, integer=False)
        if confidence_threshold is None:
            confidence_threshold = self.representation.default_confidence
        elif not (
            not isinstance(confidence_threshold, bool)
            and isinstance(confidence_threshold, int | float)
            and math.isfinite(confidence_threshold)
            and confidence_threshold >= 0
        ):
            raise ValueError(
                f"confidence_threshold must be a finite number ≥ 0 or None, got {confidence_threshold!r}"
            )
        elif confidence_threshold > 0 and not self.representation.has_confidence:
            raise ValueError(
                f"confidence_threshold needs a representation with a confidence; this model is "
                f"{self.representation.name!r} (pass None or 0)"
            )
        check_range("nms_radius", nms_radius, 0, RESOLUTION)
        if top_k is not None:
            check_range("top_k", top_k, 1, RESOLUTION**3 * MAX_SAMPLES_PER_VOXEL)
        check_range("samples_per_voxel", samples_per_voxel, 0, MAX_SAMPLES_PER_VOXEL)
        check_range("fallbacks", fallbacks, 0, MAX_SAMPLES_PER_VOXEL)
        if samples_per_voxel and fallbacks:
            raise ValueError(
                "samples_per_voxel and fallbacks both draw other rotations of a voxel: choose "
                f"one (got {samples_per_voxel} and {fallbacks})"
            )
        if validity_floor is not None:
            check_range("validity_floor", validity_floor, 0.0, validity_threshold, integer=False)
        check_range("seed", seed, 0, SEED_MAX)
        check_range("fill_holes", fill_holes, 0, MAX_FILL_HOLES)
        origin = np.asarray(workspace_origin, dtype=float)
        if origin.shape != (3,) or not np.isfinite(origin).all():
            raise ValueError(
                f"workspace_origin must be 3 finite numbers [m], got {workspace_origin}"
            )
        if samples_per_voxel and not self.representation.has_distribution:
            raise ValueError(
                f"samples_per_voxel needs a distribution; {self.representation.name!r} "
                "predicts a single rotation (use 0)"
            )
        self.device = resolve_device(str(device))
        self.model = model.to(self.device).eval()
        if not isinstance(optimize, bool):
            raise TypeError(f"optimize must be True or False, got {optimize!r}")
        if not isinstance(table_scale, bool):
            raise TypeError(f"table_scale must be True or False, got {table_scale!r}")
        self.table_scale = table_scale
        self.depth_scale = _check_depth_scale(depth_scale, table_scale)
        if not isinstance(approach_check, bool):
            raise TypeError(f"approach_check must be True or False, got {approach_check!r}")
        self.approach_check = approach_check
        self.cut_objects = check_cut_objects(cut_objects)
        self.optimize = optimize
        self._graph = torchscript.optimize(self.model) if optimize else None
        self.gripper = _check_gripper(gripper)
        self.validity_threshold = float(validity_threshold)
        self.confidence_threshold = confidence_threshold
        self.nms_radius = int(nms_radius)
        self.top_k = top_k
        self.bounds = None if bounds is None else _check_bounds(bounds)
        self.samples_per_voxel = int(samples_per_voxel)
        self.fallbacks = int(fallbacks)
        self.validity_floor = None if validity_floor is None else float(validity_floor)
        self.fill_holes = int(fill_holes)
        self.origin = origin
        self.voxel_size = VOXEL_SIZE
        if self.bounds is not None and not self._inside_bounds().any():
            raise ValueError(
                f"bounds {_xyz(self.bounds[0])}–{_xyz(self.bounds[1])} m hold no voxel centre of "
                f"the workspace, the {WORKSPACE_SIZE * 100:g} cm cube from {_xyz(origin)} m: "
                "no grasp could ever be kept"
            )
        self.seed = seed
        self.info = info or {}
        self.name = name or f"{self.representation.name}-{self.gripper.name}"
        self._version = version
        self.timing: dict[str, float] = {}
        """Milliseconds per stage of the last call (``tsdf``, ``network``, ``decode``)."""

    @classmethod
    def from_pretrained(
        cls,
        name_or_path: str | Path,
        device: str | torch.device = "auto",
        gripper: GripperSpec | None = None,
        operating_point: bool = True,
        **options: Any,
    ) -> GraspDetector:
        """A detector from a shipped model name (`symgrasp.detect.PRETRAINED`) or a checkpoint
        path written by ``symgrasp train``, for the gripper stored in it. ``gripper``: the
        gripper you will use; a model trained for another one is loaded with a warning.
        ``operating_point``: a shipped model decodes at the operating point of its model card
        (`symgrasp.detect.pretrained.shipped_operating_point`: thresholds, forced decoding, fallbacks
        chosen on training-object rounds) where ``options`` do not say otherwise; False: the
        class's defaults. ``options``: see the class."""
        if not isinstance(operating_point, bool):
            raise TypeError(f"operating_point must be True or False, got {operating_point!r}")
        if operating_point:
            options = {**shipped_operating_point(name_or_path), **options}
        path = resolve_model(name_or_path)
        model, state = load_model(path, map_location="cpu")
        trained_for = trained_gripper(state)
        used = trained_for if gripper is None else _check_gripper(gripper)
        if used != trained_for:
            warnings.warn(
                f"model {name_or_path} was trained for the {trained_for.name!r} gripper, not "
                f"{used.name!r}{same_name_note(trained_for, used)}: its grasps fit "
                f"{trained_for.name!r}'s geometry",
                stacklevel=2,
            )
        info = {k: v for k, v in state.items() if k not in ("model", "model_raw", "optimizer")}
        return cls(
            model, trained_for, device=device, info=info, name=str(name_or_path),
            version=file_sha256(path), **options,
        )  # fmt: skip

    def __repr__(self) -> str:
        return (
            f"GraspDetector(representation={self.representation.name!r}, "
            f"gripper={self.gripper.name!r}, device={str(self.device)!r})"
        )

    # -- inputs ------------------------------------------------------------------------

    def fuse(
        self,
        depth: np.ndarray | Tensor,
        intrinsic: CameraIntrinsic | np.ndarray,
        extrinsic: np.ndarray | Tensor,
    ) -> TSDFVolume:
        """The workspace TSDF of depth images ``depth`` (H, W) or (V, H, W) [m] taken by
        cameras ``intrinsic`` (a `CameraIntrinsic` or a 3×3 matrix) at ``extrinsic``
        ``T_world_camera`` (4, 4) or (V, 4, 4). NaN, inf and non-positive pixels count as
        missing (their holes filled first with ``fill_holes``)."""
        return self._fuse(*check_views(depth, intrinsic, extrinsic))

    def _fuse(self, views: np.ndarray, intrinsic: CameraIntrinsic, T: np.ndarray) -> TSDFVolume:
        views = self.prepared(views, intrinsic, T)
        return _fuse_views(views, intrinsic, T, self.origin, self.device)

    def prepared(self, views: np.ndarray, intrinsic: CameraIntrinsic, T: np.ndarray) -> np.ndarray:
        """Checked depth images ``views`` (V, H, W) [m] (`check_views`) taken from
        ``T_world_camera`` ``T`` (V, 4, 4) as the detector fuses them: their holes filled
        (``fill_holes``), their depth scale undone (``table_scale``, ``depth_scale``)."""
        if self.fill_holes:
            views = np.stack([fill_holes(view, self.fill_holes) for view in views])
        if self.table_scale:
            views = table_scaled(views, intrinsic, T, self.origin[2] + TABLE_HEIGHT)
        elif self.depth_scale is not None:  # in float64 as table_scaled: the same TSDF, bit for bit
            views = views / np.float64(self.depth_scale)
        return views

    # -- detection ---------------------------------------------------------------------

    def plan(self, observation: Observation) -> list[Grasp]:
        """`detect` on an `Observation`: what makes a detector a `GraspPlanner`."""
        return self.detect(observation.depth, observation.intrinsic, observation.T_world_camera)

    @property
    def version(self) -> str:
        """The SHA-256 of the checkpoint file it was loaded from (`from_pretrained`), else of
        its weights' bytes."""
        if self._version is None:
            digest = hashlib.sha256()
            for name, tensor in self.model.state_dict().items():
                digest.update(name.encode())
                digest.update(tensor.detach().cpu().contiguous().numpy().tobytes())
            self._version = digest.hexdigest()
        return self._version

    def detect(
        self,
        depth: np.ndarray | Tensor,
        intrinsic: CameraIntrinsic | np.ndarray,
        extrinsic: np.ndarray | Tensor,
    ) -> list[Grasp]:
        """Ranked grasps (best gravity-rejection score first) from one or several depth
        images; arguments as in `fuse`. An empty scene gives an empty list; an empty list with
        a visible cause (no depth point inside the workspace, a median depth under
        `MIN_MEDIAN_DEPTH`, a non-finite network output) comes with a `NoGraspWarning`."""
        start = time.perf_counter()
        views = check_views(depth, intrinsic, extrinsic)
        grasps, out = self._detect_views(views, start)
        if not grasps:
            _warn_no_grasp(self.no_grasp_cause(out, views))
        return grasps

    def detect_points(
        self,
        points: np.ndarray,
        T_world_camera: np.ndarray | None = None,
        *,
        viewpoint: np.ndarray | None = None,
        intrinsic: CameraIntrinsic | np.ndarray | None = None,
        frame: str = "world",
        pixel_size: float = DEFAULT_PIXEL_SIZE,
    ) -> list[Grasp]:
        """Ranked grasps from a point cloud ``points`` (N, 3) or organised (H, W, 3) [m]
        seen from ``T_world_camera`` (4, 4) or, if only that is known, from ``viewpoint`` (3,)
        [m]. The cloud becomes the depth image its camera would take (a z-buffer: each pixel
        keeps the nearest point; `symgrasp.perception.points` states the rule), fused as in
        `detect`: with the sensor's ``intrinsic`` a cloud back-projected from a depth image
        gives that image's grasps; without, a virtual camera of ``pixel_size`` [m] at the
        workspace centre. ``frame``: ``"world"`` or ``"camera"`` (the sensor's own frame,
        with ``T_world_camera``). An empty list with a visible cause comes with a
        `NoGraspWarning`, as in `detect`. `timing`'s ``tsdf`` stage counts the projection."""
        start = time.perf_counter()
        depth, camera, T = points_view(
            points, T_world_camera, viewpoint=viewpoint, intrinsic=intrinsic, frame=frame,
            origin=self.origin, pixel_size=pixel_size,
        )  # fmt: skip
        views = check_views(depth, camera, T)
        cloud = None
        if self.cut_objects != "ignore":  # the whole cloud, past the image too
            cloud = np.asarray(points, dtype=float).reshape(-1, 3)
            cloud = cloud if frame == "world" else cloud @ T[:3, :3].T + T[:3, 3]
        grasps, out = self._detect_views(views, start, cloud)
        if not grasps:
            seen = _points_cause(points, depth) or self._depth_cause(*views, POINTS_HINT)
            _warn_no_grasp(_output_cause(out), seen)
        return grasps

    def _detect_views(
        self,
        views: tuple[np.ndarray, CameraIntrinsic, np.ndarray],
        start: float,
        cloud: np.ndarray | None = None,
    ) -> tuple[list[Grasp], dict[str, Tensor]]:
        """The grasps of checked ``views`` (`check_views`), each with the opening its hand
        needs (`measured_widths`, on the fused TSDF, the ``width`` stage), and the network's
        outputs; `timing` counts the TSDF stage from ``start`` (`time.perf_counter`).
        ``cut_objects`` reads the views' points, or the world points ``cloud`` (N, 3) [m] they
        were made of."""
        volume = self._fuse(*views)
        tsdf_ms = _ms_since(start, self.device)
        begin = time.perf_counter()
        out = self.predict(volume.grid())
        network_ms = _ms_since(begin, self.device)
        kept = self.grasps_from(out, volume.tsdf, views, cloud)
        self.timing = {"tsdf": tsdf_ms, "network": network_ms, **self.timing}
        return kept, out

    def grasps_from(
        self,
        out: dict[str, Tensor],
        tsdf: Tensor,
        views: tuple[np.ndarray, CameraIntrinsic, np.ndarray],
        cloud: np.ndarray | None = None,
        viewpoints: np.ndarray | None = None,
    ) -> list[Grasp]:
        """The grasps of the network's outputs ``out`` (`predict`, `predict_many`) on the
        workspace TSDF ``tsdf`` (40, 40, 40) fused from the checked ``views`` (`check_views`):
        decoded, past the approach check, the cut check (on the views' points, or the world
        points ``cloud`` (N, 3) [m] they were made of, seen from ``viewpoints`` (N, 3) [m],
        by default the one view's camera; `raised_points`) and with the opening each hand
        needs (`measured_widths`); sets `timing` (``decode`` and the stages after it)."""
        begin = time.perf_counter()
        grasps = self._decode(out)
        self.timing = {"decode": _ms_since(begin, self.device)}
        kept = self._approach_free(grasps, tsdf)
        if self.cut_objects != "ignore" and kept:
            begin = time.perf_counter()
            if cloud is None:
                cloud, viewpoints = raised_points(*views, self.origin)
            elif viewpoints is None and len(views[2]) == 1:
                viewpoints = views[2][0, :3, 3]
            # stacklevel 4: the line that called detect, detect_points or detect_table
            kept = mark_cut(
                kept, self.gripper, cloud, self.origin, self.cut_objects, stacklevel=4,
                viewpoints=viewpoints,
            )  # fmt: skip
            self.timing["cut"] = _ms_since(begin, self.device)
        begin = time.perf_counter()
        kept = measured_widths(kept, self.gripper, tsdf, self.origin)
        self.timing["width"] = _ms_since(begin, self.device)
        return kept

    def _approach_free(self, grasps: list[Grasp], grid: np.ndarray | Tensor) -> list[Grasp]:
        """With ``approach_check``, the grasps of ``grasps`` whose approach keeps the
        benchmark's clearances from the surface of the checked TSDF ``grid`` (40, 40, 40;
        `surface_points`) and from the table, in order, timed as the ``approach`` stage;
        without, ``grasps``."""
        if not (self.approach_check and grasps):
            return grasps
        from symgrasp.sim.collision import hand_collides

        start = time.perf_counter()
        grid = torch.as_tensor(grid, dtype=torch.float32, device=self.device)
        points = surface_points(grid, WORKSPACE_SIZE, tuple(self.origin)).cpu().numpy()

        def free(checked: list[Grasp]) -> list[bool]:
            if not checked:
                return []
            hits = hand_collides(
                np.array([g.pose for g in checked]), self.gripper, points,
                tolerance=-SURFACE_CLEARANCE, table_height=self.origin[2] + TABLE_HEIGHT,
                table_tolerance=-TABLE_CLEARANCE,
            )  # fmt: skip
            return (~hits).tolist()

        own_free = free(grasps)
        kept = [grasp for grasp, ok in zip(grasps, own_free, strict=True) if ok]
        if self.fallbacks and not all(own_free):
            # drawn only now, and checked only where a voxel's own grasp was refused
            groups = self._fallback_groups()
            tried = [g for group, ok in zip(groups, own_free, strict=True) if not ok for g in group]
            tried_free = dict(zip(map(id, tried), free(tried), strict=True))
            kept = []
            for grasp, group, ok in zip(grasps, groups, own_free, strict=True):
                first = grasp if ok else next((g for g in group if tried_free[id(g)]), None)
                if first is not None:
                    kept.append(first)
        self.timing["approach"] = _ms_since(start, self.device)
        return kept

    @torch.no_grad()
    def predict(self, tsdf: np.ndarray | Tensor) -> dict[str, Tensor]:
        """The network's per-voxel outputs for a TSDF (40, 40, 40) in [-1, 1]: ``score``,
        ``validity`` (probability) ``[40, 40, 40]`` and ``rotation`` channels
        ``[40, 40, 40, C]``."""
        return self.predict_many(_check_tsdf(tsdf, self.device)[None])[0]

    @torch.no_grad()
    def predict_many(self, tsdfs: Tensor) -> list[dict[str, Tensor]]:
        """`predict` of each checked TSDF of ``tsdfs`` (B, 40, 40, 40) on the detector's device,
        in one forward pass: each cube's outputs are its own pass's up to the float rounding
        of a batched convolution (≈ 1e-4 of an output's largest magnitude: the network's
        GroupNorm normalises each cube apart)."""
        batch = tsdfs[:, None]
        out = self.model(batch) if self._graph is None else torchscript.forward(self._graph, batch)
        validity = torch.sigmoid(out.validity)
        return [
            {
                "score": out.score[b],
                "validity": validity[b],
                "rotation": out.rotation[b].movedim(0, -1),
            }
            for b in range(len(tsdfs))
        ]

    def detect_tsdf(self, tsdf: np.ndarray | Tensor) -> list[Grasp]:
        """Ranked grasps from a workspace TSDF (40, 40, 40) in [-1, 1] (ValueError outside it
        or non-finite: a TSDF's range is its definition; unobserved voxels read 1, as
        `TSDFVolume.grid` writes them). An empty list whose cause is visible (no voxel below 0:
        nothing seen inside the workspace; a non-finite network output) comes with a
        `NoGraspWarning`. With ``approach_check`` the surface checked against is the grid's own
        (`symgrasp.perception.surface_points`): the grasps of `detect` on the images it
        was fused from."""
        grasps, out = self._detect(tsdf)  # checks tsdf
        grasps = self._approach_free(grasps, tsdf)
        if not grasps:
            _warn_no_grasp(_output_cause(out), _tsdf_cause(tsdf))
        return grasps

    @torch.no_grad()
    def _detect(self, tsdf: np.ndarray | Tensor) -> tuple[list[Grasp], dict[str, Tensor]]:
        """The grasps of ``tsdf`` and the network's outputs they were decoded from; sets
        `timing`."""
        start = time.perf_counter()
        out = self.predict(tsdf)
        network_ms = _ms_since(start, self.device)
        start = time.perf_counter()
        grasps = self._decode(out)
        self.timing = {"network": network_ms, "decode": _ms_since(start, self.device)}
        return grasps, out

    def no_grasp_cause(
        self, out: dict[str, Tensor], views: tuple[np.ndarray, CameraIntrinsic, np.ndarray]
    ) -> str | None:
        """Why the network's outputs ``out`` on the checked ``views`` (`check_views`) gave no
        grasp, where that is visible (a non-finite output, the depth's `_depth_cause`): the
        `NoGraspWarning`'s message `detect` gives; None: not seen."""
        return _no_grasp_message(_output_cause(out), self._depth_cause(*views))

    def _depth_cause(
        self, views: np.ndarray, intrinsic: CameraIntrinsic, T: np.ndarray, hint: str = ""
    ) -> str | None:
        """Why depth images ``views`` (V, H, W) [m, 0 = missing] plainly hold nothing to
        grasp, or None: no pixel seen, a median depth under `MIN_MEDIAN_DEPTH`, no point inside
        the workspace cube (the message says where the points are instead, and what to check,
        ``hint`` added)."""
        seen = views[views > 0]
        if not seen.size:
            return "the depth image has no valid pixel (each is NaN, infinite or ≤ 0)"
        median = float(np.median(seen))
        near = (
            f", implausibly near for a depth camera (expected {MIN_MEDIAN_DEPTH:g}–"
            f"{MAX_MEDIAN_DEPTH:g} m): is the depth in metres?"
            if median < MIN_MEDIAN_DEPTH
            else ""
        )
        pairs = list(zip(views, T, strict=True))
        if any(len(depth_to_points(d, intrinsic, t, origin=self.origin)) for d, t in pairs):
            return f"the median depth is {median:.3g} m{near}" if near else None
        points = np.concatenate([depth_to_points(d, intrinsic, t, crop=False) for d, t in pairs])
        return (
            f"none of the {len(points)} depth points lies inside the workspace, the "
            f"{WORKSPACE_SIZE * 100:g} cm cube from {_xyz(self.origin)} to "
            f"{_xyz(self.origin + WORKSPACE_SIZE)} m; they lie around "
            f"{_xyz(np.median(points, axis=0))} m at a median depth of {median:.3g} m{near or '.'} "
            "Check that the depth is in metres (for a PNG: its scale), that the extrinsic is "
            "T_world_camera (the camera's pose in the world, not its inverse) and the workspace "
            f"origin{hint}"
        )

    def _decode(self, out: dict[str, Tensor]) -> list[Grasp]:
        """The grasps of the network's outputs ``out``: the voxels that pass the validity
        threshold, then, with ``validity_floor``, those between the floor and the threshold
        (forced decoding), each tier ranked by `rank_voxels`; each voxel's grasp followed by its
        ``fallbacks``, except with ``approach_check``, which draws them only once a voxel's own
        grasp is refused (`_fallback_groups`: the same draws)."""
        keep = None if self.bounds is None else self._inside_bounds()
        tiers = [self._rank(out, self.validity_threshold, keep, self.top_k)]
        found = len(tiers[0].index)
        if self.validity_floor is not None and (self.top_k is None or found < self.top_k):
            below = out["validity"] < self.validity_threshold
            left = None if self.top_k is None else self.top_k - found
            forced = below if keep is None else below & keep
            tiers.append(self._rank(out, self.validity_floor, forced, left))
        self._tiers, self._validity = tiers, out["validity"]
        if self.samples_per_voxel:
            generator = torch.Generator(self.device).manual_seed(self.seed)
            return [grasp for tier in tiers for grasp in self._grasps(
                tier, self.representation.sample(tier.pred, self.samples_per_voxel, generator)
            )]  # fmt: skip
        own = [grasp for tier in tiers for grasp in self._grasps(tier, tier.rotation[:, None])]
        if not self.fallbacks or self.approach_check:
            return own
        groups = self._fallback_groups()
        return [g for grasp, others in zip(own, groups, strict=True) for g in (grasp, *others)]

    def _rank(
        self, out: dict[str, Tensor], threshold: float, keep: Tensor | None, top_k: int | None
    ) -> Ranked:
        """The voxels `rank_voxels` keeps at validity ``threshold`` within ``keep``."""
        return rank_voxels(
            out["score"], out["validity"], out["rotation"], self.representation,
            validity_threshold=threshold, confidence_threshold=self.confidence_threshold,
            nms_radius=self.nms_radius, top_k=top_k, keep=keep,
        )  # fmt: skip

    def _fallback_groups(self) -> list[list[Grasp]]:
        """Each ranked voxel's ``fallbacks`` of the last decoding, in rank order (tier by tier,
        one generator seeded by ``seed``: the same draws whenever they are drawn)."""
        generator = torch.Generator(self.device).manual_seed(self.seed)
        groups = []
        for tier in self._tiers:
            if len(tier.pred):
                others = self.representation.fallbacks(tier.pred, self.fallbacks, generator)
                groups += self._grasps(tier, others, first_fallback=1, grouped=True)
        return groups

    def _inside_bounds(self) -> Tensor:
        lo, hi = (torch.as_tensor(b, device=self.device) for b in self.bounds)
        idx = torch.arange(RESOLUTION, device=self.device, dtype=torch.float64)
        axes = [self.origin[a] + (idx + 0.5) * self.voxel_size for a in range(3)]
        inside = [(axes[a] >= lo[a]) & (axes[a] <= hi[a]) for a in range(3)]
        return inside[0][:, None, None] & inside[1][None, :, None] & inside[2][None, None, :]

    def _grasps(
        self, ranked: Ranked, rotations: Tensor, first_fallback: int = 0, grouped: bool = False
    ) -> list:
        """One `Grasp` per ranked voxel and rotation ``rotations`` [M, S, 3, 3], in order, the
        s-th of a voxel numbered ``first_fallback`` + s if that is not 0 (`Grasp.fallback`):
        a flat list, or with ``grouped`` one list per voxel."""
        index, rotations = ranked.index.cpu(), rotations.cpu().numpy()
        centres = self.origin + (index.numpy() + 0.5) * self.voxel_size
        validity = self._validity[tuple(ranked.index.T)].cpu().tolist()
        score = ranked.score.cpu().tolist()
        conf = [None] * len(score) if ranked.confidence is None else ranked.confidence.tolist()
        voxels = [tuple(int(v) for v in row) for row in index.tolist()]
        groups = []
        for m in range(len(voxels)):
            group = []
            for s, R in enumerate(rotations[m]):
                pose = np.eye(4)
                pose[:3, :3], pose[:3, 3] = R, centres[m]
                fallback = first_fallback + s if first_fallback else 0
                group.append(Grasp(pose, score[m], validity[m], conf[m], voxels[m], fallback))
            groups.append(group)
        return groups if grouped else [grasp for group in groups for grasp in group]


def fuse(
    depth: np.ndarray | Tensor,
    intrinsic: CameraIntrinsic | np.ndarray,
    extrinsic: np.ndarray | Tensor,
    origin: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0),
    device: str | torch.device = "cpu",
) -> TSDFVolume:
    """The 40³ TSDF of the workspace cube from ``origin`` fused from depth images ``depth``
    (H, W) or (V, H, W) [m] taken by cameras ``intrinsic`` (a `CameraIntrinsic` or a 3×3
    matrix) at ``extrinsic`` ``T_world_camera`` (4, 4) or (V, 4, 4), on ``device``; NaN, inf
    and non-positive pixels count as missing. What `GraspDetector.fuse` runs, and the surface
    the declutter benchmark checks every planner's approach against."""
    return _fuse_views(*check_views(depth, intrinsic, extrinsic), origin, torch.device(device))


def _fuse_views(
    views: np.ndarray,
    intrinsic: CameraIntrinsic,
    T: np.ndarray,
    origin: np.ndarray | tuple[float, float, float],
    device: torch.device,
) -> TSDFVolume:
    volume = TSDFVolume(resolution=RESOLUTION, origin=tuple(origin), device=device)
    volume.integrate(views, intrinsic, T)
    return volume


def _warn_no_grasp(*causes: str | None) -> None:
    """Warn that no grasp was found, naming the visible ``causes`` (None: not seen)."""
    if message := _no_grasp_message(*causes):
        # stacklevel 3: the line that called detect or detect_tsdf
        warnings.warn(message, NoGraspWarning, stacklevel=3)


def _no_grasp_message(*causes: str | None) -> str | None:
    """The `NoGraspWarning` naming the visible ``causes`` (None: not seen); None if none is."""
    seen = [cause for cause in causes if cause]
    return "no grasp found: " + "; ".join(seen) if seen else None


def _output_cause(out: dict[str, Tensor]) -> str | None:
    """The network's outputs ``out`` (`GraspDetector.predict`) being non-finite, or None."""
    bad = ~(
        torch.isfinite(out["score"])
        & torch.isfinite(out["validity"])
        & torch.isfinite(out["rotation"]).all(-1)
    )
    if not bad.any():
        return None
    return (
        f"the network's output is NaN or infinite in {int(bad.sum())} of {bad.numel()} voxels "
        "(weights that are not finite, or ones that overflow): check the model"
    )


POINTS_HINT = "; for a point cloud, also the frame it is in (frame='world' or 'camera')"
"""What else to check when a point cloud's points miss the workspace."""


def _points_cause(points: np.ndarray, depth: np.ndarray) -> str | None:
    """The cloud ``points`` giving an empty depth image ``depth`` (its camera saw none of
    them), or None."""
    if (depth > 0).any():
        return None
    cloud = np.asarray(points, dtype=float).reshape(-1, 3)
    finite = cloud[np.isfinite(cloud).all(axis=1)]
    if not len(finite):
        return f"none of the {len(cloud)} points is finite (each has a NaN or infinite coordinate)"
    return (
        f"none of the {len(finite)} finite points lies in the camera's view of the workspace (in "
        f"front of the camera and inside its image); they lie around "
        f"{_xyz(np.median(finite, axis=0))} m. Check the frame the points are in (frame='world' "
        "or 'camera') and that the pose is T_world_camera, not its inverse"
    )


def _tsdf_cause(tsdf: np.ndarray | Tensor) -> str | None:
    """The TSDF (checked by `_check_tsdf`) showing no surface inside the workspace, or None."""
    if bool((torch.as_tensor(tsdf) < 0).any()):
        return None
    return (
        "the TSDF shows nothing inside the workspace (no voxel below 0, behind a seen surface): "
        "check the depth images and camera poses it was fused from"
    )


def _xyz(point: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.3g}" for x in point) + ")"


def _check_tsdf(tsdf: np.ndarray | Tensor, device: torch.device) -> Tensor:
    """``tsdf`` as a float32 (40, 40, 40) tensor on ``device``; ValueError unless it is one
    in [-1, 1] (a signed distance divided by the truncation and clipped)."""
    try:
        grid = torch.as_tensor(tsdf, dtype=torch.float32, device=device)
    except (TypeError, ValueError):  # a string, None, lists of strings: torch names no argument
        raise TypeError(
            f"tsdf must be a ({RESOLUTION}, {RESOLUTION}, {RESOLUTION}) array or tensor of "
            f"numbers, got {type(tsdf).__name__} {tsdf!r:.40}"
        ) from None
    if grid.shape != (RESOLUTION,) * 3:
        raise ValueError(
            f"tsdf must be ({RESOLUTION}, {RESOLUTION}, {RESOLUTION}), "
            f"got shape {tuple(grid.shape)}"
        )
    lo, hi = torch.aminmax(grid)  # NaN propagates: one reduction checks both
    if not (lo >= -1 - TSDF_TOLERANCE and hi <= 1 + TSDF_TOLERANCE):
        finite = torch.isfinite(grid)
        found = (
            f"{int((~finite).sum())} NaN or infinite values"
            if not finite.all()
            else f"values from {grid.min():.3g} to {grid.max():.3g}"
        )
        raise ValueError(
            "tsdf must be finite and within [-1, 1] (a signed distance divided by the "
            f"truncation distance), got {found}"
        )
    return grid


def check_views(
    depth: np.ndarray | Tensor,
    intrinsic: CameraIntrinsic | np.ndarray,
    extrinsic: np.ndarray | Tensor,
) -> tuple[np.ndarray, CameraIntrinsic, np.ndarray]:
    """The inputs of `GraspDetector.fuse` checked (ValueError naming what is wrong): depth
    (V, H, W) [m, 0 = missing], the `CameraIntrinsic` and ``T_world_camera`` (V, 4, 4), rigid.
    What any planner's input passes through on the command line."""
    depth = _depth_in_metres(depth)
    views = depth.reshape(-1, *depth.shape[-2:])
    return views, _as_intrinsic(intrinsic, views.shape[1:]), _check_extrinsic(extrinsic, len(views))


def _depth_in_metres(depth: np.ndarray | Tensor) -> np.ndarray:
    """``depth`` as float32 (H, W) or (V, H, W) [m] with 0 where nothing was seen; refuses
    what is likely not metres (an integer image, a median over 10 m: millimetres or raw
    sensor units would otherwise silently give no grasp)."""
    raw = depth.cpu().numpy() if isinstance(depth, Tensor) else np.asarray(depth)
    if raw.ndim == 3 and raw.shape[-1] == 1:  # (H, W, 1): one image with a channel axis
        raw = raw[..., 0]
    if raw.ndim == 3 and 1 < raw.shape[-1] <= 4:  # no depth image is 2 to 4 pixels wide
        raise ValueError(
            f"depth of shape {raw.shape} looks like a colour image or an organised point cloud "
            "(H, W, 3), not depth images (H, W) or (V, H, W) [m]: pass its depth channel alone, "
            "or an organised cloud's points to detect_points"
        )
    if raw.ndim not in (2, 3) or min(raw.shape) == 0:
        raise ValueError(f"depth must be (H, W), (H, W, 1) or (V, H, W), got shape {raw.shape}")
    if not np.issubdtype(raw.dtype, np.floating):
        hint = (
            " (a raw sensor image? multiply it by its scale, e.g. 0.001 for millimetres)"
            if np.issubdtype(raw.dtype, np.integer)
            else ""
        )
        raise ValueError(f"depth must be floating point metres, got {raw.dtype}{hint}")
    depth = raw.astype(np.float32)
    seen = np.isfinite(depth) & (depth > 0)
    metres = np.where(seen, depth, 0.0)
    # the median is over the limit only if the maximum is: a max costs a tenth of a median
    if metres.max() > MAX_MEDIAN_DEPTH:
        median = float(np.median(metres[seen]))
        if median > MAX_MEDIAN_DEPTH:
            raise ValueError(
                f"depth must be in metres; its median over the seen pixels is {median:.1f}, "
                f"over {MAX_MEDIAN_DEPTH:g} m (millimetres? multiply by 0.001)"
            )
    return metres


def _ms_since(start: float, device: torch.device) -> float:
    if device.type == "cuda":
        torch.cuda.synchronize(device)
    return 1e3 * (time.perf_counter() - start)


def _as_intrinsic(
    intrinsic: CameraIntrinsic | np.ndarray, shape: tuple[int, int]
) -> CameraIntrinsic:
    """A `CameraIntrinsic` for images of ``shape`` (H, W) from one or a 3×3 matrix."""
    height, width = int(shape[0]), int(shape[1])
    if isinstance(intrinsic, CameraIntrinsic):
        if (intrinsic.height, intrinsic.width) != (height, width):
            raise ValueError(
                f"depth images are {height}×{width} (H×W) but the intrinsic is for "
                f"{intrinsic.height}×{intrinsic.width}"
            )
        return intrinsic
    if isinstance(intrinsic, (dict, str)):  # a camera file's fields: numpy names no argument
        raise TypeError(
            f"intrinsic must be a CameraIntrinsic or 3×3 matrix, got a {type(intrinsic).__name__}"
            f" {intrinsic!r:.60} (from fx, fy, cx, cy: CameraIntrinsic(width, height, fx, fy, "
            "cx, cy))"
        )
    K = np.asarray(intrinsic, dtype=float)
    if K.shape != (3, 3):
        raise ValueError(f"intrinsic must be a CameraIntrinsic or 3×3 matrix, got shape {K.shape}")
    return CameraIntrinsic.from_matrix(K, width, height)


def _check_extrinsic(extrinsic: np.ndarray | Tensor, views: int) -> np.ndarray:
    """``T_world_camera`` as (V, 4, 4); raises ValueError unless every one is rigid."""
    T = np.asarray(torch.as_tensor(extrinsic).cpu(), dtype=float)
    if T.shape == (4, 4):
        T = T[None]
    if T.shape != (views, 4, 4):
        raise ValueError(
            f"extrinsic must be T_world_camera (4, 4) or ({views}, 4, 4) for {views} depth "
            f"image(s), got shape {T.shape}"
        )
    if not is_rigid(T):
        raise ValueError(
            f"extrinsic of shape {T.shape} is not a rigid transform: its rotation block must be "
            "orthonormal with det +1 and its last row (0, 0, 0, 1)"
        )
    return T


def _check_depth_scale(depth_scale: Any, table_scale: bool) -> float | None:
    if depth_scale is None:
        return None
    if table_scale:
        raise ValueError("depth_scale and table_scale both correct the depth scale: choose one")
    if isinstance(depth_scale, bool) or not isinstance(depth_scale, (int, float, np.floating)):
        raise TypeError(f"depth_scale must be a number or None, got {depth_scale!r}")
    if not abs(float(depth_scale) - 1) <= MAX_SCALE_ERROR:
        raise ValueError(
            f"depth_scale must be a sensor's depth over the true depth, within "
            f"1 ± {MAX_SCALE_ERROR}; got {depth_scale} (depth in another unit than metres? "
            "load_depth's png_scale converts it)"
        )
    return float(depth_scale)


def _check_gripper(gripper: Any) -> GripperSpec:
    if not isinstance(gripper, GripperSpec):
        raise TypeError(
            "gripper must be a GripperSpec (symgrasp.sim.get_gripper resolves a built-in's name "
            f"or a spec file), got {gripper!r}"
        )
    return gripper


def _check_bounds(bounds: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = (np.asarray(b, dtype=float) for b in bounds)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(lo <= hi):  # NaN compares False
        raise ValueError(
            f"bounds must be (lo (3,), hi (3,)) [m] with lo ≤ hi and no NaN, got {bounds}"
        )
    return lo, hi
