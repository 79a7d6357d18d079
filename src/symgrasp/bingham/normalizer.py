"""The Bingham normalising constant C(λ) on S² and S³, with analytic gradients.

    C(λ) = ∫_{S^{d-1}} exp(vᵀ diag(λ) v) dS(v)          (Ko et al. 2024, Sec. 3.1)

with dS the **surface measure**, so C(0) = 4π on S² and 2π² on S³. C depends only on the
eigenvalues and C(λ + c) = e^c C(λ), so every method works on sorted eigenvalues shifted to
λ₁ ≤ … ≤ λ_d = 0 and adds the shift back in log space.

The gradient is a moment of the distribution, ∂ log C / ∂λᵢ = E[vᵢ²] (in the eigenbasis),
so every method returns log C together with these second moments; `log_normalizer` wraps
them in one `torch.autograd.Function`. The moments sum to one (Σᵢ ∂C/∂λᵢ = C).

Methods:

``"quadrature"`` (S², the default there)
    Integrating over the axis of λ₁ in closed form (∫₋₁¹ e^{-αu²} du = √(π/α) erf √α) leaves
    one smooth integral over the angle φ about that axis. With a = −λ₁ ≥ b = −λ₂ ≥ 0 and
    ψ = π/2 − φ,

        C = 4 ∫₀^{π/2} e^{-b sin²ψ} M₀(a − b sin²ψ) dψ,   M₀(α) = ∫₋₁¹ e^{-αu²} du,

    and e^{-b sin²ψ} < e^{-L²} beyond sin ψ = L/√b, so Gauss–Legendre on [0, arcsin(min(1, L/√b))]
    adapts to the concentration continuously (no regime switch). With 32 nodes and L = 6.5 the
    relative error is below 1e-14 on a log grid over [−1e6, 0]² (see ``docs/bingham.md``). Only
    exp, erf and sqrt are evaluated per node, which is what makes it fast.

``"paper"`` (S² and S³)
    The contour sum of Sato, Ikeda & Nishiwaki (2023) used by the paper (Appx. B, Eq. 14):

        C = π^{d/2−1} e^c h Σ_{n=−N−1}^{N} w(|nh|) F(nh) e^{inh},  F(t) = Π_k (−λ_k + it + c)^{−1/2},

    with w(x) = ½ erfc(x/p₁ − p₂) and c, h, p₁, p₂ from N = 200, N_min = 15, r = 2.5, ω_d = 0.5,
    d = c/2 (Eqs. 16 and 17). The gradient is the same sum with F replaced by
    ∂F/∂λ_k = F / (2(−λ_k + it + c)). Accurate to about 1e-7 relative: the faithful reference.

``"bessel"`` (S³, the default there)
    Wood's one-dimensional Bessel integral. In Hopf coordinates
    v = (√t cos α, √t sin α, √(1−t) cos β, √(1−t) sin β), dS = ½ dt dα dβ,

        C = 2π² ∫₀¹ e^{tλ₂} I₀ᵉ(t(λ₂−λ₁)/2) I₀ᵉ(−(1−t)λ₃/2) dt,

    with I₀ᵉ the exponentially scaled Bessel function. The substitution t = T τ² (T the decay
    length of e^{tλ₂}) and geometrically graded Gauss–Legendre panels in τ resolve the
    t^{−1/2} knee of I₀ᵉ at every concentration.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from functools import cache

import numpy as np
import torch
from torch.autograd.function import once_differentiable

from symgrasp.bingham.validation import as_floating, check_finite

Tensor = torch.Tensor

METHODS = ("auto", "quadrature", "paper", "bessel")

# ---------------------------------------------------------------------------------------------
# "quadrature": exact S² method
# ---------------------------------------------------------------------------------------------
_S2_NODES = 32
_S2_WINDOW = 6.5  # e^{-6.5²} = 4.5e-19: the neglected tail of the Gaussian factor
_SERIES_BELOW = 0.1  # M₂(α) by its Taylor series below this α, where the closed form cancels
_SERIES_TERMS = 14  # 0.1^14 / 14! ≈ 1e-25


@cache
def _gauss_legendre(n: int, device: torch.device) -> tuple[Tensor, Tensor]:
    """Nodes and weights on [0, 1] in float64."""
    x, w = np.polynomial.legendre.leggauss(n)
    nodes = torch.as_tensor((x + 1) / 2, dtype=torch.float64, device=device)
    weights = torch.as_tensor(w / 2, dtype=torch.float64, device=device)
    return nodes, weights


def _m0(alpha: Tensor) -> Tensor:
    """M₀(α) = ∫₋₁¹ e^{-αu²} du = √(π/α) erf(√α), α ≥ 0 (M₀(0) = 2)."""
    root = alpha.sqrt()
    value = math.sqrt(math.pi) * torch.special.erf(root) / root
    return torch.where(alpha > 0, value, torch.full_like(alpha, 2.0))


def _m2(alpha: Tensor, m0: Tensor) -> Tensor:
    """M₂(α) = ∫₋₁¹ u² e^{-αu²} du = (M₀ − 2e^{-α}) / (2α), by its Taylor series for small α."""
    value = (m0 - 2 * torch.exp(-alpha)) / (2 * alpha)
    small = alpha < _SERIES_BELOW
    if small.any():
        x = -alpha[small]
        series = torch.zeros_like(x)
        for k in reversed(range(_SERIES_TERMS)):  # Σ_k x^k / k! · 2/(2k+3), Horner form
            series = series * x / (k + 1) + 2.0 / (2 * k + 3)
        value = value.masked_scatter(small, series)
    return value


def _s2_quadrature(lam: Tensor) -> tuple[Tensor, Tensor]:
    """log C and E[vᵢ²] for sorted, shifted float64 eigenvalues ``[..., 3]``."""
    a = lam[..., 0].abs().unsqueeze(-1)  # abs, not negation: −(+0.0) = −0.0 would give 1/b = −∞
    b = lam[..., 1].abs().unsqueeze(-1)
    nodes, weights = _gauss_legendre(_S2_NODES, lam.device)
    window = torch.asin(torch.clamp(_S2_WINDOW / b.sqrt(), max=1.0))
    sin2 = torch.sin(window * nodes).square()
    weight = window * weights * torch.exp(-b * sin2)
    alpha = torch.clamp(a - b * sin2, min=0.0)
    m0 = _m0(alpha)
    m2 = _m2(alpha, m0)
    c = (weight * m0).sum(-1)
    moment1 = (weight * m2).sum(-1) / c
    moment2 = (weight * sin2 * (m0 - m2)).sum(-1) / c
    moments = torch.stack([moment1, moment2, 1 - moment1 - moment2], dim=-1)
    return torch.log(4 * c), moments


# ---------------------------------------------------------------------------------------------
# "paper": the contour sum of Sato, Ikeda & Nishiwaki (2023)
# ---------------------------------------------------------------------------------------------
_PAPER_N = 200
_PAPER_N_MIN = 15
_PAPER_R = 2.5
_PAPER_OMEGA = 0.5


@cache
def _paper_constants(device: torch.device) -> tuple[float, float, Tensor, Tensor]:
    """c, h, the abscissae t_n = nh and the complex coefficients w(|t_n|) e^{i t_n}."""
    n_, r, omega = _PAPER_N, _PAPER_R, _PAPER_OMEGA
    c = _PAPER_N_MIN * math.pi / (r**2 * (1 + r) * omega)
    strip = c / 2  # the paper's "d", the half-width of the strip of analyticity
    h = math.sqrt(2 * math.pi * strip * (1 + r) / (omega * n_))
    p1 = math.sqrt(n_ * h / omega)
    p2 = math.sqrt(omega * n_ * h / 4)
    t = torch.arange(-n_ - 1, n_ + 1, dtype=torch.float64, device=device) * h
    w = 0.5 * torch.special.erfc(t.abs() / p1 - p2)
    coefficients = torch.polar(w, t)
    return c, h, t, coefficients


def _paper(lam: Tensor) -> tuple[Tensor, Tensor]:
    """log C and E[vᵢ²] by the paper's contour sum for sorted, shifted eigenvalues ``[..., d]``."""
    d = lam.shape[-1]
    c, h, t, coefficients = _paper_constants(lam.device)
    z = torch.complex(c - lam.unsqueeze(-1), t.expand(*lam.shape, -1))  # [..., d, M]
    f = torch.exp(-0.5 * torch.log(z).sum(-2))  # Π_k z_k^{-1/2}, principal branch (Re z > 0)
    weighted = coefficients * f  # [..., M]
    prefactor = math.pi ** (d / 2 - 1) * math.exp(c) * h
    value = prefactor * weighted.sum(-1).real
    gradient = prefactor * (weighted.unsqueeze(-2) / (2 * z)).sum(-1).real
    return torch.log(value), gradient / value.unsqueeze(-1)


