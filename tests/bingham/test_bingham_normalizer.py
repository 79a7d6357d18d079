"""The normalising constant against closed forms, an mpmath reference and its own calculus."""

from __future__ import annotations

import itertools
import math

import mpmath as mp
import numpy as np
import pytest
import scipy.special
import torch

from symgrasp.bingham import log_normalizer, second_moments
from symgrasp.bingham.normalizer import _S2_WINDOW, _SERIES_BELOW
from symgrasp.bingham.reference import log_normalizer_mpmath

S2_METHODS = ["quadrature", "paper"]
S3_METHODS = ["bessel", "paper"]
# Accuracy the methods promise (docs/bingham.md): paper ~1e-7 (N = 200), quadrature ≤ 1e-12.
TOLERANCE = {"quadrature": 1e-12, "paper": 1e-7, "bessel": 1e-10}


def _log_c(lam, method):
    return log_normalizer(torch.tensor(lam, dtype=torch.float64), method)


# --- closed forms ------------------------------------------------------------------------


@pytest.mark.parametrize("method", S2_METHODS)
def test_s2_closed_forms(method):
    tol = TOLERANCE[method]
    assert _log_c([0.0, 0.0, 0.0], method).item() == pytest.approx(math.log(4 * math.pi), abs=tol)
    for kappa in [1e-3, 0.7, 5.0, 60.0, 2e3, 1e6]:
        # λ₁ = λ₂ = −κ: C = 4π D(√κ)/√κ (Dawson's integral)
        dawson = 4 * math.pi * scipy.special.dawsn(math.sqrt(kappa)) / math.sqrt(kappa)
        assert _log_c([-kappa, -kappa, 0.0], method).item() == pytest.approx(
            math.log(dawson), abs=tol
        )
        # (−κ, 0, 0): C = 2π^{3/2} erf(√κ)/√κ
        erf_form = 2 * math.pi**1.5 * math.erf(math.sqrt(kappa)) / math.sqrt(kappa)
        assert _log_c([-kappa, 0.0, 0.0], method).item() == pytest.approx(
            math.log(erf_form), abs=tol
        )
    # Both concentrations large: C → 2π/√(λ₁λ₂) with relative error O(1/κ).
    l1, l2 = -3e6, -1e6
    assert _log_c([l1, l2, 0.0], method).item() == pytest.approx(
        math.log(2 * math.pi / math.sqrt(l1 * l2)), abs=2e-6
    )


@pytest.mark.parametrize("method", S3_METHODS)
def test_s3_closed_forms(method):
    tol = TOLERANCE[method]
    assert _log_c([0.0] * 4, method).item() == pytest.approx(math.log(2 * math.pi**2), abs=tol)
    for kappa in [1e-2, 3.0, 80.0, 1e4]:
        # One eigenvalue: C = |S³| ₁F₁(½; 2; −κ); three equal: C = e^{−κ} |S³| ₁F₁(½; 2; κ).
        with mp.workdps(30):
            one = float(mp.log(2 * mp.pi**2 * mp.hyp1f1(0.5, 2, -kappa)))
            three = float(-kappa + mp.log(2 * mp.pi**2 * mp.hyp1f1(0.5, 2, kappa)))
        assert _log_c([-kappa, 0.0, 0.0, 0.0], method).item() == pytest.approx(one, abs=tol)
        assert _log_c([-kappa, -kappa, -kappa, 0.0], method).item() == pytest.approx(three, abs=tol)


# --- mpmath grid ----------------------------------------------------------------------------


def _max_s2_grid_error(method: str, points: int) -> float:
    """max |Δ log C| (≈ relative error of C) on {0} ∪ −logspace(−3, 6, points) per eigenvalue."""
    values = [0.0, *(-np.logspace(-3, 6, points)).tolist()]
    pairs = [(a, b) for a in values for b in values if a <= b]
    lam = torch.tensor([[a, b, 0.0] for a, b in pairs], dtype=torch.float64)
    reference = torch.tensor(
        [log_normalizer_mpmath(row) for row in lam.tolist()], dtype=torch.float64
    )
    return (log_normalizer(lam, method) - reference).abs().max().item()


@pytest.mark.parametrize("method", S2_METHODS)
def test_s2_against_mpmath(method):
    assert _max_s2_grid_error(method, 7) < TOLERANCE[method]


@pytest.mark.slow
@pytest.mark.parametrize("method", S2_METHODS)
def test_s2_against_mpmath_dense(method):
    assert _max_s2_grid_error(method, 25) < TOLERANCE[method]


