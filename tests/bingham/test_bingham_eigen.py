"""The closed-form 3×3 eigensolver against LAPACK, at generic and degenerate spectra; the
library path `eigh` takes off the CPU held to the same conditions."""

from __future__ import annotations

import pytest
import torch

from symgrasp.bingham import eigh, eigh3, nll, triu_to_sym
from symgrasp.bingham.distribution import _library_eigh3

SOLVERS = {"eigh3": eigh3, "library": _library_eigh3}

F64 = torch.float64


def rotations(n: int, seed: int) -> torch.Tensor:
    q = torch.linalg.qr(
        torch.randn(n, 3, 3, generator=torch.Generator().manual_seed(seed), dtype=F64)
    )[0]
    return q


def assert_decomposes(A: torch.Tensor, solver=eigh3) -> None:
    lam, V = solver(A)
    scale = A.abs().amax(dim=(-2, -1), keepdim=True).clamp(min=1e-300)
    torch.testing.assert_close(
        lam / scale.squeeze(-1), torch.linalg.eigvalsh(A) / scale.squeeze(-1), rtol=0, atol=1e-13
    )
    torch.testing.assert_close(
        (A @ V - V * lam.unsqueeze(-2)) / scale, torch.zeros_like(A), rtol=0, atol=1e-13
    )
    torch.testing.assert_close(
        V.transpose(-1, -2) @ V, torch.eye(3, dtype=F64).expand_as(A), rtol=0, atol=1e-13
    )
    torch.testing.assert_close(
        torch.linalg.det(V), torch.ones(A.shape[:-2], dtype=F64), rtol=0, atol=1e-13
    )


@pytest.mark.parametrize("solver", SOLVERS)
def test_random_matrices_at_any_scale(solver):
    m = torch.randn(20_000, 3, 3, generator=torch.Generator().manual_seed(0), dtype=F64)
    A = m + m.transpose(-1, -2)
    for scale in (1.0, 1e7, 1e-200):
        assert_decomposes(A * scale, SOLVERS[solver])


@pytest.mark.parametrize(
    "spectrum",
    [
        (1, 1, 1),
        (0, 0, 0),
        (-3, -3, 5),
        (1, 2, 2),
        (1, 1 + 1e-9, 2),
        (-1e6, -1e6 + 1e-3, 0),
        (1, 2, 2 + 1e-12),
        (-50, 0, 0),
    ],
)
@pytest.mark.parametrize("solver", SOLVERS)
def test_repeated_and_nearly_repeated_eigenvalues(spectrum, solver):
    Q = rotations(2000, 1)
    A = Q @ torch.diag(torch.tensor(spectrum, dtype=F64)) @ Q.transpose(-1, -2)
    assert_decomposes(A, SOLVERS[solver])


@pytest.mark.parametrize("solver", SOLVERS)
def test_reads_the_upper_triangle_keeps_dtype_and_takes_an_empty_batch(solver):
    generator = torch.Generator().manual_seed(5)
    A = triu_to_sym(torch.randn(10, 6, dtype=F64, generator=generator))
    garbage = A + torch.tril(torch.randn(10, 3, 3, dtype=F64, generator=generator), -1)
    torch.testing.assert_close(SOLVERS[solver](garbage)[0], eigh3(A)[0], rtol=0, atol=1e-12)
    lam, V = SOLVERS[solver](A.float())
    assert lam.dtype == V.dtype == torch.float32
    lam, V = SOLVERS[solver](torch.zeros(0, 3, 3))
    assert lam.shape == (0, 3) and V.shape == (0, 3, 3)


def test_eigh_takes_the_closed_form_on_a_cpu_and_lapack_as_it_is_for_d4():
    generator = torch.Generator().manual_seed(3)
    A = triu_to_sym(torch.randn(50, 6, dtype=F64, generator=generator))
    for got, want in zip(eigh(A), eigh3(A), strict=True):
        assert torch.equal(got, want)
    B = torch.randn(50, 4, 4, generator=generator)  # float32, as a bingham3d head gives it
    B = B + B.transpose(-1, -2)
    for got, want in zip(eigh(B), torch.linalg.eigh(B), strict=True):
        assert got.dtype == torch.float32 and torch.equal(got, want)  # recorded rounds rest on it


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_cuda_eigh_decomposes_and_agrees_with_the_closed_form():
    Q = rotations(2000, 4)
    A = Q @ torch.diag_embed(torch.randn(2000, 3, dtype=F64)) @ Q.transpose(-1, -2)
    lam, V = eigh(A.cuda())
    assert lam.is_cuda and V.is_cuda
    assert_decomposes(A, lambda M: tuple(t.cpu() for t in eigh(M.cuda())))
    torch.testing.assert_close(lam.cpu(), eigh3(A)[0], rtol=0, atol=1e-12)


def test_eigh3_refuses_a_matrix_not_3x3():
    with pytest.raises(ValueError, match=r"`A` must be \[\.\.\., 3, 3\]"):
        eigh3(torch.zeros(4, 4))


@pytest.mark.parametrize("d", [3, 4])
def test_nll_gradcheck_through_triu(d):
    generator = torch.Generator().manual_seed(2)
    a = (torch.randn(5, 6 if d == 3 else 10, generator=generator, dtype=F64) * 4).requires_grad_(
        True
    )
    v = torch.nn.functional.normalize(torch.randn(5, d, generator=generator, dtype=F64), dim=-1)
    assert torch.autograd.gradcheck(lambda x: nll(triu_to_sym(x), v), (a,))
