"""The retraining campaign's 2 × 2 ablation (issues 36 and 39): today's or dense labels, clean
or noisy wider-view training images (and the noisy ones at the table's depth scale), each
detector on clean images and under noise from GIGA's side view, without and with the robot's
table depth scale → experiments/results/retrain_ablation.{json,md}.

    PYTHONPATH=src python experiments/retrain_ablation.py --root DIR [--arms A ...] \\
        [--seeds 0 1] [--rep bingham2d] [--objects vgn-pile-train] [--seed 1000000] \\
        [--rounds 200] [--num-objects 5] [--quick [DIR]]

``DIR`` is the root of experiments/campaigns/retrain.toml. Its arms (`ARMS`) train the Robotiq
``--rep`` detector on the same scenes with today's labels or dense ones (``--label-spread``) and
with clean images or the ``dex`` noise and cameras over the benchmark's views (``--noise dex
--camera-distance --camera-polar``): ``today``, ``dense``, ``sensing``, ``both``, and
``calibrated``, ``both`` with each noisy training image divided by its table's depth scale
(``--table-scale``), and ``wide``, ``dense`` with the databases' TCP offsets reaching 3 cm
towards the fingertips (``--offset -0.03 0.03``), and ``wide-calibrated``, ``wide`` with ``calibrated``'s images (the
root of experiments/campaigns/final.toml holds those two), each with the training seeds
``--seeds``. Run ``ARM-REP-sS``
(``DIR/runs``) gives three sets of rounds, all on training objects (``--objects``, round seeds ``--seed`` … ``--seed + --rounds − 1``: never a
test round), the same scenes round by round (`CONDITIONS`):

- ``clean``: the declutter validation of its *selected* checkpoint (``symgrasp select --by
  declutter``: ``selection.json`` names it, its rounds are in
  ``selection/declutter/SETTINGS/CHECKPOINT-SHA``), one noiseless image from the fixed camera;
- ``noise-side``: its val-noise benchmark (``DIR/bench/val-noise/ARM-REP-sS``, ``symgrasp bench
  declutter --noise dex --view side``) of its ``best.pt``, whose SHA-256 must be the one the
  folder recorded (a run selected again since would have another);
- ``noise-side-table``: the same with the robot reading each image's depth scale off its
  table before the detector and the collision check see it
  (``DIR/bench/val-noise-table/ARM-REP-sS``, ``--table-scale``), which undoes the noise's
  scale factor: what training cannot see, a whole scene moved along the rays, against what
  it can.

Reported, all on the rounds every compared run finished (`symgrasp.benchmark.seeds`):

- per arm and condition, SR and CR as the mean over training seeds with a 95 % interval over
  seeds, then rounds (hierarchical bootstrap, `seed_ratios`), each seed's value beside it;
- per condition, the paired effects: every arm minus ``today``, ``calibrated`` minus ``both``
  and minus ``dense``, ``wide`` minus ``dense`` and ``wide-calibrated`` minus ``wide``
  (`CONTRASTS`) (`seed_lead`: the change of the means, its
  interval with the training seed inside, and in how many pairings of training seeds the arm's
  SR is ahead), and each 2 × 2 factor's main effect, its
  two arms minus the other two, averaged over the other factor's levels (`seed_contrast`);
- per arm and noisy condition, the robustness gap, that condition − ``clean`` of the same runs
  on the same rounds (one draw of training seeds for both conditions), against issue 39's
  target: within `GAP_TARGET` of clean (met when the whole interval lies above −3 points,
  missed when it lies below, else undecided);
- per arm and condition, the rounds that ended because no grasp was found (the round's last
  attempt is ``none_found``: `symgrasp.benchmark.declutter.run_round` stops there), pooled over
  seeds with a Wilson interval over rounds, against issue 36's target of at most
  `NONE_FOUND_TARGET` (met, missed or undecided by the interval likewise).

The script plays nothing and reads whatever runs exist: a run not trained, not selected, not
validated under noise, or with rounds missing is listed with the reason, and every number says
which seeds it rests on, so it runs as the campaign's results arrive. A folder that holds
rounds of other settings (objects, seeds, rounds, sensing) is listed as unusable, naming them.

``--quick``: the shipped Robotiq model stands in for every run of seed 0 of every arm: copied
into a run folder under DIR as its one checkpoint, selected by the real ``symgrasp select``
code on one round of one ``household-train`` object and played on that round under noise from
the side, then collated.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path
from typing import Any

from common import (
    GAP_TARGET,
    PAPER_HAND,
    SHIPPED,
    add_result_option,
    add_round_options,
    campaign_root,
    percent_mean,
    sensing_gap,
    verdict,
    wilson,
)
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.atomic import read_json
from symgrasp.benchmark.declutter import NONE_FOUND
from symgrasp.benchmark.runner import MODEL_SHA, read_rounds, recorded_config, summarise
from symgrasp.benchmark.seeds import common_rounds, seed_contrast, seed_lead, seed_ratios
from symgrasp.benchmark.selection import ALIASES, checkpoint_id
from symgrasp.cli.options import approach_check
from symgrasp.config import VALIDATION_SEED, BenchmarkConfig
from symgrasp.digest import file_sha256

ARMS = {"today": (False, False, False, False), "dense": (True, False, False, False),
        "sensing": (False, True, False, False), "both": (True, True, False, False),
        "calibrated": (True, True, True, False), "wide": (True, False, False, True),
        "wide-calibrated": (True, True, True, True)}  # fmt: skip
"""Each arm and its factors: (dense labels, sensing in training, training images at the table's
depth scale, database grasps whose TCP reaches 3 cm towards the fingertips). The first four are
the 2 × 2; ``calibrated`` is ``both`` with each noisy training image divided by its table's
depth scale before fusion (``data generate --table-scale``); ``wide`` is ``dense`` with the
databases' TCP offset range widened to −3…+3 cm (``--offset -0.03 0.03``: grasps that reach down
to the table over thin objects lying flat, experiments/thin_objects.py); ``wide-calibrated`` is
``wide`` with ``calibrated``'s images (experiments/campaigns/final.toml's stage 3)."""
FACTORS = ("labels", "sensing", "table_scaled_images", "tip_offsets")
"""The factors' names, in `ARMS`' order."""
FACTORIAL = ("today", "dense", "sensing", "both")
"""The 2 × 2's arms, the only ones the main effects are read from."""
MAIN_EFFECTS = tuple(f for i, f in enumerate(FACTORS) if len({ARMS[a][i] for a in FACTORIAL}) > 1)
"""The factors the 2 × 2 varies (labels and sensing), each with a main effect."""
CONTRASTS = (("calibrated", "both"), ("calibrated", "dense"), ("wide", "dense"),
             ("wide-calibrated", "wide"))  # fmt: skip
