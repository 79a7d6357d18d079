"""triu, nll, the Bingham class and its sampler."""

from __future__ import annotations

import math

import pytest
import torch
from torch.distributions import Categorical, Distribution, Independent, MixtureSameFamily

from symgrasp.bingham import (
    Bingham,
    fit,
    log_normalizer,
    nll,
    optimal_b,
    sampling,
    second_moments,
    sym_to_triu,
    triu_to_sym,
)

F64 = torch.float64


def random_symmetric(batch: int, d: int, scale: float, seed: int) -> torch.Tensor:
    generator = torch.Generator().manual_seed(seed)
    m = torch.randn(batch, d, d, generator=generator, dtype=F64) * scale
    return (m + m.transpose(-1, -2)) / 2


def uniform_sphere(n: int, d: int, seed: int) -> torch.Tensor:
    v = torch.randn(n, d, generator=torch.Generator().manual_seed(seed), dtype=F64)
    return v / v.norm(dim=-1, keepdim=True)


# --- triu ----------------------------------------------------------------------------------


def test_triu_order_and_round_trip():
    A = triu_to_sym(torch.arange(6.0))
    torch.testing.assert_close(A, torch.tensor([[0.0, 1, 2], [1, 3, 4], [2, 4, 5]]))
    a = torch.randn(5, 2, 10)
    torch.testing.assert_close(sym_to_triu(triu_to_sym(a)), a)
    assert triu_to_sym(torch.randn(7, 6)).shape == (7, 3, 3)


def test_triu_bad_sizes():
    with pytest.raises(ValueError, match=r"`a`.*6 or 10"):
        triu_to_sym(torch.zeros(4, 7))
    with pytest.raises(ValueError, match="`A`"):
        sym_to_triu(torch.zeros(2, 3))


# --- nll -------------------------------------------------------------------------------------


def test_nll_gradient_is_moment_difference_and_finite_at_degenerate_spectra():
    v = torch.tensor([[0.6, 0.0, 0.8], [0.0, 1.0, 0.0]], dtype=F64)
    # A = 0 and a doubly degenerate spectrum, where a backward through eigenvectors is NaN.
    A = torch.stack(
        [torch.zeros(3, 3, dtype=F64), torch.diag(torch.tensor([-4.0, -4.0, 0.0], dtype=F64))]
    )
    A.requires_grad_(True)
    nll(A, v).sum().backward()
    assert torch.isfinite(A.grad).all()
    # d nll/dA = E[vvᵀ] − vvᵀ; at A = 0, E[vvᵀ] = I/3.
    torch.testing.assert_close(A.grad[0], torch.eye(3, dtype=F64) / 3 - torch.outer(v[0], v[0]))
    moments = second_moments(torch.tensor([-4.0, -4.0, 0.0], dtype=F64))
    torch.testing.assert_close(A.grad[1], torch.diag(moments) - torch.outer(v[1], v[1]))


def test_nll_at_zero_is_log_area_and_float32_gradient_is_finite():
    A = torch.zeros(4, 3, 3, requires_grad=True)
    loss = nll(A, uniform_sphere(4, 3, 0).float())
    loss.sum().backward()
    torch.testing.assert_close(loss, torch.full((4,), math.log(4 * math.pi)))
    assert torch.isfinite(A.grad).all()


def test_nll_invariances():
    A = random_symmetric(8, 3, 10.0, 1)
    v = uniform_sphere(8, 3, 2)
    base = nll(A, v)
    torch.testing.assert_close(nll(A, -v), base, rtol=0, atol=0)  # antipodal: bit-exact
    torch.testing.assert_close(nll(A + 7.5 * torch.eye(3, dtype=F64), v), base)  # shift
    R = torch.linalg.qr(torch.randn(3, 3, dtype=F64))[0]
    torch.testing.assert_close(nll(R @ A @ R.T, v @ R.T), base)  # rotation


def test_density_integrates_to_one():
    """E_uniform[p(v)] · |S²| = 1: Monte Carlo under the uniform distribution, an independent check."""
    d = Bingham(torch.diag(torch.tensor([-6.0, -2.0, 0.0], dtype=F64)))
    v = uniform_sphere(400_000, 3, 3)
    integral = d.log_prob(v).exp().mean() * 4 * math.pi
    assert integral.item() == pytest.approx(1.0, abs=0.01)


