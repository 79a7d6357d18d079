"""The recipe study: each training factor against the baseline recipe, per training seed, on
declutter rounds no checkpoint was chosen by → experiments/results/recipe.{json,md}.

    PYTHONPATH=src SYMGRASP_DATA=DIR python experiments/recipe.py --runs ROOT/runs \\
        [--factor NAME=RUN,RUN ...] [--flags NAME=OPTIONS ...] [--rounds 400] [--seed 2000000]
        [--workers 2] [--quick [DIR]]

Every run has been selected first (``symgrasp select RUN --by declutter``: its best.pt is the
checkpoint with the best declutter validation SR + CR, 200 rounds on training objects from seed
1 000 000). Choosing the best of several noisy validations flatters the winner, so each run's
best.pt is judged again on **other** rounds: ``--rounds`` rounds of 5 ``--objects`` (training
objects, default vgn-pile-train) from ``--seed`` (2 000 000), the same rounds for every run
(`symgrasp.benchmark.selection.declutter_validation`: test sets and seeds are refused). Each
factor's runs (one per training seed, named ``…-sN``) are compared with the baseline's run of
the same seed on those rounds, paired round by round (`symgrasp.benchmark.compare`).

The rule fixed before any run was judged (docs/model.md, "The recipe"): a factor is adopted
when, for **every** training seed, its paired SR and CR changes sum to more than zero. With
``--flags`` (each factor's options of ``symgrasp train``), the adopted factors' options are
written to ``RESULT.flags``, one line, for the final runs to train with (stage 3 of the plan).
``--quick``: the shipped Robotiq model stands in for two runs (a baseline and a factor), one
round of one object of household-train.
"""

from __future__ import annotations

import argparse
import re
from dataclasses import asdict
from pathlib import Path
from typing import Any

from common import SHIPPED, add_approach_check, add_result_option
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.atomic import write_atomic
from symgrasp.benchmark import selection as sel
from symgrasp.benchmark.compare import paired_change, paired_rounds, percent_change
from symgrasp.cli.options import approach_check
from symgrasp.config import JUDGE_SEED
from symgrasp.detect.pretrained import shipped_path
from symgrasp.parallel.options import add_parallel_options, parallel_from_args

FACTORS = {
    "baseline": ("lc-7200-s0", "base-s1"),
    "cosine": ("cosine-s0", "cosine-s1"),
    "ema": ("ema-s0", "ema-s1"),
    "focal": ("focal-s0", "focal-s1"),
    "batch16": ("batch16-s0", "batch16-s1"),
}
"""Default factors: their runs in ``experiments/campaigns/robust_training.toml`` (stage 2)."""

QUICK_FACTORS = {"baseline": ("a-s0",), "other": ("b-s0",)}
QUICK_FLAGS = {"other": "--ema 0.999"}


def training_seed(run: str) -> int:
    """The training seed in a run's name (``…-sN``); ValueError naming --factor otherwise."""
    match = re.search(r"-s(\d+)$", run)
    if not match:
        raise ValueError(f"--factor: run {run!r} does not end in -sN, its training seed")
    return int(match.group(1))


def parse_factor(text: str) -> tuple[str, tuple[str, ...]]:
    """``NAME=RUN,RUN`` → (name, runs)."""
    name, _, runs = text.partition("=")
    if not name or not runs:
        raise argparse.ArgumentTypeError(f"--factor: expected NAME=RUN,RUN, got {text!r}")
    return name, tuple(runs.split(","))


def parse_flags(text: str) -> tuple[str, str]:
    """``NAME=OPTIONS`` → (name, options)."""
    name, _, options = text.partition("=")
    if not name or not options.strip():
        raise argparse.ArgumentTypeError(f"--flags: expected NAME=OPTIONS, got {text!r}")
    return name, options.strip()