@pytest.mark.parametrize("method", S3_METHODS)
def test_s3_against_mpmath(method):
    values = [0.0, -0.05, -3.0, -90.0, -4e3, -1e6]
    triples = [t for t in itertools.product(values, repeat=3) if t[0] <= t[1] <= t[2]][::3]
    lam = torch.tensor([[*t, 0.0] for t in triples], dtype=torch.float64)
    reference = torch.tensor(
        [log_normalizer_mpmath([*t, 0.0]) for t in triples], dtype=torch.float64
    )
    assert (log_normalizer(lam, method) - reference).abs().max().item() < TOLERANCE[method]


# --- invariances, gradients, robustness ------------------------------------------------------


@pytest.mark.parametrize(
    ("method", "d"), [("quadrature", 3), ("paper", 3), ("bessel", 4), ("paper", 4)]
)
def test_order_and_shift(method, d):
    generator = torch.Generator().manual_seed(0)
    lam = -torch.rand(16, d, generator=generator, dtype=torch.float64) * 50
    shift = torch.randn(16, 1, generator=generator, dtype=torch.float64) * 30
    permuted = lam[:, torch.randperm(d, generator=generator)]
    expected = log_normalizer(lam, method) + shift.squeeze(-1)
    torch.testing.assert_close(
        log_normalizer(permuted + shift, method), expected, rtol=0, atol=1e-12
    )


@pytest.mark.parametrize(
    ("method", "d"), [("quadrature", 3), ("paper", 3), ("bessel", 4), ("paper", 4)]
)
def test_gradcheck(method, d):
    generator = torch.Generator().manual_seed(1)
    lam = torch.cat(
        [
            -torch.rand(4, d, generator=generator, dtype=torch.float64) * 40,
            torch.tensor([[-7.0] * (d - 1) + [0.0]], dtype=torch.float64),  # ties
            torch.tensor([[-3e4, -2e2] + [0.0] * (d - 2)], dtype=torch.float64),  # concentrated
        ]
    ).requires_grad_(True)
    # atol covers the method's own accuracy (the paper's sum is good to ~1e-8).
    assert torch.autograd.gradcheck(
        lambda x: log_normalizer(x, method), (lam,), atol=1e-6, rtol=1e-5
    )


def test_gradient_identity_and_methods_agree():
    """Σᵢ ∂ log C/∂λᵢ = 1 (so Σ ∂C/∂λᵢ = C), and the two methods' gradients agree."""
    lam = torch.tensor(
        [[-30.0, -2.0, 0.0], [-1e5, -1e3, 0.0], [-0.01, 0.0, 0.0], [0.0, 0.0, 0.0]],
        dtype=torch.float64,
    )
    for method in S2_METHODS:
        x = lam.clone().requires_grad_(True)
        log_normalizer(x, method).sum().backward()
        torch.testing.assert_close(
            x.grad.sum(-1), torch.ones(4, dtype=torch.float64), rtol=0, atol=1e-7
        )
    torch.testing.assert_close(
        second_moments(lam, "quadrature"), second_moments(lam, "paper"), rtol=1e-6, atol=1e-10
    )


def test_gradient_against_mpmath_finite_difference():
    """E[v₁²] from the quadrature against a central difference of the mpmath reference."""
    l1, l2, h = -12.0, -3.0, 1e-6
    fd = (log_normalizer_mpmath([l1 + h, l2, 0.0]) - log_normalizer_mpmath([l1 - h, l2, 0.0])) / (
        2 * h
    )
    assert second_moments(torch.tensor([l1, l2, 0.0], dtype=torch.float64))[
        0
    ].item() == pytest.approx(fd, rel=1e-7)


def _second_difference(f, lam: torch.Tensor, axis: int, step: float) -> torch.Tensor:
    """f(λ − h) − 2f(λ) + f(λ + h) along one eigenvalue: O(h²) where f is smooth, a jump shows."""
    shifted = lam.repeat(3, 1)
    shifted[0, axis] -= step
    shifted[2, axis] += step
    values = f(shifted)
    return values[0] - 2 * values[1] + values[2]


def test_continuity_across_internal_switches():
    """The integration window starts shrinking at b = L², the M₂ series takes over at α = 0.1."""
    step = 1e-7
    at_window = torch.tensor([[-80.0, -(_S2_WINDOW**2), 0.0]], dtype=torch.float64)
    at_series = torch.tensor([[-_SERIES_BELOW, 0.0, 0.0]], dtype=torch.float64)
    for lam, axis in [(at_window, 1), (at_series, 0)]:
        assert _second_difference(log_normalizer, lam, axis, step).abs().item() < 1e-13
        assert _second_difference(second_moments, lam, axis, step).abs().max().item() < 1e-13


