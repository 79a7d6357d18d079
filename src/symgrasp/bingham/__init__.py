"""Bingham distributions on S² and S³ (pure torch).

The density on the unit sphere S^{d−1} is exp(vᵀAv)/C(λ(A)) with respect to the surface
measure (C(0) = 4π on S², 2π² on S³); A is symmetric d×d, d = 3 or 4. Eigenvalues are reported
ascending; internally they are shifted so the largest is 0.
"""

from symgrasp.bingham.distribution import Bingham, eigh, fit, nll
from symgrasp.bingham.eigen import eigh3
from symgrasp.bingham.normalizer import METHODS, log_normalizer, second_moments
from symgrasp.bingham.sampling import optimal_b
from symgrasp.bingham.symmetric import sym_to_triu, triu_to_sym

__all__ = [
    "METHODS",
    "Bingham",
    "eigh",
    "eigh3",
    "fit",
    "log_normalizer",
    "nll",
    "optimal_b",
    "second_moments",
    "sym_to_triu",
    "triu_to_sym",
]