# ---------------------------------------------------------------------------------------------
# "bessel": Wood's integral on S³
# ---------------------------------------------------------------------------------------------
_S3_NODES = 16  # Gauss–Legendre nodes per panel
_S3_PANEL_RATIO = 0.25  # panel ends at {1, 0.25, 0.0625, …} in τ
_S3_PANELS = 10
_S3_DECAY = 40.0  # e^{-40} = 4e-18: where e^{tλ₂} is cut


@cache
def _s3_rule(device: torch.device) -> tuple[Tensor, Tensor]:
    """Composite Gauss–Legendre nodes and weights for ∫₀¹ dτ, graded towards τ = 0."""
    nodes, weights = _gauss_legendre(_S3_NODES, device)
    ends = [_S3_PANEL_RATIO**k for k in range(_S3_PANELS)] + [0.0]
    all_nodes, all_weights = [], []
    for hi, lo in itertools.pairwise(ends):
        all_nodes.append(lo + (hi - lo) * nodes)
        all_weights.append((hi - lo) * weights)
    return torch.cat(all_nodes), torch.cat(all_weights)


def _s3_bessel(lam: Tensor) -> tuple[Tensor, Tensor]:
    """log C and E[vᵢ²] for sorted, shifted float64 eigenvalues ``[..., 4]``."""
    l1, l2, l3 = (lam[..., i].unsqueeze(-1) for i in range(3))
    length = torch.clamp(_S3_DECAY / l2.abs(), max=1.0)  # T: e^{tλ₂} is negligible beyond
    tau, tau_weights = _s3_rule(lam.device)
    t = length * tau.square()
    dt = length * 2 * tau * tau_weights  # dt = 2Tτ dτ
    x = t * (l2 - l1) / 2
    y = -(1 - t) * l3 / 2
    i0x, i1x = torch.special.i0e(x), torch.special.i1e(x)
    i0y, i1y = torch.special.i0e(y), torch.special.i1e(y)
    base = dt * torch.exp(t * l2)
    integrand = base * i0x * i0y
    c = integrand.sum(-1)
    # ∂/∂λ of e^{tλ₂} I₀ᵉ(x) I₀ᵉ(y), with (I₀ᵉ)' = I₁ᵉ − I₀ᵉ for a positive argument:
    d_x = base * (i1x - i0x) * i0y
    d_y = base * i0x * (i1y - i0y)
    moment1 = (-t / 2 * d_x).sum(-1) / c
    moment2 = (t * integrand + t / 2 * d_x).sum(-1) / c
    moment3 = (-(1 - t) / 2 * d_y).sum(-1) / c
    moments = torch.stack([moment1, moment2, moment3, 1 - moment1 - moment2 - moment3], dim=-1)
    return torch.log(2 * math.pi**2 * c), moments


