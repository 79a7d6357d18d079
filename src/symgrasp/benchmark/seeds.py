"""Declutter ratios over several training seeds of one detector, with intervals that include the
training seed's luck.

A detector trained with another seed clears piles differently (issue 17 measured 23 points of
SR between two seeds of one recipe), so an interval over rounds alone describes one training
run, not the recipe. Here each detector is a list of runs (one per training seed), each a list
of round records (`symgrasp.benchmark.runner`), and:

- the point estimate is the **mean over training seeds** of each run's pooled ratio
  (`symgrasp.benchmark.runner.pooled_ratio`: SR = successes / executed grasps, CR = successes
  / objects presented);
- the 95 % interval is a **hierarchical bootstrap** (Davison & Hinkley 1997, §3.8; Field &
  Welsh 2007): resample the training seeds with replacement, then the rounds within each drawn
  run, and take the mean of the drawn runs' ratios; the percentiles of 2 000 such means;
- two detectors that played the **same rounds** are compared by the difference of their means,
  resampling each detector's training seeds independently (they are independent training runs)
  and one draw of rounds shared by every run of both (the same seeds drop the same objects the
  same way, so the rounds' luck cancels, as in `symgrasp.benchmark.compare`); any weighted
  sum of detectors (`seed_contrast`: a 2 × 2 design's main effects) the same way, with one draw
  of training seeds shared by detectors that are the same training runs played under other
  conditions (a run's luck then cancels too).

- one detector's **lead** over another (`seed_lead`): that change, and the paired change of
  every pairing of their training seeds (`symgrasp.benchmark.compare.paired_change`), with the
  number of pairings in which the first is ahead;
- how much of a **spread** between the seeds (max − min of their ratios) the rounds' own noise
  makes when the seeds are equally good: under that hypothesis the runs' records of one round
  are exchangeable, so a permutation test (Good 2005, ch. 3) shuffles them among the runs
  round by round, keeping each round's difficulty, and compares the observed spread with the
  spreads of 2 000 shuffles.

With three seeds the seed level of the bootstrap is coarse (ten distinct resamples); the
intervals are then a floor on the uncertainty, and the per-seed values belong beside them.
"""

from __future__ import annotations

import itertools
from collections.abc import Hashable
from typing import Any

import numpy as np

from symgrasp.benchmark.compare import paired_change
from symgrasp.benchmark.runner import (
    BOOTSTRAP,
    COUNTS,
    RATIOS,
    SR_PLUS_CR,
    pooled_ratio,
    round_counts,
)

ROWS = {name: COUNTS.index(by) for name, by in RATIOS.items()}
"""Each pooled ratio and the row of `round_counts` it divides the successes (row 0) by."""


def _check(runs: list[list[dict[str, Any]]], name: str) -> None:
    if not runs or any(not run for run in runs):
        raise ValueError(f"{name}: expected one or more runs, each with one or more rounds")


def _check_aligned(runs: list[list[dict[str, Any]]], name: str) -> None:
    """ValueError unless every run holds the same round seeds in order and none crashed (what
    `common_rounds` leaves)."""
    seeds = [r["seed"] for r in runs[0]]
    if any([r["seed"] for r in run] != seeds for run in runs):
        raise ValueError(f"{name}: every run must hold the same round seeds in order")
    if any("error" in r for run in runs for r in run):
        raise ValueError(f"{name}: leave out crashed rounds from every run first")


def seed_ratios(runs: list[list[dict[str, Any]]], seed: int = 0) -> dict[str, list[float]]:
    """SR and CR of a detector trained with ``len(runs)`` seeds: ``{name: [mean over seeds, low,
    high]}``, the interval by the hierarchical bootstrap (module docstring), and
    ``per_seed_<name>``: each run's pooled ratio."""
    _check(runs, "runs")
    counts = [round_counts(run) for run in runs]
    rng = np.random.default_rng(seed)
    result: dict[str, list[float]] = {}
    for name, row in ROWS.items():
        per_seed = [float(pooled_ratio(c[0], c[row])) for c in counts]
        means = np.empty(BOOTSTRAP)
        for b in range(BOOTSTRAP):
            drawn = rng.integers(len(counts), size=len(counts))
            ratios = []
            for s in drawn:
                picks = rng.integers(counts[s].shape[1], size=counts[s].shape[1])
                ratios.append(pooled_ratio(counts[s][0, picks], counts[s][row, picks]))
            means[b] = np.nanmean(ratios) if np.isfinite(ratios).any() else np.nan
        means = means[np.isfinite(means)]
        interval = np.percentile(means, [2.5, 97.5]) if len(means) else [np.nan] * 2
        result[name] = [float(np.nanmean(per_seed)), *map(float, interval)]
        result[f"per_seed_{name}"] = per_seed
    return result


