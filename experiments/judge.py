"""The final campaign's judging rounds: each run's selected checkpoint on training-object rounds
no choice was made on, and the training seed each model ships →
experiments/results/judge_retrained.{json,md}.

    PYTHONPATH=src python experiments/judge.py --root DIR [--runs NAME ...] [--shipped NAME ...] \\
        [--contrast A B ...] [--objects vgn-pile-train] [--seed 2000000] [--rounds 400] [--num-objects 5] \\
        [--scene pile] [--test NAME] [--quick [DIR]]

``DIR`` is the root of experiments/campaigns/final.toml. Each run ``DIR/runs/MODEL-sS`` (a
model's recipe and data, trained with seed S) was selected by the declutter validation
(``symgrasp select --by declutter``: 200 rounds of training objects from round seed
1 000 000) and its ``best.pt`` played on the judging rounds (``DIR/bench/judge/MODEL-sS``:
``symgrasp bench declutter --objects vgn-pile-train --seed 2000000 --rounds 400``), the same
rounds for every run, off the selection's seeds and off every test seed. Choosing the best of
several noisy validations flatters the winner; these rounds do not.

- per run: SR and CR with 95 % intervals over rounds, SR + CR, executed grasps, the rounds
  that ended because no grasp was found, and its chosen epoch with that epoch's declutter
  validation SR / CR (the winner's numbers, for the curse's size);
- per model: the run with the highest SR + CR on these rounds ships (the rule fixed before
  any final run was trained, docs/models.md), with its seeds' difference paired round by round
  (`symgrasp.benchmark.compare`), which says how much the pick rests on chance;
- ``--shipped NAME``: a model the package ships, judged on the same rounds
  (``DIR/bench/judge/shipped-NAME``: ``symgrasp bench declutter --model NAME``), listed as the
  one-run model ``shipped-NAME``, what a retrained model would replace;
- ``--contrast A B``: model A minus model B on the rounds every run of both finished, SR, CR
  and SR + CR, the change of the means over training seeds with the training seed inside the
  interval (`symgrasp.benchmark.seeds.seed_lead`) and the pairings of seeds in which A's SR is
  ahead; A *beats* B when the SR + CR interval lies above 0, *trails* when below, else
  undecided: the campaigns' rule for an arm replacing another (experiments/campaigns/noback.toml);
- ``--test NAME``: the same tables from each run's test rounds in ``DIR/bench/NAME/RUN`` (e.g.
  links to the Table 1 cells of round seeds 100–199, ``--objects vgn-pile-test --seed 100
  --rounds 100``, ``--scene packed`` for packed scenes), with no pick: test rounds report, they
  never choose.

The script plays nothing: a run not selected, not judged yet, or judged with another ``best.pt``
than its own (selected again since) is listed with the reason, and a model picks only once
every run of it is judged. ``--quick``: the shipped Robotiq model stands in for seeds 0 and 1
of one model, each selected by the real ``symgrasp select`` code and judged on one round of one
``household-train`` object, then collated.
"""

from __future__ import annotations

import argparse
import itertools
import re
import shutil
from pathlib import Path
from typing import Any

from common import SHIPPED, add_result_option, add_round_options, campaign_root
from retrain_ablation import CONDITIONS, clean_folder, ended_none_found
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.atomic import read_json
from symgrasp.benchmark.compare import paired_change, paired_rounds, percent_change
from symgrasp.benchmark.runner import (
    MODEL_SHA,
    SR_PLUS_CR,
    read_rounds,
    recorded_config,
    summarise,
)
from symgrasp.benchmark.seeds import seed_lead
from symgrasp.cli.options import approach_check
from symgrasp.config import JUDGE_SEED, BenchmarkConfig
from symgrasp.detect.pretrained import PRETRAINED, shipped_path
from symgrasp.digest import file_sha256

RUNS = tuple(f"{model}-{rep}-s{seed}" for model in ("wide", "dense-franka")
             for rep in ("bingham2d", "rotmat6d") for seed in (0, 1))  # fmt: skip
"""The final campaign's runs: the Robotiq's (``wide``) and the Franka's (``dense-franka``)."""
RUN_NAME = re.compile(r"(.+)-s(\d+)")
"""``MODEL-sS``: a run's folder name, its model and training seed."""
SHIPPED_PREFIX = "shipped-"
"""``shipped-NAME``: the judging rounds' folder and the model of the shipped model ``NAME``."""


def parse_run(text: str) -> tuple[str, int]:
    """``MODEL-sS`` → (model, training seed)."""
    match = RUN_NAME.fullmatch(text)
    if not match:
        raise argparse.ArgumentTypeError(
            f"--runs: expected MODEL-sS (e.g. wide-bingham2d-s0), got {text!r}"
        )
    return match.group(1), int(match.group(2))