@pytest.mark.parametrize(
    ("method", "d"), [("quadrature", 3), ("paper", 3), ("bessel", 4), ("paper", 4)]
)
def test_finite_over_the_whole_range(method, d):
    values = [0.0, -1e-300, -1e-12, -1e-3, -1.0, -42.25, -1e3, -1e6, -1e7]
    lam = torch.tensor(
        [list(t) for t in itertools.product(values, repeat=d - 1)], dtype=torch.float64
    )
    lam = torch.cat([lam, torch.zeros(len(lam), 1, dtype=torch.float64)], -1).requires_grad_(True)
    log_c = log_normalizer(lam, method)
    log_c.sum().backward()
    assert torch.isfinite(log_c).all() and torch.isfinite(lam.grad).all()
    assert (lam.grad >= -1e-12).all()  # second moments are non-negative


def test_float32_in_float32_out():
    lam = torch.tensor([[-5.0, -1.0, 0.0]], dtype=torch.float32, requires_grad=True)
    out = log_normalizer(lam)
    out.sum().backward()
    assert out.dtype == torch.float32 and lam.grad.dtype == torch.float32
    assert out.item() == pytest.approx(_log_c([-5.0, -1.0, 0.0], "quadrature").item(), rel=1e-6)


def test_integer_and_bool_input_in_the_default_float_dtype():
    integer = torch.tensor([[-2, -1, 0], [1, 0, 0]])
    torch.testing.assert_close(log_normalizer(integer), log_normalizer(integer.float()))
    assert log_normalizer(integer)[0].item() == pytest.approx(1.6619056, rel=1e-6)  # not 1
    boolean = torch.tensor([True, False, False, False])
    torch.testing.assert_close(log_normalizer(boolean), log_normalizer(boolean.float()))
    default = torch.get_default_dtype()
    try:
        torch.set_default_dtype(torch.float64)
        torch.testing.assert_close(
            log_normalizer(integer), _log_c([[-2, -1, 0], [1, 0, 0]], "quadrature")
        )
    finally:
        torch.set_default_dtype(default)
    with pytest.raises(TypeError, match=r"`eigenvalues` must be real, got torch\.complex64"):
        log_normalizer(torch.zeros(3, dtype=torch.complex64))


def test_empty_batch():
    assert log_normalizer(torch.zeros(0, 3)).shape == (0,)
    assert log_normalizer(torch.zeros(0, 4), "paper").shape == (0,)


def test_bad_input():
    with pytest.raises(ValueError, match=r"eigenvalues.*trailing size 3"):
        log_normalizer(torch.zeros(2, 5))
    with pytest.raises(ValueError, match="unknown `method`"):
        log_normalizer(torch.zeros(3), method="laplace")
    with pytest.raises(ValueError, match="not available on S\\^3"):
        log_normalizer(torch.zeros(4), method="quadrature")


@pytest.mark.parametrize("function", [log_normalizer, second_moments])
def test_non_finite_eigenvalues_are_refused_naming_them(function):
    """A NaN made every method return NaN, −inf a NaN gradient, silently (issue 66)."""
    with pytest.raises(ValueError, match=r"`eigenvalues` must be finite: got \[nan, -1\.0, 0\.0\]"):
        function(torch.tensor([torch.nan, -1.0, 0.0]))
    batch = torch.zeros(3, 2, 4)
    batch[1, 0, 2] = -torch.inf
    batch[2, 1, 0] = torch.nan
    with pytest.raises(
        ValueError,
        match=r"`eigenvalues` must be finite: 2 of 6 vectors hold NaN or inf, the first at "
        r"batch index \(1, 0\) \(shape \(3, 2, 4\)\)",
    ):
        function(batch)
    with pytest.raises(TypeError, match=r"`eigenvalues` must be a torch\.Tensor, got list"):
        function([-1.0, 0.0, 0.0])


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
@pytest.mark.parametrize(
    ("method", "d"), [("quadrature", 3), ("paper", 3), ("bessel", 4), ("paper", 4)]
)
def test_cuda_matches_cpu(method, d):
    lam = -torch.rand(64, d, dtype=torch.float64) * 100
    torch.testing.assert_close(
        log_normalizer(lam.cuda(), method).cpu(), log_normalizer(lam, method)
    )
