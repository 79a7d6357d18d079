"""`symgrasp.rates.wilson` against its closed forms."""

import math

import pytest

from symgrasp.rates import Z95, wilson


@pytest.mark.parametrize("n", [1, 10, 200])
def test_all_or_none_succeeding_has_the_closed_form_bounds(n):
    # k = n: lower n / (n + z²), upper 1; k = 0 mirrors it
    assert wilson(n, n) == pytest.approx((n / (n + Z95**2), 1.0))
    assert wilson(0, n) == pytest.approx((0.0, Z95**2 / (n + Z95**2)))
    assert wilson(0, n)[0] >= 0.0 and wilson(n, n)[1] <= 1.0


def test_the_interval_holds_the_rate_mirrors_and_narrows():
    lo, hi = wilson(30, 100)
    assert lo < 0.3 < hi
    assert wilson(70, 100) == pytest.approx((1 - hi, 1 - lo))
    assert wilson(300, 1000)[1] - wilson(300, 1000)[0] < hi - lo
    assert all(math.isnan(x) for x in wilson(0, 0))
