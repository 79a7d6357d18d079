"""Ratios over training seeds (`symgrasp.benchmark.seeds`): the mean over seeds, intervals
that include the seed's luck, one detector's lead over another in every pairing of seeds, and
the spread the rounds' noise alone would make."""

import numpy as np
import pytest

from symgrasp.benchmark.runner import summarise
from symgrasp.benchmark.seeds import (
    common_rounds,
    seed_contrast,
    seed_lead,
    seed_paired_change,
    seed_ratios,
    spread_null,
)


def _run(counts, first=0):
    """Round records: round ``first + i`` had ``counts[i]`` = (successes, executed, objects)."""
    return [{"seed": first + i, "successes": s, "executed": e, "objects": o, "attempts": [],
             "renderer": "test"}
            for i, (s, e, o) in enumerate(counts)]  # fmt: skip


def _random_run(rng, rounds=60, p=0.7):
    counts = []
    for _ in range(rounds):
        executed = int(rng.integers(2, 7))
        successes = int(rng.binomial(executed, p))
        counts.append((successes, executed, min(5, successes + int(rng.integers(0, 3)))))
    return _run(counts)


def test_the_point_is_the_mean_of_each_seeds_pooled_ratio():
    runs = [_run([(3, 4, 5), (1, 4, 5)]), _run([(2, 2, 5)]), _run([(0, 3, 5), (3, 3, 5)])]
    result = seed_ratios(runs)
    assert result["per_seed_success_ratio"] == pytest.approx([4 / 8, 1.0, 3 / 6])
    assert result["success_ratio"][0] == pytest.approx((0.5 + 1.0 + 0.5) / 3)
    assert result["clear_ratio"][0] == pytest.approx((4 / 10 + 2 / 5 + 3 / 10) / 3)
    for name in ("success_ratio", "clear_ratio"):
        point, low, high = result[name]
        assert low <= point <= high


def test_seeds_that_disagree_widen_the_interval_that_rounds_alone_would_not():
    # Within a run every round is alike, so a bootstrap over rounds has no width; the two
    # training seeds disagree completely, and the interval must span both.
    runs = [_run([(2, 2, 2)] * 30), _run([(0, 2, 2)] * 30)]
    for run in runs:
        low, high = summarise(run)["success_ratio_ci95"]
        assert low == high
    point, low, high = seed_ratios(runs)["success_ratio"]
    assert point == pytest.approx(0.5)
    assert low == pytest.approx(0.0) and high == pytest.approx(1.0)


def test_one_seed_gives_the_interval_of_a_bootstrap_over_rounds():
    run = _random_run(np.random.default_rng(3))
    ours = seed_ratios([run], seed=1)["success_ratio"]
    rounds = summarise(run, seed=2)
    assert ours[0] == pytest.approx(rounds["success_ratio"])
    assert ours[1:] == pytest.approx(rounds["success_ratio_ci95"], abs=0.02)


def test_crashed_rounds_are_left_out_of_a_run():
    run = [*_run([(1, 2, 5), (2, 2, 5)]), {"seed": 2, "error": "boom"}]
    assert seed_ratios([run])["success_ratio"][0] == pytest.approx(3 / 4)


def test_paired_change_of_a_detector_with_itself_is_exactly_zero():
    run = _random_run(np.random.default_rng(0))
    change = seed_paired_change([run], [run])
    assert change["success_ratio"] == [0.0, 0.0, 0.0]
    assert change["clear_ratio"] == [0.0, 0.0, 0.0]


def test_a_constant_lead_per_round_survives_shared_round_draws():
    # A clears one object more than B in every round, with the same grasps, in every seed.
    base = [(2, 4, 5)] * 40
    lead = [(3, 4, 5)] * 40
    change = seed_paired_change([_run(lead), _run(lead)], [_run(base), _run(base)])
    assert change["success_ratio"] == pytest.approx([0.25, 0.25, 0.25])
    assert change["clear_ratio"] == pytest.approx([0.2, 0.2, 0.2])
    assert change["sr_plus_cr"] == pytest.approx([0.45, 0.45, 0.45])


