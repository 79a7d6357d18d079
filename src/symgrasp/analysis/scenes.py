"""The analysis scenes of Sec. 4.1 and 4.2 and one voxel layer of a detector's output over them.

The world frame is the workspace frame: the cube [0, 0.3]³ m with the table top at z = 0.05 m
(`symgrasp.sim.world`); voxel [i, j, k] of the 40³ grid has its centre at (i, j, k) + ½ voxel,
i along x.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch
from matplotlib.axes import Axes
from matplotlib.image import AxesImage
from matplotlib.patches import Circle, Patch, Rectangle

from symgrasp.detect import GraspDetector
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.rotation import Representation
from symgrasp.sim import ObjectSpec, Part, World
from symgrasp.sim.render import make_renderer
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE, WORKSPACE_SIZE

SLICE_HEIGHT = 0.057
"""World height [m] of the paper's cross-sections (z = 57 mm, 7 mm above the table). Where a
model's valid grasp centres lie higher (they depend on where the gripper's TCP is), pass
``height=None`` for the layer with the most valid voxels (`busiest_layer`)."""

"""Edge of a voxel [m]."""

ARROW_LENGTH = 1.6 * VOXEL_SIZE
"""Drawn length [m] of a horizontal unit e_z; a sampled e_z's segment in the distribution plot
is as long."""

VIEW_MARGIN = 0.03
"""The field plots show the objects' footprints and this much around them [m]."""

DepthView = tuple[np.ndarray, CameraIntrinsic, np.ndarray]
"""A depth image (H, W) [m], its camera's intrinsic and ``T_world_camera`` (4, 4)."""


@dataclass(frozen=True)
class Placed:
    """An upright, axis-aligned box or cylinder standing on the table.

    ``size`` holds the full extents (x, y, z) [m]; a cylinder's x and y are its diameter.
    """

    name: str
    kind: Literal["box", "cylinder"]
    centre: tuple[float, float]
    """x, y of the footprint's centre [m]."""
    size: tuple[float, float, float]

    def spec(self) -> ObjectSpec:
        """The object, its frame at the centre of its base (`symgrasp.sim.objects`)."""
        half = tuple(s / 2 for s in self.size)
        if self.kind == "box":
            part = Part("box", half, (0.0, 0.0, half[2]))
        else:
            part = Part("cylinder", (half[0], half[2]), (0.0, 0.0, half[2]))
        return ObjectSpec(self.name, self.kind, (part,), mass=0.2, friction=0.8)

    def pose(self) -> np.ndarray:
        """``T_world_object`` (4, 4): standing on the table top at ``centre``."""
        T = np.eye(4)
        T[:3, 3] = (*self.centre, TABLE_HEIGHT)
        return T

    def footprint_distance(self, xy: np.ndarray) -> np.ndarray:
        """Horizontal distance [m] of points ``xy [..., 2]`` to the footprint, 0 inside."""
        d = np.abs(xy - np.asarray(self.centre))
        if self.kind == "box":
            return np.linalg.norm(np.maximum(d - np.asarray(self.size[:2]) / 2, 0.0), axis=-1)
        return np.maximum(np.linalg.norm(d, axis=-1) - self.size[0] / 2, 0.0)

    def outline(self) -> Patch:
        """The footprint as an unfilled matplotlib patch."""
        style = {
            "fill": False,
            "edgecolor": "black",
            "linewidth": 1.0,
            "linestyle": "--",
            "zorder": 3,
        }
        if self.kind == "box":
            corner = (self.centre[0] - self.size[0] / 2, self.centre[1] - self.size[1] / 2)
            return Rectangle(corner, self.size[0], self.size[1], **style)
        return Circle(self.centre, self.size[0] / 2, **style)


LONG_BOX = Placed("box", "box", (WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2), (0.2, 0.06, 0.06))
"""Sec. 4.1: 60×60×200 mm at the workspace centre, long side along x (e_z must be ±y)."""

FLAT_CYLINDER = Placed(
    "cylinder", "cylinder", (WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2 + 0.1), (0.07, 0.07, 0.06)
)
"""Sec. 4.2: 70 mm across, 60 mm tall, on its flat face, 10 cm beside the box along +y."""


def render_depth(objects: Sequence[Placed]) -> DepthView:
    """One depth image of ``objects`` on the table from the default camera (workspace
    centre + (0.5, 0, 0.5) m, looking at the centre), as in Sec. 4.1."""
    world = World([o.spec() for o in objects], np.stack([o.pose() for o in objects]))
    intrinsic, T_world_camera = CameraIntrinsic(), default_extrinsic()
    return make_renderer(intrinsic).render(world, T_world_camera), intrinsic, T_world_camera


