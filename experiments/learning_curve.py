"""The learning curve: declutter test SR against the number of training scenes →
experiments/results/learning_curve.{json,md}, docs/figures/learning_curve.png.

    PYTHONPATH=src python experiments/learning_curve.py \\
        [--study experiments/results/selection.json] [--by declutter] [--bench DIR]
        [--quick [DIR]]

Reads the model-selection study (``experiments/selection.py``: every kept checkpoint of each
run with its validation measures and its test SR on vgn-pile-test, 100 rounds) and groups its
runs by the training scenes they used (their ``--train-scenes``; 0 = the whole split). Per
run, the checkpoint ``--by`` chooses (the rule of ``symgrasp select``,
`symgrasp.benchmark.selection`: validation measures only) and that checkpoint's test SR and CR
with their 95 % intervals; beside it the best test SR any checkpoint of the run reached, an
upper bound no selection rule can know; and its SR and CR minus those of the largest run's
choice, paired round by round on the study's test rounds (``--bench``). Nothing here is
trained or played: the study did that. ``--quick`` runs ``selection.py --quick`` into DIR
first and reads its result.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

from common import add_result_option
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.benchmark import selection as sel
from symgrasp.benchmark.compare import paired_change, paired_rounds, percent_change
from symgrasp.model.checkpoint import load_checkpoint


def train_scenes(checkpoint: Path) -> int:
    """The training scenes of the run that wrote ``checkpoint``: its ``--train-scenes`` (0: the
    whole split)."""
    return int(load_checkpoint(checkpoint)["config"].get("train_scenes", 0))


def curve(study: dict[str, Any], by: str, bench: Path) -> list[dict[str, Any]]:
    """One cell per run of ``study``: its size, the checkpoint ``by`` chooses and its test
    numbers, the best test SR of the run, and its SR and CR minus those of the largest run's
    choice on the same test rounds (played by the study into ``bench``), sorted by size."""
    measure = sel.ALIASES.get(by, by)
    sign = sel.direction(measure)
    cells = []
    for path in study["settings"]["runs"]:
        run = Path(path)
        rows = [row for row in study["cells"] if row["run"] == run.name]
        chosen = sel.choose(rows, measure, sign)
        checkpoint = run / chosen["checkpoint"]
        cells.append({
            "run": run.name, "train_scenes": train_scenes(checkpoint),
            "checkpoint": chosen["checkpoint"], "epoch": chosen["epoch"],
            "measure": measure, "value": chosen[measure],
            "test_sr": chosen["test_sr"], "test_sr_ci95": chosen["test_sr_ci95"],
            "test_cr": chosen["test_cr"], "test_grasps": chosen["test_grasps"],
            "best_test_sr": max(row["test_sr"] for row in rows),
            "checkpoints": len(rows),
            "test_folder": str(bench / run.name / sel.checkpoint_id(checkpoint)),
        })  # fmt: skip
    cells.sort(key=lambda c: (c["train_scenes"] or math.inf, c["run"]))
    largest = cells[-1]
    for cell in cells:
        change = paired_change(*paired_rounds(cell["test_folder"], largest["test_folder"]))
        cell["vs_largest"] = {"run": largest["run"], **change}
    return cells


def markdown(cells: list[dict[str, Any]]) -> str:
    text = [
        "| training scenes | run | chosen checkpoint (measure) | test SR % [95 % CI] | "
        "test CR % | grasps | best test SR % of the run | SR / CR change vs "
        f"{cells[-1]['run']} (paired, same rounds) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in cells:
        low, high = (100 * v for v in c["test_sr_ci95"])
        change = " / ".join(
            percent_change(c["vs_largest"][key]) for key in ("success_ratio", "clear_ratio")
        )
        text.append(
            f"| {c['train_scenes'] or 'all'} | {c['run']} | {c['checkpoint']} "
            f"({c['measure']} {c['value']:.3g}) | {100 * c['test_sr']:.1f} [{low:.1f}, "
            f"{high:.1f}] | {100 * c['test_cr']:.1f} | {c['test_grasps']} | "
            f"{100 * c['best_test_sr']:.1f} | {change} |"
        )
    return "\n".join(text) + "\n"


def figure(path: Path, cells: list[dict[str, Any]]) -> None:
    """Test SR of the chosen checkpoints (with intervals) and the runs' best against size."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axis = plt.subplots(figsize=(5.2, 3.4), constrained_layout=True)
    sizes = [c["train_scenes"] or 1 for c in cells]
    ticks = sorted(set(sizes))
    # runs of one size (other training seeds) side by side, named
    shared = {size: [i for i, s in enumerate(sizes) if s == size] for size in ticks}
    for size, members in shared.items():
        for k, i in enumerate(members if len(members) > 1 else []):
            sizes[i] = size * 1.08 ** (k - (len(members) - 1) / 2)
            axis.annotate(cells[i]["run"], (sizes[i], 100 * cells[i]["test_sr"]), fontsize=6,
                          xytext=(3, -8), textcoords="offset points")  # fmt: skip
    sr = [100 * c["test_sr"] for c in cells]
    errors = [[s - 100 * c["test_sr_ci95"][0] for s, c in zip(sr, cells, strict=True)],
              [100 * c["test_sr_ci95"][1] - s for s, c in zip(sr, cells, strict=True)]]  # fmt: skip
    axis.errorbar(sizes, sr, yerr=errors, fmt="o", capsize=3,
                  label=f"checkpoint chosen by {cells[0]['measure']}")  # fmt: skip
    axis.scatter(sizes, [100 * c["best_test_sr"] for c in cells], marker="_", s=120,
                 color="grey", label="best checkpoint of the run (not knowable)")  # fmt: skip
    axis.set_xscale("log")
    axis.set_xticks(ticks, [str(s) for s in ticks])
    axis.set_xticks([], minor=True)  # the log axis' own minor labels collide with the sizes
    axis.set_xlabel("training scenes")
    axis.set_ylabel("declutter SR % (vgn-pile-test)")
    axis.legend(fontsize=7)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", default="experiments/results/selection.json",
                        help="result of experiments/selection.py (default: %(default)s)")  # fmt: skip
    parser.add_argument("--by", default="declutter",
                        help="the selection measure that chooses each run's checkpoint, as "
                        "symgrasp select --by (default: %(default)s)")  # fmt: skip
    parser.add_argument("--bench", default=None,
                        help="the folder the study played its test rounds into (its --out; "
                        "default: the one the study recorded)")  # fmt: skip
    add_result_option(parser, "learning_curve")
    parser.add_argument(
        "--figure",
        default="docs/figures/learning_curve.png",
        help="the picture of the curve (default: %(default)s)",
    )
    args = parse_args(parser, outputs=("result", "figure"), quick={},
                      also="runs selection.py --quick into DIR/study first")  # fmt: skip
    study_path = Path(args.study)
    if args.quick:
        done = subprocess.run([sys.executable, str(Path(__file__).with_name("selection.py")),
                               "--quick", str(args.quick / "study")])  # fmt: skip
        if done.returncode:
            raise SystemExit(done.returncode)
        study_path = args.quick / "study" / "selection.json"
    if not study_path.is_file():
        raise SystemExit(
            f"error: --study {study_path}: no such file (run experiments/selection.py)"
        )
    study = json.loads(study_path.read_text())
    bench = args.bench or study["settings"].get("out")
    if bench is None:
        raise SystemExit(f"error: --study {study_path} records no test folder: give --bench")
    cells = curve(study, args.by, Path(bench))
    table = markdown(cells)
    print(table, end="")
    figure(Path(args.figure), cells)
    write_result(
        args.result,
        "declutter test SR against training scenes, each run's checkpoint chosen by a "
        "validation measure",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        study=str(study_path),
        study_date=study.get("date"),
        test=study["settings"]["test"],
        figure=str(args.figure),
    )


if __name__ == "__main__":
    run_main(main)
