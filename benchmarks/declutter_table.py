"""The paper's Table 1 on symgrasp's simulator → benchmarks/results/declutter.{json,md}.

    PYTHONPATH=src python benchmarks/declutter_table.py [--runs runs] [--out out/bench]
        [--rounds 100] [--num-objects 5] [--workers 2] [--backend ray [--ray-address HOST:PORT]] [--collate-only] [--quick [DIR]]

Runs `symgrasp bench declutter` (`symgrasp.benchmark.runner.run_benchmark`, failure modes
on) for every representation × gripper × object set, plus ``bingham2d`` without
its confidence threshold. ``bingham2d`` is the shipped model of each gripper; the baselines
are the checkpoints ``--runs/REP-<robotiq|franka>/best.pt`` that ``symgrasp train --rep REP``
wrote (commands in docs/results.md). A cell whose run is missing or unfinished is listed as –;
a cell whose ``--out`` folder already holds the same configuration's diagnosed results is
read, not rerun, so the script resumes after an interruption and fills cells as runs finish.
Household cells are also broken down by the family of the object each grasp was aimed at.
The collated table (with the paper's numbers beside ours) goes to ``--result`` and into
``--docs`` (between its markers), a bar chart to ``--figure``. ``--quick`` plays the shipped
models' cells only, one round of one object each, lists the baselines as –, and updates a copy
of the page.
"""

from __future__ import annotations

import argparse
import itertools
import shutil
from pathlib import Path
from typing import Any

import torch
from common import parse_args, write_result

from symgrasp.benchmark.failures import MODES
from symgrasp.benchmark.runner import (
    BenchmarkConfig,
    percent_with_interval,
    run_or_reuse,
    saved_rounds,
    summarise,
)
from symgrasp.cli import add_parallel_options, parallel_from_args
from symgrasp.config import ParallelConfig

GRIPPERS = {"robotiq-2f85": "robotiq", "franka": "franka"}
OBJECTS = ("household-test", "large-box")
ROWS = (  # (representation, confidence threshold on)
    ("bingham2d", True),
    ("bingham2d", False),
    ("rotmat6d", True),
    ("quaternion", True),
    ("bingham3d", True),
)
PAPER = {  # Table 1 of the paper, SR / CR [%], on its own simulator and objects
    ("robotiq-2f85", "bingham2d", True): {"household-test": (79.0, 76.6), "large-box": (62.9, 70.6)},
    ("robotiq-2f85", "bingham2d", False): {"household-test": (73.7, 74.9), "large-box": (54.3, 59.9)},
    ("robotiq-2f85", "rotmat6d", True): {"household-test": (65.5, 70.2), "large-box": (46.1, 52.0)},
    ("robotiq-2f85", "quaternion", True): {"household-test": (58.3, 62.4), "large-box": (22.2, 24.6)},
    ("robotiq-2f85", "bingham3d", True): {"household-test": (45.6, 47.4), "large-box": (16.4, 17.5)},
    ("franka", "bingham2d", True): {"household-test": (63.1, 64.9), "large-box": (67.7, 80.6)},
    ("franka", "bingham2d", False): {"household-test": (63.6, 66.6), "large-box": (66.2, 79.4)},
    ("franka", "rotmat6d", True): {"household-test": (58.7, 63.8), "large-box": (48.7, 57.5)},
    ("franka", "quaternion", True): {"household-test": (47.8, 48.2), "large-box": (38.5, 48.4)},
    ("franka", "bingham3d", True): {"household-test": (39.1, 39.8), "large-box": (20.5, 23.4)},
}  # fmt: skip


def model_for(gripper: str, rep: str, runs: Path) -> str | None:
    """The model of a cell: the shipped ``bingham2d``, or the baseline's training run once it
    has run all its epochs (None before)."""
    if rep == "bingham2d":
        return f"bingham2d-{gripper}"
    run = runs / f"{rep}-{GRIPPERS[gripper]}"
    if not (run / "last.pt").exists():
        return None
    last = torch.load(run / "last.pt", map_location="cpu", weights_only=False)
    return str(run / "best.pt") if last["epoch"] >= last["config"]["epochs"] else None


def cell(
    config: BenchmarkConfig, out: Path, parallel: ParallelConfig, collate_only: bool
) -> dict | None:
    """The summary of one cell: read when ``out`` holds it, else run (unless collating)."""
    rounds = saved_rounds(config, out)
    if rounds is None and not collate_only:
        rounds = run_or_reuse(config, out, parallel)
    return None if rounds is None else summarise(rounds, config.seed)


