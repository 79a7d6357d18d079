"""The declutter benchmark: many independent rounds, pooled ratios with confidence intervals.

Round ``r`` of a benchmark with seed ``s`` is `run_round` with seed ``s + r``: a pure task, so
rounds run on any executor (`symgrasp.parallel`: this process, local processes, a Ray
cluster) and a round can be rerun alone. A round that raises is recorded as an error with its
seed, the message and the traceback; the benchmark goes on, writes its results (counting the
failed rounds, averaging over none of them) and then stops (`TasksFailed`, naming the first
error and how many rounds failed), so that a run with failures never passes for a result.
Ratios pool the rounds that finished, as
the paper and VGN do (`RATIOS`: SR = successes / executed grasps, CR = successes / objects
presented, `pooled_ratio`); their 95 % intervals come from a bootstrap over rounds (rounds are
the independent units; attempts within a round are not).

A round is the same bytes wherever it is played (this process, local workers, a Ray node, a
loaded machine or an idle one): it runs on `ROUND_THREADS` torch thread, whatever the
process's own setting (restored after it), and its depth images come from the driver's
renderer (`local_renderer`: OpenGL or the ray cast), which every round records; a worker that
renders otherwise fails its rounds, and a resume where depth is rendered otherwise than in the
folder's rounds is refused (`check_out`).

Layout of a benchmark folder (`run_benchmark`)::

    config.json     the configuration, written (atomically) before any round runs
    model.sha256    the SHA-256 of what it plays (`planner_version`: the model file, VGN's weights,
                    a user's planner's source file): a file of the same name with other weights
                    (a run selected again) is refused, not taken for the old one
    rounds.jsonl    one line per round, appended as each finishes; in seed order at the end
    results.json    configuration and summary, derived from rounds.jsonl at the end (strict
                    JSON: an undefined ratio is null)
    results.md      the summary as a Markdown table row, and under it, when rounds failed,
                    how many and that the ratios are over the others only

A killed run loses only the rounds in flight; ``resume=True`` (``--resume``) plays the rounds
missing from ``rounds.jsonl`` and those recorded as failed, and refuses a folder of another
configuration. Before it plays them it rewrites ``rounds.jsonl`` (atomically) without the
failed records, so the file never holds two records of a seed. A folder holding
anything else, or held by another run, is refused (`BENCHMARK`, `symgrasp.folders`).
"""

from __future__ import annotations

import functools
import json
import math
import os
from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from symgrasp.atomic import check_json, read_json, write_atomic
from symgrasp.benchmark.declutter import Round, picture_observer, run_round
from symgrasp.benchmark.failures import MODES, STRUCK
from symgrasp.benchmark.sensing import Sensor
from symgrasp.config import BenchmarkConfig, ParallelConfig
from symgrasp.folders import Outputs, check_folder, check_owned, writes_folder
from symgrasp.objects.sets import resolve, unrecorded_decomposition
from symgrasp.parallel import Executor, Failure, Job, TasksFailed, open_executor, torch_threads
from symgrasp.peers.planners import load_planner, planner_version

MODEL_SHA = "model.sha256"
"""The file of a benchmark folder that records the SHA-256 of what it plays: the model file, VGN's
weights, or a user's planner's source (`symgrasp.peers.planners.planner_version`)."""

BENCHMARK = Outputs("a benchmark", record=("config.json", "rounds.jsonl", "results.json"))
"""A benchmark folder (`symgrasp.folders`): its record is written before any round, so a
folder without one must be empty (a user's ``results.md`` is not taken for a benchmark's)."""

BOOTSTRAP = 2000
"""Bootstrap resamples for the confidence intervals (of the rounds, and of whatever else a study
resamples)."""

COUNTS = ("successes", "executed", "objects")
"""What a finished round counts: successful grasps, executed grasps, objects presented."""

RATIOS = {"success_ratio": "executed", "clear_ratio": "objects"}
"""Each pooled ratio and the count of `COUNTS` it divides the successes by: SR = successes /
executed grasps, CR = successes / objects presented (the paper's and VGN's)."""

SR_PLUS_CR = "sr_plus_cr"
"""SR + CR, the one number the campaigns' judging rules rank detectors by (docs/models.md):
the key of its change beside `RATIOS`' in a paired comparison."""