def fibonacci_sphere(n: int) -> torch.Tensor:
    """``n`` points of the Fibonacci lattice on S², each standing for an area 4π/n."""
    i = torch.arange(n, dtype=F64) + 0.5
    z = 1 - 2 * i / n
    phi = math.pi * (3 - math.sqrt(5)) * i
    r = (1 - z**2).sqrt()
    return torch.stack([r * phi.cos(), r * phi.sin(), z], -1)


@pytest.mark.parametrize("d", [3, 4])
def test_any_accepted_matrix_gives_a_density_that_integrates_to_one(d):
    """A non-symmetric A is used by its symmetric part, the one vᵀAv reads: the normaliser used
    to read one triangle (the density of triu(A) then integrated to 0.014 on S², 7.1 on S³)."""
    generator = torch.Generator().manual_seed(7)
    A = torch.randn(d, d, generator=generator, dtype=F64) * 3  # not symmetric
    assert not torch.equal(A, A.T)
    dist = Bingham(A, validate_args=False)  # torch's default validation would refuse it
    if d == 3:  # the lattice's quadrature: error far below the tolerance for this smooth density
        integral = dist.log_prob(fibonacci_sphere(200_000)).exp().mean() * 4 * math.pi
        assert integral.item() == pytest.approx(1.0, abs=1e-3)
    else:  # Monte Carlo under the uniform distribution on S³, of area 2π²
        integral = dist.log_prob(uniform_sphere(1_000_000, 4, 8)).exp().mean() * 2 * math.pi**2
        assert integral.item() == pytest.approx(1.0, abs=0.03)
    v = uniform_sphere(16, d, 9)
    torch.testing.assert_close(dist.log_prob(v), Bingham((A + A.T) / 2).log_prob(v))
    torch.testing.assert_close(nll(A, v), nll((A + A.T) / 2, v))
    symmetric = (A + A.T) / 2
    assert torch.equal(Bingham(symmetric).A, symmetric), "a symmetric A is kept bit for bit"


def test_bad_sizes_and_types_are_refused_naming_the_argument():
    dist = Bingham(torch.diag(torch.tensor([-5.0, -1.0, 0.0])))
    with pytest.raises(ValueError, match="`sample_shape` must be an integer ≥ 0, got -1"):
        dist.sample((-1,))
    with pytest.raises(ValueError, match=r"at most .* per call"):
        dist.sample((10**12,))  # refused before it allocates
    with pytest.raises(TypeError, match="`sample_shape` must be a tuple"):
        dist.sample(5)
    for bad in (lambda: dist.acceptance_rate(0), lambda: dist.percentile_angle_mc(0.9, 0, 0)):
        with pytest.raises(ValueError, match="`num_samples` must be an integer ≥ 1, got 0"):
            bad()
    with pytest.raises(ValueError, match="N ≥ 1"):
        fit(torch.zeros(0, 3))
    with pytest.raises(TypeError, match=r"`A` must be a torch.Tensor, got ndarray"):
        Bingham(torch.eye(3).numpy())
    with pytest.raises(TypeError, match=r"`v` must be a torch\.Tensor"):
        nll(torch.eye(3), [1.0, 0.0, 0.0])
    assert dist.sample((0,)).shape == (0, 3)  # an empty draw is a valid one


