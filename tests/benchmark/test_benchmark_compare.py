"""`symgrasp bench compare`: the paired change of two benchmarks on their shared rounds."""

import dataclasses
import json
import math

import numpy as np
import pytest

from symgrasp.benchmark.compare import compare_table, paired_change, paired_rounds, percent_change
from symgrasp.cli import main
from symgrasp.config import BenchmarkConfig


def _bench(folder, counts, **config):
    """A benchmark folder whose round ``seed`` had ``counts[seed]`` = (successes, executed,
    objects)."""
    folder.mkdir()
    cfg = dataclasses.replace(BenchmarkConfig(), **config).record()
    (folder / "config.json").write_text(json.dumps(cfg))
    lines = [
        json.dumps({"seed": seed, "successes": s, "executed": e, "objects": o})
        for seed, (s, e, o) in counts.items()
    ]
    (folder / "rounds.jsonl").write_text("\n".join(lines) + "\n")
    return folder


def test_a_constant_lead_in_every_round_has_no_spread(tmp_path):
    """Each round of A clears one object more with the same grasps: CR + 1/5 and SR + 1/4 in
    every resample, so the interval collapses on the change."""
    a = _bench(tmp_path / "a", {s: (3, 4, 5) for s in range(20)})
    b = _bench(tmp_path / "b", {s: (2, 4, 5) for s in range(20)})
    change = paired_change(*paired_rounds(a, b))
    assert change["clear_ratio"] == pytest.approx([0.2, 0.2, 0.2])
    assert change["success_ratio"] == pytest.approx([0.25, 0.25, 0.25])
    assert change["sr_plus_cr"] == pytest.approx([0.45, 0.45, 0.45])
    assert "| SR + CR | 135.0 | 90.0 | +45.0 [+45.0, +45.0] |" in compare_table(a, b)


def test_the_sum_resamples_sr_and_cr_together(tmp_path):
    """SR and CR of a round move together (a round that clears more has more successes):
    drawn apart, their sum's interval would be wider than drawn together, and an interval of
    the sum equal to the sum of intervals would say it was."""
    rng = np.random.default_rng(3)
    counts = {s: (int(k), 4, 5) for s, k in enumerate(rng.integers(0, 5, size=60))}
    a = _bench(tmp_path / "a", counts)
    b = _bench(tmp_path / "b", {s: (2, 4, 5) for s in range(60)})
    change = paired_change(*paired_rounds(a, b))
    point, low, high = change["sr_plus_cr"]
    assert point == pytest.approx(change["success_ratio"][0] + change["clear_ratio"][0])
    # every round executes 4 of 5: SR + CR = successes (1/4 + 1/5), exactly 1.8 × CR's change
    assert [low, high] == pytest.approx([1.8 * v / 0.8 for v in change["clear_ratio"][1:]])


def test_only_the_shared_rounds_are_paired(tmp_path):
    a = _bench(tmp_path / "a", {s: (1, 2, 5) for s in range(10)})
    b = _bench(tmp_path / "b", {s: (1, 2, 5) for s in range(5, 15)})
    rounds_a, rounds_b = paired_rounds(a, b)
    assert [r["seed"] for r in rounds_a] == [r["seed"] for r in rounds_b] == list(range(5, 10))
    assert "5 rounds played by both (seeds 5–9)" in compare_table(a, b)
    assert "+0.0 [+0.0, +0.0]" in compare_table(a, a)


def test_a_round_that_crashed_in_either_is_left_out(tmp_path):
    a = _bench(tmp_path / "a", {s: (1, 2, 5) for s in range(4)})
    (tmp_path / "a" / "rounds.jsonl").open("a").write(
        json.dumps({"seed": 4, "error": "boom"}) + "\n"
    )
    b = _bench(tmp_path / "b", {s: (2, 2, 5) for s in range(5)})
    rounds_a, _ = paired_rounds(a, b)
    assert [r["seed"] for r in rounds_a] == [0, 1, 2, 3]


def test_an_undefined_ratio_is_nan_not_zero(tmp_path):
    """No rounds, or no grasp executed: SR is undefined, in the change and in the table."""
    assert all(math.isnan(v) for r in paired_change([], []).values() for v in r)
    a = _bench(tmp_path / "a", {s: (0, 0, 5) for s in range(3)})  # nothing found, ever
    b = _bench(tmp_path / "b", {s: (1, 2, 5) for s in range(3)})
    change = paired_change(*paired_rounds(a, b))
    assert all(math.isnan(v) for v in change["success_ratio"])
    assert change["clear_ratio"] == pytest.approx([-0.2, -0.2, -0.2])
    assert "| SR % | nan | 50.0 | +nan [+nan, +nan] |" in compare_table(a, b)


def test_rounds_that_crashed_are_refused_not_read():
    crashed = [{"seed": 0, "error": "RuntimeError: unstable"}]
    with pytest.raises(ValueError, match="crashed"):
        paired_change(crashed, [{"seed": 0, "successes": 1, "executed": 1, "objects": 5}])


def test_a_change_prints_as_signed_points():
    assert percent_change([0.061, -0.036, 0.155]) == "+6.1 [-3.6, +15.5]"


def test_different_worlds_are_refused(tmp_path, capsys):
    a = _bench(tmp_path / "a", {0: (1, 1, 5)})
    b = _bench(tmp_path / "b", {0: (1, 1, 5)}, objects="large-box")
    with pytest.raises(
        SystemExit, match=r"different rounds \(objects: 'household-test' vs 'large-box'"
    ):
        main(["bench", "compare", str(a), str(b)])
    (tmp_path / "empty").mkdir()
    with pytest.raises(SystemExit, match="holds no benchmark"):
        main(["bench", "compare", str(a), str(tmp_path / "empty")])
    with pytest.raises(SystemExit):
        main(["bench", "compare", str(a), str(tmp_path / "none")])
    assert "argument b: expected an existing folder" in capsys.readouterr().err
    c = _bench(tmp_path / "c", {7: (1, 1, 5)})
    with pytest.raises(SystemExit, match="share no finished round"):
        main(["bench", "compare", str(a), str(c)])