def round_counts(rounds: list[dict[str, Any]]) -> np.ndarray:
    """``(3, n)`` float array of `COUNTS` of the ``n`` rounds that did not crash, in order."""
    done = [r for r in rounds if "error" not in r]
    return np.array([[r[k] for r in done] for k in COUNTS], dtype=float)


def pooled_ratio(successes: np.ndarray, denominator: np.ndarray) -> np.ndarray:
    """``sum(successes) / sum(denominator)`` over the last axis (the rounds), the one definition
    of SR and CR (`RATIOS`); NaN where the denominator sums to 0: no grasp executed (SR) or no
    object presented (CR) leaves the ratio undefined, not 0."""
    total = denominator.sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, successes.sum(-1) / total, np.nan)


def round_record(record: Round) -> dict[str, Any]:
    """A round as plain JSON data; each attempt's ``pose`` is the executed grasp's
    ``T_world_tcp`` (4×4 nested lists, metres; None when none was found)."""
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
                "struck": list(a.struck),
                "score": None if a.grasp is None else a.grasp.score,
                "confidence": None if a.grasp is None else a.grasp.confidence,
                "validity": None if a.grasp is None else a.grasp.validity,
                "fallback": None if a.grasp is None else a.grasp.fallback,
                "pose": None if a.grasp is None else a.grasp.pose.tolist(),
                "candidates": a.candidates,
                "rejected": a.rejected,
                "planning_s": a.planning_s,
            }
            for a in record.attempts
        ],
        "presented": record.presented,
        "left": record.left,
    }


ROUND_THREADS = 1
"""Torch threads every round runs on, wherever it is played, the process's own setting restored
after it: a float reduction split over threads rounds differently (a sum of 10⁶ float32 differs
on 1 and 2 threads), and a grasp's score, pose or rank then depends on the executor, the
machine and its load. One thread is also a worker's one core."""

_WORKER: dict[str, Any] = {}


def _init_worker(config: BenchmarkConfig, out: Path) -> None:
    _WORKER["config"] = config
    _WORKER["out"] = out
    _WORKER["objects"] = resolve(  # once for all its rounds
        config.objects, config.mesh_unit, config.decomposition
    )
    _WORKER["planner"] = load_planner(config.model, config.options, device="cpu")


def _round_task(seed: int) -> dict[str, Any]:
    config: BenchmarkConfig = _WORKER["config"]
    planner = _WORKER["planner"]
    observer = None
    if config.pictures:
        folder = _WORKER["out"] / "pictures" / f"seed_{seed:04d}"
        observer = picture_observer(folder, planner.gripper, f"seed {seed}, ")
    record = run_round(
        planner, _WORKER["objects"], config.num_objects, seed, scene=config.scene,
        sensor=Sensor(config.noise, config.view, config.views, table_scale=config.table_scale),
        observer=observer,
        diagnose=config.diagnose,
        table_clearance=config.table_clearance,
        surface_clearance=config.surface_clearance,
        protocol=config.protocol,
    )  # fmt: skip
    return round_record(record)


def _played_round(renderer: str, seed: int) -> dict[str, Any]:
    """The benchmark's task: round ``seed`` on `ROUND_THREADS` torch threads, refused where
    depth images come from another renderer than ``renderer`` (the driver's)."""
    here = local_renderer()
    if here != renderer:
        raise RuntimeError(
            f"depth images on this worker come from the {here} renderer, the benchmark's from "
            f"{renderer}: its rounds would differ; give every worker the driver's OpenGL "
            f"(MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!r} here)"
        )
    with torch_threads(ROUND_THREADS):
        return _round_task(seed)


@functools.cache
def local_renderer() -> str:
    """The depth renderer of the rounds played in this process: ``"gl"`` where MuJoCo opens an
    OpenGL context (``MUJOCO_GL``, `symgrasp.gl_backend`), else ``"raycast"``
    (`symgrasp.sim.render.make_renderer`). Their images differ by float noise, so a benchmark's
    rounds are all of one."""
    from symgrasp.sim.render import make_renderer

    return make_renderer().name


def round_seeds(config: BenchmarkConfig) -> list[int]:
    """The seeds of ``config``'s rounds, in order: ``seed … seed + rounds − 1``."""
    return [config.seed + r for r in range(config.rounds)]


