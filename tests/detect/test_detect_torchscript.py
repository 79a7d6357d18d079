"""The network as a TorchScript graph: the optimised detector and the exported file give the
eager network's outputs, and the exported file runs where symgrasp cannot be imported."""

import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from symgrasp.cli import main
from symgrasp.detect import PRETRAINED, GraspDetector, export_torchscript
from symgrasp.detect.pretrained import TORCHSCRIPT_FORMAT
from symgrasp.model import GraspNet
from symgrasp.model.torchscript import METADATA, trace
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene

MODEL = "bingham2d-robotiq-2f85"


@pytest.fixture(scope="module")
def tsdf():
    """A rendered five-object pile fused as the detector fuses it: voxels pass the threshold."""
    detector = GraspDetector.from_pretrained(MODEL, device="cpu")
    world = pile_scene(object_set("household-test", 5, seed=0), seed=0, gripper=detector.gripper)
    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    depth = make_renderer(intrinsic).render(world, T)
    return detector.fuse(depth, intrinsic, T).grid()


CUDA = pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device here")


@pytest.mark.parametrize("device", ["cpu", pytest.param("cuda", marks=CUDA)])
@pytest.mark.parametrize("name", PRETRAINED)
def test_the_optimized_detector_gives_the_eager_outputs_and_grasps(name, device, tsdf):
    eager = GraspDetector.from_pretrained(name, device=device)
    fast = GraspDetector.from_pretrained(name, device=device, optimize=True)
    a, b = eager.predict(tsdf), fast.predict(tsdf)
    for key in ("score", "validity", "rotation"):
        assert a[key].shape == b[key].shape
        torch.testing.assert_close(b[key], a[key], atol=1e-4, rtol=1e-4)
    slow_grasps, fast_grasps = eager.detect_tsdf(tsdf), fast.detect_tsdf(tsdf)
    assert slow_grasps, "the scene must give grasps for the comparison to mean something"
    assert [g.voxel for g in fast_grasps] == [g.voxel for g in slow_grasps]
    for x, y in zip(fast_grasps, slow_grasps, strict=True):
        np.testing.assert_allclose(x.pose, y.pose, atol=1e-4)


def test_optimize_must_be_a_bool_and_trace_needs_eval_mode():
    with pytest.raises(TypeError, match="optimize must be True or False"):
        GraspDetector.from_pretrained(MODEL, device="cpu", optimize="yes")
    with pytest.raises(ValueError, match="eval mode"):
        trace(GraspNet().train())


# Runs in a fresh interpreter where importing symgrasp fails: what another stack has.
WITHOUT_SYMGRASP = """
import json, sys
sys.modules["symgrasp"] = None
import numpy as np, torch
extra = {"symgrasp.json": ""}
module = torch.jit.load(sys.argv[1], _extra_files=extra)
module = torch.jit.optimize_for_inference(module) if sys.argv[4] == "optimize" else module
tsdf = torch.from_numpy(np.load(sys.argv[2]))[None, None]
with torch.no_grad():
    score, validity, rotation = module(tsdf)
np.savez(sys.argv[3], score=score.numpy(), validity=validity.numpy(), rotation=rotation.numpy(),
         metadata=np.array(extra["symgrasp.json"].decode()))
"""


@pytest.fixture(scope="module")
def exported(tsdf, tmp_path_factory):
    folder = tmp_path_factory.mktemp("exported")
    path = export_torchscript(MODEL, folder / "model.pt")
    np.save(folder / "tsdf.npy", tsdf.numpy())
    runs = {}
    for how in ("frozen", "optimize"):
        out = folder / f"{how}.npz"
        subprocess.run(
            [sys.executable, "-c", WITHOUT_SYMGRASP, str(path), str(folder / "tsdf.npy"), str(out), how],
            check=True, capture_output=True, text=True,
        )  # fmt: skip
        runs[how] = dict(np.load(out))
    return runs