def label(rep: str, threshold: bool) -> str:
    """A table row's name."""
    return f"`{rep}`" + ("" if threshold else ", no threshold")


def markdown(rows: list[dict[str, Any]]) -> str:
    """One table per gripper, the paper's numbers beside ours."""
    text = []
    for gripper in GRIPPERS:
        text += [
            f"### {gripper}\n",
            "| representation | household-test SR | household-test CR | large-box SR | "
            "large-box CR | paper household SR / CR | paper large box SR / CR |",
            "|---|---|---|---|---|---|---|",
        ]
        for rep, threshold in ROWS:
            cells = {r["objects"]: r for r in rows if r["key"] == [gripper, rep, threshold]}
            ours = []
            for objects in OBJECTS:
                summary = cells.get(objects, {}).get("summary")
                ours += [percent_with_interval(summary, n) for n in ("success_ratio", "clear_ratio")] if summary else ["–", "–"]  # fmt: skip
            paper = PAPER[(gripper, rep, threshold)]
            theirs = [f"{paper[o][0]} / {paper[o][1]}" for o in OBJECTS]
            text.append(f"| {label(rep, threshold)} | " + " | ".join(ours + theirs) + " |")
        text += ["", f"Attempts by mode ({gripper}; `symgrasp.benchmark.failures`):", ""]
        text += ["| representation | objects | " + " | ".join(MODES) + " | wrong yaw / executed |",
                 "|---|---|" + "---|" * (len(MODES) + 1)]  # fmt: skip
        for row in rows:
            if row["key"][0] == gripper and row["summary"] and row["summary"]["modes"]:
                modes, executed = row["summary"]["modes"], row["summary"]["executed"]
                counts = [str(modes.get(mode, 0)) for mode in MODES]
                share = f"{modes.get('wrong_yaw', 0) / executed:.0%}" if executed else "–"
                text.append(
                    f"| {label(*row['key'][1:])} | {row['objects']} | "
                    + " | ".join(counts)
                    + f" | {share} |"
                )
        text += ["", *family_table(rows, gripper), ""]
    return "\n".join(text)


def family_table(rows: list[dict[str, Any]], gripper: str) -> list[str]:
    """Household-test grasps per aimed-at object family: SR and wrong-yaw share of the
    executed grasps (their count in brackets) for each representation with its threshold."""
    cells = {r["key"][1]: r["summary"]["families"] for r in rows
             if r["key"][0] == gripper and r["key"][2] and r["objects"] == "household-test"
             and r["summary"] and "families" in r["summary"]}  # fmt: skip
    if not cells:
        return []
    text = [f"Household-test grasps by the family of the object aimed at ({gripper}): success "
            "ratio / wrong-yaw share of executed grasps, [executed]:", "",
            "| family | " + " | ".join(f"`{rep}`" for rep in cells) + " |",
            "|---|" + "---|" * len(cells)]  # fmt: skip
    for family in sorted({f for families in cells.values() for f in families}):
        entries = []
        for families in cells.values():
            n = families.get(family, {"executed": 0, "successes": 0, "wrong_yaw": 0})
            shares = [f"{n[k] / n['executed']:.0%}" if n["executed"] else "–"
                      for k in ("successes", "wrong_yaw")]  # fmt: skip
            entries.append(f"{shares[0]} / {shares[1]} [{n['executed']}]")
        text.append(f"| {family} | " + " | ".join(entries) + " |")
    return text