def run_rounds(
    config: BenchmarkConfig,
    executor: Executor,
    out: str | Path = ".",
    seeds: Iterable[int] | None = None,
) -> Iterator[dict[str, Any]]:
    """The round records of ``seeds`` (default: all of ``config``'s) as ``executor`` finishes
    them, with a progress bar: in seed order in process, in any order otherwise. A round that
    raised is ``{"seed", "error", "traceback"}`` (pictures, if asked for, go under ``out`` on
    the machine that plays the round). Every round is played on `ROUND_THREADS` torch threads
    and rendered as in this process (`local_renderer`), or fails."""
    seeds = round_seeds(config) if seeds is None else list(seeds)
    task = functools.partial(_played_round, local_renderer())
    job = Job(task, _init_worker, (config, Path(out)))
    for seed, result in executor.map(job, seeds, "declutter rounds"):
        if isinstance(result, Failure):  # a crashed round is data, not the end of the benchmark
            result = {"seed": seed, "error": result.error, "traceback": result.traceback}
        yield result


def summarise(rounds: list[dict[str, Any]], seed: int = 0) -> dict[str, Any]:
    """Pooled SR and CR with bootstrap 95 % intervals, outcome and failure-mode counts, what
    the collisions hit (``struck``: attempts per `STRUCK` kind, one attempt under each kind it
    touched; records older than the field count nowhere), executed grasps, successes and
    wrong yaws per aimed-at object family, the objects left on the table per family
    (`left_on_table`), planning time, all over the rounds that finished; ``rounds`` counts
    every round and ``errors`` lists the failed ones (seed and message), which nothing is
    averaged over."""
    done = [r for r in rounds if "error" not in r]
    counts = dict(zip(COUNTS, round_counts(done), strict=True))
    outcomes = Counter(a["outcome"] for r in done for a in r["attempts"])
    modes = Counter(a.get("mode") for r in done for a in r["attempts"])
    modes.pop(None, None)
    hit = Counter(kind for r in done for a in r["attempts"] for kind in a.get("struck", ()))
    planning = [a["planning_s"] for r in done for a in r["attempts"]]
    summary = {
        "rounds": len(rounds),
        "errors": [{"seed": r["seed"], "error": r["error"]} for r in rounds if "error" in r],
        "objects": int(counts["objects"].sum()),
        "executed": int(counts["executed"].sum()),
        "successes": int(counts["successes"].sum()),
        **{
            name: float(pooled_ratio(counts["successes"], counts[by]))
            for name, by in RATIOS.items()
        },
        "outcomes": dict(sorted(outcomes.items())),
        "modes": {mode: modes[mode] for mode in MODES if mode in modes},
        "struck": {kind: hit[kind] for kind in STRUCK if kind in hit},
        "families": _by_family([a for r in done for a in r["attempts"]]),
        "left_on_table": left_on_table(done),
        "planning_s_median": float(np.median(planning)) if planning else float("nan"),
        "renderers": sorted({r["renderer"] for r in done}),
    }
    rng = np.random.default_rng(seed)
    picks = rng.integers(len(done), size=(BOOTSTRAP, len(done))) if done else None
    for name, by in RATIOS.items():
        interval = [float("nan")] * 2
        if picks is not None and counts[by].sum() > 0:
            ratios = pooled_ratio(counts["successes"][picks], counts[by][picks])
            interval = [float(np.percentile(ratios[np.isfinite(ratios)], q)) for q in (2.5, 97.5)]
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


def left_on_table(rounds: list[dict[str, Any]]) -> dict[str, dict[str, int]]:
    """Objects presented and left on the table when the round ended, per family, the family
    most often left first (by share, then count); records older than the ``presented`` and
    ``left`` fields count nowhere."""
    presented = Counter(f for r in rounds for f in r.get("presented", ()))
    left = Counter(f for r in rounds for f in r.get("left", ()))
    order = sorted(presented, key=lambda f: (-left[f] / presented[f], -left[f], f))
    return {f: {"presented": presented[f], "left": left[f]} for f in order}


def percent_with_interval(summary: dict[str, Any], name: str) -> str:
    """``summary[name]`` and its 95 % interval in percent, e.g. ``81.7 [77.0, 86.2]``; ``—``
    for an undefined ratio (nothing counted: `pooled_ratio`)."""
    if not math.isfinite(summary[name]):
        return "—"
    lo, hi = summary[f"{name}_ci95"]
    return f"{100 * summary[name]:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]"


