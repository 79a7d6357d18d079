"""Declutter ratios over several training seeds of one detector, with intervals that include the
training seed's luck.

A detector trained with another seed clears piles differently (issue 17 measured 23 points of
SR between two seeds of one recipe), so an interval over rounds alone describes one training
run, not the recipe. Here each detector is a list of runs (one per training seed), each a list
of round records (`symgrasp.benchmark.runner`), and:

- the point estimate is the **mean over training seeds** of each run's pooled ratio
  (SR = successes / executed grasps, CR = successes / objects presented);
- the 95 % interval is a **hierarchical bootstrap** (Davison & Hinkley 1997, §3.8; Field &
  Welsh 2007): resample the training seeds with replacement, then the rounds within each drawn
  run, and take the mean of the drawn runs' ratios; the percentiles of 2 000 such means;
- two detectors that played the **same rounds** are compared by the difference of their means,
  resampling each detector's training seeds independently (they are independent training runs)
  and one draw of rounds shared by every run of both (the same seeds drop the same objects the
  same way, so the rounds' luck cancels, as in `symgrasp.benchmark.compare`).

- how much of a **spread** between the seeds (max − min of their ratios) the rounds' own noise
  makes when the seeds are equally good: under that hypothesis the runs' records of one round
  are exchangeable, so a permutation test (Good 2005, ch. 3) shuffles them among the runs
  round by round, keeping each round's difficulty, and compares the observed spread with the
  spreads of 2 000 shuffles.

With three seeds the seed level of the bootstrap is coarse (ten distinct resamples); the
intervals are then a floor on the uncertainty, and the per-seed values belong beside them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symgrasp.benchmark.runner import BOOTSTRAP

RATIOS = {"success_ratio": 1, "clear_ratio": 2}
"""Each pooled ratio and the row of `_counts` it divides the successes by (executed grasps,
objects presented)."""


def _counts(rounds: list[dict[str, Any]]) -> np.ndarray:
    """(3, rounds) successes, executed grasps, objects of the rounds that did not crash."""
    done = [r for r in rounds if "error" not in r]
    return np.array([[r[k] for r in done] for k in ("successes", "executed", "objects")], float)


def _ratio(successes: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """successes / denominator along the last axis; NaN where nothing was counted."""
    total = denominator.sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, successes.sum(-1) / total, np.nan)


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
    counts = [_counts(run) for run in runs]
    rng = np.random.default_rng(seed)
    result: dict[str, list[float]] = {}
    for name, row in RATIOS.items():
        per_seed = [float(_ratio(c[0], c[row])) for c in counts]
        means = np.empty(BOOTSTRAP)
        for b in range(BOOTSTRAP):
            drawn = rng.integers(len(counts), size=len(counts))
            ratios = []
            for s in drawn:
                picks = rng.integers(counts[s].shape[1], size=counts[s].shape[1])
                ratios.append(_ratio(counts[s][0, picks], counts[s][row, picks]))
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
    round seeds differ."""
    _check(runs_a, "runs_a")
    _check(runs_b, "runs_b")
    _check_aligned([*runs_a, *runs_b], "runs_a, runs_b")
    a = np.stack([_counts(run) for run in runs_a])  # (seeds, 3, rounds)
    b = np.stack([_counts(run) for run in runs_b])
    rng = np.random.default_rng(seed)
    result = {}
    for name, row in RATIOS.items():
        point = np.nanmean(_ratio(a[:, 0], a[:, row])) - np.nanmean(_ratio(b[:, 0], b[:, row]))
        changes = np.empty(BOOTSTRAP)
        for i in range(BOOTSTRAP):
            picks = rng.integers(a.shape[2], size=a.shape[2])  # the rounds, shared
            da = a[rng.integers(len(a), size=len(a))][:, :, picks]
            db = b[rng.integers(len(b), size=len(b))][:, :, picks]
            changes[i] = np.nanmean(_ratio(da[:, 0], da[:, row])) - np.nanmean(
                _ratio(db[:, 0], db[:, row])
            )
        changes = changes[np.isfinite(changes)]
        interval = np.percentile(changes, [2.5, 97.5]) if len(changes) else [np.nan] * 2
        result[name] = [float(point), *map(float, interval)]
    return result


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
    counts = np.stack([_counts(run) for run in runs])  # (runs, 3, rounds)
    n_runs, _, n_rounds = counts.shape
    rng = np.random.default_rng(seed)
    # one permutation of the runs per round and draw: which run's record each run gets
    order = rng.permuted(np.broadcast_to(np.arange(n_runs), (BOOTSTRAP, n_rounds, n_runs)), axis=2)
    shuffled = counts[order, :, np.arange(n_rounds)[None, :, None]]  # (draws, rounds, runs, 3)
    result = {}
    for name, row in RATIOS.items():
        observed = _ratio(counts[:, 0], counts[:, row])
        ratios = _ratio(shuffled[..., 0].transpose(0, 2, 1), shuffled[..., row].transpose(0, 2, 1))
        spreads = ratios.max(1) - ratios.min(1)
        spread = float(observed.max() - observed.min())
        result[name] = {
            "spread": spread,
            "null_median": float(np.median(spreads)),
            "null_95": float(np.percentile(spreads, 95)),
            "p": float(np.mean(spreads >= spread - 1e-12)),
        }
    return result