"""Pairs compared beside each arm − `BASELINE`: what the table's scale in training changes
(against its uncalibrated twin), each added arm against ``dense``, the recipe it would
replace in the final detectors, and sensing in training on top of the final labels
(``wide-calibrated`` − ``wide``)."""
CONDITIONS = {
    "clean": {"noise": "none", "view": "fixed", "views": 1, "options": [], "table_scale": False},
    "noise-side": {"noise": "dex", "view": "side", "views": 1, "options": [],
                   "table_scale": False},
    "noise-side-table": {"noise": "dex", "view": "side", "views": 1, "options": [],
                         "table_scale": True},
}  # fmt: skip
"""What the cameras saw in each set of a run's rounds (`BenchmarkConfig`'s sensing fields) and
the detector's options, as a benchmark folder records them."""
NOISY = {"noise-side": "val-noise", "noise-side-table": "val-noise-table"}
"""The noisy conditions and the folder of the campaign's benchmarks (``DIR/bench/FOLDER/RUN``)."""
BASELINE = "today"
"""The arm every other one is compared with: today's labels and images."""
NONE_FOUND_TARGET = 0.10
"""Issue 36: at most 10 % of the rounds ended because no grasp was found."""


def run_name(arm: str, rep: str, seed: int) -> str:
    """A run's folder name in the campaign (``ARM-REP-sS``)."""
    return f"{arm}-{rep}-s{seed}"


def wanted(condition: str, args: argparse.Namespace) -> dict[str, Any]:
    """The configuration fields a run's rounds in ``condition`` must have been played with."""
    return {"objects": args.objects, "scene": "pile", "num_objects": args.num_objects,
            "rounds": args.rounds, "seed": args.seed, **approach_check(args),
            **CONDITIONS[condition]}  # fmt: skip


