"""`detect_table`'s cubes share one pass of the work (`symgrasp.detect.scene`: the images
checked once, the points the cubes leave out found once, the TSDFs through the network
`NETWORK_BATCH` at a time): each cube's grasps must be those the detector gives at that cube on
its own. The oracle is the detector itself, one cube at a time, on a rendered table of the
shipped model's kind: boxes in three groups and one 40 cm tall box the cube cuts."""

import warnings

import numpy as np
import pytest

from symgrasp.detect import GraspDetector, NoGraspWarning
from symgrasp.detect import scene as scene_module
from symgrasp.detect.detector import fuse
from symgrasp.detect.limits import CutObjectWarning
from symgrasp.detect.scene import detect_table
from symgrasp.perception import CameraIntrinsic, look_at
from symgrasp.sim import World
from symgrasp.sim.objects import flat_box
from symgrasp.sim.render import make_renderer
from symgrasp.workspace import TABLE_HEIGHT

K = CameraIntrinsic().scaled(0.5)
CAMERA = look_at(np.array([0.15, -0.25, 0.95]), np.array([0.15, 0.15, TABLE_HEIGHT]))
BOXES = [  # centre x, y, size x, y, z [m]
    (-0.25, 0.0, 0.05, 0.05, 0.06),
    (0.55, 0.30, 0.05, 0.07, 0.06),
    (0.15, 0.15, 0.05, 0.05, 0.40),  # taller than the cube: cut at its top
    (0.24, 0.15, 0.04, 0.06, 0.06),
]


@pytest.fixture(scope="module")
def depth():
    objects = [
        flat_box((sx, sy, sz), "box", f"box_{i}") for i, (_, _, sx, sy, sz) in enumerate(BOXES)
    ]
    poses = np.tile(np.eye(4), (len(objects), 1, 1))
    poses[:, :2, 3] = [(x, y) for x, y, *_ in BOXES]
    poses[:, 2, 3] = TABLE_HEIGHT
    return make_renderer(K).render(World(objects, poses), CAMERA)


@pytest.fixture(scope="module")
def shipped():
    return GraspDetector.from_pretrained("bingham2d-robotiq-2f85", device="cpu")


def _same(a, b, atol: float = 1e-4) -> bool:
    """Whether grasps ``a`` and ``b`` agree: score, validity and opening to float rounding, the
    pose to 1e-3 (a rotation decoded as an eigenvector moves ≈ 5e-5 with outputs moved by
    1e-5), voxel, fallback and cut flag exactly."""
    return (
        np.allclose(a.pose, b.pose, atol=1e-3)
        and abs(a.score - b.score) <= atol
        and abs(a.validity - b.validity) <= atol
        and (a.voxel, a.fallback, a.cut) == (b.voxel, b.fallback, b.cut)
        and a.opening_width == pytest.approx(b.opening_width, abs=atol)
    )


def test_each_cubes_grasps_are_the_detectors_own_at_that_cube(shipped, depth):
    """Every grasp of the whole table, cube k's, is one the detector gives with its workspace
    at cube k alone (the per-cube oracle); the tall box's cut grasps flagged alike."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CutObjectWarning)
        found = detect_table(shipped, depth, K, CAMERA, merge_radius=0.0)
        alone = []
        for origin in found.origins:
            cube = GraspDetector.from_pretrained(
                "bingham2d-robotiq-2f85", device="cpu", workspace_origin=tuple(origin)
            )
            warnings.simplefilter("ignore", NoGraspWarning)
            alone.append(cube.detect(depth, K, CAMERA))
    assert len(found.origins) == 3 and len(found.grasps) >= 3
    for grasp, k in zip(found.grasps, found.workspace, strict=True):
        assert any(_same(grasp, other) for other in alone[k]), (k, grasp.position)
    assert any(g.cut for g in found.grasps) == any(g.cut for cube in alone for g in cube)


@pytest.mark.parametrize("batch", [1, 2, 8])
def test_the_network_batch_changes_no_grasp(shipped, depth, monkeypatch, batch):
    """One cube per forward pass (the per-cube path), two, or all at once: the same grasps in
    the same order, to float rounding."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CutObjectWarning)
        reference = detect_table(shipped, depth, K, CAMERA)
        monkeypatch.setattr(scene_module, "NETWORK_BATCH", batch)
        batched = detect_table(shipped, depth, K, CAMERA)
    assert len(batched.grasps) == len(reference.grasps) > 0
    assert batched.workspace == reference.workspace
    for a, b in zip(batched.grasps, reference.grasps, strict=True):
        assert _same(a, b)


def test_predict_many_is_predict_of_each_cube(shipped, depth):
    """A batch of three fused cubes through one pass: each cube's outputs its own pass's, to
    the float rounding of a batched convolution (GroupNorm normalises each cube apart): within
    1e-3 of the output's largest magnitude (measured: ≈ 1.5e-4)."""
    import torch

    origins = [(-0.4, -0.15, 0.0), (0.0, 0.0, 0.0), (0.4, 0.15, 0.0)]
    grids = torch.stack([fuse(depth, K, CAMERA, origin).grid() for origin in origins])
    assert all((grid < 0).any() for grid in grids)  # each cube sees a surface
    for own, batched in zip(
        [shipped.predict(grid) for grid in grids], shipped.predict_many(grids), strict=True
    ):
        for key in ("score", "validity", "rotation"):
            error = float((own[key] - batched[key]).abs().max())
            assert error <= 1e-3 * max(1.0, float(own[key].abs().max())), (key, error)


def test_a_cut_warning_names_the_line_that_called_detect_table(shipped, depth):
    with pytest.warns(CutObjectWarning) as caught:
        detect_table(shipped, depth, K, CAMERA)
    assert {record.filename for record in caught} == {__file__}
