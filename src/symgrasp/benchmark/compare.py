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

from symgrasp.benchmark.runner import BOOTSTRAP, read_rounds, recorded_config

SAME_WORLD = ("objects", "mesh_unit", "scene", "num_objects")
"""Configuration fields that decide what the rounds play: two benchmarks compare only when
these agree (the model, thresholds and diagnosis may differ)."""


def paired_change(
    rounds: list[dict[str, Any]], baseline: list[dict[str, Any]], seed: int = 0
) -> dict[str, list[float]]:
    """CR and SR of ``rounds`` minus those of ``baseline`` (the same seeds, in order): the
    change and its 95 % interval, ``[change, low, high]``, from one bootstrap over rounds
    resampled in pairs."""
    if [r["seed"] for r in rounds] != [r["seed"] for r in baseline]:
        raise ValueError("rounds and baseline must be the same seeds in the same order")
    counts = {name: np.array([[r[key] for r in rs] for key in ("successes", "executed", "objects")],
                             dtype=float) for name, rs in (("a", rounds), ("b", baseline))}  # fmt: skip
    picks = np.random.default_rng(seed).integers(len(rounds), size=(BOOTSTRAP, len(rounds)))
    change = {}
    for name, row in (("clear_ratio", 2), ("success_ratio", 1)):
        a, b = counts["a"], counts["b"]
        point = a[0].sum() / a[row].sum() - b[0].sum() / b[row].sum()
        resampled = a[0][picks].sum(1) / a[row][picks].sum(1) - b[0][picks].sum(1) / b[row][
            picks
        ].sum(1)
        change[name] = [float(point), *map(float, np.percentile(resampled, [2.5, 97.5]))]
    return change


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
    """Markdown: SR and CR of ``a`` and ``b`` on their shared rounds, and ``a`` − ``b`` with a
    paired 95 % interval."""
    rounds_a, rounds_b = paired_rounds(a, b)
    change = paired_change(rounds_a, rounds_b)

    def ratio(rounds: list[dict], key: str) -> float:
        return 100 * sum(r["successes"] for r in rounds) / max(sum(r[key] for r in rounds), 1)

    lines = [
        f"{len(rounds_a)} rounds played by both (seeds {rounds_a[0]['seed']}–{rounds_a[-1]['seed']})",
        "",
        "| | A | B | A − B [paired 95 % CI] |",
        "|---|---|---|---|",
    ]
    for name, key in (("SR %", "executed"), ("CR %", "objects")):
        point, low, high = (
            100 * v for v in change["success_ratio" if key == "executed" else "clear_ratio"]
        )
        lines.append(
            f"| {name} | {ratio(rounds_a, key):.1f} | {ratio(rounds_b, key):.1f} | "
            f"{point:+.1f} [{low:+.1f}, {high:+.1f}] |"
        )
    lines.append(f"\nA: {a}\nB: {b}")
    return "\n".join(lines)
