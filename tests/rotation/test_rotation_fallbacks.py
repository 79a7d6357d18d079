"""`Representation.fallbacks`: the other rotations a detector tries when an approach is refused."""

import math

import pytest
import torch

from symgrasp import rotation
from symgrasp.bingham import sym_to_triu
from symgrasp.rotation.base import yaw_turns

POINT_ESTIMATES = ("rotmat6d", "rotmat6d_naive", "quaternion")


def _preds(name: str, n: int = 6) -> torch.Tensor:
    torch.manual_seed(3)
    return 3 * torch.randn(n, rotation.get(name).channels, dtype=torch.float64)


def _is_rotation(R: torch.Tensor) -> bool:
    eye = torch.eye(3, dtype=R.dtype)
    return bool(
        torch.allclose(R.transpose(-1, -2) @ R, eye, atol=1e-12)
        and torch.allclose(torch.linalg.det(R), torch.ones((), dtype=R.dtype), atol=1e-12)
    )


@pytest.mark.parametrize("name", rotation.NAMES)
def test_fallbacks_are_k_proper_rotations_per_element_and_reproducible(name):
    rep, pred = rotation.get(name), _preds(name)
    drawn = rep.fallbacks(pred, 5, torch.Generator().manual_seed(1))
    assert drawn.shape == (6, 5, 3, 3) and _is_rotation(drawn)
    again = rep.fallbacks(pred, 5, torch.Generator().manual_seed(1))
    assert torch.equal(drawn, again)
    assert rep.fallbacks(pred, 0).shape == (6, 0, 3, 3)
    for bad in (-1, 2.0, True):
        with pytest.raises(ValueError, match="`k` must be an integer"):
            rep.fallbacks(pred, bad)


@pytest.mark.parametrize("name", ["bingham2d", *POINT_ESTIMATES])
def test_fallbacks_keep_the_decoded_approach_axis(name):
    rep, pred = rotation.get(name), _preds(name)
    e_x = rep.decode(pred).rotation[..., 0]
    drawn = rep.fallbacks(pred, 7, torch.Generator().manual_seed(0))
    assert torch.allclose(drawn[..., 0], e_x[:, None].expand_as(drawn[..., 0]), atol=1e-12)


def test_bingham2d_fallbacks_are_draws_of_its_closing_axis_most_probable_first():
    """A Bingham with gap 1 towards e_y and 40 towards e_x: draws spread about e_x, and each
    element's list is sorted by e_zᵀ A e_z (the density up to the element's normaliser)."""
    rep = rotation.get("bingham2d")
    R = torch.eye(3, dtype=torch.float64)
    A = R @ torch.diag(torch.tensor([-40.0, -1.0, 0.0], dtype=torch.float64)) @ R.T
    pred = torch.cat([sym_to_triu(A), R[:, 0]])[None]
    drawn = rep.fallbacks(pred, 400, torch.Generator().manual_seed(0))[0]
    e_z = drawn[:, :, 2]
    exponent = torch.einsum("ni,ij,nj->n", e_z, A, e_z)
    assert bool((exponent[:-1] >= exponent[1:]).all())
    # the turn about e_x of a draw: e_z = (0, sin, cos) up to sign; with gap 1 its angle is
    # broad (an SD near 1/√(2·1) rad about the mode), never collapsed onto the mode
    yaw = torch.atan2(e_z[:, 1].abs(), e_z[:, 2].abs())
    assert 0.3 < float(yaw.std()) < 0.7 and float(yaw.max()) > 0.8
    # against the same draws in the sampler's order: the same set, another order
    sampled = rep.sample(pred, 400, torch.Generator().manual_seed(0))[0]
    assert torch.allclose(sampled.sum(0), drawn.sum(0), atol=1e-9)


def test_point_estimates_turn_the_yaw_in_even_steps_nearest_first():
    turned = yaw_turns(torch.eye(3, dtype=torch.float64), 5)
    angles = [math.degrees(math.atan2(T[2, 1], T[1, 1])) for T in turned]
    assert angles == pytest.approx([30.0, 150.0, 60.0, 120.0, 90.0], abs=1e-9)
    rep = rotation.get("rotmat6d")
    pred = _preds("rotmat6d", 4)
    decoded = rep.decode(pred).rotation
    drawn = rep.fallbacks(pred, 3)  # 45°, 135°, 90°
    cosines = torch.einsum("ni,nki->nk", decoded[..., 2], drawn[..., 2])
    expected = torch.tensor([math.cos(math.pi / 4), math.cos(3 * math.pi / 4), 0.0])
    assert torch.allclose(cosines, expected.to(cosines).expand_as(cosines), atol=1e-12)
