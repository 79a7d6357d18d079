"""GraspNet shapes for every representation, its cost against a closed form, bad input."""

import copy

import pytest
import torch
from torch import nn

from symgrasp import rotation
from symgrasp.model import GraspNet, NetworkConfig, count_flops, count_parameters, grasp_losses
from symgrasp.model.network import BINGHAM_BOUND, PointwiseConv3d
from symgrasp.model.synthetic import SyntheticGraspDataset, collate_scenes


@pytest.fixture(scope="module")
def batch():
    dataset = SyntheticGraspDataset(2, seed=3)
    return collate_scenes([dataset[0], dataset[1]])


@pytest.mark.parametrize("name", rotation.NAMES)
def test_shapes_and_finite_loss_for_every_representation(name, batch):
    torch.manual_seed(0)
    model = GraspNet(NetworkConfig(name))
    output = model(batch["tsdf"])
    assert output.score.shape == output.validity.shape == (2, 40, 40, 40)
    assert output.rotation.shape == (2, rotation.get(name).channels, 40, 40, 40)
    losses = grasp_losses(output, batch, model.representation)
    assert all(torch.isfinite(v) for v in losses.values())
    losses["total"].backward()
    assert all(torch.isfinite(p.grad).all() for p in model.parameters())


def test_flops_match_the_closed_form_and_stay_below_half_a_gigaflop():
    model = GraspNet(NetworkConfig("bingham2d"))
    expected, size = 0, {}
    # Every conv costs 2 · (output voxels) · C_out · C_in · k³; record output sizes by hook.
    hooks = [
        m.register_forward_hook(lambda m, i, o: size.__setitem__(m, o.shape[2:].numel()))
        for m in model.modules()
        if isinstance(m, nn.Conv3d)
    ]
    model(torch.zeros(1, 1, 40, 40, 40))
    for hook in hooks:
        hook.remove()
    for conv, voxels in size.items():
        expected += 2 * voxels * conv.out_channels * conv.in_channels * conv.kernel_size[0] ** 3
    assert count_flops(model) == expected
    assert 2e8 < expected < 5e8
    assert count_parameters(model) == sum(p.numel() for p in model.parameters())


def test_only_the_rotation_head_differs_between_representations():
    shapes = {
        name: {k: v.shape for k, v in GraspNet(NetworkConfig(name)).state_dict().items()}
        for name in ("bingham2d", "quaternion")
    }
    differing = {
        k for k in shapes["bingham2d"] if shapes["bingham2d"][k] != shapes["quaternion"][k]
    }
    assert differing == {"rotation_head.weight", "rotation_head.bias"}


def test_bingham_parameters_are_bounded_and_the_rest_is_not():
    model = GraspNet(NetworkConfig("bingham2d"))
    with torch.no_grad():
        model.rotation_head.bias.fill_(1e4)
    rotation_out = model(torch.zeros(1, 1, 8, 8, 8)).rotation
    assert rotation_out[:, :6].abs().max() <= BINGHAM_BOUND
    assert rotation_out[:, 6:].min() > 1e3


def test_bad_input_raises():
    model = GraspNet()
    with pytest.raises(ValueError, match="tsdf must be"):
        model(torch.zeros(1, 40, 40, 40))
    with pytest.raises(ValueError, match="divisible by 8"):
        model(torch.zeros(1, 1, 36, 40, 40))
    with pytest.raises(ValueError, match="unknown rotation representation"):
        NetworkConfig("euler")
    with pytest.raises(ValueError, match="widths"):
        NetworkConfig(widths=(8, 16, 32))


def test_channels_last_float32_outputs_match_a_float64_pass_of_the_same_weights():
    """The layout is an implementation detail: outputs equal a float64 evaluation (another code
    path: oneDNN has no float64 convolutions) to float32 rounding, in the default layout."""
    torch.manual_seed(0)
    net = GraspNet(NetworkConfig("bingham2d")).eval()
    assert net.enc0.weight.is_contiguous(memory_format=torch.channels_last_3d)
    tsdf = torch.rand(2, 1, 40, 40, 40) * 2 - 1
    with torch.no_grad():
        single = net(tsdf)
        double = copy.deepcopy(net).double()(tsdf.double())
    for name in ("score", "validity", "rotation"):
        assert getattr(single, name).is_contiguous()
        torch.testing.assert_close(
            getattr(single, name).double(), getattr(double, name), rtol=1e-5, atol=1e-5
        )


CUDA = pytest.param(
    "cuda", marks=pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device here")
)


@pytest.mark.parametrize("device", ["cpu", CUDA])
@pytest.mark.parametrize("layout", [torch.contiguous_format, torch.channels_last_3d])
def test_pointwise_convolution_equals_a_1x1x1_conv3d_in_value_and_gradient(layout, device):
    """`PointwiseConv3d` is a matrix product standing in for a 1×1×1 convolution: the same
    state dict, and outputs and gradients of `F.conv3d` computed in float64 on the CPU; its
    output is channels-last on every device."""
    torch.manual_seed(0)
    reference = nn.Conv3d(24, 16, 1).double()
    pointwise = PointwiseConv3d(24, 16, 1).to(device, memory_format=torch.channels_last_3d)
    pointwise.load_state_dict({k: v.float() for k, v in reference.state_dict().items()})
    x = torch.randn(2, 24, 8, 6, 4, dtype=torch.float64).contiguous(memory_format=layout)
    xs = x.float().to(device).requires_grad_()
    xd = x.clone().requires_grad_()
    out, expected = pointwise(xs), reference(xd)
    assert out.is_contiguous(memory_format=torch.channels_last_3d)
    upstream = torch.randn_like(expected)
    out.backward(upstream.float().to(device))
    expected.backward(upstream)
    torch.testing.assert_close(out.double().cpu(), expected, rtol=1e-5, atol=1e-5)
    torch.testing.assert_close(xs.grad.double().cpu(), xd.grad, rtol=1e-5, atol=1e-5)
    for mine, theirs in zip(pointwise.parameters(), reference.parameters(), strict=True):
        torch.testing.assert_close(mine.grad.double().cpu(), theirs.grad, rtol=1e-4, atol=1e-4)


def test_every_1x1x1_convolution_of_the_network_is_pointwise():
    net = GraspNet(NetworkConfig("bingham2d"))
    ones = [m for m in net.modules() if isinstance(m, nn.Conv3d) and m.kernel_size == (1, 1, 1)]
    assert ones and all(isinstance(m, PointwiseConv3d) for m in ones)
