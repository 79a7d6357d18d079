"""High-precision mpmath values of log C, the oracle for tests and benchmarks (slow, scalar).

Derived independently of the fast methods: on S² the integral runs about the axis of the
*largest* eigenvalue with an unscaled I₀ (the ``"quadrature"`` method integrates about the
smallest with erf); on S³ it is Wood's Bessel integral at 30 significant digits with breakpoints
at every concentration's length scale.
"""

from __future__ import annotations

from collections.abc import Sequence

import mpmath as mp

_DIGITS = 30
_KNOT_SCALES = (0.1, 1, 10, 100)


def _knots(concentrations: Sequence[mp.mpf]) -> list[mp.mpf]:
    """0, 1 and points k/κ, 1 − k/κ where the integrands change."""
    knots = {mp.mpf(0), mp.mpf(1)}
    for kappa in concentrations:
        for k in _KNOT_SCALES:
            if k < kappa:
                knots |= {mp.mpf(k) / kappa, 1 - mp.mpf(k) / kappa}
    return sorted(knots)


def log_normalizer_mpmath(eigenvalues: Sequence[float]) -> float:
    """log C for 3 (S²) or 4 (S³) eigenvalues, any order and shift, surface measure."""
    if len(eigenvalues) not in (3, 4):
        raise ValueError(
            f"log_normalizer_mpmath: expected 3 or 4 eigenvalues, got {len(eigenvalues)}"
        )
    with mp.workdps(_DIGITS):
        lam = sorted(mp.mpf(x) for x in eigenvalues)
        top = lam[-1]
        lam = [x - top for x in lam]
        if len(lam) == 3:
            l1, l2, _ = lam

            def integrand(u):  # u = v₃ (axis of λ₃ = 0); in w = 1 − u the mass sits near w = 0
                s = 1 - u * u
                return mp.exp(s * (l1 + l2) / 2) * mp.besseli(0, s * (l1 - l2) / 2)

            knots = [1 - w for w in reversed(_knots([-l1, -l2]))]
            value = 4 * mp.pi * mp.quad(integrand, knots)
        else:
            l1, l2, l3, _ = lam

            def integrand(t):
                return (
                    mp.exp(t * (l1 + l2) / 2)
                    * mp.besseli(0, t * (l1 - l2) / 2)
                    * mp.exp((1 - t) * l3 / 2)
                    * mp.besseli(0, (1 - t) * l3 / 2)
                )

            value = 2 * mp.pi**2 * mp.quad(integrand, _knots([-l1, -l2, -l3]))
        return float(mp.log(value) + top)