def test_nll_validation():
    A, v = torch.zeros(3, 3), torch.tensor([1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="`A` must be symmetric"):
        nll(torch.triu(torch.ones(3, 3)), v, validate_args=True)
    with pytest.raises(ValueError, match="`A` must be finite"):
        nll(torch.full((3, 3), float("nan")), v, validate_args=True)
    with pytest.raises(ValueError, match="`v` must hold finite unit vectors"):
        nll(A, 2 * v, validate_args=True)
    with pytest.raises(ValueError, match=r"`v` must be \[\.\.\., 3\]"):
        nll(A, torch.zeros(4))  # trailing sizes are checked even without validate_args
    with pytest.raises(ValueError, match="`A` must be"):
        Bingham(torch.zeros(2, 3))
    nll(torch.triu(torch.ones(3, 3)), v)  # symmetry is checked only with validate_args
    assert torch.isnan(nll(torch.full((3, 3), torch.nan), v))  # NaN in A propagates without it


def test_nll_refuses_non_unit_v():
    A, v = random_symmetric(8, 3, 5.0, 20), uniform_sphere(8, 3, 21)
    v[[2, 5]] *= 1.01
    with pytest.raises(
        ValueError,
        match=r"`v` must hold finite unit vectors.*2 of 8 are not, the first at batch index \(2,\) with ‖v‖ = 1.01",
    ):
        nll(A, v)
    with pytest.raises(ValueError, match=r"`v` must hold finite unit vectors.*got ‖v‖ = nan"):
        Bingham(A[0]).log_prob(torch.tensor([torch.nan, 0.0, 0.0], dtype=F64))
    with pytest.raises(ValueError, match="`v` must hold finite unit vectors"):
        fit(2 * uniform_sphere(100, 3, 22))


def test_nll_accepts_unit_vectors_normalised_in_float32():
    A = random_symmetric(1000, 3, 30.0, 23).float()
    v = torch.nn.functional.normalize(
        torch.randn(1000, 3, generator=torch.Generator().manual_seed(24)) * 1e3, dim=-1
    )
    R = torch.linalg.qr(torch.randn(3, 3, generator=torch.Generator().manual_seed(25)))[0]
    rotated = v @ R.T  # one more float32 rounding
    assert torch.isfinite(nll(A, rotated)).all()
    assert torch.isfinite(nll(A.double(), v.double())).all()  # float32 data cast to float64


def test_nll_promotes_dtypes_and_checks_batch_shapes():
    A, v = random_symmetric(4, 3, 5.0, 25), uniform_sphere(4, 3, 26)
    mixed = nll(A.float(), v)
    assert mixed.dtype == F64
    torch.testing.assert_close(mixed, nll(A.float().double(), v), rtol=0, atol=0)
    diagonal = torch.diag(torch.tensor([-3, -1, 0]))
    torch.testing.assert_close(
        nll(diagonal, torch.tensor([0, 0, 1])), nll(diagonal.float(), torch.tensor([0.0, 0, 1]))
    )
    assert nll(A[:, None], v[None, :3]).shape == (4, 3)  # batch dimensions broadcast
    message = r"`A` \[\.\.\., 3, 3\] and `v` \[\.\.\., 3\] must broadcast in their batch dimensions; got `A` \(4, 3, 3\), `v` \(5, 3\)"
    with pytest.raises(ValueError, match=message):
        nll(A, uniform_sphere(5, 3, 27))
    with pytest.raises(ValueError, match=message):
        Bingham(A).log_prob(uniform_sphere(5, 3, 27).float())
    with pytest.raises(TypeError, match=r"`A` must be real, got torch\.complex128"):
        nll(A.to(torch.complex128), v)


# --- the distribution --------------------------------------------------------------------------


def test_mode_and_confidence_on_hand_made_matrices():
    d = Bingham(torch.diag(torch.tensor([-5.0, 1.0, -3.0], dtype=F64)))
    torch.testing.assert_close(d.mode, torch.tensor([0.0, 1.0, 0.0], dtype=F64))
    assert d.confidence.item() == pytest.approx(6.0 + 4.0)
    # A = −κ(I − e eᵀ) + shift: mode e (sign-canonical), confidence 2κ.
    e = torch.tensor([-2.0, 3.0, -6.0], dtype=F64) / 7
    A = -20.0 * (torch.eye(3, dtype=F64) - torch.outer(e, e)) + 3.0 * torch.eye(3, dtype=F64)
    d = Bingham(A)
    torch.testing.assert_close(d.mode, -e)  # largest-magnitude component made positive
    assert d.confidence.item() == pytest.approx(40.0)
    assert d.batch_shape == () and d.event_shape == (3,)


def test_entropy():
    assert Bingham(torch.zeros(3, 3, dtype=F64)).entropy().item() == pytest.approx(
        math.log(4 * math.pi)
    )
    assert Bingham(torch.zeros(4, 4, dtype=F64)).entropy().item() == pytest.approx(
        math.log(2 * math.pi**2)
    )
    d = Bingham(torch.diag(torch.tensor([-30.0, -4.0, 0.0], dtype=F64)))
    samples = d.sample((200_000,), generator=torch.Generator().manual_seed(0))
    monte_carlo = -d.log_prob(samples).mean()
    assert d.entropy().item() == pytest.approx(monte_carlo.item(), abs=0.01)


@pytest.mark.parametrize(
    "lam", [[-50.0, -10.0, 0.0], [-0.3, 0.0, 0.0], [-2e4, -3.0, 0.0], [-40.0, -9.0, -1.0, 0.0]]
)
def test_sample_second_moments_match_the_gradient_of_log_c(lam):
    lam = torch.tensor(lam, dtype=F64)
    d = len(lam)
    R = torch.linalg.qr(torch.randn(d, d, dtype=F64, generator=torch.Generator().manual_seed(5)))[0]
    dist = Bingham(R @ torch.diag(lam) @ R.T)
    n = 200_000
    v = dist.sample((n,), generator=torch.Generator().manual_seed(6))
    assert v.shape == (n, d)
    torch.testing.assert_close(v.norm(dim=-1), torch.ones(n, dtype=F64))
    in_eigenbasis = (v @ R).square()
    expected = second_moments(lam)
    # Five standard errors of each mean of vᵢ² (variance ≤ E[vᵢ⁴] ≤ E[vᵢ²]).
    tolerance = 5 * (expected / n).sqrt() + 1e-12
    assert ((in_eigenbasis.mean(0) - expected).abs() <= tolerance).all()


def test_samples_are_antipodally_symmetric():
    dist = Bingham(torch.diag(torch.tensor([-30.0, -5.0, 0.0], dtype=F64)))
    n = 100_000
    v = dist.sample((n,), generator=torch.Generator().manual_seed(7))
    positive = (v[:, 2] > 0).double().mean().item()
    assert abs(positive - 0.5) < 5 * 0.5 / math.sqrt(n)  # five binomial standard errors
    assert v.mean(0).abs().max().item() < 5 / math.sqrt(n)


def test_sampler_batch_shapes_reproducibility_and_acceptance():
    A = random_symmetric(6, 3, 30.0, 8).reshape(2, 3, 3, 3)
    dist = Bingham(A)
    a = dist.sample((4, 5), generator=torch.Generator().manual_seed(9))
    b = dist.sample((4, 5), generator=torch.Generator().manual_seed(9))
    assert a.shape == (4, 5, 2, 3, 3)
    torch.testing.assert_close(a, b, rtol=0, atol=0)
    rate = dist.acceptance_rate(2000, generator=torch.Generator().manual_seed(10))
    assert rate.shape == (2, 3)
    assert (rate > 0.45).all() and (rate <= 1).all()
    assert Bingham(torch.zeros(3, 3)).sample().shape == (3,)


def test_sample_refuses_non_finite_rows_instead_of_hanging():
    A = torch.diag(torch.tensor([-3.0, -1.0, 0.0])).repeat(1000, 1, 1)
    A[417, 1, 2] = A[417, 2, 1] = torch.nan
    A[900, 0, 0] = torch.inf
    with pytest.raises(
        ValueError,
        match=r"`A` must be finite: 2 of 1000 matrices hold NaN or inf, the first at batch index \(417,\)",
    ):
        Bingham(A).sample()
    with pytest.raises(ValueError, match="`A` must be finite"):
        Bingham(A[417]).acceptance_rate(10)
    huge = torch.diag(torch.tensor([-1e308, 0.0, 0.0], dtype=F64))  # finite, but 2κ overflows
    with pytest.raises(ValueError, match=r"`concentrations` λ_max − λ must be finite"):
        Bingham(huge).sample((1000,))


def test_sampler_rounds_are_bounded(monkeypatch):
    monkeypatch.setattr(sampling, "_MAX_ROUNDS", 0)
    dist = Bingham(torch.zeros(3, 3, 3))
    assert dist.sample((0,)).shape == (0, 3, 3)  # nothing to draw: no round needed
    with pytest.raises(
        RuntimeError,
        match="15 of 15 samples are still unaccepted after 0 rounds of rejection, in 3 of 3",
    ):
        dist.sample((5,))


def test_optimal_b_solves_its_equation():
    kappa = torch.tensor(
        [[0.0, 0.0, 0.0], [0.0, 5.0, 50.0], [0.0, 1e7, 1e7], [0.0, 1.0, 2.0, 3.0]][:3], dtype=F64
    )
    b = optimal_b(kappa)
    torch.testing.assert_close(
        (1 / (b.unsqueeze(-1) + 2 * kappa)).sum(-1), torch.ones(3, dtype=F64)
    )
    assert b[0].item() == pytest.approx(3.0)


def test_percentile_angle_approximation_matches_monte_carlo_when_concentrated():
    dist = Bingham(torch.diag(torch.tensor([-2000.0, -500.0, 0.0], dtype=F64)))
    generator = torch.Generator().manual_seed(11)
    for axis in (0, 1):
        approx = dist.percentile_angle(0.99, axis)
        monte_carlo = dist.percentile_angle_mc(0.99, axis, num_samples=100_000, generator=generator)
        assert approx.item() == pytest.approx(monte_carlo.item(), rel=0.03)
    with pytest.raises(ValueError, match="`p`"):
        dist.percentile_angle(1.5, 0)
    with pytest.raises(ValueError, match="`axis`"):
        dist.percentile_angle(0.5, 2)


def test_fit_recovers_parameters():
    R = torch.linalg.qr(torch.randn(3, 3, dtype=F64, generator=torch.Generator().manual_seed(12)))[
        0
    ]
    truth = Bingham(R @ torch.diag(torch.tensor([-80.0, -15.0, 0.0], dtype=F64)) @ R.T)
    estimate = fit(truth.sample((100_000,), generator=torch.Generator().manual_seed(13)))
    lam = estimate.eigenvalues - estimate.eigenvalues[-1]
    torch.testing.assert_close(
        lam, torch.tensor([-80.0, -15.0, 0.0], dtype=F64), rtol=0.03, atol=1e-9
    )
    assert abs(torch.dot(estimate.mode, truth.mode).item()) > 0.9999


def test_log_prob_consistent_with_normalizer():
    A = random_symmetric(5, 4, 5.0, 14)
    v = uniform_sphere(5, 4, 15)
    expected = torch.einsum("bi,bij,bj->b", v, A, v) - log_normalizer(torch.linalg.eigvalsh(A))
    torch.testing.assert_close(Bingham(A).log_prob(v), expected)


# --- as a torch distribution -------------------------------------------------------------------


@pytest.fixture
def default_validation():
    """torch's global default of `validate_args`, restored after the test."""
    default = Distribution._validate_args
    yield
    Distribution.set_default_validate_args(default)


def test_is_a_torch_distribution_with_shapes_support_and_constraints():
    A = random_symmetric(10, 4, 5.0, 30).reshape(2, 5, 4, 4)
    dist = Bingham(A)
    assert isinstance(dist, Distribution) and not dist.has_rsample
    assert dist.batch_shape == (2, 5) and dist.event_shape == (4,)
    v = dist.sample((7,), generator=torch.Generator().manual_seed(31))
    assert v.shape == (7, 2, 5, 4)
    assert dist.support.event_dim == 1 and dist.support.check(v).all()
    off = torch.tensor([[0.0, 0.0, 1.01], [0.0, torch.nan, 0.0], [0.6, 0.0, 0.8]])
    assert dist.support.check(off).tolist() == [False, False, True]
    assert dist.support.check(torch.tensor([0, 0, -1])).item()  # integers promoted
    assert dist.arg_constraints["A"].check(dist.A).all()
    with pytest.raises(NotImplementedError, match="`mean` is 0 for every A"):
        dist.mean  # noqa: B018
    with pytest.raises(NotImplementedError):
        dist.rsample()


def test_validate_args_follows_torchs_default(default_validation):
    skew = torch.triu(torch.ones(3, 3))
    nan = torch.full((3, 3), torch.nan)
    Distribution.set_default_validate_args(True)
    with pytest.raises(ValueError, match="`A` must be symmetric, got relative asymmetry 1"):
        Bingham(skew)
    with pytest.raises(ValueError, match=r"`A` must be finite: got \[\[nan, nan, nan\]"):
        Bingham(nan)
    unchecked = Bingham(skew, validate_args=False)
    assert not unchecked._validate_args
    torch.testing.assert_close(unchecked.A, (skew + skew.T) / 2)
    assert torch.isnan(Bingham(nan, validate_args=False).confidence)  # NaN propagates

    Distribution.set_default_validate_args(False)
    assert not Bingham(skew)._validate_args
    with pytest.raises(ValueError, match="`A` must be symmetric"):
        Bingham(skew, validate_args=True)
    with pytest.raises(ValueError, match="`v` must hold finite unit vectors"):
        Bingham(skew).log_prob(torch.tensor([0.0, 0.0, 2.0]))  # values are checked either way


def test_expand_repeats_the_distribution_without_copying():
    A = random_symmetric(2, 3, 8.0, 32)
    dist = Bingham(A, validate_args=False)
    wide = dist.expand((4, 2))
    assert wide.batch_shape == (4, 2) and wide.event_shape == (3,)
    assert wide.A.data_ptr() == dist.A.data_ptr() and not wide._validate_args
    v = uniform_sphere(8, 3, 33).reshape(4, 2, 3)
    torch.testing.assert_close(wide.log_prob(v), Bingham(A.repeat(4, 1, 1, 1)).log_prob(v))
    torch.testing.assert_close(wide.mode, dist.mode.expand(4, 2, 3))
    assert wide.sample((5,), torch.Generator().manual_seed(34)).shape == (5, 4, 2, 3)
    with pytest.raises(RuntimeError):
        dist.expand((3,))  # torch's own error: 2 does not expand to 3


def test_composes_with_independent_and_mixture():
    """torch's `Independent` sums the log densities; `MixtureSameFamily` of two Binghams is a
    density (its integral over the Fibonacci lattice is 1) whose samples split by the weights."""
    A = random_symmetric(5, 3, 4.0, 35)
    v = uniform_sphere(5, 3, 36)
    joint = Independent(Bingham(A), 1)
    assert joint.batch_shape == () and joint.event_shape == (5, 3)
    torch.testing.assert_close(joint.log_prob(v), Bingham(A).log_prob(v).sum())

    along_z = torch.diag(torch.tensor([-60.0, -60.0, 0.0], dtype=F64))
    along_x = torch.diag(torch.tensor([0.0, -60.0, -60.0], dtype=F64))
    weights = torch.tensor([0.3, 0.7], dtype=F64)
    mixture = MixtureSameFamily(Categorical(weights), Bingham(torch.stack([along_z, along_x])))
    lattice = fibonacci_sphere(200_000)
    integral = mixture.log_prob(lattice).exp().mean() * 4 * math.pi
    assert integral.item() == pytest.approx(1.0, abs=1e-4)
    expected = torch.logsumexp(
        torch.stack([Bingham(along_z).log_prob(v), Bingham(along_x).log_prob(v)]).T + weights.log(),
        dim=-1,
    )
    torch.testing.assert_close(mixture.log_prob(v), expected)
    n = 20_000
    with torch.random.fork_rng():
        torch.manual_seed(37)
        samples = mixture.sample((n,))
    near_z = (samples[:, 2].abs() > samples[:, 0].abs()).double().mean().item()
    assert near_z == pytest.approx(0.3, abs=5 * math.sqrt(0.3 * 0.7 / n))  # five binomial SE
    with pytest.raises(ValueError, match="support"):
        mixture.log_prob(2 * v)  # torch's check of the sample against `support`


@pytest.mark.parametrize("seed", [40, 41])
def test_entropy_against_lattice_quadrature_on_s2(seed):
    """−∫ p log p dS by the Fibonacci lattice, an oracle independent of the normaliser's
    gradient, for rotated, shifted batches of moderate concentration."""
    A = random_symmetric(4, 3, 6.0, seed) + 2.5 * torch.eye(3, dtype=F64)
    dist = Bingham(A)
    log_p = dist.log_prob(fibonacci_sphere(200_000)[:, None])  # [n, 4]
    quadrature = -(log_p.exp() * log_p).mean(0) * 4 * math.pi
    torch.testing.assert_close(dist.entropy(), quadrature, rtol=0, atol=1e-6)


def test_entropy_in_the_concentrated_limit_and_on_s3():
    """Concentrated on S²: two antipodal Gaussians of variances 1/(2κᵢ), entropy
    log 2 + log(πe/√(κ₁κ₂)) up to O(1/κ); on S³ the Monte-Carlo −E[log p] of exact samples."""
    kappa = torch.tensor([4e4, 1e4], dtype=F64)
    dist = Bingham(torch.diag(torch.cat([-kappa, torch.zeros(1, dtype=F64)])))
    limit = math.log(2) + math.log(math.pi * math.e / kappa.prod().sqrt().item())
    assert dist.entropy().item() == pytest.approx(limit, abs=1e-3)

    R = torch.linalg.qr(torch.randn(4, 4, dtype=F64, generator=torch.Generator().manual_seed(42)))[
        0
    ]
    dist = Bingham(R @ torch.diag(torch.tensor([-20.0, -6.0, -1.0, 0.0], dtype=F64)) @ R.T)
    log_p = dist.log_prob(dist.sample((100_000,), torch.Generator().manual_seed(43)))
    standard_error = log_p.std().item() / math.sqrt(len(log_p))
    assert dist.entropy().item() == pytest.approx(-log_p.mean().item(), abs=5 * standard_error)