def test_the_sum_of_a_change_is_the_sum_of_its_sr_and_cr_and_leaves_them_as_they_were():
    rng = np.random.default_rng(11)
    a = [_random_run(rng, p=0.8), _random_run(rng, p=0.6)]
    b = [_random_run(rng, p=0.5), _random_run(rng, p=0.7)]
    change = seed_paired_change(a, b)
    assert change["sr_plus_cr"][0] == pytest.approx(
        change["success_ratio"][0] + change["clear_ratio"][0]
    )
    low, high = change["sr_plus_cr"][1:]
    assert low < change["sr_plus_cr"][0] < high
    # SR's and CR's draws come first, as before the sum existed
    first = seed_contrast([a, b], [1.0, -1.0])
    assert {k: first[k] for k in ("success_ratio", "clear_ratio")} == {
        k: change[k] for k in ("success_ratio", "clear_ratio")
    }


def test_paired_change_includes_the_seed_spread_of_each_detector():
    rng = np.random.default_rng(5)
    a = [_random_run(rng, p=0.9), _random_run(np.random.default_rng(6), p=0.5)]
    b = [_random_run(np.random.default_rng(7), p=0.6)] * 2
    point, low, high = seed_paired_change(a, b)["success_ratio"]
    means = [seed_ratios(r)["success_ratio"][0] for r in (a, b)]
    assert point == pytest.approx(means[0] - means[1])
    assert low < 0 < high  # one seed of A far ahead of B, one behind: no claim either way


def test_a_main_effect_averages_the_factors_changes_over_the_other_factors_levels():
    # a 2 × 2 whose cells grasp every object (1), 3 of 4 or half of their attempts, the same in
    # every round and seed: the first factor adds 0.5 at its first level of the second and 0.25
    # at its second, so its main effect is 0.375 in every draw; the second factor's is −0.125
    cells = {"a1b1": (2, 4, 4), "a2b1": (4, 4, 4), "a1b2": (2, 4, 4), "a2b2": (3, 4, 4)}
    runs = {name: [_run([c] * 30), _run([c] * 30)] for name, c in cells.items()}
    detectors = [runs[name] for name in ("a1b1", "a2b1", "a1b2", "a2b2")]
    first = seed_contrast(detectors, [-0.5, 0.5, -0.5, 0.5])
    assert first["success_ratio"] == pytest.approx([0.375] * 3)
    second = seed_contrast(detectors, [-0.5, -0.5, 0.5, 0.5])
    assert second["clear_ratio"] == pytest.approx([-0.125] * 3)
    # weights (1, −1) are the paired change, draw for draw
    assert seed_contrast(detectors[:2], [1.0, -1.0], seed=4) == seed_paired_change(
        *detectors[:2], seed=4
    )


def test_the_same_runs_under_two_conditions_share_their_seed_draws():
    # seed 0 grasps 2 of 2 and seed 1 0 of 2 in every round, clean or noisy, except that noise
    # costs seed 0 one grasp in every fourth round: drawn together, the seeds' gulf cancels and
    # the change is the rounds' alone; drawn apart, it spans the gulf
    good, bad = _run([(2, 2, 2)] * 40), _run([(0, 2, 2)] * 40)
    noisy_good = _run([(1, 2, 2) if i % 4 == 0 else (2, 2, 2) for i in range(40)])
    noisy, clean = [noisy_good, bad], [good, bad]
    together = seed_contrast([noisy, clean], [1.0, -1.0], trained=["runs", "runs"])
    point, low, high = together["success_ratio"]
    assert point == pytest.approx(-0.125 / 2)  # seed 0 loses 1 grasp in 8, seed 1 nothing
    # every draw loses between nothing (seed 1 drawn twice: a quarter of the draws) and the
    # grasps of the drawn noisy rounds of seed 0, at most one in two
    assert -0.5 < low < point < high == 0.0
    apart = seed_contrast([noisy, clean], [1.0, -1.0])["success_ratio"]
    assert apart[0] == point and apart[1] < -0.5 and apart[2] > 0.5


def test_a_contrast_refuses_what_does_not_fit():
    run = _run([(1, 2, 2)] * 3)
    with pytest.raises(ValueError, match="weights: expected 2"):
        seed_contrast([[run], [run]], [1.0])
    with pytest.raises(ValueError, match="trained: expected 2"):
        seed_contrast([[run], [run]], [1.0, -1.0], trained=[0])
    with pytest.raises(ValueError, match="same training runs, but hold 1 and 2"):
        seed_contrast([[run], [run, run]], [1.0, -1.0], trained=[0, 0])
    with pytest.raises(ValueError, match="same round seeds"):
        seed_contrast([[run], [_run([(1, 2, 2)] * 3, first=3)]], [1.0, -1.0])


