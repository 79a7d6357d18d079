"""The declutter benchmark: many independent rounds, pooled ratios with confidence intervals.

Round ``r`` of a benchmark with seed ``s`` is `run_round` with seed ``s + r``: a pure task, so
rounds run in any number of processes (or on a cluster engine) and a round can be rerun alone.
A round that raises is recorded as an error with its seed and the message; the benchmark goes
on. Ratios pool all rounds, as the paper and VGN do (SR = successes / executed grasps,
CR = successes / objects presented); their 95 % intervals come from a bootstrap over rounds
(rounds are the independent units; attempts within a round are not).
"""

from __future__ import annotations

import json
import multiprocessing
import os
import traceback
from collections import Counter
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from symgrasp.benchmark.declutter import Round, picture_observer, run_round
from symgrasp.benchmark.failures import MODES
from symgrasp.config import BenchmarkConfig

BOOTSTRAP = 2000
"""Bootstrap resamples of the rounds for the confidence intervals."""


def round_record(record: Round) -> dict[str, Any]:
    """A round as plain JSON data."""
    return {
        "seed": record.seed,
        "objects": record.objects,
        "renderer": record.renderer,
        "successes": record.successes,
        "executed": record.executed,
        "attempts": [
            {
                "outcome": a.outcome,
                "mode": a.mode,
                "target": a.target,
                "score": None if a.grasp is None else a.grasp.score,
                "confidence": None if a.grasp is None else a.grasp.confidence,
                "candidates": a.candidates,
                "rejected": a.rejected,
                "planning_s": a.planning_s,
            }
            for a in record.attempts
        ],
    }


_WORKER: dict[str, Any] = {}


def _init_worker(config: BenchmarkConfig, threads: int, out: Path) -> None:
    import torch

    from symgrasp.detect import GraspDetector

    torch.set_num_threads(threads)
    _WORKER["config"] = config
    _WORKER["out"] = out
    _WORKER["detector"] = GraspDetector.from_pretrained(
        config.model, device="cpu", **dict(config.options)
    )


def _round_task(seed: int) -> dict[str, Any]:
    config: BenchmarkConfig = _WORKER["config"]
    detector = _WORKER["detector"]
    observer = None
    if config.pictures:
        folder = _WORKER["out"] / "pictures" / f"seed_{seed:04d}"
        observer = picture_observer(folder, detector.gripper, f"seed {seed}, ")
    try:
        record = run_round(
            detector, config.objects, config.num_objects, seed, observer=observer,
            diagnose=config.diagnose,
        )  # fmt: skip
        return round_record(record)
    except Exception as error:  # a crashed round is data, not the end of the benchmark
        return {"seed": seed, "error": f"{type(error).__name__}: {error}",
                "traceback": traceback.format_exc()}  # fmt: skip


def run_rounds(
    config: BenchmarkConfig, workers: int = 1, out: str | Path = "."
) -> Iterator[dict[str, Any]]:
    """The round records of ``config``, in seed order, with a progress bar (pictures, if
    asked for, go under ``out``)."""
    seeds = [config.seed + r for r in range(config.rounds)]
    bar = tqdm(total=len(seeds), desc="declutter rounds", unit="round")
    if workers <= 1:
        _init_worker(config, max(1, min(2, os.cpu_count() or 1)), Path(out))
        results: Iterator[dict[str, Any]] = map(_round_task, seeds)
        for result in results:
            bar.update()
            yield result
    else:
        spawn = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(workers, spawn, initializer=_init_worker,
                                 initargs=(config, 1, Path(out))) as pool:  # fmt: skip
            for result in pool.map(_round_task, seeds, chunksize=1):
                bar.update()
                yield result
    bar.close()