def wanted(args: argparse.Namespace) -> dict[str, Any]:
    """The configuration fields the judging rounds must have been played with."""
    return {"objects": args.objects, "scene": args.scene, "num_objects": args.num_objects,
            "rounds": args.rounds, "seed": args.seed, **approach_check(args),
            **CONDITIONS["clean"]}  # fmt: skip


def rounds_folder(run: str, args: argparse.Namespace) -> Path:
    """Where ``run``'s rounds are: its judging rounds, or with ``--test NAME`` its test rounds."""
    return args.root / "bench" / (args.test or "judge") / run


def judged(name: str, args: argparse.Namespace) -> tuple[list[dict] | None, dict[str, Any]]:
    """Run ``name``'s judging rounds in seed order (None until all are there and its own), and
    its record: model, seed, chosen epoch and its validation, or why it has no rounds yet."""
    model, seed = parse_run(name)
    run, folder = args.root / "runs" / name, rounds_folder(name, args)
    record: dict[str, Any] = {"run": name, "model": model, "seed": seed, "folder": str(folder)}
    selected, why = clean_folder(run)
    if selected is None:
        return None, {**record, "missing": why}
    selection = read_json(run / "selection.json", "selection record", dict, ("chosen",))
    chosen = selection["chosen"]
    row = next((r for r in selection.get("checkpoints", [])
                if r.get("checkpoint") == chosen["checkpoint"]), {})  # fmt: skip
    record.update(epoch=chosen["epoch"], validation_sr=row.get("declutter_sr"),
                  validation_cr=row.get("declutter_cr"))  # fmt: skip
    played = folder / MODEL_SHA  # absent in folders from before the record: taken as they are
    if played.exists() and played.read_text().strip() != file_sha256(run / "best.pt"):
        return None, {
            **record,
            "missing": "judged another best.pt than the run's (selected again since?)",
        }
    return judging_rounds(folder, record, args)


def judging_rounds(
    folder: Path, record: dict[str, Any], args: argparse.Namespace
) -> tuple[list[dict] | None, dict[str, Any]]:
    """The judging rounds in ``folder`` in seed order (None, and why in ``record``, unless all
    were played with the wanted settings)."""
    recorded = recorded_config(folder)
    if recorded is None:
        return None, {**record, "missing": "not judged"}
    differ = sorted(k for k, v in wanted(args).items() if recorded[k] != v)
    if differ:
        return None, {**record, "missing": f"holds other rounds (its {', '.join(differ)} differ)"}
    done = read_rounds(folder / "rounds.jsonl")
    seeds = range(args.seed, args.seed + args.rounds)
    if not all(s in done for s in seeds):
        return None, {
            **record,
            "missing": f"{sum(s in done for s in seeds)} of {args.rounds} rounds judged",
        }
    return [done[s] for s in seeds], record


def judged_shipped(name: str, args: argparse.Namespace) -> tuple[list[dict] | None, dict]:
    """The shipped model ``name``'s judging rounds, as `judged`'s for a one-run model."""
    model = SHIPPED_PREFIX + name
    folder = rounds_folder(model, args)
    record: dict[str, Any] = {"run": model, "model": model, "seed": None, "folder": str(folder)}
    played = folder / MODEL_SHA
    if played.exists() and played.read_text().strip() != file_sha256(shipped_path(name)):
        return None, {**record, "missing": f"judged another {name} than the one shipped now"}
    return judging_rounds(folder, record, args)


def numbers(rounds: list[dict]) -> dict[str, Any]:
    """A run's judging numbers (`summarise`'s, and the rounds no grasp was found in)."""
    summary = summarise(rounds)
    return {
        **{k: summary[k] for k in ("success_ratio", "success_ratio_ci95", "clear_ratio",
                                   "clear_ratio_ci95", "executed", "rounds", "errors")},
        SR_PLUS_CR: summary["success_ratio"] + summary["clear_ratio"],
        "ended_none_found": ended_none_found(rounds),
    }  # fmt: skip