def test_runs_of_other_rounds_are_refused():
    with pytest.raises(ValueError, match="round seeds"):
        seed_paired_change([_run([(1, 1, 1)])], [_run([(1, 1, 1)], first=5)])
    with pytest.raises(ValueError, match="crashed"):
        seed_paired_change([[{"seed": 0, "error": "x"}]], [[{"seed": 0, "error": "x"}]])
    with pytest.raises(ValueError, match="runs"):
        seed_ratios([])


def test_the_lead_counts_every_pairing_of_seeds_on_the_rounds_every_run_finished():
    """A grasps 2 of 2 in every round with seeds 0 and 1, 0 of 2 with seed 2; B 1 of 2 with
    every seed: A is ahead in the 6 pairings of its seeds 0 and 1, behind in the 3 of seed 2.
    A round that crashed in one run is left out of the change and of that run's pairings."""
    good, bad, half = _run([(2, 2, 5)] * 20), _run([(0, 2, 5)] * 20), _run([(1, 2, 5)] * 20)
    crashed = [*half[:5], {"seed": 5, "error": "RuntimeError: unstable"}, *half[6:]]
    lead = seed_lead([good, good, bad], [half, half, crashed])
    assert (lead["ahead"], len(lead["pairings"]), lead["rounds"]) == (6, 9, 19)
    assert [p["success_ratio"][0] > 0 for p in lead["pairings"]] == [True] * 6 + [False] * 3
    change, low, high = lead["change"]["success_ratio"]
    assert change == pytest.approx(2 / 3 - 1 / 2)
    assert low < 0 < high  # one seed of three is worse in every round: the seed decides
    shared = common_rounds(good, good, bad, half, half, crashed)
    assert lead["change"] == seed_paired_change(shared[:3], shared[3:])


def test_common_rounds_keeps_the_seeds_every_run_finished():
    a = _run([(1, 1, 1)] * 4)
    b = _run([(0, 1, 1)] * 3, first=1)
    b[1] = {"seed": 2, "error": "boom"}
    kept_a, kept_b = common_rounds(a, b)
    assert [r["seed"] for r in kept_a] == [1, 3] == [r["seed"] for r in kept_b]


def test_spread_null_matches_the_binomial_closed_form():
    # Seed A grasps every round's one object, seed B never does. Shuffling the two records of
    # each of the 10 rounds gives A K successes, K ~ Binomial(10, 1/2), and a SR spread of
    # |2K/10 - 1|: median 0.2 (P(K = 5) = 0.246 < 0.5 <= P(|K - 5| <= 1) = 0.656), 95th
    # percentile 0.6 (P(spread >= 0.6) = 0.109, P(spread >= 0.8) = 0.021), and the observed
    # spread 1 only when K is 0 or 10: p = 2 / 1024.
    a, b = _run([(1, 1, 1)] * 10), _run([(0, 1, 1)] * 10)
    result = spread_null([a, b])["success_ratio"]
    assert result["spread"] == 1.0
    assert result["null_median"] == pytest.approx(0.2)
    assert result["null_95"] == pytest.approx(0.6)
    assert result["p"] == pytest.approx(2 / 1024, abs=0.003)


def test_equal_runs_have_no_spread_and_no_evidence_against_equality():
    run = _random_run(np.random.default_rng(3))
    for name, row in spread_null([run, run, run]).items():
        assert row == {"spread": 0.0, "null_median": 0.0, "null_95": 0.0, "p": 1.0}, name


def test_a_spread_within_the_rounds_noise_is_not_significant():
    # Three seeds drawn from one success probability: their spread is the rounds' noise.
    rng = np.random.default_rng(5)
    runs = [_random_run(rng) for _ in range(3)]
    result = spread_null(runs)["success_ratio"]
    assert result["spread"] > 0 and result["null_95"] > result["spread"] and result["p"] > 0.05


def test_spread_null_refuses_one_run_and_other_rounds():
    run = _run([(1, 1, 1), (0, 1, 1)])
    with pytest.raises(ValueError, match="two or more runs"):
        spread_null([run])
    with pytest.raises(ValueError, match="same round seeds"):
        spread_null([run, _run([(1, 1, 1), (0, 1, 1)], first=5)])