def slice_layer(height: float) -> int:
    """The voxel layer k holding world height ``height`` [m]: ⌊height / voxel⌋ (7 at 57 mm)."""
    k = math.floor(height / VOXEL_SIZE + 1e-9)
    if not 0 <= k < RESOLUTION:
        raise ValueError(f"--height must lie in [0, {WORKSPACE_SIZE}) m, got {height}")
    return k


def busiest_layer(outputs: Iterable[dict[str, torch.Tensor]], validity: float) -> int:
    """The voxel layer k with the most voxels of validity ≥ ``validity``, summed over the
    network ``outputs`` (`GraspDetector.predict`); the lowest such layer on ties."""
    counts = sum((out["validity"] >= validity).sum(dim=(0, 1)).cpu().numpy() for out in outputs)
    return int(np.argmax(counts))


def choose_layer(
    height: float | None, outputs: Iterable[dict[str, torch.Tensor]], validity: float
) -> int:
    """`slice_layer` of ``height``, or `busiest_layer` where ``height`` is None."""
    return busiest_layer(outputs, validity) if height is None else slice_layer(height)


def voxel_centres_xy() -> np.ndarray:
    """x, y [m] of the voxel centres of one layer, ``[40, 40, 2]`` indexed [i, j]."""
    axis = (np.arange(RESOLUTION) + 0.5) * VOXEL_SIZE
    return np.stack(np.meshgrid(axis, axis, indexing="ij"), axis=-1)


@dataclass(frozen=True)
class FieldSlice:
    """A detector's outputs in voxel layer ``layer``, arrays indexed [i (x), j (y)]."""

    representation: Representation
    layer: int
    score: np.ndarray
    """``[40, 40]`` gravity-rejection score."""
    validity: np.ndarray
    """``[40, 40]`` validity probability."""
    rotation: torch.Tensor
    """``[40, 40, C]`` float64: the representation's channels."""


def predict(detector: GraspDetector, view: DepthView) -> dict[str, torch.Tensor]:
    """Fuse the depth image into the 40³ TSDF and run the network: ``score`` and ``validity``
    ``[40, 40, 40]``, ``rotation`` ``[40, 40, 40, C]`` (`GraspDetector.predict`)."""
    return detector.predict(detector.fuse(*view).grid())


def cut_layer(
    out: dict[str, torch.Tensor], representation: Representation, layer: int
) -> FieldSlice:
    """Voxel layer ``layer`` of the network outputs ``out`` (`predict`)."""
    return FieldSlice(
        representation,
        layer,
        out["score"][:, :, layer].cpu().numpy(),
        out["validity"][:, :, layer].cpu().numpy(),
        out["rotation"][:, :, layer].cpu().double(),
    )


def parse_model_specs(specs: Sequence[str]) -> dict[str, str]:
    """``LABEL=PATH`` strings (``--model bingham2d=runs/a/best.pt``) as {label: path}."""
    models: dict[str, str] = {}
    for spec in specs:
        label, separator, path = spec.partition("=")
        if not separator or not label or not path:
            raise ValueError(f"--model must be LABEL=PATH, e.g. bingham2d=best.pt; got {spec!r}")
        if label in models:
            raise ValueError(f"--model: the label {label!r} is given twice")
        models[label] = path
    if not models:
        raise ValueError("--model: give at least one LABEL=PATH")
    return models


def check_validity(validity: float) -> None:
    """Raise ValueError unless the validity threshold is a probability."""
    if not 0.0 <= validity <= 1.0:
        raise ValueError(f"--validity must be in [0, 1], got {validity}")


def view_limits(objects: Sequence[Placed]) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper x, y corners [m] of the footprints plus `VIEW_MARGIN`, inside the
    workspace."""
    centres = np.array([o.centre for o in objects])
    halves = np.array([o.size[:2] for o in objects]) / 2
    lo = np.maximum((centres - halves).min(0) - VIEW_MARGIN, 0.0)
    hi = np.minimum((centres + halves).max(0) + VIEW_MARGIN, WORKSPACE_SIZE)
    return lo, hi


def draw_field(
    ax: Axes, field: FieldSlice, valid: np.ndarray, objects: Sequence[Placed], cmap: str
) -> AxesImage:
    """The score of the valid voxels (the others blank) and the objects' outlines, framed to
    the footprints plus `VIEW_MARGIN`."""
    score = np.ma.masked_where(~valid, field.score)
    image = ax.imshow(
        score.T, origin="lower", extent=(0, WORKSPACE_SIZE, 0, WORKSPACE_SIZE), cmap=cmap
    )
    for o in objects:
        ax.add_patch(o.outline())
    lo, hi = view_limits(objects)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    return image
