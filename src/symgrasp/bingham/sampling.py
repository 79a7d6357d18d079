"""Exact Bingham sampling by rejection from an angular central Gaussian (ACG) envelope.

Kent, Ganeiber & Mardia (2013), "A new method to simulate the Bingham and related
distributions in directional data analysis with applications", Sec. 4. In the eigenbasis,
with concentrations κᵢ = λ_max − λᵢ ≥ 0, the Bingham density is ∝ exp(−Σ κᵢ xᵢ²). The ACG
density with Ω = I + 2 diag(κ)/b, ∝ (xᵀΩx)^{−q/2}, bounds it for every b > 0 as

    exp(−xᵀ diag(κ) x) ≤ M(b) (xᵀΩx)^{−q/2},   M(b) = e^{−(q−b)/2} (q/b)^{q/2},

and M is smallest at the root of Σᵢ 1/(b + 2κᵢ) = 1. An ACG draw is y/|y| with
y ~ N(0, Ω⁻¹). Each distribution of the batch is sampled independently, vectorised.
"""

from __future__ import annotations

import torch

Tensor = torch.Tensor

_NEWTON_MAX_STEPS = 60
_NEWTON_TOLERANCE = 1e-13
# Every candidate is accepted with probability above 0.4 (measured over concentrations in
# [0, 1e8]^q), so a round leaves at most ~1/5 of a distribution's need, and a need of one
# survives a round with probability below 0.6⁴ = 0.13: a million distributions finish in about
# 40 rounds with probability 1 − 1e-20. The bound guarantees that no input loops forever, also
# one that slipped past the check of the envelope.
_MAX_ROUNDS = 100


def _sum_last(t: Tensor) -> Tensor:
    """Sum over a last axis of size 3 or 4, unrolled: a reduction kernel over so few entries
    is several times slower than the elementwise adds."""
    return sum(t.unbind(-1))  # type: ignore[return-value]


def optimal_b(concentrations: Tensor) -> Tensor:
    """Root b ∈ [1, q] of Σᵢ 1/(b + 2κᵢ) = 1 for ``[..., q]`` concentrations κ ≥ 0 (one is 0)."""
    b = torch.ones_like(concentrations[..., 0])
    two_kappa = 2 * concentrations
    for _ in range(_NEWTON_MAX_STEPS):
        inv = (b.unsqueeze(-1) + two_kappa).reciprocal()
        excess = _sum_last(inv) - 1
        # f(b) = Σ 1/(b+2κ) − 1 is convex and decreasing, and f(1) ≥ 0, so Newton steps from
        # b = 1 increase monotonically towards the root and never overshoot.
        b = b + excess / _sum_last(inv.square())
        if excess.numel() == 0 or excess.abs().max() < _NEWTON_TOLERANCE:
            break
    q = concentrations.shape[-1]
    return b.clamp(1.0, float(q))


def sample_in_eigenbasis(
    concentrations: Tensor, n: int, generator: torch.Generator | None = None
) -> tuple[Tensor, Tensor]:
    """Draw ``n`` unit vectors per distribution, in the eigenbasis.

    Args:
        concentrations: ``[B, q]`` float64, κ = λ_max − λ ≥ 0.
        n: samples per distribution.
        generator: for reproducibility.

    Returns:
        ``[B, n, q]`` samples and the number of candidates drawn per distribution ``[B]``
        (acceptance rate = n / candidates).

    Raises:
        ValueError: if the envelope of a distribution is not finite (a concentration is NaN,
            inf, or so large that 2κ overflows), which no candidate could pass.
        RuntimeError: if some samples are still unaccepted after `_MAX_ROUNDS` rounds: the
            guarantee that no input loops forever.
    """
    rows, q = concentrations.shape
    device, dtype = concentrations.device, concentrations.dtype
    b = optimal_b(concentrations)
    omega = 1 + 2 * concentrations / b.unsqueeze(-1)
    overflow = ~torch.isfinite(omega).all(-1)
    if overflow.any():
        row = int(overflow.nonzero()[0])
        raise ValueError(
            f"Bingham sampling: `concentrations` λ_max − λ must be finite and below 8.9e307; "
            f"{int(overflow.sum())} of {rows} distributions are not, the first (row {row} of the "
            f"flattened batch) has {concentrations[row].tolist()}: scale A down"
        )
    inv_sqrt_omega = omega.rsqrt()
    log_m = -(q - b) / 2 + q / 2 * torch.log(q / b)
    out = torch.empty(rows, n, q, device=device, dtype=dtype)
    filled = torch.zeros(rows, dtype=torch.long, device=device)
    drawn = torch.zeros(rows, dtype=torch.long, device=device)
    active = torch.arange(rows, device=device)
    rounds = 0
    while active.numel() > 0 and n > 0:
        if rounds == _MAX_ROUNDS:
            raise RuntimeError(
                f"Bingham sampling: {int((n - filled[active]).sum())} of {rows * n} samples are "
                f"still unaccepted after {_MAX_ROUNDS} rounds of rejection, in {active.numel()} "
                f"of {rows} distributions. Finite concentrations accept each candidate with "
                "probability above 0.4 and finish in a few rounds, so non-finite numbers (from A "
                "with NaN, inf or entries near the float64 limit) escaped the checks."
            )
        rounds += 1
        need = n - filled[active]
        # The acceptance rate is above 0.4 on S² and S³: 2·need + 2 candidates finish most rows in
        # one round, and the few that fall short get another.
        m = 2 * int(need.max()) + 2
        z = torch.randn(active.numel(), m, q, generator=generator, device=device, dtype=dtype)
        y = z * inv_sqrt_omega[active].unsqueeze(1)  # y ~ N(0, Ω⁻¹); the candidate is x = y/|y|
        y2 = y.square()
        norm2 = _sum_last(y2)
        kappa_term = _sum_last(y2 * concentrations[active].unsqueeze(1)) / norm2
        omega_term = _sum_last(y2 * omega[active].unsqueeze(1)) / norm2
        # log of Bingham(x) / (M · ACG(x)), both unnormalised; ≤ 0 up to rounding.
        log_ratio = -kappa_term + q / 2 * torch.log(omega_term) - log_m[active].unsqueeze(1)
        exponential = torch.empty_like(log_ratio).exponential_(generator=generator)  # −log U
        accepted = -exponential < log_ratio
        rank = accepted.cumsum(-1)
        keep = accepted & (rank <= need.unsqueeze(-1))
        slot = filled[active].unsqueeze(-1) + rank - 1
        flat_index = (active.unsqueeze(-1) * n + slot)[keep]
        out.view(rows * n, q)[flat_index] = y[keep] / norm2[keep].sqrt().unsqueeze(-1)
        # Candidates up to the last one kept count as drawn; the rest were never needed.
        done = rank[:, -1] >= need
        drawn[active] += torch.where(done, (rank < need.unsqueeze(-1)).sum(-1) + 1, m)
        filled[active] += keep.sum(-1)
        active = active[filled[active] < n]
    return out, drawn
