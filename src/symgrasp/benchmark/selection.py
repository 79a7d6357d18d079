"""Model selection: which checkpoint of a training run becomes ``best.pt``.

Validation loss and the all-voxel metrics could not tell apart two training seeds whose
detectors clear piles very differently (declutter SR 81.7 vs 58.7 on the test objects), so a
run can instead be selected by a measure closer to grasping:

- `declutter_validation`: the real declutter benchmark (`symgrasp.benchmark.runner`) of a
  checkpoint on **training** objects (default `VALIDATION_OBJECTS`, vgn-pile-train) with round
  seeds from `VALIDATION_SEED` (1 000 000 on): never a test object set, never a seed below
  `TEST_SEED_LIMIT` (the test tables use 0…99 and 1000…1099); both are refused;
- any column of the run's ``metrics.csv`` (validation loss, validity AP, the top-k metrics of
  `symgrasp.model.metrics`, …), with the direction `direction` gives it.

`select_checkpoint` (``symgrasp select RUN_DIR --by MEASURE``) evaluates every kept checkpoint
of a run (``epoch_NNN.pt``, and ``last.pt`` when its epoch has no file of its own), caches each
result in ``RUN_DIR/selection/`` (atomically, keyed by the checkpoint's hash, so a rerun skips
what is done and a killed declutter validation resumes round by round), writes
``selection.csv`` and ``selection.json`` (every measure of every checkpoint, the choice) and
copies the chosen checkpoint to ``best.pt``, recording the choice in it (``"selection"``).

Selection plays the benchmark, so it lives above it, in the benchmark package; training
(`symgrasp.model`) never imports it.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import re
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from torch.utils.data import DataLoader

from symgrasp.atomic import read_json, write_atomic, write_csv
from symgrasp.benchmark.runner import PLAYED_BEFORE, run_or_reuse, summarise
from symgrasp.config import (
    SURFACE_CLEARANCE,
    TABLE_CLEARANCE,
    TEST_SEED_LIMIT,
    VALIDATION_OBJECTS,
    VALIDATION_ROUNDS,
    VALIDATION_SEED,
    BenchmarkConfig,
    ParallelConfig,
    PlannerOptions,
    TrainConfig,
)
from symgrasp.data.dataset import GraspDataset, collate_scenes
from symgrasp.device import resolve_device
from symgrasp.digest import file_sha256
from symgrasp.folders import writes_folder
from symgrasp.model.checkpoint import (
    load_checkpoint,
    load_model,
    save_checkpoint,
    trained_gripper,
)
from symgrasp.model.train import FirstScenes, evaluate
from symgrasp.names import DECLUTTER_MEASURES, TEST_OBJECT_SETS
from symgrasp.names import MEASURE_ALIASES as ALIASES
from symgrasp.names import measure_direction as direction
from symgrasp.sim.grippers import same_name_note

__all__ = [
    "TEST_SEED_LIMIT",
    "VALIDATION_OBJECTS",
    "VALIDATION_ROUNDS",
    "VALIDATION_SEED",
    "DeclutterValidation",
    "Revalidation",
    "check_validation_rounds",
    "checkpoint_id",
    "checkpoint_measures",
    "choose",
    "declutter_validation",
    "direction",
    "find_checkpoints",
    "select_checkpoint",
    "selected_checkpoint",
    "validation_metrics",
]

BOOKKEEPING = ("epoch", "world_size", "global_batch_size", "lr", "seconds")
"""metrics.csv columns that describe a run rather than measure it."""

CHECKPOINT = re.compile(r"epoch_(\d+)\.pt")
"""The file name of a kept per-epoch checkpoint (``symgrasp train --keep-every N``)."""


def check_validation_rounds(objects: str, rounds: int, seed: int) -> None:
    """Raise ValueError unless the rounds ``seed … seed + rounds − 1`` on ``objects`` stay off
    the test sets: no seed below `TEST_SEED_LIMIT`, no named test object set."""
    if isinstance(seed, int) and isinstance(rounds, int) and seed < TEST_SEED_LIMIT:
        raise ValueError(
            f"seed: declutter validation rounds play seeds {seed}…{seed + rounds - 1}, which "
            f"overlap the test seeds 0…{TEST_SEED_LIMIT - 1} (reserved for test benchmarks); "
            f"use a seed ≥ {TEST_SEED_LIMIT} (default {VALIDATION_SEED})"
        )
    tests = [p for p in str(objects).split(",") if p in TEST_OBJECT_SETS]
    if tests:
        raise ValueError(
            f"objects: {', '.join(tests)} is a test object set; declutter validation plays "
            f"training objects (default {VALIDATION_OBJECTS}, household-train or "
            "thin-boxes-train)"
        )


@dataclass(frozen=True)
class DeclutterValidation:
    """The settings of a declutter validation (`declutter_validation`'s arguments), checked when
    made: ``rounds`` rounds from seed ``seed`` of ``num_objects`` objects of ``objects`` as a
    ``scene``. ValueError names the argument (seed, objects, or the benchmark's own checks)."""

    objects: str = VALIDATION_OBJECTS
    rounds: int = VALIDATION_ROUNDS
    seed: int = VALIDATION_SEED
    num_objects: int = 5
    scene: str = "pile"
    mesh_unit: str = "auto"
    table_clearance: float = TABLE_CLEARANCE
    surface_clearance: float = SURFACE_CLEARANCE

    def __post_init__(self) -> None:
        check_validation_rounds(self.objects, self.rounds, self.seed)
        BenchmarkConfig(**asdict(self))

    @property
    def settings(self) -> dict[str, Any]:
        """The settings as recorded (in the slug's hash and in best.pt's ``"selection"``): a
        field at the value rounds were played with before it existed (`runner.PLAYED_BEFORE`)
        is left out, so a selection made then keeps its folder and its best.pt byte for byte."""
        return {
            k: v for k, v in asdict(self).items() if k not in PLAYED_BEFORE or v != PLAYED_BEFORE[k]
        }

    @property
    def slug(self) -> str:
        """A folder name for these settings: readable, and unique by a hash of `settings`."""
        digest = hashlib.sha256(json.dumps(self.settings, sort_keys=True).encode()).hexdigest()[:8]
        name = re.sub(r"[^A-Za-z0-9_.-]+", "_", Path(str(self.objects)).name)[:40]
        return f"{name}-{self.scene}{self.num_objects}-r{self.rounds}-s{self.seed}-{digest}"


@dataclass(frozen=True)
class Revalidation:
    """Recompute checkpoints' validation metrics (`validation_metrics`' arguments) instead of
    reading the run's metrics.csv: on the validation split of ``data`` (default: the dataset
    each run trained on, as it validated), or on ``datasets`` = (val split, collate function);
    ``batch_size`` scenes per batch (default: the run's)."""

    data: str | None = None
    datasets: tuple[Any, Any] | None = None
    batch_size: int | None = None
    device: str = "cpu"

    @property
    def key(self) -> str:
        """Which validation data and batch size the cached metrics were computed with."""
        data = self.data or ("given datasets" if self.datasets is not None else "trained on")
        return f"{data}, batch {self.batch_size or 'as trained'}"


def declutter_validation(
    checkpoint: str | Path,
    out: str | Path,
    objects: str = VALIDATION_OBJECTS,
    rounds: int = VALIDATION_ROUNDS,
    seed: int = VALIDATION_SEED,
    *,
    num_objects: int = 5,
    scene: str = "pile",
    mesh_unit: str = "auto",
    table_clearance: float = TABLE_CLEARANCE,
    surface_clearance: float = SURFACE_CLEARANCE,
    options: PlannerOptions = PlannerOptions(),
    workers: int | None = None,
    parallel: ParallelConfig | None = None,
) -> dict[str, Any]:
    """The declutter benchmark of ``checkpoint`` on training objects, played into (or read back
    from, or resumed in) the benchmark folder ``out`` (`symgrasp.benchmark.runner.run_or_reuse`).

    Rounds use seeds ``seed … seed + rounds − 1`` (refused when they reach the test seeds,
    `check_validation_rounds`), ``num_objects`` objects of ``objects`` as a ``scene``, the
    detector's default thresholds unless ``options`` (its `PlannerOptions`) say otherwise, the
    approach check's ``table_clearance`` and ``surface_clearance``, and no failure diagnosis (its replays cost time and change no ratio). ``workers`` local processes, or the executor ``parallel``.

    Returns the pooled ``success_ratio`` and ``clear_ratio`` with their bootstrap 95 %
    intervals (``*_ci95``), the counts (``rounds``, ``objects``, ``executed``, ``successes``,
    ``errors``: 0, as a validation with failed rounds has no value) and the benchmark's
    ``config``. Raises `symgrasp.objects.folder.MissingData` when ``objects`` is not in the
    data folder and `TasksFailed` naming the first error when a round failed (played again on
    the next call), as `run_or_reuse` does.
    """
    check_validation_rounds(objects, rounds, seed)
    config = BenchmarkConfig(
        model=str(checkpoint), objects=objects, mesh_unit=mesh_unit, scene=scene,
        num_objects=num_objects, rounds=rounds, seed=seed, options=options,
        diagnose=False, table_clearance=table_clearance,
        surface_clearance=surface_clearance,
    )  # fmt: skip
    if parallel is None:
        parallel = ParallelConfig(workers=workers)
    elif workers is not None:
        raise ValueError("workers: give workers or parallel, not both")
    summary = summarise(run_or_reuse(config, out, parallel), seed)
    keys = ("rounds", "objects", "executed", "successes", "success_ratio", "success_ratio_ci95",
            "clear_ratio", "clear_ratio_ci95")  # fmt: skip
    return {
        **{key: summary[key] for key in keys},
        "errors": len(summary["errors"]),
        "config": config.record(),
    }


def validation_metrics(
    checkpoint: str | Path,
    data: str | None = None,
    *,
    datasets: tuple[Any, Any] | None = None,
    batch_size: int | None = None,
    device: str = "cpu",
) -> dict[str, float]:
    """Validation losses (``val_*``) and `MetricAccumulator` metrics of ``checkpoint`` on the
    validation split of ``data``, computed anew: for a run trained before a metric existed (the
    top-k ones). By default on the dataset it was trained on and as its training validated (its
    ``val_scenes``, batch size and validity loss), so that metrics.csv's values come back.
    ``datasets`` = (val split, collate function) replaces the dataset folder: that split, whole
    (tests and quick benchmarks pass synthetic scenes)."""
    model, state = load_model(checkpoint)
    recorded = TrainConfig.from_record(state["config"])
    if datasets is None:
        folder = data or recorded.data
        val_set = GraspDataset(folder, split="val", augment=False)
        trained_for = trained_gripper(state)
        if val_set.gripper != trained_for:
            raise ValueError(
                f"data: {folder} was produced for the gripper {val_set.gripper.name!r}, "
                f"{checkpoint} was trained for {trained_for.name!r}"
                f"{same_name_note(val_set.gripper, trained_for)}"
            )
        if data is None and recorded.val_scenes:
            val_set = FirstScenes(val_set, recorded.val_scenes, "the run's val_scenes")
        datasets = (val_set, collate_scenes)
    val_set, collate = datasets
    if not len(val_set):
        raise ValueError(f"data: {data or recorded.data} has no validation scene")
    device = resolve_device(device)
    loader = DataLoader(val_set, batch_size=batch_size or recorded.batch_size, collate_fn=collate)
    losses, metrics = evaluate(
        model.to(device), loader, recorded.loss_weights, device, recorded.validity,
        recorded.autocast,
    )  # fmt: skip
    return {**{f"val_{k}": v for k, v in losses.items()}, **metrics}


def find_checkpoints(run_dir: str | Path) -> list[tuple[int, Path]]:
    """(epoch, path) of every kept checkpoint of the run ``run_dir``, by epoch: its
    ``epoch_NNN.pt`` files and ``last.pt`` when no ``epoch_NNN.pt`` holds its epoch.
    ValueError naming RUN_DIR when the folder or its checkpoints are missing."""
    run = Path(run_dir)
    if not run.is_dir():
        raise ValueError(f"RUN_DIR {run}: no such folder")
    kept = {
        int(match.group(1)): path
        for path in run.iterdir()
        if (match := CHECKPOINT.fullmatch(path.name)) and path.is_file()
    }
    if not kept:
        raise ValueError(
            f"RUN_DIR {run} holds no epoch_NNN.pt checkpoint to select from (train with "
            "--keep-every N to keep them)"
        )
    if (run / "last.pt").is_file():
        last = load_checkpoint(run / "last.pt")["epoch"]
        kept.setdefault(int(last), run / "last.pt")
    return sorted(kept.items())


def _number(text: Any) -> Any:
    try:
        return float(text)
    except (TypeError, ValueError):
        return text


def _metric_rows(run: Path, checkpoints: list[tuple[int, Path]]) -> dict[int, dict[str, Any]]:
    """The metrics.csv row of each epoch (numbers as floats); from the last checkpoint's
    history when the run has no metrics.csv."""
    path = run / "metrics.csv"
    if path.is_file():
        with open(path, newline="") as file:
            rows = list(csv.DictReader(file))
    else:
        rows = load_checkpoint(checkpoints[-1][1]).get("history", [])
    return {int(float(row["epoch"])): {k: _number(v) for k, v in row.items()} for row in rows}


class _Cache:
    """What is known of one checkpoint, in ``RUN_DIR/selection/<stem>-<hash>.json``, rewritten
    atomically after each new piece."""

    def __init__(self, folder: Path, path: Path, epoch: int) -> None:
        self.sha = file_sha256(path)
        self.id = checkpoint_id(path, self.sha)
        self.file = folder / f"{self.id}.json"
        self.data = {"checkpoint": path.name, "epoch": epoch, "sha256": self.sha}
        if self.file.is_file():
            self.data = {**self.data, **read_json(self.file, "checkpoint selection record")}

    def get(self, part: str, key: str) -> Any:
        return self.data.get(part, {}).get(key)

    def put(self, part: str, key: str, value: Any) -> None:
        self.data.setdefault(part, {})[key] = value
        text = json.dumps(self.data, indent=1) + "\n"
        write_atomic(self.file, lambda file: file.write(text), mode="w")


def checkpoint_measures(
    run_dir: str | Path,
    *,
    declutter: bool = False,
    validation: DeclutterValidation = DeclutterValidation(),
    parallel: ParallelConfig | None = None,
    revalidate: Revalidation | None = None,
) -> list[dict[str, Any]]:
    """One row per kept checkpoint of ``run_dir`` (`find_checkpoints`, by epoch):
    ``checkpoint`` (file name), ``epoch``, ``sha256``, its metrics.csv row (recomputed by
    `validation_metrics` when ``revalidate`` is given), and the declutter validation's numbers
    (``declutter_sr``, ``declutter_cr``, their ``_low``/``_high`` bounds, their sum
    ``declutter_sr_cr``, ``declutter_grasps`` …) when ``declutter`` is set or they are cached for the ``validation`` settings. Every
    result is cached in ``run_dir/selection/`` (`select_checkpoint`), a declutter validation
    only when none of its rounds failed: one that did raises `TasksFailed` naming the first
    error (`declutter_validation`), and its failed rounds play again on the next call."""
    run = Path(run_dir)
    checkpoints = find_checkpoints(run)
    rows = _metric_rows(run, checkpoints)
    folder = run / "selection"
    slug = validation.slug
    table = []
    for epoch, path in checkpoints:
        cache = _Cache(folder, path, epoch)
        row: dict[str, Any] = {"checkpoint": path.name, "epoch": epoch, "sha256": cache.sha}
        row.update({k: v for k, v in rows.get(epoch, {}).items() if k not in BOOKKEEPING})
        if revalidate is not None:
            if cache.get("validation", revalidate.key) is None:
                fresh = validation_metrics(
                    path, revalidate.data, datasets=revalidate.datasets,
                    batch_size=revalidate.batch_size, device=revalidate.device,
                )  # fmt: skip
                cache.put("validation", revalidate.key, fresh)
            row.update(cache.get("validation", revalidate.key))
        result = cache.get("declutter", slug)
        if result is not None and result["errors"]:  # cached by an older version: not a value
            result = None
        if result is None and declutter:
            out = folder / "declutter" / slug / cache.id
            result = declutter_validation(
                path.resolve(), out, parallel=parallel, **asdict(validation)
            )
            cache.put("declutter", slug, result)
        if result is not None:
            row.update(_declutter_columns(result))
        table.append(row)
    return table


def checkpoint_id(path: str | Path, sha256: str | None = None) -> str:
    """A checkpoint's name for caches (its declutter validation plays in
    ``selection/declutter/SETTINGS/ID``): its file stem and the start of its SHA-256 (``sha256``
    when known, e.g. from ``selection.json``, else the file's), so that a file overwritten by
    other weights is never taken for the old one."""
    return f"{Path(path).stem}-{(sha256 or file_sha256(path))[:12]}"


@writes_folder(None, "run_dir")
def select_checkpoint(
    run_dir: str | Path,
    by: str,
    *,
    validation: DeclutterValidation = DeclutterValidation(),
    parallel: ParallelConfig | None = None,
    revalidate: Revalidation | None = None,
    copy: bool = True,
) -> dict[str, Any]:
    """Evaluate every kept checkpoint of ``run_dir`` (`checkpoint_measures`), choose the best by
    ``by``, write ``run_dir/selection.csv`` and ``selection.json`` and copy the choice to
    ``best.pt`` (unless ``copy`` is false); returns what ``selection.json`` holds.

    ``by``: ``declutter`` (the declutter validation's SR + CR; ``declutter_sr`` its SR, with the
    higher CR first among ties, ``declutter_cr`` its CR), ``val_loss`` or a column of the run's
    ``metrics.csv`` (`direction` says which way is better). Ties go to the earlier epoch;
    checkpoints whose measure is NaN (no grasp executed) are never chosen. The declutter validation (``validation``'s settings) runs when ``by``
    is a declutter measure; results already cached for these settings are reported either
    way. ``revalidate`` recomputes each checkpoint's validation metrics (`validation_metrics`)
    instead of reading metrics.csv, for metrics added after the run trained.

    Raises ValueError naming the argument (RUN_DIR, --by) before any evaluation starts, and when
    another process holds ``run_dir`` (training it, or selecting in it: one writer at a time,
    `symgrasp.folders.output_folder`).
    """
    measure = ALIASES.get(by, by)
    sign = direction(measure)
    run = Path(run_dir)
    checkpoints = find_checkpoints(run)
    columns = {key for row in _metric_rows(run, checkpoints).values() for key in row}
    columns -= set(BOOKKEEPING)
    if measure not in DECLUTTER_MEASURES and revalidate is None and measure not in columns:
        raise ValueError(
            f"--by: {by!r} is neither declutter, declutter_sr, declutter_cr, val_loss nor a column of "
            f"{run / 'metrics.csv'} or the checkpoints' history "
            f"({', '.join(sorted(columns)) or 'none'}); --revalidate "
            "recomputes the validation metrics, the top-k ones included"
        )
    table = checkpoint_measures(
        run, declutter=measure in DECLUTTER_MEASURES, validation=validation, parallel=parallel,
        revalidate=revalidate,
    )  # fmt: skip
    chosen = choose(table, measure, sign)
    folder = run / "selection" / "declutter" / validation.slug
    selection = {
        "by": measure,
        "better": "higher" if sign > 0 else "lower",
        "chosen": {
            "checkpoint": chosen["checkpoint"], "epoch": chosen["epoch"],
            "value": chosen[measure], "sha256": chosen["sha256"],
        },
        "declutter": {**validation.settings, "folder": str(folder)}
        if measure in DECLUTTER_MEASURES else None,
        "revalidated": revalidate is not None,
        "checkpoints": table,
    }  # fmt: skip
    write_csv(run / "selection.csv", table)
    text = json.dumps(selection, indent=1) + "\n"
    write_atomic(run / "selection.json", lambda file: file.write(text), mode="w")
    if copy:
        _install(run, run / chosen["checkpoint"], selection)
    return selection


def selected_checkpoint(run_dir: str | Path, by: str = "declutter") -> Path:
    """``run_dir/best.pt`` when `select_checkpoint` chose it by ``by`` (default the declutter
    validation); ValueError naming RUN_DIR, and the command that would select it, otherwise
    (a best.pt that training chose by validation loss, or none)."""
    run, measure = Path(run_dir), ALIASES.get(by, by)
    best = run / "best.pt"
    if best.is_file():
        if load_checkpoint(best).get("selection", {}).get("by") == measure:
            return best
    raise ValueError(
        f"RUN_DIR {run}: best.pt was not chosen by {measure}; run "
        f"symgrasp select {run} --by {by} first"
    )


def _declutter_columns(result: dict[str, Any]) -> dict[str, Any]:
    """The declutter validation's numbers as flat columns of selection.csv."""
    columns = {}
    for short, name in (("sr", "success_ratio"), ("cr", "clear_ratio")):
        low, high = result[f"{name}_ci95"]
        columns.update({f"declutter_{short}": result[name], f"declutter_{short}_low": low,
                        f"declutter_{short}_high": high})  # fmt: skip
    columns["declutter_sr_cr"] = columns["declutter_sr"] + columns["declutter_cr"]
    columns.update(declutter_grasps=result["executed"], declutter_rounds=result["rounds"],
                   declutter_errors=result["errors"])  # fmt: skip
    return columns


def _finite(value: Any) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)


def choose(table: list[dict[str, Any]], measure: str, sign: int) -> dict[str, Any]:
    """The row with the best finite ``measure``; ties: higher CR (for declutter_sr), earlier."""
    candidates = [row for row in table if _finite(row.get(measure))]
    if not candidates:
        raise ValueError(
            f"--by: no checkpoint has a value of {measure} (all missing or NaN, e.g. a "
            "declutter validation without an executed grasp)"
        )

    def key(row: dict[str, Any]) -> tuple[float, float, int]:
        second = row.get("declutter_cr") if measure == "declutter_sr" else None
        return (sign * row[measure], second if _finite(second) else -math.inf, -row["epoch"])

    return max(candidates, key=key)


def _install(run: Path, chosen: Path, selection: dict[str, Any]) -> None:
    """Copy ``chosen`` to ``run/best.pt`` with the choice recorded in it (``"selection"``) and
    without the optimizer's state, which only resuming training reads (from ``last.pt``): a
    third of the file, so that a campaign's bank keeps a selected run for 0.9 MB, not 2.7.
    Atomically. A best.pt that training chose by validation loss is kept once, as
    ``best_val_loss.pt``."""
    best = run / "best.pt"
    if best.is_file() and not (run / "best_val_loss.pt").exists():
        previous = load_checkpoint(best)
        if "selection" not in previous:
            save_checkpoint(run / "best_val_loss.pt", previous)
    state = load_checkpoint(chosen)
    state.pop("optimizer", None)
    state["selection"] = {key: value for key, value in selection.items() if key != "checkpoints"}
    save_checkpoint(best, state)
