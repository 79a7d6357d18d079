"""Two detectors (or two hands, two thresholds) on the same rounds: the paired change of SR and
CR with a bootstrap interval, what ``symgrasp bench compare A B`` prints.

Rounds with the same seed drop the same objects the same way, so the difference of two runs
is measured round by round: one bootstrap resamples the rounds in pairs, which keeps the
rounds' shared luck out of the interval (an unpaired comparison of two intervals is far
wider).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from symgrasp.benchmark.runner import (
    BOOTSTRAP,
    COUNTS,
    RATIOS,
    SR_PLUS_CR,
    pooled_ratio,
    read_rounds,
    recorded_config,
    round_counts,
)

SAME_WORLD = ("objects", "mesh_unit", "scene", "num_objects")
"""Configuration fields that decide what the rounds play: two benchmarks compare only when
these agree (the model, thresholds and diagnosis may differ)."""


def paired_change(
    rounds: list[dict[str, Any]], baseline: list[dict[str, Any]], seed: int = 0
) -> dict[str, list[float]]:
    """CR and SR (`symgrasp.benchmark.runner.pooled_ratio`) of ``rounds`` minus those of
    ``baseline`` (the same seeds, in order, none crashed: `paired_rounds`,
    `symgrasp.benchmark.seeds.common_rounds`), and their sum (`SR_PLUS_CR`): the change and its
    95 % interval, ``[change, low, high]``, from one bootstrap over rounds resampled in pairs,
    the same draws for all three; NaN where a ratio is undefined (no rounds, no grasp
    executed)."""
    if [r["seed"] for r in rounds] != [r["seed"] for r in baseline]:
        raise ValueError("rounds and baseline must be the same seeds in the same order")
    if any("error" in r for r in (*rounds, *baseline)):
        raise ValueError("rounds and baseline: leave out the rounds that crashed in either first")
    a, b = round_counts(rounds), round_counts(baseline)
    picks = np.random.default_rng(seed).integers(len(rounds), size=(BOOTSTRAP, len(rounds)))
    points, draws = {}, {}
    for name in ("clear_ratio", "success_ratio"):
        row = COUNTS.index(RATIOS[name])
        points[name] = pooled_ratio(a[0], a[row]) - pooled_ratio(b[0], b[row])
        draws[name] = pooled_ratio(a[0][picks], a[row][picks]) - pooled_ratio(
            b[0][picks], b[row][picks]
        )
    points[SR_PLUS_CR] = points["success_ratio"] + points["clear_ratio"]
    draws[SR_PLUS_CR] = draws["success_ratio"] + draws["clear_ratio"]
    change = {}
    for name, resampled in draws.items():
        resampled = resampled[np.isfinite(resampled)]
        interval = np.percentile(resampled, [2.5, 97.5]) if len(resampled) else [np.nan] * 2
        change[name] = [float(points[name]), *map(float, interval)]
    return change


def percent_change(change: list[float]) -> str:
    """A change of ratios and its interval, ``[change, low, high]`` (`paired_change`), as signed
    percent points: ``+6.1 [-3.6, +15.5]``."""
    point, low, high = (100 * v for v in change)
    return f"{point:+.1f} [{low:+.1f}, {high:+.1f}]"


def paired_rounds(a: str | Path, b: str | Path) -> tuple[list[dict], list[dict]]:
    """The rounds that benchmark folders ``a`` and ``b`` both finished without an error, in
    seed order; refused (ValueError naming the folder or field) when a folder holds no
    benchmark, their rounds play different worlds, or they share no seed."""
    configs = {}
    for folder in (a, b):
        configs[folder] = recorded_config(folder)
        if configs[folder] is None:
            raise ValueError(f"{folder} holds no benchmark (no config.json of bench declutter)")
    differ = [k for k in SAME_WORLD if configs[a].get(k) != configs[b].get(k)]
    if differ:
        fields = ", ".join(f"{k}: {configs[a].get(k)!r} vs {configs[b].get(k)!r}" for k in differ)
        raise ValueError(f"{a} and {b} play different rounds ({fields})")
    done = [
        {
            seed: r
            for seed, r in read_rounds(Path(folder) / "rounds.jsonl").items()
            if "error" not in r
        }
        for folder in (a, b)
    ]  # a round that crashed in either has nothing to pair
    seeds = sorted(set(done[0]) & set(done[1]))
    if not seeds:
        raise ValueError(f"{a} and {b} share no finished round")
    return [done[0][s] for s in seeds], [done[1][s] for s in seeds]


def compare_table(a: str | Path, b: str | Path) -> str:
    """Markdown: SR, CR and SR + CR of ``a`` and ``b`` on their shared rounds, and ``a`` − ``b``
    with a paired 95 % interval."""
    rounds_a, rounds_b = paired_rounds(a, b)
    change = paired_change(rounds_a, rounds_b)
    counts = (round_counts(rounds_a), round_counts(rounds_b))
    lines = [
        f"{len(rounds_a)} rounds played by both (seeds {rounds_a[0]['seed']}–{rounds_a[-1]['seed']})",
        "",
        "| | A | B | A − B [paired 95 % CI] |",
        "|---|---|---|---|",
    ]
    ratios = {name: [100 * pooled_ratio(c[0], c[COUNTS.index(by)]) for c in counts]
              for name, by in RATIOS.items()}  # fmt: skip
    ratios[SR_PLUS_CR] = [sr + cr for sr, cr in zip(*ratios.values(), strict=True)]
    for label, name in (
        ("SR %", "success_ratio"),
        ("CR %", "clear_ratio"),
        ("SR + CR", SR_PLUS_CR),
    ):
        ratio_a, ratio_b = ratios[name]
        lines.append(
            f"| {label} | {ratio_a:.1f} | {ratio_b:.1f} | {percent_change(change[name])} |"
        )
    lines.append(f"\nA: {a}\nB: {b}")
    return "\n".join(lines)