def summarise(rounds: list[dict[str, Any]], seed: int = 0) -> dict[str, Any]:
    """Pooled SR and CR with bootstrap 95 % intervals, outcome and failure-mode counts,
    executed grasps, successes and wrong yaws per aimed-at object family, planning time."""
    done = [r for r in rounds if "error" not in r]
    successes = np.array([r["successes"] for r in done], dtype=float)
    executed = np.array([r["executed"] for r in done], dtype=float)
    objects = np.array([r["objects"] for r in done], dtype=float)
    outcomes = Counter(a["outcome"] for r in done for a in r["attempts"])
    modes = Counter(a.get("mode") for r in done for a in r["attempts"])
    modes.pop(None, None)
    planning = [a["planning_s"] for r in done for a in r["attempts"]]
    summary = {
        "rounds": len(rounds),
        "errors": [{"seed": r["seed"], "error": r["error"]} for r in rounds if "error" in r],
        "objects": int(objects.sum()),
        "executed": int(executed.sum()),
        "successes": int(successes.sum()),
        "success_ratio": _ratio(successes, executed),
        "clear_ratio": _ratio(successes, objects),
        "outcomes": dict(sorted(outcomes.items())),
        "modes": {mode: modes[mode] for mode in MODES if mode in modes},
        "families": _by_family([a for r in done for a in r["attempts"]]),
        "planning_s_median": float(np.median(planning)) if planning else float("nan"),
        "renderers": sorted({r["renderer"] for r in done}),
    }
    rng = np.random.default_rng(seed)
    picks = rng.integers(len(done), size=(BOOTSTRAP, len(done))) if done else None
    for name, denominator in (("success_ratio", executed), ("clear_ratio", objects)):
        interval = [float("nan")] * 2
        if picks is not None and denominator.sum() > 0:
            totals = denominator[picks].sum(1)
            ratios = successes[picks].sum(1)[totals > 0] / totals[totals > 0]
            interval = [float(np.percentile(ratios, q)) for q in (2.5, 97.5)]
        summary[f"{name}_ci95"] = interval
    return summary


def _by_family(attempts: list[dict[str, Any]]) -> dict[str, dict[str, int]]:
    """Executed grasps, successes and wrong yaws per ``target`` family (older records
    without targets count nowhere)."""
    families: dict[str, Counter] = {}
    for a in attempts:
        if a.get("target") is None:
            continue
        counts = families.setdefault(a["target"], Counter())
        counts["executed"] += 1
        counts["successes"] += a["outcome"] == "success"
        counts["wrong_yaw"] += a.get("mode") == "wrong_yaw"
    keys = ("executed", "successes", "wrong_yaw")
    return {name: {k: families[name][k] for k in keys} for name in sorted(families)}


def _ratio(numerator: np.ndarray, denominator: np.ndarray) -> float:
    """Pooled ratio sum(numerator) / sum(denominator), NaN when the denominator is 0."""
    total = float(denominator.sum())
    return float(numerator.sum()) / total if total else float("nan")


def percent_with_interval(summary: dict[str, Any], name: str) -> str:
    """``summary[name]`` and its 95 % interval in percent, e.g. ``81.7 [77.0, 86.2]``."""
    lo, hi = summary[f"{name}_ci95"]
    return f"{100 * summary[name]:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]"


def markdown_table(summary: dict[str, Any], config: BenchmarkConfig) -> str:
    """One Markdown row per benchmark (with its header)."""

    return (
        "| model | objects | rounds | SR % [95 % CI] | CR % [95 % CI] | grasps | errors |\n"
        "|---|---|---|---|---|---|---|\n"
        f"| {config.model} | {config.objects} | {summary['rounds']} | {percent_with_interval(summary, 'success_ratio')} "
        f"| {percent_with_interval(summary, 'clear_ratio')} | {summary['executed']} | {len(summary['errors'])} |\n"
    )


def run_benchmark(config: BenchmarkConfig, out: str | Path, workers: int = 1) -> dict[str, Any]:
    """Run ``config``, write ``rounds.jsonl``, ``results.json`` and ``results.md`` into
    ``out``, and return the summary."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rounds = []
    with open(out / "rounds.jsonl", "w") as lines:
        for record in run_rounds(config, workers, out):
            rounds.append(record)
            lines.write(json.dumps(record) + "\n")
    summary = summarise(rounds, config.seed)
    result = {"config": asdict(config), "summary": summary}
    (out / "results.json").write_text(json.dumps(result, indent=1) + "\n")
    (out / "results.md").write_text(markdown_table(summary, config))
    return summary


def saved_rounds(config: BenchmarkConfig, out: str | Path) -> list[dict[str, Any]] | None:
    """The round records in ``out`` when its ``results.json`` is of ``config``, else None."""
    saved = Path(out) / "results.json"
    if not saved.exists():
        return None
    if json.loads(saved.read_text())["config"] != json.loads(json.dumps(asdict(config))):
        return None
    return [json.loads(line) for line in (Path(out) / "rounds.jsonl").read_text().splitlines()]


def run_or_reuse(
    config: BenchmarkConfig, out: str | Path, workers: int = 1
) -> list[dict[str, Any]]:
    """The round records of ``config``: those already in ``out`` (`saved_rounds`), else
    `run_benchmark`'s, so scripts over many benchmarks resume where they stopped."""
    rounds = saved_rounds(config, out)
    if rounds is None:
        run_benchmark(config, out, workers)
        rounds = saved_rounds(config, out)
    return rounds