def test_the_exported_file_runs_without_symgrasp_and_gives_the_networks_outputs(tsdf, exported):
    eager = GraspDetector.from_pretrained(MODEL, device="cpu")
    with torch.no_grad():
        want = eager.model(tsdf[None, None])
    # Frozen: the same operations, summed in another order where the processes' torch thread
    # counts differ (float rounding, ≈ 5e-6 on logits near −13).
    for how, tolerance in (("frozen", 2e-5), ("optimize", 1e-4)):
        got = exported[how]
        np.testing.assert_allclose(got["score"], want.score.numpy(), atol=tolerance)
        np.testing.assert_allclose(got["validity"], want.validity.numpy(), atol=tolerance)
        np.testing.assert_allclose(got["rotation"], want.rotation.numpy(), atol=tolerance)
    metadata = json.loads(str(exported["frozen"]["metadata"]))
    assert metadata["format"] == TORCHSCRIPT_FORMAT
    assert metadata["representation"] == "bingham2d" and metadata["channels"] == 9
    assert metadata["gripper"]["name"] == "robotiq-2f85"
    assert metadata["input"]["shape"] == [1, 1, 40, 40, 40]
    assert metadata["defaults"]["validity_threshold"] == eager.validity_threshold


def test_the_decoding_docs_detect_md_gives_reproduces_the_detectors_grasps(tsdf, exported):
    """docs/detect.md's recipe for bingham2d, written here in numpy from the exported outputs
    alone: the voxels over the validity threshold, e_z the eigenvector of the largest
    eigenvalue of A = triu(a), e_x the approach channels, Gram–Schmidt keeping e_x. The
    detector's grasps at those voxels are the same frames up to the flip (e_y, e_z → −e_y, −e_z).
    """
    detector = GraspDetector.from_pretrained(
        MODEL, device="cpu", nms_radius=0, operating_point=False
    )
    grasps = detector.detect_tsdf(tsdf)
    out = exported["frozen"]
    probability = 1 / (1 + np.exp(-out["validity"][0]))
    voxels = np.argwhere(probability >= detector.validity_threshold)
    channels = out["rotation"][0][(slice(None), *voxels.T)].T.astype(np.float64)  # [N, 9]
    a, x = channels[:, :6], channels[:, 6:]
    A = np.zeros((len(a), 3, 3))
    for n, (i, j) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        A[:, i, j] = A[:, j, i] = a[:, n]
    values, vectors = np.linalg.eigh(A)
    e_x = x / np.linalg.norm(x, axis=1, keepdims=True)
    e_z = vectors[:, :, 2] - (vectors[:, :, 2] * e_x).sum(1, keepdims=True) * e_x
    e_z /= np.linalg.norm(e_z, axis=1, keepdims=True)
    confidence = 2 * values[:, 2] - values[:, 1] - values[:, 0]
    kept = confidence >= detector.confidence_threshold
    by_voxel = {
        tuple(v): (ex, ez) for v, ex, ez, k in zip(voxels, e_x, e_z, kept, strict=True) if k
    }
    assert sorted(by_voxel) == sorted(g.voxel for g in grasps) and grasps
    for g in grasps:
        ex, ez = by_voxel[g.voxel]
        np.testing.assert_allclose(g.pose[:3, 0], ex, atol=1e-4)
        assert abs(abs(g.pose[:3, 2] @ ez) - 1) < 1e-6


def test_symgrasp_export_torchscript_writes_a_loadable_file(tmp_path, capsys):
    main(["export", MODEL, str(tmp_path / "model.pt"), "--torchscript"])
    assert capsys.readouterr().out.strip() == str(tmp_path / "model.pt")
    extra = {METADATA: ""}
    module = torch.jit.load(str(tmp_path / "model.pt"), _extra_files=extra)
    assert json.loads(extra[METADATA])["model"] == MODEL
    outputs = module(torch.ones(1, 1, 40, 40, 40))
    assert [tuple(o.shape) for o in outputs] == [(1, 40, 40, 40)] * 2 + [(1, 9, 40, 40, 40)]
    with pytest.raises(SystemExit):
        main(["export", MODEL, str(tmp_path), "--torchscript"])