# ---------------------------------------------------------------------------------------------
# Public entry point
# ---------------------------------------------------------------------------------------------
_Kernel = Callable[[Tensor], tuple[Tensor, Tensor]]
_KERNELS: dict[tuple[str, int], _Kernel] = {
    ("quadrature", 3): _s2_quadrature,
    ("paper", 3): _paper,
    ("paper", 4): _paper,
    ("bessel", 4): _s3_bessel,
}
_AUTO = {3: "quadrature", 4: "bessel"}


def _chunk_rows(device: torch.device) -> int:
    # On the CPU, chunks of 4096 rows keep the [rows, nodes] temporaries in cache: twice as fast
    # as one pass over 10⁵ rows (measured). On a GPU, large chunks keep it busy.
    return 4096 if device.type == "cpu" else 1 << 18


def _log_c_and_moments(eigenvalues: Tensor, method: str) -> tuple[Tensor, Tensor]:
    """log C and ∂ log C/∂λ (in the input's order) in float64, for any order and shift."""
    lam = eigenvalues.to(torch.float64)
    sorted_lam, order = lam.sort(dim=-1)
    top = sorted_lam[..., -1:]
    kernel = _KERNELS[(method, lam.shape[-1])]
    flat = (sorted_lam - top).reshape(-1, lam.shape[-1])
    parts = [kernel(chunk) for chunk in flat.split(_chunk_rows(lam.device))]
    log_c = torch.cat([p[0] for p in parts]) if parts else flat.new_empty(0)
    moments = torch.cat([p[1] for p in parts]) if parts else flat.new_empty(0, lam.shape[-1])
    log_c = log_c.reshape(lam.shape[:-1]) + top.squeeze(-1)
    return log_c, torch.empty_like(lam).scatter_(-1, order, moments.reshape(lam.shape))


