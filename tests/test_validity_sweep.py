"""benchmarks/validity_sweep.py's choice of a model's own threshold on training rounds."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import validity_sweep as sweep


def _row(validity, success_ratio, clear_ratio):
    return {"validity": validity,
            "summary": {"success_ratio": success_ratio, "clear_ratio": clear_ratio}}  # fmt: skip


def test_own_threshold_maximises_sr_plus_cr_lower_on_a_tie_and_never_an_empty_cell():
    assert sweep.own_threshold([_row(0.04, 0.70, 0.58), _row(0.08, 0.79, 0.57)]) == 0.08
    assert sweep.own_threshold([_row(0.11, 0.80, 0.50), _row(0.06, 0.75, 0.55)]) == 0.06
    assert sweep.own_threshold([_row(0.02, float("nan"), 0.0), _row(0.15, 0.1, 0.0)]) == 0.15