def clean_folder(run: Path) -> tuple[Path | None, str | None]:
    """The folder of the declutter validation of ``run``'s selected checkpoint, or why there is
    none (not trained, not selected, selected by another measure)."""
    if not run.is_dir():
        return None, "not trained"
    if not (run / "selection.json").is_file():
        return None, "not selected"
    selection = read_json(run / "selection.json", "selection record", dict,
                          ("by", "chosen", "declutter"))  # fmt: skip
    if selection["by"] != ALIASES["declutter"] or not selection["declutter"]:
        return None, f"selected by {selection['by']}, not by the declutter validation"
    chosen, settings = selection["chosen"], Path(selection["declutter"]["folder"]).name
    return run / "selection" / "declutter" / settings / checkpoint_id(
        chosen["checkpoint"], chosen["sha256"]
    ), None


def noise_folder(run: Path, root: Path, condition: str) -> tuple[Path | None, str | None]:
    """The benchmark of ``run`` in the noisy ``condition`` in the campaign ``root`` (`NOISY`),
    unless it played another ``best.pt`` than the run's (the run was selected again since):
    then why not."""
    folder = root / "bench" / NOISY[condition] / run.name
    if (folder / MODEL_SHA).is_file() and (run / "best.pt").is_file():
        if (folder / MODEL_SHA).read_text().strip() != file_sha256(run / "best.pt"):
            return None, "played another best.pt than the run's (selected again since?)"
    return folder, None


def rounds_in(
    folder: Path, condition: str, args: argparse.Namespace
) -> tuple[list | None, str | None]:
    """The round records of the benchmark in ``folder`` in seed order when it was played with
    ``condition``'s configuration (`wanted`) and holds every round (failed ones as their
    records), else None and why."""
    recorded = recorded_config(folder)
    if recorded is None:
        return None, "not played"
    differ = sorted(k for k, v in wanted(condition, args).items() if recorded[k] != v)
    if differ:
        return None, f"holds other rounds (its {', '.join(differ)} differ)"
    done = read_rounds(folder / "rounds.jsonl")
    seeds = range(args.seed, args.seed + args.rounds)
    if not all(s in done for s in seeds):
        return None, f"{sum(s in done for s in seeds)} of {args.rounds} rounds played"
    return [done[s] for s in seeds], None


def gather(args: argparse.Namespace) -> tuple[dict[tuple[str, str, int], list], list[dict]]:
    """Every run's rounds in each condition, ``{(arm, condition, seed): rounds}``, and a record
    of each run: its folders (where known) and, per condition, why it has no rounds yet (None
    when it has)."""
    rounds, runs = {}, []
    for arm in args.arms:
        for seed in args.seeds:
            name = run_name(arm, args.rep, seed)
            run = args.root / "runs" / name
            record: dict[str, Any] = {"run": name, "arm": arm, "seed": seed, "missing": {}}
            folders = {"clean": clean_folder(run)}
            folders.update({c: noise_folder(run, args.root, c) for c in NOISY})
            for condition, (folder, reason) in folders.items():
                if folder is not None:
                    record[condition] = str(folder)
                    found, reason = rounds_in(folder, condition, args)
                    if found is not None:
                        rounds[arm, condition, seed] = found
                        record[f"{condition}_errors"] = sum("error" in r for r in found)
                record["missing"][condition] = reason
            runs.append(record)
    return rounds, runs


def arm_runs(
    rounds: dict, arm: str, condition: str, seeds: list[int] | None = None
) -> dict[int, list]:
    """The rounds of each training seed of ``arm`` played in ``condition`` (of ``seeds`` only,
    when given), by seed."""
    return {s: r for (a, c, s), r in sorted(rounds.items())
            if (a, c) == (arm, condition) and (seeds is None or s in seeds)}  # fmt: skip


def ended_none_found(rounds: list[dict]) -> int:
    """The finished rounds whose last attempt found no grasp: those ``none_found`` ended."""
    return sum(1 for r in rounds if "error" not in r and r["attempts"]
               and r["attempts"][-1]["outcome"] == NONE_FOUND)  # fmt: skip