class _LogNormalizer(torch.autograd.Function):
    @staticmethod
    def forward(ctx, eigenvalues: Tensor, method: str) -> Tensor:  # type: ignore[override]
        log_c, moments = _log_c_and_moments(eigenvalues, method)
        ctx.save_for_backward(moments)
        return log_c.to(eigenvalues.dtype)

    @staticmethod
    @once_differentiable
    def backward(ctx, grad_output: Tensor) -> tuple[Tensor, None]:  # type: ignore[override]
        (moments,) = ctx.saved_tensors
        return (grad_output.unsqueeze(-1) * moments).to(grad_output.dtype), None


def resolve_method(method: str, d: int) -> str:
    """The concrete method that ``method`` means for dimension ``d``; raises for bad pairs."""
    if method not in METHODS:
        raise ValueError(f"log_normalizer: unknown `method` {method!r}; expected one of {METHODS}")
    concrete = _AUTO[d] if method == "auto" else method
    if (concrete, d) not in _KERNELS:
        raise ValueError(f"log_normalizer: `method` {method!r} is not available on S^{d - 1}")
    return concrete


def _checked(eigenvalues: Tensor, method: str, caller: str) -> tuple[Tensor, str]:
    """``eigenvalues [..., 3 | 4]`` as floating point and the concrete method, or an error
    naming ``caller`` and the argument."""
    eigenvalues = as_floating(eigenvalues, "eigenvalues")
    if eigenvalues.ndim == 0 or eigenvalues.shape[-1] not in (3, 4):
        raise ValueError(
            f"{caller}: `eigenvalues` must have trailing size 3 (S²) or 4 (S³), "
            f"got shape {tuple(eigenvalues.shape)}"
        )
    concrete = resolve_method(method, eigenvalues.shape[-1])
    check_finite(eigenvalues, "eigenvalues", event_dim=1)
    return eigenvalues, concrete


def log_normalizer(eigenvalues: Tensor, method: str = "auto") -> Tensor:
    """log C(λ) of the Bingham distribution on S² (``[..., 3]``) or S³ (``[..., 4]``).

    C uses the surface measure (C(0) = 4π on S², 2π² on S³). Eigenvalues may come in any order
    and with any shift. Computed in float64 and returned in the input's dtype (integer and bool
    input in the default float dtype, as torch functions promote it); differentiable in the
    eigenvalues with the analytic gradient ∂ log C/∂λᵢ = E[vᵢ²].

    Args:
        eigenvalues: ``[..., 3]`` or ``[..., 4]``, real; refused unless finite (every method
            would return NaN for a NaN, and a NaN gradient for an inf).
        method: ``"auto"`` (``"quadrature"`` on S², ``"bessel"`` on S³), ``"quadrature"``,
            ``"paper"`` or ``"bessel"``; see the module docstring.

    Returns:
        ``[...]`` log C.
    """
    eigenvalues, concrete = _checked(eigenvalues, method, "log_normalizer")
    return _LogNormalizer.apply(eigenvalues, concrete)


def second_moments(eigenvalues: Tensor, method: str = "auto") -> Tensor:
    """E[vᵢ²] along each eigenvector, ``[..., d]``: the gradient of log C, in float64; the
    arguments as in `log_normalizer`."""
    eigenvalues, concrete = _checked(eigenvalues, method, "second_moments")
    return _log_c_and_moments(eigenvalues.detach(), concrete)[1]