def picks(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per model: the run that ships (highest SR + CR) once all its runs are judged, and the
    paired difference of every two of its seeds on the rounds both finished."""
    result = []
    for model in dict.fromkeys(r["model"] for r in runs if r["seed"] is not None):
        mine = [r for r in runs if r["model"] == model]
        entry: dict[str, Any] = {"model": model, "runs": [r["run"] for r in mine]}
        waiting = [r["run"] for r in mine if "missing" in r]
        if waiting:
            result.append({**entry, "waiting": waiting})
            continue
        entry["ships"] = max(mine, key=lambda r: (r[SR_PLUS_CR], -r["seed"]))["run"]
        entry["seed_differences"] = [
            {"run": a["run"], "minus": b["run"],
             **paired_change(*paired_rounds(a["folder"], b["folder"]))}
            for a, b in itertools.combinations(mine, 2)
        ]  # fmt: skip
        result.append(entry)
    return result


def contrasts(
    runs: list[dict[str, Any]], rounds: dict[str, list[dict]], pairs: list[list[str]]
) -> list[dict[str, Any]]:
    """Each pair's model A minus model B (`seed_lead` on the judging rounds), with the verdict of
    its SR + CR interval; waiting while a run of either has no rounds yet."""
    result = []
    for a, b in pairs:
        entry: dict[str, Any] = {"a": a, "b": b}
        mine = {m: [r["run"] for r in runs if r["model"] == m] for m in (a, b)}
        waiting = [n for m in (a, b) for n in mine[m] if n not in rounds]
        if waiting:
            result.append({**entry, "waiting": waiting})
            continue
        lead = seed_lead([rounds[n] for n in mine[a]], [rounds[n] for n in mine[b]])
        _, low, high = lead["change"][SR_PLUS_CR]
        verdict = "beats" if low > 0 else "trails" if high < 0 else "undecided"
        result.append({**entry, **lead, "verdict": verdict})
    return result


def markdown(
    runs: list[dict[str, Any]],
    picked: list[dict[str, Any]],
    contrasted: list[dict[str, Any]],
    args: argparse.Namespace,
) -> str:
    def pct(value: float, interval: list[float]) -> str:
        return f"{100 * value:.1f} [{100 * interval[0]:.1f}, {100 * interval[1]:.1f}]"

    def validation(run: dict[str, Any]) -> str:
        if run.get("validation_sr") is None:
            return "–"
        return f"{100 * run['validation_sr']:.1f} / {100 * run['validation_cr']:.1f}"

    first, last = (f"{s:,}".replace(",", " ") for s in (args.seed, args.seed + args.rounds - 1))
    what = f"test rounds (`{args.test}`, no pick made on them)" if args.test else "judging rounds"
    lines = [
        f"{args.rounds} {what} of {args.num_objects} `{args.objects}` objects, {args.scene} "
        f"scenes (round seeds {first}–{last}), clean, the same rounds for every run:",
        "",
        "| run | chosen epoch | declutter validation SR / CR % | SR % [95 % CI] | CR % [95 % CI] "
        "| SR + CR | grasps | rounds ended with no grasp found |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for run in runs:
        if "missing" in run:
            lines.append(f"| {run['run']} | {run.get('epoch', '–')} | {validation(run)} | "
                         f"{run['missing']} | | | | |")  # fmt: skip
            continue
        lines.append(
            f"| {run['run']} | {run.get('epoch', '–')} | {validation(run)} | "
            f"{pct(run['success_ratio'], run['success_ratio_ci95'])} | "
            f"{pct(run['clear_ratio'], run['clear_ratio_ci95'])} | "
            f"{100 * run[SR_PLUS_CR]:.1f} | {run['executed']} | {run['ended_none_found']} |"
        )
    if picked:
        lines += ["", "| model | ships (highest SR + CR) | seeds' difference, paired: SR | CR |",
                  "|---|---|---|---|"]  # fmt: skip
    for pick in picked:
        if "waiting" in pick:
            lines.append(f"| {pick['model']} | waiting for {', '.join(pick['waiting'])} | | |")
            continue
        for i, d in enumerate(pick["seed_differences"] or [None]):
            ships = pick["ships"] if i == 0 else ""
            if d is None:
                lines.append(f"| {pick['model']} | {ships} | one seed | |")
                continue
            lines.append(f"| {pick['model']} | {ships} | {d['run']} − {d['minus']}: "
                         f"{percent_change(d['success_ratio'])} | {percent_change(d['clear_ratio'])} |")  # fmt: skip
    if contrasted:
        lines += ["", "Model A minus model B on the same rounds: change of the means over "
                  "training seeds [95 %, seeds and rounds]; A beats B when the SR + CR interval "
                  "lies above 0:", "",
                  "| A − B | rounds | SR | CR | SR + CR | A's SR ahead in | verdict |",
                  "|---|---|---|---|---|---|---|"]  # fmt: skip
    for c in contrasted:
        if "waiting" in c:
            lines.append(f"| {c['a']} − {c['b']} | waiting for {', '.join(c['waiting'])} "
                         "| | | | | |")  # fmt: skip
            continue
        change = c["change"]
        lines.append(f"| {c['a']} − {c['b']} | {c['rounds']} | "
                     f"{percent_change(change['success_ratio'])} | "
                     f"{percent_change(change['clear_ratio'])} | "
                     f"{percent_change(change[SR_PLUS_CR])} | "
                     f"{c['ahead']} of {len(c['pairings'])} | {c['verdict']} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def quick_root(root: Path, args: argparse.Namespace) -> None:
    """Two runs of one model with the shipped model as each one's checkpoint, selected by the
    declutter validation and judged on ``args``' rounds (what final.toml's steps do)."""
    from symgrasp.benchmark.runner import run_or_reuse
    from symgrasp.benchmark.selection import DeclutterValidation, select_checkpoint

    validation = DeclutterValidation(objects=args.objects, rounds=args.rounds,
                                     num_objects=args.num_objects,
                                     **approach_check(args))  # fmt: skip
    for name in args.runs:
        run = root / "runs" / name
        run.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(shipped_path(SHIPPED), run / "epoch_001.pt")
        select_checkpoint(run, "declutter", validation=validation)
        config = BenchmarkConfig(model=str(run / "best.pt"), objects=args.objects,
                                 rounds=args.rounds, seed=args.seed, num_objects=args.num_objects,
                                 **approach_check(args))  # fmt: skip
        run_or_reuse(config, root / "bench" / "judge" / name)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=None,
                        help="the final campaign's root (campaign.py run experiments/campaigns/"
                        "final.toml --root DIR): runs in DIR/runs, judging rounds in "
                        "DIR/bench/judge")  # fmt: skip
    parser.add_argument("--runs", nargs="+", default=list(RUNS), metavar="MODEL-sS",
                        help="the runs judged (default: %(default)s)")  # fmt: skip
    parser.add_argument("--shipped", nargs="+", default=[], choices=sorted(PRETRAINED),
                        metavar="NAME",
                        help="shipped models judged on the same rounds, in "
                        "DIR/bench/judge/shipped-NAME, listed as the models shipped-NAME "
                        "(default: none)")  # fmt: skip
    parser.add_argument("--contrast", nargs=2, action="append", default=[], metavar=("A", "B"),
                        help="model A minus model B (MODEL of the runs' MODEL-sS, or "
                        "shipped-NAME), paired on the rounds, the training seed inside the "
                        "interval; repeat for more (default: none)")  # fmt: skip
    add_round_options(parser, JUDGE_SEED, 400, "the judging rounds")
    parser.add_argument("--scene", choices=("pile", "packed"), default="pile",
                        help="scene of the rounds read (default: %(default)s)")  # fmt: skip
    parser.add_argument("--test", default=None, metavar="NAME",
                        help="read each run's rounds from DIR/bench/NAME/RUN instead of its "
                        "judging rounds: test rounds, only reported: no model's pick is made "
                        "on them, as no choice is made on test rounds (default: the judging "
                        "rounds, and each model's pick)")  # fmt: skip
    add_result_option(parser, "judge_retrained")
    args = parse_args(parser, outputs=("result",),
                      quick={"rounds": 1, "num_objects": 1, "objects": "household-train",
                             "runs": ["quick-bingham2d-s0", "quick-bingham2d-s1"]},
                      also=f"{SHIPPED} for two runs, selected and judged under DIR/final")  # fmt: skip
    for name in args.runs:
        try:
            parse_run(name)
        except argparse.ArgumentTypeError as error:
            parser.error(str(error))
    models = {parse_run(n)[0] for n in args.runs} | {SHIPPED_PREFIX + n for n in args.shipped}
    for pair in args.contrast:
        for model in pair:
            if model not in models:
                parser.error(f"--contrast: {model!r} is none of the models judged: "
                             f"{', '.join(sorted(models))}")  # fmt: skip
    campaign_root(parser, args, "final", quick_root)

    runs, rounds = [], {}
    for name in args.runs:
        played, record = judged(name, args)
        runs.append(record if played is None else {**record, **numbers(played)})
        if played is not None:
            rounds[name] = played
    for name in args.shipped:
        played, record = judged_shipped(name, args)
        runs.append(record if played is None else {**record, **numbers(played)})
        if played is not None:
            rounds[record["run"]] = played
    picked = [] if args.test else picks(runs)
    contrasted = contrasts(runs, rounds, args.contrast)
    table = markdown(runs, picked, contrasted, args)
    print(table, end="")
    write_result(
        args.result,
        f"The final campaign's runs on the test rounds {args.test} (reported, no pick)"
        if args.test
        else "The final campaign's runs on the judging rounds (training objects, "
        "no choice made on them): SR / CR per run and the training seed each model ships "
        "(highest SR + CR)",
        command_line("PYTHONPATH=src"),
        runs,
        table,
        picks=picked,
        contrasts=contrasted,
        judging=wanted(args),
    )


if __name__ == "__main__":
    run_main(main)
