"""symgrasp.rotation.geometry against scipy.spatial.transform.Rotation as the oracle."""

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from symgrasp.rotation.geometry import (
    flip,
    flip_quaternion,
    gram_schmidt,
    matrix_to_quaternion,
    quaternion_to_matrix,
)

DTYPES = [torch.float32, torch.float64]


def _scipy_rotations(n: int = 200, seed: int = 0) -> Rotation:
    random = Rotation.random(n, random_state=seed)
    # Near-180° rotations (trace ≈ −1) break naive quaternion extraction; near 0° too.
    axes = np.random.default_rng(seed).normal(size=(40, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate([np.pi - np.logspace(-8, -1, 20), np.logspace(-8, -1, 20)])
    special = Rotation.from_rotvec(axes * angles[:, None])
    exact = Rotation.from_rotvec(np.pi * np.eye(3))  # 180° about x, y, z
    return Rotation.concatenate([random, special, exact, Rotation.identity()])


def _assert_proper(R: torch.Tensor, atol: float = 1e-6) -> None:
    eye = torch.eye(3, dtype=R.dtype).expand_as(R)
    assert torch.allclose(R.mT @ R, eye, atol=atol)
    assert torch.allclose(torch.linalg.det(R), torch.ones(R.shape[:-2], dtype=R.dtype), atol=atol)


def _same_up_to_sign(q: torch.Tensor, expected: torch.Tensor, atol: float) -> None:
    sign = torch.sign((q * expected).sum(-1, keepdim=True))
    torch.testing.assert_close(q * sign, expected, atol=atol, rtol=0)


@pytest.mark.parametrize("dtype", DTYPES)
def test_quaternion_to_matrix_matches_scipy(dtype):
    rotations = _scipy_rotations()
    q = torch.as_tensor(rotations.as_quat(), dtype=dtype)  # scipy is scalar-last (x, y, z, w)
    expected = torch.as_tensor(rotations.as_matrix(), dtype=dtype)
    atol = 1e-6 if dtype == torch.float32 else 1e-12
    torch.testing.assert_close(quaternion_to_matrix(q), expected, atol=atol, rtol=0)


@pytest.mark.parametrize("dtype", DTYPES)
def test_matrix_to_quaternion_matches_scipy_near_180_degrees(dtype):
    rotations = _scipy_rotations()
    R = torch.as_tensor(rotations.as_matrix(), dtype=dtype)
    expected = torch.as_tensor(rotations.as_quat(), dtype=dtype)
    q = matrix_to_quaternion(R)
    atol = 1e-6 if dtype == torch.float32 else 1e-12
    torch.testing.assert_close(q.norm(dim=-1), torch.ones(len(q), dtype=dtype), atol=atol, rtol=0)
    _same_up_to_sign(q, expected, atol)
    # The sign convention: the largest-magnitude component is positive.
    assert (q.gather(-1, q.abs().argmax(-1, keepdim=True)) > 0).all()


def test_matrix_to_quaternion_keeps_batch_shape():
    R = torch.as_tensor(Rotation.random(6, random_state=1).as_matrix()).reshape(2, 3, 3, 3)
    assert matrix_to_quaternion(R).shape == (2, 3, 4)
    with pytest.raises(ValueError, match=r"`R` must be \[\.\.\., 3, 3\]"):
        matrix_to_quaternion(torch.zeros(2, 4, 4))


def test_flip_is_180_degrees_about_the_approach_axis():
    rotations = _scipy_rotations()
    R = torch.as_tensor(rotations.as_matrix())
    expected = (rotations * Rotation.from_rotvec([np.pi, 0.0, 0.0])).as_matrix()
    torch.testing.assert_close(flip(R), torch.as_tensor(expected), atol=1e-12, rtol=0)
    torch.testing.assert_close(flip(R)[..., 0], R[..., 0], atol=0, rtol=0)  # same approach


def test_flip_quaternion_matches_flipped_matrix_and_is_orthogonal():
    rotations = _scipy_rotations()
    q = torch.as_tensor(rotations.as_quat())
    expected = torch.as_tensor((rotations * Rotation.from_rotvec([np.pi, 0.0, 0.0])).as_quat())
    flipped = flip_quaternion(q)
    _same_up_to_sign(flipped, expected, 1e-12)
    torch.testing.assert_close((q * flipped).sum(-1), torch.zeros(len(q), dtype=q.dtype))


@pytest.mark.parametrize("dtype", DTYPES)
def test_gram_schmidt_reproduces_rotations_and_keeps_the_approach_direction(dtype):
    R = torch.as_tensor(_scipy_rotations().as_matrix(), dtype=dtype)
    scale = torch.rand(len(R), 1, dtype=dtype, generator=torch.Generator().manual_seed(0)) + 0.1
    torch.testing.assert_close(gram_schmidt(3 * scale * R[..., 0], R[..., 2] / scale), R)
    # Perturbed inputs: e_x keeps x's direction, e_z stays in the plane of x and z.
    generator = torch.Generator().manual_seed(1)
    x = torch.randn(500, 3, dtype=dtype, generator=generator)
    z = torch.randn(500, 3, dtype=dtype, generator=generator)
    out = gram_schmidt(x, z)
    _assert_proper(out)
    torch.testing.assert_close(out[..., 0], x / x.norm(dim=-1, keepdim=True))
    normal = torch.linalg.cross(x, z)
    in_plane = (out[..., 2] * normal).sum(-1) / normal.norm(dim=-1)
    torch.testing.assert_close(in_plane, torch.zeros_like(in_plane), atol=1e-6, rtol=0)
    assert ((out[..., 2] * z).sum(-1) > 0).all()  # e_z points to z's side


@pytest.mark.parametrize("dtype", DTYPES)
def test_gram_schmidt_degenerate_inputs_give_proper_rotations(dtype):
    generator = torch.Generator().manual_seed(2)
    x = torch.randn(100, 3, dtype=dtype, generator=generator)
    tiny = torch.randn(100, 3, dtype=dtype, generator=generator) * 1e-7
    zero = torch.zeros(3, dtype=dtype)
    cases = {
        "zeros": (zero, zero),
        "x zero": (zero, x[0]),
        "z zero": (x, zero.expand_as(x)),
        "parallel": (x, 2.5 * x),
        "antiparallel": (x, -x),
        "nearly parallel": (x, x + tiny),
        "axis": (
            torch.tensor([0.0, 0.0, 1.0], dtype=dtype),
            torch.tensor([0, 0, 5.0], dtype=dtype),
        ),
    }
    for case, (a, b) in cases.items():
        out = gram_schmidt(a, b)
        assert torch.isfinite(out).all(), case
        _assert_proper(out.reshape(-1, 3, 3))
    # Deterministic fallbacks.
    torch.testing.assert_close(gram_schmidt(zero, zero), torch.eye(3, dtype=dtype))
    torch.testing.assert_close(gram_schmidt(x, x), gram_schmidt(x, -3 * x))