def markdown_table(summary: dict[str, Any], config: BenchmarkConfig) -> str:
    """One Markdown row per benchmark (with its header); when rounds failed, a line under it
    says how many, the first error, and that the ratios are over the finished rounds only (or
    that there is none), so that a partial run is not read as the benchmark's result."""
    table = (
        "| model | objects | rounds | SR % [95 % CI] | CR % [95 % CI] | grasps | errors |\n"
        "|---|---|---|---|---|---|---|\n"
        f"| {config.model} | {config.objects} | {summary['rounds']} | {percent_with_interval(summary, 'success_ratio')} "
        f"| {percent_with_interval(summary, 'clear_ratio')} | {summary['executed']} | {len(summary['errors'])} |\n"
    )
    errors, rounds = summary["errors"], summary["rounds"]
    if not errors:
        return table
    finished = rounds - len(errors)
    ratios = f"SR and CR are over the {finished} that finished only" if finished else "no ratio"
    return table + (
        f"\n**Not a result: {_how_many_failed(len(errors), rounds)} failed** (the first, seed "
        f"{errors[0]['seed']}: {errors[0]['error']}); {ratios}. `--resume` plays the failed "
        "rounds again.\n"
    )


def _how_many_failed(failed: int, rounds: int) -> str:
    """``failed`` of ``rounds`` rounds in words: "every one of the 3 rounds", "1 of the 3 rounds"."""
    if failed == rounds:
        return f"every one of the {rounds} rounds"
    return f"{failed} of the {rounds} rounds"


