"""Which validation measure ranks checkpoints as the declutter test does → experiments/results/selection.{json,md}, docs/figures/selection.png.

    PYTHONPATH=src SYMGRASP_DATA=DIR python experiments/selection.py \\
        --runs runs/bingham2d-robotiq-seed0 runs/bingham2d-robotiq-seed1 [--revalidate] \\
        [--workers 2] [--backend ray [--ray-address HOST:PORT]] [--quick [DIR]]

The runs are trained with ``symgrasp train … --keep-every N`` so that they keep their
per-epoch checkpoints. For every kept checkpoint of every run (``epoch_NNN.pt``, and
``last.pt`` when its epoch has no file) this script gathers each **candidate measure**
(`symgrasp.benchmark.selection.checkpoint_measures`): the run's metrics.csv row (validation loss,
validity AP, median angles, the top-k metrics; recomputed on the validation split with
``--revalidate``, for runs trained before the top-k metrics existed) and the declutter
validation on **training** objects (``--val-objects`` vgn-pile-train, ``--val-rounds`` 50,
seeds from 1 000 000; cached in ``RUN/selection/``). Then the **test SR**: the declutter
benchmark on ``--test-objects`` (vgn-pile-test), ``--test-rounds`` 100, seeds 0…99, into
``--out/RUN_NAME/CHECKPOINT-HASH`` (read back when finished, resumed when not). Test objects
and seeds are used here only to judge the candidates; this script selects nothing, and
``symgrasp select`` refuses them.

Per candidate: the Spearman rank correlation (scipy) with the test SR over all checkpoints,
signed so that +1 means "orders the checkpoints exactly as the test SR does" (a lower loss
counts as better), with a 95 % bootstrap interval over checkpoints (2 000 resamples); the same
with the test CR and with the test SR + CR; the correlation with the test SR within each run;
and, per run, the test SR and CR of the checkpoint the candidate would choose (and their means
over the runs) next to the best test SR any checkpoint of that run reached. A scatter panel
per candidate (against the test SR) goes to ``--figure``. ``--quick`` makes two 2-checkpoint "runs" from the shipped Robotiq model (itself,
and copies with a shifted validity bias, a perturbed rotation head, a negated score head),
revalidates them on one synthetic scene and plays one round of one object per declutter cell
(household-train for validation, household-test for the test): no VGN meshes, no training.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np
from common import SHIPPED, add_approach_check, add_result_option
from scipy.stats import spearmanr
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.benchmark import selection as sel
from symgrasp.benchmark.runner import BOOTSTRAP, BenchmarkConfig, run_or_reuse, summarise
from symgrasp.cli.options import approach_check
from symgrasp.config import VALIDATION_OBJECTS, VALIDATION_SEED
from symgrasp.parallel.options import add_parallel_options, parallel_from_args


def spearman(x: np.ndarray, y: np.ndarray) -> float:
    """Spearman's ρ of the pairs where both are finite; NaN for fewer than 3 or a constant."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    finite = np.isfinite(x) & np.isfinite(y)
    x, y = x[finite], y[finite]
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return math.nan
    return float(spearmanr(x, y).statistic)


def bootstrap_interval(x: np.ndarray, y: np.ndarray, seed: int = 0) -> list[float]:
    """2.5 and 97.5 percentiles of ρ over checkpoints resampled with replacement (resamples
    where ρ is undefined are left out; NaN when all are)."""
    rng = np.random.default_rng(seed)
    picks = rng.integers(len(x), size=(BOOTSTRAP, len(x)))
    rhos = np.array([spearman(x[p], y[p]) for p in picks])
    rhos = rhos[np.isfinite(rhos)]
    return [float(np.percentile(rhos, q)) for q in (2.5, 97.5)] if len(rhos) else [math.nan] * 2