def figure(rows: list[dict[str, Any]], path: str | Path, rounds: int, num_objects: int) -> None:
    """Bars of SR and CR with their 95 % intervals per representation, one panel per gripper
    and object set; the paper's values as black ticks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharey=True)
    for (i, gripper), (j, objects) in itertools.product(enumerate(GRIPPERS), enumerate(OBJECTS)):
        ax = axes[i, j]
        for k, (rep, threshold) in enumerate(ROWS):
            row = next(r for r in rows if r["key"] == [gripper, rep, threshold]
                       and r["objects"] == objects)  # fmt: skip
            paper = PAPER[(gripper, rep, threshold)][objects]
            for m, (name, colour) in enumerate((("success_ratio", "C0"), ("clear_ratio", "C1"))):
                x = k + (m - 0.5) * 0.38
                ax.plot([x - 0.17, x + 0.17], [paper[m]] * 2, color="k", lw=2)
                if row["summary"] is None:
                    ax.text(x, 2, "–", ha="center")
                    continue
                value = 100 * row["summary"][name]
                lo, hi = (100 * v for v in row["summary"][f"{name}_ci95"])
                ax.bar(x, value, 0.36, color=colour, yerr=[[value - lo], [hi - value]],
                       capsize=3, label=name.replace("_", " ") if k == 0 else None)  # fmt: skip
        labels = [rep + ("" if threshold else "\nno thr.") for rep, threshold in ROWS]
        ax.set_xticks(range(len(ROWS)), labels, fontsize=8)
        ax.set_title(f"{gripper}, {objects}")
        ax.set_ylim(0, 100)
        ax.grid(axis="y", alpha=0.3)
    axes[0, 0].set_ylabel("%")
    axes[1, 0].set_ylabel("%")
    axes[0, 0].plot([], [], color="k", lw=2, label="the paper (its simulator)")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="lower center", ncol=3, fontsize=9)
    fig.suptitle(
        f"Simulated decluttering, {rounds} rounds of {num_objects} objects, 95 % intervals"
    )
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


BEGIN, END = "<!-- declutter-table: begin -->", "<!-- declutter-table: end -->"


def update_page(page: Path, table: str) -> None:
    """Replace the text between the ``BEGIN`` and ``END`` markers of ``page`` by ``table``."""
    text = page.read_text()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"error: --docs {page} has no {BEGIN} … {END} markers")
    head, rest = text.split(BEGIN, 1)
    page.write_text(f"{head}{BEGIN}\n{table}{END}{rest.split(END, 1)[1]}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", default="runs", help="folder of the baselines' training runs")
    parser.add_argument("--out", default="out/bench", help="folder of the per-cell benchmark runs")
    parser.add_argument("--rounds", type=int, default=100, help="rounds per cell (default: 100)")
    parser.add_argument("--num-objects", type=int, default=5, help="objects per round (default: 5)")
    add_parallel_options(parser, "rounds")
    parser.set_defaults(workers=2)
    parser.add_argument(
        "--collate-only", action="store_true", help="tabulate the cells already run; run none"
    )
    parser.add_argument("--result", default="benchmarks/results/declutter", help="result stem")
    parser.add_argument(
        "--figure", default="docs/figures/declutter_comparison.png", help="bar chart path"
    )
    parser.add_argument(
        "--docs",
        default="docs/results.md",
        help="page whose tables (between the declutter-table markers) are replaced",
    )
    args = parse_args(
        parser,
        outputs=("out", "result", "figure", "docs"),
        quick={"rounds": 1, "num_objects": 1, "workers": 1},
        also=", the shipped models only",
    )
    if args.quick:  # the page's copy, so that its markers are still checked
        shutil.copyfile(parser.get_default("docs"), args.docs)

    rows = []
    for gripper, short in GRIPPERS.items():
        for rep, threshold in ROWS:
            shipped_only = args.quick and rep != "bingham2d"
            model = None if shipped_only else model_for(gripper, rep, Path(args.runs))
            for objects in OBJECTS:
                key = [gripper, rep, threshold]
                if model is None:
                    rows.append({"key": key, "objects": objects, "model": model, "summary": None})
                    continue
                options = () if threshold else (("confidence_threshold", 0.0),)
                config = BenchmarkConfig(
                    model=model,
                    objects=objects,
                    num_objects=args.num_objects,
                    rounds=args.rounds,
                    seed=0,
                    options=options,
                )
                folder = Path(args.out) / short / (rep + ("" if threshold else "-noconf")) / objects
                print(f"{gripper} {rep}{'' if threshold else ' (no threshold)'} on {objects}")
                summary = cell(config, folder, parallel_from_args(args), args.collate_only)
                rows.append({"key": key, "objects": objects, "model": model, "summary": summary})

    table = markdown(rows)
    print(table)
    write_result(
        args.result,
        "declutter comparison: SR / CR per representation, gripper, objects",
        "PYTHONPATH=src python benchmarks/declutter_table.py",
        rows,
        table,
        rounds=args.rounds,
        num_objects=args.num_objects,
        seed=0,
    )
    figure(rows, args.figure, args.rounds, args.num_objects)
    update_page(Path(args.docs), table)


if __name__ == "__main__":
    main()