def adopted_flags(verdicts: dict[str, dict[str, Any]], flags: dict[str, str]) -> str:
    """The training options of the adopted factors, in the factors' order, one line."""
    return " ".join(flags[factor] for factor, v in verdicts.items() if v["adopted"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", default="runs", help="folder of the training runs")
    parser.add_argument("--factor", type=parse_factor, action="append", default=None,
                        help="NAME=RUN,RUN: a factor's runs, one per training seed; the first "
                        "factor is the baseline (default: the stage-2 runs of "
                        "robust_training.toml, "
                        + " ".join(f"{f}={','.join(r)}" for f, r in FACTORS.items()) + ")")  # fmt: skip
    parser.add_argument("--flags", type=parse_flags, action="append", default=None,
                        help="NAME=OPTIONS: the options of symgrasp train a factor changes, for "
                        "every factor but the baseline; the adopted ones go to RESULT.flags")  # fmt: skip
    parser.add_argument("--objects", default=sel.VALIDATION_OBJECTS,
                        help="judging objects, training ones (default: %(default)s)")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=400, help="judging rounds (default: 400)")
    parser.add_argument("--seed", type=int, default=JUDGE_SEED,
                        help="judging round 0 (default: %(default)s)")  # fmt: skip
    parser.add_argument("--num-objects", type=int, default=5, help="objects per round (default: 5)")
    add_parallel_options(parser, "rounds")
    parser.set_defaults(workers=2)
    parser.add_argument("--out", default="out/bench/recipe", help="judging benchmark folders")
    add_result_option(parser, "recipe")
    add_approach_check(parser)
    args = parse_args(
        parser, outputs=("out", "result"),
        quick={"rounds": 1, "num_objects": 1, "workers": 1, "objects": "household-train"},
        also=f"{SHIPPED} for every run",
    )  # fmt: skip
    factors = dict(args.factor or (QUICK_FACTORS if args.quick else FACTORS).items())
    flags = dict(args.flags or (QUICK_FLAGS.items() if args.quick and not args.factor else ()))
    others = list(factors)[1:]  # the first is the baseline
    missing = [f for f in others if f not in flags]
    if flags and missing:
        parser.error(f"--flags: no options for factor(s) {', '.join(missing)}")
    unknown = [f for f in flags if f not in others]
    if unknown:
        parser.error(
            f"--flags: {', '.join(unknown)} is not a factor other than the baseline "
            f"({', '.join(others) or 'none'})"
        )
    validation = sel.DeclutterValidation(
        objects=args.objects, rounds=args.rounds, seed=args.seed, num_objects=args.num_objects,
        **approach_check(args),
    )  # fmt: skip
    parallel = parallel_from_args(args)
    folders, cells = {}, []
    for factor, runs in factors.items():
        for run in runs:
            checkpoint = (shipped_path(SHIPPED) if args.quick
                          else sel.selected_checkpoint(Path(args.runs) / run))  # fmt: skip
            folder = Path(args.out) / run / f"{sel.checkpoint_id(checkpoint)}-{validation.slug}"
            result = sel.declutter_validation(
                checkpoint, folder, parallel=parallel, **asdict(validation)
            )
            folders[factor, training_seed(run)] = folder
            cells.append({
                "factor": factor, "run": run, "seed": training_seed(run),
                "checkpoint": str(checkpoint), "sr": result["success_ratio"],
                "sr_ci95": result["success_ratio_ci95"], "cr": result["clear_ratio"],
                "cr_ci95": result["clear_ratio_ci95"], "grasps": result["executed"],
                "errors": result["errors"],
            })  # fmt: skip
    baseline = next(iter(factors))
    for cell in cells:
        base = folders.get((baseline, cell["seed"]))
        if cell["factor"] != baseline and base is not None:
            change = paired_change(*paired_rounds(folders[cell["factor"], cell["seed"]], base))
            cell["sr_change"], cell["cr_change"] = change["success_ratio"], change["clear_ratio"]
    verdicts = verdict(cells, baseline)
    for factor, v in verdicts.items():
        v["flags"] = flags.get(factor)
    table = markdown(cells, verdicts, baseline)
    print(table, end="")
    write_result(
        args.result,
        "each training factor against the baseline recipe per training seed, on judging "
        "declutter rounds of training objects (paired by round)",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        judging=asdict(validation),
        baseline=baseline,
        verdicts=verdicts,
    )
    if flags:
        line = adopted_flags(verdicts, flags)
        write_atomic(f"{args.result}.flags", lambda f: f.write(line + "\n"), mode="w")
        print(f"adopted options ({args.result}.flags): {line or '(none)'}")


def verdict(cells: list[dict[str, Any]], baseline: str) -> dict[str, dict[str, Any]]:
    """Per factor: its mean SR/CR change over seeds and whether the rule adopts it (SR + CR
    change above zero for every seed that has a baseline run)."""
    result = {}
    for factor in dict.fromkeys(c["factor"] for c in cells if c["factor"] != baseline):
        mine = [c for c in cells if c["factor"] == factor and "sr_change" in c]
        if not mine:
            continue
        result[factor] = {
            "seeds": [c["seed"] for c in mine],
            "mean_sr_change": sum(c["sr_change"][0] for c in mine) / len(mine),
            "mean_cr_change": sum(c["cr_change"][0] for c in mine) / len(mine),
            "adopted": all(c["sr_change"][0] + c["cr_change"][0] > 0 for c in mine),
        }
    return result


def markdown(cells: list[dict[str, Any]], verdicts: dict[str, Any], baseline: str) -> str:
    def pct(value: float, interval: list[float]) -> str:
        return f"{100 * value:.1f} [{100 * interval[0]:.1f}, {100 * interval[1]:.1f}]"

    def change(triple: list[float] | None) -> str:
        return "–" if triple is None else percent_change(triple)

    text = [
        f"| factor | run (training seed) | SR % [95 % CI] | CR % [95 % CI] | SR + CR | grasps | "
        f"SR − {baseline}, same seed [paired 95 % CI] | CR − {baseline} |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in cells:
        text.append(
            f"| {c['factor']} | {c['run']} ({c['seed']}) | {pct(c['sr'], c['sr_ci95'])} | "
            f"{pct(c['cr'], c['cr_ci95'])} | {100 * (c['sr'] + c['cr']):.1f} | {c['grasps']} | "
            f"{change(c.get('sr_change'))} | {change(c.get('cr_change'))} |"
        )
    text.append("")
    for factor, v in verdicts.items():
        text.append(
            f"- {factor}: mean change over seeds {', '.join(map(str, v['seeds']))}: SR "
            f"{100 * v['mean_sr_change']:+.1f}, CR {100 * v['mean_cr_change']:+.1f} points; "
            f"{'adopted' if v['adopted'] else 'not adopted'} (SR + CR change > 0 for every seed)"
        )
    return "\n".join(text) + "\n" + evidence(cells, verdicts, baseline)


def evidence(cells: list[dict[str, Any]], verdicts: dict[str, Any], baseline: str) -> str:
    """The recipe's evidence as docs/model.md shows it: per factor, its options, the training
    seeds, SR / CR of the baseline's run (before) and of the factor's (after) per seed, the
    paired SR + CR change per seed, and the verdict."""
    if not verdicts:
        return ""
    runs = {(c["factor"], c["seed"]): c for c in cells}
    text = ["", f"| factor | change | training seeds | before ({baseline}): SR / CR % | after: SR / "
            "CR % | SR + CR change, points | adopted |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for factor, v in verdicts.items():
        before, after, change = [], [], []
        for seed in v["seeds"]:
            b, a = runs[baseline, seed], runs[factor, seed]
            before.append(f"{100 * b['sr']:.1f} / {100 * b['cr']:.1f}")
            after.append(f"{100 * a['sr']:.1f} / {100 * a['cr']:.1f}")
            change.append(f"{100 * (a['sr_change'][0] + a['cr_change'][0]):+.1f}")
        text.append(
            f"| {factor} | `{v.get('flags') or '–'}` | {', '.join(map(str, v['seeds']))} | "
            f"{'; '.join(before)} | {'; '.join(after)} | {'; '.join(change)} | "
            f"{'**yes**' if v['adopted'] else 'no'} |"
        )
    return "\n".join(text) + "\n"


if __name__ == "__main__":
    run_main(main)
