"""The Wilson score interval of a success rate, for every rate the package and its studies
report with an interval (E. B. Wilson, "Probable inference, the law of succession, and
statistical inference", JASA 22, 1927). Imports nothing."""

from __future__ import annotations

import math

Z95 = 1.96
"""The standard normal quantile of a two-sided 95 % interval."""


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval (lower, upper) of the rate ``k / n`` as fractions in [0, 1]
    (NaN for ``n = 0``); 95 % by default."""
    if n == 0:
        return float("nan"), float("nan")
    p, d = k / n, 1 + z * z / n
    centre = (p + z * z / (2 * n)) / d
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(0.0, centre - half), min(1.0, centre + half)  # clear of rounding's ±1e-17