def arm_cell(rounds: dict, arm: str, condition: str) -> dict[str, Any]:
    """One arm in one condition: the seeds played, SR and CR over them (`seed_ratios`), each
    seed's summary, and the rounds ``none_found`` ended against `NONE_FOUND_TARGET`."""
    mine = arm_runs(rounds, arm, condition)
    labels, sensing, table_scaled, tips = ARMS[arm]
    cell: dict[str, Any] = {"arm": arm, "dense_labels": labels, "sensing": sensing,
                            "table_scaled_images": table_scaled, "tip_offsets": tips,
                            "condition": condition, "seeds": sorted(mine)}  # fmt: skip
    if not mine:
        return cell
    cell["ratios"] = seed_ratios(list(mine.values()))
    keys = ("rounds", "executed", "successes", "success_ratio", "clear_ratio")
    cell["per_seed"] = {}
    for s, r in mine.items():
        summary = summarise(r)
        cell["per_seed"][str(s)] = {
            **{k: summary[k] for k in keys},
            "errors": len(summary["errors"]),
            "ended_none_found": ended_none_found(r),
        }
    ended = sum(c["ended_none_found"] for c in cell["per_seed"].values())
    finished = sum(c["rounds"] - c["errors"] for c in cell["per_seed"].values())
    low, high = (max(0.0, v / 100) for v in wilson(ended, finished))  # no −0.0
    cell["none_found"] = {
        "rounds": ended,
        "of": finished,
        "share": ended / finished if finished else float("nan"),
        "ci95": [low, high],
        "target": verdict(low, high, highest=NONE_FOUND_TARGET),
    }
    return cell


def effects(rounds: dict, condition: str) -> list[dict[str, Any]]:
    """In ``condition``, each arm minus `BASELINE` and the `CONTRASTS` (`seed_lead`), and the
    main effects of labels and sensing in the 2 × 2 (`seed_contrast`), on the rounds every run
    they rest on finished; those whose arms have no run yet are left out."""
    by_arm = {arm: list(arm_runs(rounds, arm, condition).values()) for arm in ARMS}
    seeds = {arm: sorted(arm_runs(rounds, arm, condition)) for arm in ARMS}
    out = []
    pairs = [(arm, BASELINE) for arm in ARMS if arm != BASELINE] + list(CONTRASTS)
    for arm, other in pairs:
        if not by_arm[arm] or not by_arm[other]:
            continue
        lead = seed_lead(by_arm[arm], by_arm[other])
        out.append({"effect": f"{arm} − {other}", "condition": condition,
                    "seeds": {arm: seeds[arm], other: seeds[other]},
                    "rounds": lead["rounds"], "change": lead["change"], "ahead": lead["ahead"],
                    "pairings": len(lead["pairings"])})  # fmt: skip
    if all(by_arm[arm] for arm in FACTORIAL):
        arms = list(FACTORIAL)
        shared = common_rounds(*(run for arm in arms for run in by_arm[arm]))
        groups, start = [], 0
        for arm in arms:
            groups.append(shared[start : start + len(by_arm[arm])])
            start += len(by_arm[arm])
        for factor in MAIN_EFFECTS:
            i = FACTORS.index(factor)
            weights = [0.5 if ARMS[arm][i] else -0.5 for arm in arms]
            out.append({"effect": f"{factor} (main effect)", "condition": condition,
                        "seeds": seeds, "rounds": len(shared[0]),
                        "change": seed_contrast(groups, weights)})  # fmt: skip
    return out


def gap(rounds: dict, arm: str, condition: str) -> dict[str, Any] | None:
    """The noisy ``condition`` − ``clean`` of ``arm``'s runs that played both (`sensing_gap`:
    the change of the means over seeds, each seed's own paired change, issue 39's target); None
    when no run played both."""
    seeds = sorted(set(arm_runs(rounds, arm, "clean")) & set(arm_runs(rounds, arm, condition)))
    if not seeds:
        return None
    noisy = list(arm_runs(rounds, arm, condition, seeds).values())
    clean = list(arm_runs(rounds, arm, "clean", seeds).values())
    found = sensing_gap(noisy, clean)
    return {"arm": arm, "condition": condition, "seeds": seeds, "rounds": found["rounds"],
            "change": found["change"],
            "per_seed": dict(zip(map(str, seeds), found["per_run"], strict=True)),
            "target": found["target"]}  # fmt: skip