def candidates(rows: list[dict[str, Any]]) -> list[str]:
    """The measures found in ``rows`` that have a better direction (no training losses)."""
    names = []
    for key in dict.fromkeys(k for row in rows for k in row):
        if key.startswith("train_") or key.endswith(("_low", "_high")):
            continue
        try:
            sel.direction(key)
        except ValueError:
            continue
        if any(isinstance(row.get(key), float) and math.isfinite(row[key]) for row in rows):
            names.append(key)
    return names


def correlations(rows: list[dict[str, Any]], measures: list[str]) -> dict[str, dict[str, Any]]:
    """Per measure: signed ρ with the test SR (all checkpoints, interval, per run), with the
    test CR and with the test SR + CR (all checkpoints, interval), and the test SR and CR of the
    checkpoint it would choose in each run, with their means over the runs."""
    runs = list(dict.fromkeys(row["run"] for row in rows))
    sr = np.array([row["test_sr"] for row in rows], dtype=float)
    cr = np.array([row["test_cr"] for row in rows], dtype=float)
    result = {}
    for measure in measures:
        sign = sel.direction(measure)
        x = sign * np.array([_float(row.get(measure)) for row in rows])
        per_run, picks = {}, {}
        for run in runs:
            mine = [i for i, row in enumerate(rows) if row["run"] == run]
            per_run[run] = spearman(x[mine], sr[mine])
            try:
                pick = sel.choose([rows[i] for i in mine], measure, sign)
            except ValueError:
                continue
            picks[run] = {key: pick[key] for key in ("checkpoint", "test_sr", "test_cr")}
        result[measure] = {
            "better": "higher" if sign > 0 else "lower",
            "spearman": spearman(x, sr),
            "ci95": bootstrap_interval(x, sr),
            **{f"with_{name}": {"spearman": spearman(x, y), "ci95": bootstrap_interval(x, y)}
               for name, y in (("test_cr", cr), ("test_sr_cr", sr + cr))},
            "checkpoints": int((np.isfinite(x) & np.isfinite(sr)).sum()),
            "per_run": per_run,
            "picks": picks,
            "picks_mean": {key: float(np.mean([p[key] for p in picks.values()]))
                           if picks else math.nan for key in ("test_sr", "test_cr")},
        }  # fmt: skip
    return result


def _float(value: Any) -> float:
    return float(value) if isinstance(value, int | float) else math.nan


def markdown(result: dict[str, dict[str, Any]], rows: list[dict[str, Any]]) -> str:
    runs = list(dict.fromkeys(row["run"] for row in rows))
    best = {run: max((_float(r["test_sr"]) for r in rows if r["run"] == run), default=math.nan)
            for run in runs}  # fmt: skip
    text = [
        "| measure | better | ρ with test SR, all checkpoints [95 % CI] | ρ with test CR | "
        "ρ with test SR + CR | ρ with test SR within each run | test SR / CR % of its choice "
        "per run | mean of its choices, SR / CR % |",
        "|---|---|---|---|---|---|---|---|",
    ]
    order = sorted(result, key=lambda m: -_float(result[m]["spearman"]) if
                   math.isfinite(_float(result[m]["spearman"])) else math.inf)  # fmt: skip
    for measure in order:
        r = result[measure]
        lo, hi = r["ci95"]
        within = ", ".join(f"{_fmt(r['per_run'][run])}" for run in runs)
        picked = ", ".join(
            f"{100 * _float(r['picks'][run]['test_sr']):.1f} / "
            f"{100 * _float(r['picks'][run]['test_cr']):.1f}" if run in r["picks"] else "–"
            for run in runs
        )  # fmt: skip
        others = " | ".join(
            f"{_fmt(r[key]['spearman'])} [{_fmt(r[key]['ci95'][0])}, {_fmt(r[key]['ci95'][1])}]"
            for key in ("with_test_cr", "with_test_sr_cr")
        )
        mean = r["picks_mean"]
        text.append(
            f"| {measure} | {r['better']} | {_fmt(r['spearman'])} [{_fmt(lo)}, {_fmt(hi)}] "
            f"(n = {r['checkpoints']}) | {others} | {within} | {picked} | "
            f"{100 * mean['test_sr']:.1f} / {100 * mean['test_cr']:.1f} |"
        )
    text.append("")
    text.append(f"Runs, in order: {', '.join(runs)}; best test SR % per run: "
                + ", ".join(f"{100 * best[run]:.1f}" for run in runs) + ".")  # fmt: skip
    return "\n".join(text) + "\n"