def common_rounds(*runs: list[dict[str, Any]]) -> list[list[dict[str, Any]]]:
    """Each run restricted to the round seeds that every run finished without an error, in seed
    order: what `seed_paired_change` compares."""
    finished = [{r["seed"]: r for r in run if "error" not in r} for run in runs]
    shared = sorted(set.intersection(*(set(f) for f in finished))) if finished else []
    return [[f[seed] for seed in shared] for f in finished]


def seed_paired_change(
    runs_a: list[list[dict[str, Any]]], runs_b: list[list[dict[str, Any]]], seed: int = 0
) -> dict[str, list[float]]:
    """SR and CR of detector A minus detector B, both given as runs (one per training seed) that
    played the same rounds (the same round seeds, in the same order; `common_rounds` leaves out
    those that crashed in any run): ``{name: [change of the means over seeds, low, high]}`` by the
    hierarchical bootstrap with shared round draws (module docstring). ValueError when the runs'
    round seeds differ. `seed_contrast` with weights (1, −1)."""
    _check(runs_a, "runs_a")
    _check(runs_b, "runs_b")
    _check_aligned([*runs_a, *runs_b], "runs_a, runs_b")
    return seed_contrast([runs_a, runs_b], [1.0, -1.0], seed=seed)


def seed_contrast(
    detectors: list[list[list[dict[str, Any]]]],
    weights: list[float],
    trained: list[Hashable] | None = None,
    seed: int = 0,
) -> dict[str, list[float]]:
    """The weighted sum of detectors' SR and CR, each the mean over its training seeds, for
    detectors (each given as runs, one per training seed) that played the same rounds (the same
    round seeds in the same order, none crashed: `common_rounds`), and of their SR + CR
    (`SR_PLUS_CR`): ``{name: [sum, low, high]}`` by the hierarchical bootstrap with one draw of rounds shared by every run (module
    docstring). Weights (1, −1) give a paired change (`seed_paired_change`); (−½, ½, −½, ½) of
    a 2 × 2 design's cells (a1b1, a2b1, a1b2, a2b2) the main effect of the first factor,
    averaged over the second's two levels.

    Each detector's training seeds are drawn on their own, as independent training runs, except
    for detectors given the same label in ``trained``: the same training runs played under other
    conditions (another sensing, say), which share one draw of seeds, so that a run's own luck
    cancels in their difference as the rounds' does. ValueError when ``weights`` or ``trained``
    do not give one entry per detector, detectors of one label hold different numbers of runs,
    or the runs' round seeds differ."""
    if len(weights) != len(detectors):
        raise ValueError(
            f"weights: expected {len(detectors)}, one per detector, got {len(weights)}"
        )
    trained = list(range(len(detectors))) if trained is None else list(trained)
    if len(trained) != len(detectors):
        raise ValueError(
            f"trained: expected {len(detectors)}, one per detector, got {len(trained)}"
        )
    for i, runs in enumerate(detectors):
        _check(runs, f"detectors[{i}]")
    _check_aligned([run for runs in detectors for run in runs], "detectors")
    sizes: dict[Hashable, int] = {}
    for label, runs in zip(trained, detectors, strict=True):
        if sizes.setdefault(label, len(runs)) != len(runs):
            raise ValueError(
                f"trained: detectors labelled {label!r} are the same training runs, but hold "
                f"{sizes[label]} and {len(runs)} runs"
            )
    # per detector: (seeds, 3, rounds)
    counts = [np.stack([round_counts(run) for run in runs]) for runs in detectors]
    n_rounds = counts[0].shape[2]
    rng = np.random.default_rng(seed)
    result = {}

    def contrast(drawn: list[np.ndarray], rows: tuple[int, ...]) -> float:
        """The weighted sum of the detectors' means over seeds of the ratios of ``rows``."""
        return sum(
            w * np.nanmean(pooled_ratio(c[:, 0], c[:, row]))
            for w, c in zip(weights, drawn, strict=True)
            for row in rows
        )

    # SR + CR draws its own resamples after SR's and CR's, which stay what they were without it
    for name, rows in [*((n, (r,)) for n, r in ROWS.items()), (SR_PLUS_CR, tuple(ROWS.values()))]:
        point = contrast(counts, rows)
        values = np.empty(BOOTSTRAP)
        for i in range(BOOTSTRAP):
            picks = rng.integers(n_rounds, size=n_rounds)  # the rounds, shared
            runs_drawn: dict[Hashable, np.ndarray] = {}
            for label, c in zip(trained, counts, strict=True):
                if label not in runs_drawn:
                    runs_drawn[label] = rng.integers(len(c), size=len(c))
            drawn = [
                c[runs_drawn[label]][:, :, picks] for label, c in zip(trained, counts, strict=True)
            ]
            values[i] = contrast(drawn, rows)
        values = values[np.isfinite(values)]
        interval = np.percentile(values, [2.5, 97.5]) if len(values) else [np.nan] * 2
        result[name] = [float(point), *map(float, interval)]
    return result