def _signed(change: list[float]) -> str:
    """A change ``[point, low, high]`` in percentage points, signed."""
    point, low, high = (100 * v for v in change)
    return f"{point:+.1f} [{low:+.1f}, {high:+.1f}]".replace("-", "−")


def markdown(cells: list[dict], effects_: list[dict], gaps: list[dict], runs: list[dict],
             args: argparse.Namespace) -> str:  # fmt: skip
    """The tables: each arm per condition, the effects, the robustness gaps, what is missing."""
    seeds = list(args.seeds)
    text = [
        f"{args.rounds} rounds of {args.num_objects} objects of {args.objects} (round seeds "
        f"{args.seed}–{args.seed + args.rounds - 1}, training objects); `{args.rep}`, training "
        f"seeds {' / '.join(map(str, seeds))}. Mean over training seeds [95 % interval over "
        "seeds and rounds] (each seed's value); rounds ended because no grasp was found, pooled "
        f"over seeds [Wilson 95 % over rounds], against issue 36's ≤ {NONE_FOUND_TARGET * 100:.0f} %:",
        "",
        "| arm | dense labels | sensing in training | images at the table's scale | "
        "TCP offsets to −3 cm | condition | SR % | CR % | ended by none_found |",
        "|---|---|---|---|---|---|---|---|---|",
    ]  # fmt: skip
    for c in cells:
        head = (f"| {c['arm']} | {'yes' if c['dense_labels'] else 'no'} | "
                f"{'yes' if c['sensing'] else 'no'} | "
                f"{'yes' if c['table_scaled_images'] else 'no'} | "
                f"{'yes' if c['tip_offsets'] else 'no'} | {c['condition']} |")  # fmt: skip
        if "ratios" not in c:
            text.append(f"{head} – | – | – |")
            continue
        values = []
        for name in ("success_ratio", "clear_ratio"):
            each = " / ".join(f"{100 * c['per_seed'][str(s)][name]:.1f}" if str(s) in c["per_seed"]
                              else "–" for s in seeds)  # fmt: skip
            values.append(f"{percent_mean(c['ratios'][name])} ({each})")
        n = c["none_found"]
        low, high = n["ci95"]
        values.append(f"{n['rounds']} of {n['of']} ({100 * n['share']:.1f} %) [{100 * low:.1f}, "
                      f"{100 * high:.1f}]: {n['target']}")  # fmt: skip
        text.append(f"{head} {' | '.join(values)} |")
    text += ["", "Effects on the same rounds: change of the means over training seeds [95 %, "
             "seeds and rounds], in points; for one arm against another, the pairings of training "
             "seeds in which its SR is ahead; a main effect is its factor's two arms minus the "
             "other two, averaged over the other factor:", "",
             "| effect | condition | rounds | SR change | CR change | SR ahead in |",
             "|---|---|---|---|---|---|"]  # fmt: skip
    for e in effects_:
        ahead = f"{e['ahead']} of {e['pairings']}" if "ahead" in e else "–"
        text.append(f"| {e['effect']} | {e['condition']} | {e['rounds']} | "
                    f"{_signed(e['change']['success_ratio'])} | "
                    f"{_signed(e['change']['clear_ratio'])} | {ahead} |")  # fmt: skip
    if not effects_:
        text.append("| – | | | | | |")
    text += ["", "Robustness gap, noise + side view (without and with the table's depth scale) − "
             "clean, of the same runs on the same rounds (issue 39: within "
             f"{GAP_TARGET * 100:.0f} points; met when the interval lies above "
             f"−{GAP_TARGET * 100:.0f}):", "",
             "| arm | condition | seeds | rounds | SR gap | CR gap | SR / CR gap per seed | "
             "target |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for g in gaps:
        each = ", ".join(f"s{s}: {100 * v['success_ratio'][0]:+.1f} / "
                         f"{100 * v['clear_ratio'][0]:+.1f}"
                         for s, v in g["per_seed"].items()).replace("-", "−")  # fmt: skip
        text.append(f"| {g['arm']} | {g['condition']} | {' / '.join(map(str, g['seeds']))} | "
                    f"{g['rounds']} | "
                    f"{_signed(g['change']['success_ratio'])} | "
                    f"{_signed(g['change']['clear_ratio'])} | {each} | {g['target']} |")  # fmt: skip
    if not gaps:
        text.append("| – | | | | | | | |")
    missing = [f"{r['run']} ({condition}: {why})" for r in runs
               for condition, why in r["missing"].items() if why]  # fmt: skip
    if missing:
        text += ["", f"Missing ({len(missing)}): " + "; ".join(missing) + "."]
    return "\n".join(text) + "\n"


def quick_root(root: Path, args: argparse.Namespace) -> None:
    """The campaign's outputs for ``args``' runs with the shipped model as every run's one
    checkpoint: each selected by the declutter validation on ``args``' rounds (`wanted`) and
    played on them under noise from the side, without and with the table's depth scale (what
    retrain.toml's steps do)."""
    from symgrasp.benchmark.runner import run_or_reuse
    from symgrasp.benchmark.selection import DeclutterValidation, select_checkpoint
    from symgrasp.detect.pretrained import shipped_path

    validation = DeclutterValidation(objects=args.objects, rounds=args.rounds, seed=args.seed,
                                     num_objects=args.num_objects,
                                     **approach_check(args))  # fmt: skip
    for arm in args.arms:
        for seed in args.seeds:
            name = run_name(arm, args.rep, seed)
            run = root / "runs" / name
            run.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(shipped_path(SHIPPED), run / "epoch_001.pt")
            select_checkpoint(run, "declutter", validation=validation)
            for condition, folder in NOISY.items():
                fields = {k: v for k, v in wanted(condition, args).items() if k != "options"}
                config = BenchmarkConfig(model=str(run / "best.pt"), **fields)
                run_or_reuse(config, root / "bench" / folder / name)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=None,
                        help="the campaign's root (campaign.py run experiments/campaigns/"
                        "retrain.toml --root DIR): runs in DIR/runs, the noisy benchmarks in "
                        "DIR/bench/val-noise and DIR/bench/val-noise-table")  # fmt: skip
    parser.add_argument("--arms", nargs="+", choices=list(ARMS), default=list(ARMS),
                        help="arms collated (default: all: %(choices)s; the main effects need "
                        f"the 2 × 2's four: {', '.join(FACTORIAL)})")  # fmt: skip
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1],
                        help="training seeds of each arm (default: 0 1)")  # fmt: skip
    parser.add_argument("--rep", default="bingham2d",
                        help=f"the arms' representation, ARM-REP-sS (default: %(default)s; the "
                        f"{PAPER_HAND}'s ablation)")  # fmt: skip
    add_round_options(parser, VALIDATION_SEED, 200, "the declutter validation's rounds")
    add_result_option(parser, "retrain_ablation")
    args = parse_args(parser, outputs=("result",),
                      quick={"rounds": 1, "num_objects": 1, "objects": "household-train",
                             "seeds": [0]},
                      also=f"{SHIPPED} for every run, selected and played under DIR/retrain")  # fmt: skip
    campaign_root(parser, args, "retrain", quick_root)

    rounds, runs = gather(args)
    cells = [arm_cell(rounds, arm, condition) for arm in args.arms for condition in CONDITIONS]
    effects_ = [e for condition in CONDITIONS for e in effects(rounds, condition)]
    gaps = [g for arm in args.arms for c in NOISY if (g := gap(rounds, arm, c))]
    table = markdown(cells, effects_, gaps, runs, args)
    print(table, end="")
    write_result(
        args.result,
        "The retraining ablation (issues 36 and 39): today's or dense labels × clean or noisy "
        "wider-view training images, each run's selected checkpoint on clean training-object "
        "rounds and under noise from the side view: SR / CR over training seeds, the paired "
        "effects, the robustness gaps and the rounds no grasp was found in",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        effects=effects_,
        gaps=gaps,
        runs=runs,
        settings={
            "root": str(args.root),
            "rep": args.rep,
            "seeds": list(args.seeds),
            "arms": {arm: dict(zip(FACTORS, ARMS[arm], strict=True)) for arm in args.arms},
            "conditions": {c: wanted(c, args) for c in CONDITIONS},
            "gap_target": GAP_TARGET,
            "none_found_target": NONE_FOUND_TARGET,
        },
    )


if __name__ == "__main__":
    run_main(main)