def _strict_json(value: Any) -> Any:
    """``value`` (JSON data) with every non-finite float as None: strict JSON, an undefined
    ratio (NaN) written as null."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _strict_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_strict_json(v) for v in value]
    return value


# --- the output folder: configuration record, streamed rounds, derived results ------------


def recorded_config(out: str | Path) -> dict[str, Any] | None:
    """The configuration recorded in ``out``: its ``config.json``, or, in a folder finished
    before ``config.json`` was written, its ``results.json``'s; None when it has neither. Fields
    the record predates read as what its rounds were played with (`PLAYED_BEFORE`; the
    decomposition by its objects, `symgrasp.objects.sets.unrecorded_decomposition`)."""
    out = Path(out)
    if (out / "config.json").exists():
        recorded = read_json(out / "config.json", "benchmark configuration")
    elif (out / "results.json").exists():
        results = read_json(out / "results.json", "benchmark result", dict, ("config",))
        recorded = check_json(results["config"], out / "results.json", "benchmark configuration")
    else:
        return None
    objects = recorded.get("objects", BenchmarkConfig.objects)
    before = {**PLAYED_BEFORE, "decomposition": unrecorded_decomposition(objects)}
    return {**BenchmarkConfig().record(), **before, **recorded}


PLAYED_BEFORE = {"table_clearance": -0.002, "surface_clearance": -0.002}
"""What a folder recorded before a field was added played, where it is not the field's
default; the decomposition, which depends on the objects, apart (`recorded_config`); other
fields added later read as their defaults."""


def check_out(config: BenchmarkConfig, out: str | Path, resume: bool = False) -> None:
    """Raise ValueError unless ``out`` may take ``config``'s rounds: a folder path holding
    nothing (`BENCHMARK`), or, with ``resume``, a benchmark of ``config`` played by the same
    model file, of readable rounds (`read_rounds`) rendered as rounds played here would be
    (`local_renderer`). Reads small files and hashes the model file, so the CLI calls it
    before it loads a model or starts workers."""
    out = check_folder(out)
    check_owned(out, BENCHMARK)
    if not any((out / name).exists() for name in ("config.json", "rounds.jsonl", "results.json")):
        return
    if not resume:
        raise ValueError(
            f"out {out} already holds a benchmark; pass resume=True (--resume) to finish it, "
            "or choose another out (--out)"
        )
    recorded, wanted = recorded_config(out), config.record()
    if recorded is None:
        raise ValueError(
            f"out {out} holds rounds of an unrecorded configuration (no config.json); "
            "choose another out (--out)"
        )
    if recorded != wanted:
        differ = sorted(
            k for k in recorded.keys() | wanted.keys() if recorded.get(k) != wanted.get(k)
        )
        raise ValueError(
            f"out {out} holds a benchmark of another configuration (its {', '.join(differ)} "
            "differ); choose another out (--out)"
        )
    _check_model(config, out)
    rounds = read_rounds(out / "rounds.jsonl")  # a line torn in the middle: named before any work
    _check_renderer(rounds.values(), out)


def _check_renderer(rounds: Iterable[dict[str, Any]], out: Path) -> None:
    """ValueError when the finished ``rounds`` of ``out`` were rendered otherwise than rounds
    played here would be (`local_renderer`): the benchmark would mix rounds of two renderers."""
    rendered = sorted({r["renderer"] for r in rounds if "error" not in r})
    here = local_renderer()
    if rendered and rendered != [here]:
        raise ValueError(
            f"out {out} holds rounds rendered by {' and '.join(rendered)}, but depth images here "
            f"come from the {here} renderer (MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!r}): the "
            f"rounds played now would differ; resume where the {rendered[0]} renderer works, or "
            "choose another out (--out)"
        )


def _check_model(config: BenchmarkConfig, out: Path) -> None:
    """ValueError when ``out`` recorded another SHA-256 than ``config.model``'s now (its model
    file's, VGN's weights', a user's planner's source's; folders from before the record are
    taken as they are)."""
    if not (out / MODEL_SHA).exists():
        return
    played, now = (out / MODEL_SHA).read_text().strip(), _version(config)
    if played != now:
        raise ValueError(
            f"out {out} holds rounds of another model file: {config.model} has changed since "
            f"they were played (SHA-256 {played[:12]}…, now {now[:12]}…); choose another out "
            "(--out) or delete it to play them again"
        )


def _version(config: BenchmarkConfig) -> str:
    """The SHA-256 of what ``config`` plays (`planner_version`: the model file, VGN's weights,
    the oracle's source and databases, a user's planner's source)."""
    return planner_version(config.model, config.options)


def read_rounds(path: str | Path) -> dict[int, dict[str, Any]]:
    """The round records of a ``rounds.jsonl`` by seed: the first record of each seed, or its
    first finished one after a failed one (`run_benchmark` keeps one record a seed; this
    holds whatever a file holds to the same rule). An incomplete last line, left by a run killed
    while writing it, is ignored: its round is missing and reruns. Any other line that is not
    a JSON object with a seed is an error naming the file and the line."""
    path = Path(path)
    if not path.exists():
        return {}
    text = path.read_text()
    rounds: dict[int, dict[str, Any]] = {}
    for number, line in enumerate(text[: text.rfind("\n") + 1].splitlines(), 1):
        try:
            record = json.loads(line)
        except json.JSONDecodeError as err:
            raise ValueError(f"{path} line {number} is not a valid round record: {err}") from None
        check_json(record, f"{path} line {number}", "round record", dict, ("seed",))
        if "error" in rounds.get(record["seed"], {"error": None}):
            rounds[record["seed"]] = record
    return rounds


def _write_text(path: Path, text: str) -> None:
    """Replace ``path`` by ``text`` (`write_atomic`)."""
    write_atomic(path, lambda f: f.write(text), mode="w")


def _write_rounds(path: Path, rounds: Iterable[dict[str, Any]]) -> None:
    """Replace ``path`` by ``rounds``, one JSON line each."""
    _write_text(path, "".join(json.dumps(r) + "\n" for r in rounds))


def _append_round(lines: TextIO, record: dict[str, Any]) -> None:
    """Append ``record`` to the open ``rounds.jsonl`` and make it durable now. The one write
    that is not `write_atomic`'s: rounds stream in for hours, and a finished round must
    survive a kill of the run. A kill mid-line leaves a torn last line, which `read_rounds`
    ignores and `run_benchmark` drops before it appends again."""
    lines.write(json.dumps(record) + "\n")
    lines.flush()
    os.fsync(lines.fileno())


@writes_folder(BENCHMARK)
def run_benchmark(
    config: BenchmarkConfig,
    out: str | Path,
    resume: bool = False,
    parallel: ParallelConfig = ParallelConfig(),
) -> dict[str, Any]:
    """Play ``config``'s rounds into the folder ``out`` on the executor ``parallel`` describes
    and return their summary.

    ``config.json`` records the configuration before any round runs; each round is appended
    to ``rounds.jsonl`` as it finishes (in any order with several workers). At the end
    ``rounds.jsonl`` is rewritten in seed order, and ``results.json`` and ``results.md`` are
    derived from it. With ``resume``, only the rounds missing from ``out`` are played. ``out``
    is held for the call (`symgrasp.folders.output_folder`): one writer at a time.
    Raises ValueError as `check_out` and `open_executor` do, or when another process holds
    ``out``, and `symgrasp.objects.folder.MissingData` when the object set is not in the data
    folder, before anything is played or written; `TasksFailed` after writing them when any
    round failed."""
    out = Path(out)
    check_out(config, out, resume)
    path = out / "rounds.jsonl"
    done = {seed: r for seed, r in read_rounds(path).items() if "error" not in r}  # failed: again
    missing = [seed for seed in round_seeds(config) if seed not in done]
    if missing:  # here, once, rather than in every round a worker plays
        resolve(config.objects, config.mesh_unit, config.decomposition)
    # a cluster is joined (or refused) before anything is written, and not at all for no rounds
    with open_executor(parallel if missing else ParallelConfig()) as executor:
        if not (out / "config.json").exists():
            _write_text(out / MODEL_SHA, _version(config) + "\n")
            _write_text(out / "config.json", json.dumps(config.record(), indent=1) + "\n")
        _write_rounds(path, done.values())  # without failed rounds or a torn last line
        if missing:
            with open(path, "a") as lines:
                for record in run_rounds(config, executor, out, missing):
                    _append_round(lines, record)
                    done[record["seed"]] = record
    rounds = [done[seed] for seed in round_seeds(config)]  # seed order: the bootstrap's order
    _write_rounds(path, rounds)
    summary = summarise(rounds, config.seed)
    result = _strict_json({"config": config.record(), "summary": summary})
    _write_text(out / "results.json", json.dumps(result, indent=1, allow_nan=False) + "\n")
    _write_text(out / "results.md", markdown_table(summary, config))
    _check_finished(rounds, out)
    return summary


def _check_finished(rounds: list[dict[str, Any]], out: Path) -> None:
    """`TasksFailed` naming the first failed round's error and how many failed when any of
    ``rounds`` (those of the benchmark in ``out``) failed: ratios over the others would pass
    for the benchmark's, and whatever failed (a missing object set on a worker, a broken
    model, an unstable simulation) may fail again; ``--resume`` plays them again."""
    failed = [r for r in rounds if "error" in r]
    if failed:
        raise TasksFailed(
            f"{_how_many_failed(len(failed), len(rounds))} in {out} failed; the first (seed "
            f"{failed[0]['seed']}): "
            f"{failed[0]['error']} (tracebacks in {out / 'rounds.jsonl'}; --resume plays them "
            "again)"
        )


def saved_rounds(
    config: BenchmarkConfig, out: str | Path, check_model: bool = True
) -> list[dict[str, Any]] | None:
    """The round records of ``config`` in seed order when ``out`` holds every one of them
    (failed ones included, as their records: a reader counts them apart), else None (no benchmark, an unfinished one, or another configuration's). ValueError when
    the model file has changed since they were played; ``check_model=False`` skips that check,
    for stored rounds whose model file is not on this machine."""
    if recorded_config(out) != config.record():
        return None
    if check_model:
        _check_model(config, Path(out))
    done = read_rounds(Path(out) / "rounds.jsonl")
    seeds = round_seeds(config)
    return [done[seed] for seed in seeds] if all(seed in done for seed in seeds) else None


def run_or_reuse(
    config: BenchmarkConfig, out: str | Path, parallel: ParallelConfig = ParallelConfig()
) -> list[dict[str, Any]]:
    """The round records of ``config``: those in ``out`` when it holds them all and none
    failed (`saved_rounds`), else `run_benchmark`'s resuming ``out``, so scripts over many
    benchmarks skip finished ones and finish interrupted or failed ones. Raises ValueError
    when ``out`` holds another configuration's benchmark, and as `run_benchmark` does
    (`TasksFailed` when a round failed again)."""
    rounds = saved_rounds(config, out)
    if rounds is None or any("error" in r for r in rounds):
        run_benchmark(config, out, resume=True, parallel=parallel)
        rounds = saved_rounds(config, out)
    return rounds
