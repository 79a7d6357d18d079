"""The optimised inference graph's parts (`symgrasp.model.torchscript`) against float64
references: its channels-last GroupNorm keeps the default layout's accuracy where PyTorch's own
channels-last kernel loses it."""

import pytest
import torch
import torch.nn.functional as F

from symgrasp.model import GraspNet
from symgrasp.model.torchscript import ChannelsLastGroupNorm, optimize

CL = torch.channels_last_3d


def _norm(channels: int, groups: int) -> torch.nn.GroupNorm:
    norm = torch.nn.GroupNorm(groups, channels)
    with torch.no_grad():
        norm.weight.uniform_(0.5, 2.0)
        norm.bias.uniform_(-1.0, 1.0)
    return norm


@pytest.mark.parametrize("mean", [0.0, 5.0, 50.0])
@pytest.mark.parametrize(("channels", "groups", "size"), [(8, 4, 40), (16, 4, 20), (64, 4, 5)])
def test_channels_last_group_norm_is_as_exact_as_the_default_layouts(mean, channels, groups, size):
    torch.manual_seed(0)
    norm = _norm(channels, groups)
    x = torch.randn(2, channels, size, size, size) * 3 + mean
    exact = F.group_norm(x.double(), groups, norm.weight.double(), norm.bias.double(), norm.eps)
    with torch.no_grad():
        ours = ChannelsLastGroupNorm(norm)(x.contiguous(memory_format=CL))
        default = norm(x)
    assert ours.shape == x.shape and ours.is_contiguous(memory_format=CL)
    error = (ours.double() - exact).abs().max().item()
    assert error <= max(4 * (default.double() - exact).abs().max().item(), 1e-6)
    assert error < 2e-5  # the channels-last kernel's error at mean 50 is ≈ 2e-3


def test_a_constant_group_normalises_to_its_bias():
    """Zero variance: (x − mean) = 0 exactly, so every voxel reads β (no NaN from rsqrt)."""
    norm = _norm(8, 4)
    x = torch.full((1, 8, 4, 4, 4), 3.25).contiguous(memory_format=CL)
    with torch.no_grad():
        out = ChannelsLastGroupNorm(norm)(x)
    expected = norm.bias.detach().view(1, 8, 1, 1, 1).expand_as(out)
    torch.testing.assert_close(out, expected, atol=0, rtol=0)


def test_the_optimized_graph_keeps_the_networks_outputs_on_inputs_far_from_zero():
    """A random network on a TSDF of mostly ±1 (free space and unseen voxels, as real scenes
    are): the inputs where the channels-last kernel's statistics go wrong."""
    torch.manual_seed(1)
    model = GraspNet().eval()
    tsdf = torch.ones(1, 1, 40, 40, 40)
    tsdf[..., :12] = -1.0
    tsdf[..., 12:16] = torch.linspace(-1, 1, 4)
    with torch.no_grad():
        eager, fast = model(tsdf), optimize(model)(tsdf)
    for a, b in zip(eager, fast, strict=True):
        torch.testing.assert_close(b, a, atol=1e-4, rtol=1e-4)
