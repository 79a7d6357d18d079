"""A detector that says why it found nothing: no grasp is an answer, and when the input or the
network's output shows why, a `NoGraspWarning` names it; a real empty scene gives none. The
single bad inputs are the tables of tests/bad_input_cases.py (tests/test_bad_input.py); here are
the rules behind them."""

import warnings

import numpy as np
import pytest
import torch
from bad_input_cases import CAMERA, FOOT, INTRINSIC, MODEL, table_depth
from PIL import Image

from symgrasp.detect import GraspDetector, NoGraspWarning
from symgrasp.detect.files import load_depth, save_png_depth
from symgrasp.model.network import GraspNet, NetworkConfig
from symgrasp.perception import CameraIntrinsic
from symgrasp.sim import ROBOTIQ_2F85


@pytest.fixture(scope="module")
def detector():
    return GraspDetector.from_pretrained(MODEL, device="cpu")


def _quiet(call):
    """``call()``, failing on any `NoGraspWarning`."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", NoGraspWarning)
        return call()


def test_an_empty_table_is_no_grasp_without_a_warning(detector):
    depth = table_depth()
    assert _quiet(lambda: detector.detect(depth, INTRINSIC, CAMERA)) == []
    tsdf = detector.fuse(depth, INTRINSIC, CAMERA).grid()
    assert _quiet(lambda: detector.detect_tsdf(tsdf)) == []


def test_one_view_that_sees_the_workspace_is_enough(detector):
    views = np.stack([table_depth(), table_depth() / FOOT])
    assert _quiet(lambda: detector.detect(views, INTRINSIC, np.stack([CAMERA, CAMERA]))) == []


def test_the_warning_says_where_the_points_are_and_can_be_filtered(detector):
    far = GraspDetector.from_pretrained(MODEL, device="cpu", workspace_origin=(100.0, 0, 0))
    with pytest.warns(NoGraspWarning) as caught:
        assert far.detect(table_depth(), INTRINSIC, CAMERA) == []
    message = str(caught[0].message)
    assert "from (100, 0, 0) to (100, 0.3, 0.3) m" in message
    centre = [float(x) for x in message.split("lie around (")[1].split(")")[0].split(", ")]
    assert centre[2] == pytest.approx(0.05, abs=1e-3)  # on the table, 100 m from the cube
    assert "T_world_camera" in message and "metres" in message
    assert caught[0].filename == __file__  # points at the caller's line
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", NoGraspWarning)  # the last filter set is matched first
        assert far.detect(table_depth(), INTRINSIC, CAMERA) == []


def test_depth_in_centimetres_read_as_metres_is_implausibly_near(detector):
    with pytest.warns(NoGraspWarning, match=r"median depth of 0\.0\d+ m, implausibly near"):
        detector.detect(table_depth() * 0.1, INTRINSIC, CAMERA)


def test_a_non_finite_network_output_is_named_whatever_the_input():
    net = GraspNet(NetworkConfig())
    with torch.no_grad():
        next(net.parameters()).fill_(torch.nan)
    broken = GraspDetector(net, ROBOTIQ_2F85, device="cpu")
    for call in (
        lambda: broken.detect(table_depth(), INTRINSIC, CAMERA),
        lambda: broken.detect_tsdf(broken.fuse(table_depth(), INTRINSIC, CAMERA).grid()),
    ):
        with pytest.warns(NoGraspWarning, match=r"network's output is NaN or infinite in 64000"):
            assert call() == []


def test_a_tsdf_is_finite_and_within_its_range(detector):
    fused = detector.fuse(table_depth(), INTRINSIC, CAMERA).grid()
    assert -1 <= fused.min() < 0 and fused.max() == 1
    detector.predict(fused + 5e-5)  # float rounding of a fused average
    for bad, said in ((1.01, "values from"), (-np.inf, "1 NaN or infinite"), (np.nan, "1 NaN")):
        tsdf = fused.clone()
        tsdf[3, 4, 5] = bad
        with pytest.raises(ValueError, match=f"tsdf must be finite and within .*{said}"):
            detector.detect_tsdf(tsdf)
    with pytest.warns(NoGraspWarning, match="TSDF shows nothing inside the workspace"):
        detector.detect_tsdf(torch.ones(40, 40, 40))


def test_bounds_must_hold_a_voxel_of_the_workspace():
    def bounded(lo, hi, **options):
        return GraspDetector.from_pretrained(MODEL, device="cpu", bounds=(lo, hi), **options)

    assert bounded(np.full(3, -np.inf), np.full(3, np.inf)).bounds is not None
    bounded(np.zeros(3), np.full(3, 0.01))  # one voxel centre, 3.75 mm in
    for lo, hi in ((np.full(3, np.nan), np.ones(3)), (np.ones(3), np.zeros(3))):
        with pytest.raises(ValueError, match="lo ≤ hi and no NaN"):
            bounded(lo, hi)
    with pytest.raises(ValueError, match=r"hold no voxel centre .* from \(1, 0, 0\) m"):
        bounded(np.zeros(3), np.full(3, 0.3), workspace_origin=(1.0, 0, 0))
    with pytest.raises(ValueError, match="hold no voxel centre"):
        bounded(np.zeros(3), np.full(3, 0.003))  # a corner inside the first voxel's half


def test_load_depth_reads_metres_and_16_bit_pngs_and_refuses_the_rest(tmp_path):
    depth = table_depth()
    np.save(tmp_path / "metres.npy", depth.astype(np.float64))
    assert np.array_equal(load_depth(tmp_path / "metres.npy"), depth)
    save_png_depth(tmp_path / "mm.png", depth)
    assert np.abs(load_depth(tmp_path / "mm.png") - depth).max() <= 0.0005
    assert np.abs(load_depth(tmp_path / "mm.png", png_scale=0.01) - 10 * depth).max() <= 0.005
    refused = {
        "int.npy": (np.uint16(depth * 1000), "holds uint16 values.*raw sensor units"),
        "bool.npy": (depth > 0, "holds bool values; a .npy depth image holds floating-point metres$"),
        "complex.npy": (depth.astype(complex), "holds complex128 values"),
        "object.npy": (np.array([depth, "x"], dtype=object), "cannot read an image"),
    }  # fmt: skip
    for name, (values, said) in refused.items():
        np.save(tmp_path / name, values, allow_pickle=True)
        with pytest.raises(ValueError, match=said) as error:
            load_depth(tmp_path / name)
        assert str(tmp_path / name) in str(error.value)
    pictures = {"grey.png": np.uint8(depth * 100), "colour.png": np.zeros((48, 64, 3), np.uint8)}
    for name, values in pictures.items():
        Image.fromarray(values).save(tmp_path / name)
        with pytest.raises(ValueError, match=f"{name} is a PNG of mode .*picture of depth"):
            load_depth(tmp_path / name)


def test_a_depth_image_with_colour_channels_is_refused_but_not_a_stack_of_views(detector):
    """(H, W, 2–4) is one image with channels (no depth image is 2 to 4 pixels wide), refused
    whatever the camera; (V, H, W) of 3 views of the same image fuses as that image."""
    depth = table_depth()
    for channels in (2, 3, 4):
        for image in (np.repeat(depth[..., None], channels, -1), torch.zeros(48, 64, channels)):
            with pytest.raises(ValueError, match=rf"\(48, 64, {channels}\) looks like a colour"):
                detector.fuse(image, INTRINSIC, CAMERA)
    one = detector.fuse(depth, INTRINSIC, CAMERA).grid()
    three = detector.fuse(np.stack([depth] * 3), INTRINSIC, np.stack([CAMERA] * 3)).grid()
    torch.testing.assert_close(three, one, rtol=0, atol=1e-6)  # the same image, averaged


def test_an_intrinsic_is_a_camera_or_its_matrix_not_its_fields(detector):
    fields = {"fx": INTRINSIC.fx, "fy": INTRINSIC.fy, "cx": INTRINSIC.cx, "cy": INTRINSIC.cy}
    for given in (fields, "intrinsic.json"):
        with pytest.raises(TypeError, match=f"intrinsic must be .* got a {type(given).__name__}"):
            detector.fuse(table_depth(), given, CAMERA)
    by_fields = detector.fuse(table_depth(), CameraIntrinsic(64, 48, **fields), CAMERA).grid()
    by_matrix = detector.fuse(table_depth(), INTRINSIC.K, CAMERA).grid()
    assert torch.equal(by_fields, by_matrix)


def test_a_tsdf_is_numbers_in_any_container_but_not_text(detector):
    tsdf = torch.ones(40, 40, 40)
    for given in (tsdf.numpy(), tsdf.tolist()):
        with pytest.warns(NoGraspWarning, match="TSDF shows nothing"):  # read as the tensor
            assert detector.detect_tsdf(given) == []
    for text in ("abc", [["a"]], None):
        with pytest.raises(TypeError, match=r"tsdf must be a \(40, 40, 40\) array or tensor"):
            detector.detect_tsdf(text)