def seed_lead(
    runs_a: list[list[dict[str, Any]]], runs_b: list[list[dict[str, Any]]], seed: int = 0
) -> dict[str, Any]:
    """Detector A's lead over detector B, each given as runs (one per training seed) of the same
    round seeds:

    - ``change``: `seed_paired_change` on the ``rounds`` rounds every run of both finished
      (`common_rounds`);
    - ``pairings``: for every pairing of a run of A with a run of B (A's runs outer), the
      paired change of SR and CR on the rounds those two finished (`paired_change`);
    - ``ahead``: the number of pairings in which A's SR is higher.

    A lead that holds in every pairing holds whichever seeds one had trained with."""
    shared = common_rounds(*runs_a, *runs_b)
    pairings = [paired_change(*common_rounds(a, b)) for a, b in itertools.product(runs_a, runs_b)]
    return {
        "rounds": len(shared[0]),
        "change": seed_paired_change(shared[: len(runs_a)], shared[len(runs_a) :], seed),
        "pairings": pairings,
        "ahead": sum(p["success_ratio"][0] > 0 for p in pairings),
    }


def spread_null(runs: list[list[dict[str, Any]]], seed: int = 0) -> dict[str, dict[str, float]]:
    """The SR and CR spread (max − min over the runs of one detector, one per training seed,
    that played the same rounds in the same order; `common_rounds`) against the spreads of
    2 000 shuffles of the runs' records within each round (module docstring): ``{name:
    {"spread", "null_median", "null_95", "p"}}``, ``p`` the share of shuffles whose spread is at
    least the observed one. ValueError for fewer than two runs or differing round seeds."""
    _check(runs, "runs")
    if len(runs) < 2:
        raise ValueError(f"runs: a spread needs two or more runs, got {len(runs)}")
    _check_aligned(runs, "runs")
    counts = np.stack([round_counts(run) for run in runs])  # (runs, 3, rounds)
    n_runs, _, n_rounds = counts.shape
    rng = np.random.default_rng(seed)
    # one permutation of the runs per round and draw: which run's record each run gets
    order = rng.permuted(np.broadcast_to(np.arange(n_runs), (BOOTSTRAP, n_rounds, n_runs)), axis=2)
    shuffled = counts[order, :, np.arange(n_rounds)[None, :, None]]  # (draws, rounds, runs, 3)
    result = {}
    for name, row in ROWS.items():
        observed = pooled_ratio(counts[:, 0], counts[:, row])
        ratios = pooled_ratio(
            shuffled[..., 0].transpose(0, 2, 1), shuffled[..., row].transpose(0, 2, 1)
        )
        spreads = ratios.max(1) - ratios.min(1)
        spread = float(observed.max() - observed.min())
        result[name] = {
            "spread": spread,
            "null_median": float(np.median(spreads)),
            "null_95": float(np.percentile(spreads, 95)),
            "p": float(np.mean(spreads >= spread - 1e-12)),
        }
    return result