def _fmt(value: float) -> str:
    return f"{value:+.2f}" if math.isfinite(value) else "–"


def figure(path: Path, result: dict[str, dict[str, Any]], rows: list[dict[str, Any]]) -> None:
    """A scatter panel per measure: the measure against the test SR, one colour per run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    measures = list(result)
    columns = min(4, max(1, len(measures)))
    lines = math.ceil(len(measures) / columns) or 1
    fig, axes = plt.subplots(lines, columns, figsize=(3.6 * columns, 3.0 * lines),
                             squeeze=False, constrained_layout=True)  # fmt: skip
    runs = list(dict.fromkeys(row["run"] for row in rows))
    for axis, measure in zip(axes.flat, measures, strict=False):
        for n, run in enumerate(runs):
            mine = [r for r in rows if r["run"] == run]
            axis.scatter([_float(r.get(measure)) for r in mine],
                         [100 * _float(r["test_sr"]) for r in mine],
                         s=16, color=f"C{n}", label=run)  # fmt: skip
        r = result[measure]
        axis.set_title(f"{measure} ({r['better']} better)\nρ = {_fmt(r['spearman'])}",
                       fontsize=9)  # fmt: skip
        axis.set_ylabel("test SR %", fontsize=8)
        axis.tick_params(labelsize=7)
    for axis in list(axes.flat)[len(measures) :]:
        axis.axis("off")
    axes.flat[0].legend(fontsize=7)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def quick_runs(folder: Path) -> list[Path]:
    """Two runs of two checkpoints each, made from the shipped Robotiq model (``--quick``)."""
    import torch

    from symgrasp.detect.pretrained import shipped_path
    from symgrasp.model.checkpoint import load_checkpoint, save_checkpoint

    state = load_checkpoint(shipped_path(SHIPPED))
    generator = torch.Generator().manual_seed(0)

    def changed(how: str) -> dict:
        weights = {k: v.clone() for k, v in state["model"].items()}
        if how == "validity":
            weights["validity_head.bias"] -= 1.0
        elif how == "rotation":
            w = weights["rotation_head.weight"]
            weights["rotation_head.weight"] = w + 0.5 * torch.randn(w.shape, generator=generator)
        elif how == "score":
            weights["score_head.weight"] *= -1
        return weights

    runs = []
    for run_name, variants in (("a", ("shipped", "validity")), ("b", ("rotation", "score"))):
        run = folder / run_name
        for epoch, how in enumerate(variants, start=1):
            path = run / f"epoch_{epoch:03d}.pt"
            if not path.exists():
                save_checkpoint(path, {**state, "epoch": epoch, "model": changed(how)})
        runs.append(run)
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", nargs="+", default=["runs/bingham2d-robotiq-seed0",
                        "runs/bingham2d-robotiq-seed1"],
                        help="run folders holding epoch_NNN.pt checkpoints")  # fmt: skip
    parser.add_argument("--revalidate", action="store_true",
                        help="recompute the validation metrics of every checkpoint")  # fmt: skip
    parser.add_argument("--data", default=None,
                        help="dataset of --revalidate (default: each run's own)")  # fmt: skip
    parser.add_argument(
        "--val-objects",
        default=VALIDATION_OBJECTS,
        help=f"declutter validation objects (default: {VALIDATION_OBJECTS})",
    )
    parser.add_argument(
        "--val-rounds",
        type=int,
        default=sel.VALIDATION_ROUNDS,
        help=f"declutter validation rounds (default: {sel.VALIDATION_ROUNDS})",
    )
    parser.add_argument(
        "--val-seed",
        type=int,
        default=VALIDATION_SEED,
        help=f"declutter validation round 0 (default: {VALIDATION_SEED})",
    )
    parser.add_argument(
        "--test-objects", default="vgn-pile-test", help="test objects (default: vgn-pile-test)"
    )
    parser.add_argument("--test-rounds", type=int, default=100, help="test rounds (default: 100)")
    parser.add_argument("--test-seed", type=int, default=0, help="test round 0 (default: 0)")
    parser.add_argument("--num-objects", type=int, default=5, help="objects per round (default: 5)")
    add_parallel_options(parser, "rounds")
    parser.set_defaults(workers=2)
    parser.add_argument("--out", default="out/bench/selection", help="test benchmark folders")
    add_result_option(parser, "selection")
    parser.add_argument("--figure", default="docs/figures/selection.png", help="scatter figure")
    add_approach_check(parser)
    args = parse_args(
        parser,
        outputs=("out", "result", "figure"),
        quick={"val_rounds": 1, "test_rounds": 1, "num_objects": 1, "workers": 1,
               "val_objects": "household-train", "test_objects": "household-test"},
        also=f"two runs made from {SHIPPED}, revalidated on one synthetic scene",
    )  # fmt: skip

    datasets = None
    runs = [Path(r) for r in args.runs]
    if args.quick:
        from symgrasp.model.synthetic import SyntheticGraspDataset, collate_scenes

        runs = quick_runs(args.quick / "runs")
        datasets = ([SyntheticGraspDataset(1, seed=9)[0]], collate_scenes)  # made once
    parallel = parallel_from_args(args)
    validation = sel.DeclutterValidation(
        objects=args.val_objects, rounds=args.val_rounds, seed=args.val_seed,
        num_objects=args.num_objects, **approach_check(args),
    )  # fmt: skip
    revalidate = args.revalidate or bool(args.quick)
    rows = []
    for run in runs:
        table = sel.checkpoint_measures(
            run, declutter=True, validation=validation, parallel=parallel,
            revalidate=sel.Revalidation(args.data, datasets) if revalidate else None,
        )  # fmt: skip
        for row in table:
            path = run / row["checkpoint"]
            config = BenchmarkConfig(
                model=str(path.resolve()), objects=args.test_objects,
                num_objects=args.num_objects, rounds=args.test_rounds, seed=args.test_seed,
                diagnose=False, **approach_check(args),
            )  # fmt: skip
            folder = Path(args.out) / run.name / sel.checkpoint_id(path)
            test = summarise(run_or_reuse(config, folder, parallel), args.test_seed)
            rows.append({
                "run": run.name, **row, "test_sr": test["success_ratio"],
                "test_sr_ci95": test["success_ratio_ci95"], "test_cr": test["clear_ratio"],
                "test_grasps": test["executed"],
            })  # fmt: skip
            print(f"{run.name} {row['checkpoint']}: test SR {100 * test['success_ratio']:.1f}, "
                  f"declutter validation SR {100 * row.get('declutter_sr', math.nan):.1f}")  # fmt: skip

    measures = candidates(rows)
    result = correlations(rows, measures)
    table = markdown(result, rows)
    print(table, end="")
    figure(Path(args.figure), result, rows)
    settings = {
        "runs": [str(r) for r in runs], "revalidated": revalidate, "out": str(args.out),
        "validation": {"objects": args.val_objects, "rounds": args.val_rounds,
                       "seed": args.val_seed, "num_objects": args.num_objects},
        "test": {"objects": args.test_objects, "rounds": args.test_rounds,
                 "seed": args.test_seed, "num_objects": args.num_objects},
        "bootstrap": BOOTSTRAP,
    }  # fmt: skip
    write_result(
        args.result,
        "how well each candidate selection measure ranks checkpoints as the declutter test SR, "
        "CR and SR + CR do (signed Spearman ρ, bootstrap over checkpoints)",
        command_line("PYTHONPATH=src"),
        rows,
        table,
        settings=settings,
        correlations=result,
        figure=str(args.figure),
    )


if __name__ == "__main__":
    run_main(main)
