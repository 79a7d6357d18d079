"""The paper's Table 1 on VGN's objects with three training seeds per cell, and the field's
pile/packed table → experiments/results/declutter.{json,md}, docs/figures/declutter_comparison.png,
docs/results.md (between its markers) and the rounds behind them,
experiments/results/declutter_rounds.tar.gz.

    PYTHONPATH=src SYMGRASP_DATA=DIR python experiments/declutter_table.py --runs ROOT/runs \\
        [--out ROOT/bench/table] [--grippers G ...] [--reps REP ...] [--seeds 0 1 2] \\
        [--rounds 100] [--first-seed 0] [--workers 2] [--collate-only | --play-only] [--quick [DIR]]

Every cell is one training run (``--runs/PREFIX-REP-sSEED``, the prefix per gripper from
``--prefix``) whose ``best.pt`` the declutter validation chose (``symgrasp select RUN --by
declutter``; training objects and seeds only), playing ``--rounds`` rounds of 5 objects from
round seed ``--first-seed`` (default 0) with failure diagnosis into
``--out/GRIPPER/REP[-noconf]/sSEED/OBJECTS[-packed]`` (`symgrasp.benchmark.cells`; a cell
already there is read, not replayed, so the script resumes and picks up runs as they are
selected; a run not yet selected is listed as waiting).

**Round seeds.** Table 1's rounds are seeds 0–99, which have informed choices since (the
operating point, the recipe, …). ``--first-seed 100`` plays the same cells on seeds 100–199,
test rounds no choice was made on (issue 36): their cells live in folders of their own
(``OBJECTS[-packed]-first-seed-100``), and their result, figure, archive and page markers get
``-first-seed-100`` after the default names, so the two sets of rounds never mix and Table 1's
outputs stay as they are. Every table says which round seeds it reports.

- **Table 1**: per gripper, object set (``--objects``, pile) and representation (the paper's
  five rows: ``bingham2d`` with and without its confidence threshold, ``rotmat6d``,
  ``quaternion``, ``bingham3d``): SR and CR as the mean over training seeds with a 95 %
  interval that includes the seed (hierarchical bootstrap, seeds then rounds;
  `symgrasp.benchmark.seeds`), each seed's value, and the paper's numbers beside them.
- **bingham2d − each other row**, per gripper and object set, on the same rounds: the change of
  the means over seeds with its hierarchical interval, and in how many pairings of training
  seeds ``bingham2d`` is ahead (each pairing paired round by round).
- **Failure modes** per representation, pooled over seeds (`symgrasp.benchmark.failures`).
- **The field's table**: VGN's protocol objects, ``--field`` (``vgn-pile-test`` pile and
  ``vgn-packed-test`` packed) with the ``--field-gripper`` (Franka, VGN's hand), every
  representation with its threshold, and below them the published numbers of VGN, GIGA and
  EdgeGraspNet on those scenes (``PUBLISHED``; how their protocols differ: docs/benchmark.md,
  "Published numbers on VGN's scenes").

A campaign plays each run's cells in a step of its own as soon as the run is selected
(``--play-only --grippers G --reps REP --seeds S``, ``--field`` left empty for a hand that is
not the field's) and collates once at the end (``--collate-only``).

Every collation also packs the rounds it collated into ``--archive``
(experiments/results/declutter_rounds.tar.gz, the same bytes for the same rounds). Unpacked into
``--out``, they collate again on a machine without the training runs, to the same tables and
the same archive::

    mkdir -p out/bench/table && tar xzf experiments/results/declutter_rounds.tar.gz -C out/bench/table
    PYTHONPATH=src python experiments/declutter_table.py --collate-only

``--quick``: the shipped Robotiq model stands in for every run; two seeds, one round of one
household-test object (pile and packed), the Robotiq only, a copy of the page updated.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
from collections import Counter
from pathlib import Path
from typing import Any

from common import (
    GRIPPERS,
    SHIPPED,
    add_approach_check,
    add_mode_options,
    add_result_option,
    update_page,
    write_rounds_archive,
)
from scripts import command_line, output_path, parse_args, run_main, write_result

from symgrasp.benchmark.cells import Cell
from symgrasp.benchmark.compare import percent_change
from symgrasp.benchmark.failures import MODES
from symgrasp.benchmark.runner import recorded_config, run_or_reuse, saved_rounds, summarise
from symgrasp.benchmark.seeds import seed_lead, seed_ratios
from symgrasp.benchmark.selection import selected_checkpoint
from symgrasp.cli.options import approach_check
from symgrasp.detect.pretrained import shipped_path
from symgrasp.parallel.options import add_parallel_options, parallel_from_args
from symgrasp.rotation import get as get_representation

PREFIXES = {"robotiq-2f85": "final", "franka": "final-franka"}
"""The run folders' prefix per gripper (experiments/campaigns/*.toml)."""
REPS = ("bingham2d", "rotmat6d", "quaternion", "bingham3d")
ROWS = (("bingham2d", True), ("bingham2d", False), ("rotmat6d", True), ("quaternion", True),
        ("bingham3d", True))  # fmt: skip
"""Table 1's rows: (representation, confidence threshold on)."""
OBJECTS = ("vgn-pile-test", "large-box")
FIELD = ("vgn-pile-test:pile", "vgn-packed-test:packed")
PAPER = {  # Table 1 of the paper, SR / CR [%], on its own simulator and objects
    ("robotiq-2f85", "bingham2d", True): {"vgn-pile-test": (79.0, 76.6), "large-box": (62.9, 70.6)},
    ("robotiq-2f85", "bingham2d", False): {"vgn-pile-test": (73.7, 74.9), "large-box": (54.3, 59.9)},
    ("robotiq-2f85", "rotmat6d", True): {"vgn-pile-test": (65.5, 70.2), "large-box": (46.1, 52.0)},
    ("robotiq-2f85", "quaternion", True): {"vgn-pile-test": (58.3, 62.4), "large-box": (22.2, 24.6)},
    ("robotiq-2f85", "bingham3d", True): {"vgn-pile-test": (45.6, 47.4), "large-box": (16.4, 17.5)},
    ("franka", "bingham2d", True): {"vgn-pile-test": (63.1, 64.9), "large-box": (67.7, 80.6)},
    ("franka", "bingham2d", False): {"vgn-pile-test": (63.6, 66.6), "large-box": (66.2, 79.4)},
    ("franka", "rotmat6d", True): {"vgn-pile-test": (58.7, 63.8), "large-box": (48.7, 57.5)},
    ("franka", "quaternion", True): {"vgn-pile-test": (47.8, 48.2), "large-box": (38.5, 48.4)},
    ("franka", "bingham3d", True): {"vgn-pile-test": (39.1, 39.8), "large-box": (20.5, 23.4)},
}  # fmt: skip
"""The paper's "VGN Dataset" column is its subset of VGN's meshes; ours is VGN's pile test set."""
PUBLISHED = (  # GSR / DR [%], mean ± SD as reported, 5 objects per round, on VGN's test meshes
    ("GPD", {"pile": ("17.7 ± 2.3", "9.2 ± 1.3"), "packed": ("35.4 ± 1.9", "30.7 ± 2.0")}, "GIGA"),
    ("SHAF", {"pile": ("50.7 ± 1.7", "42.6 ± 2.8"), "packed": ("56.6 ± 2.0", "58.0 ± 3.0")}, "GIGA"),
    ("VGN (single view)", {"pile": ("60.7 ± 4.2", "44.0 ± 4.9"), "packed": ("74.5 ± 1.3", "79.2 ± 2.3")}, "GIGA"),
    ("GIGA-Aff", {"pile": ("67.8 ± 3.0", "49.7 ± 1.9"), "packed": ("77.2 ± 2.3", "78.9 ± 1.7")}, "GIGA"),
    ("GIGA", {"pile": ("69.3 ± 3.3", "49.8 ± 3.9"), "packed": ("83.5 ± 2.4", "84.3 ± 2.2")}, "GIGA"),
    ("GIGA (HR, 60³ queries)", {"pile": ("69.8 ± 3.2", "51.1 ± 2.8"), "packed": ("87.9 ± 3.0", "86.0 ± 3.2")}, "GIGA"),
    ("GIGA-High", {"pile": ("74.1 ± 1.5", None), "packed": ("88.5 ± 2.0", None)}, "EGN"),
    ("PointNetGPD", {"pile": ("75.6 ± 2.3", None), "packed": (None, None)}, "EGN"),
    ("EdgeGraspNet", {"pile": ("89.9 ± 1.8", "92.8 ± 1.6"), "packed": ("92.0 ± 1.4", None)}, "EGN"),
    ("VN-EdgeGraspNet", {"pile": ("92.3 ± 1.5", None), "packed": ("92.3 ± 1.2", None)}, "EGN"),
)  # fmt: skip
"""Published grasp-success (GSR ≈ our SR) and declutter (DR ≈ our CR) rates on VGN's pile and
packed test scenes, from other simulators and protocols. Sources: GIGA = Jiang et al., RSS 2021
(arXiv 2104.01542v2), Table I; EGN = Huang et al., Edge Grasp Network, ICRA 2023 (arXiv
2211.00191v1), Table I (EdgeGraspNet's packed GSR: Table III, 64-4k), read through a reading
note. What each protocol does and how it differs from ours: docs/benchmark.md, "Published
numbers on VGN's scenes"."""


def parse_prefix(text: str) -> tuple[str, str]:
    """``GRIPPER=PREFIX`` → (gripper, prefix)."""
    gripper, _, prefix = text.partition("=")
    if gripper not in GRIPPERS or not prefix:
        raise argparse.ArgumentTypeError(
            f"--prefix: expected GRIPPER=PREFIX with GRIPPER one of {', '.join(GRIPPERS)}, "
            f"got {text!r}"
        )
    return gripper, prefix


def parse_field(text: str) -> tuple[str, str]:
    """``OBJECTS:SCENE`` → (objects, scene)."""
    objects, _, scene = text.rpartition(":")
    if not objects or scene not in ("pile", "packed"):
        raise argparse.ArgumentTypeError(f"--field: expected OBJECTS:pile|packed, got {text!r}")
    return objects, scene


def label(rep: str, threshold: bool) -> str:
    """A row's name."""
    return f"`{rep}`" + ("" if threshold else ", no threshold")


def grid(args: argparse.Namespace) -> list[Cell]:
    """Every cell of both tables, each once (the field's pile cells are Table 1's)."""
    first = args.first_seed
    cells = [Cell(g, rep, seed, objects, "pile", threshold, first)
             for g, (rep, threshold), objects, seed
             in itertools.product(args.grippers, args.rows, args.objects, args.seeds)]  # fmt: skip
    cells += [Cell(args.field_gripper, rep, seed, objects, scene, first_seed=first)
              for (objects, scene), rep, seed in itertools.product(args.field, args.reps, args.seeds)]  # fmt: skip
    return list(dict.fromkeys(cells))


def play(cell: Cell, args: argparse.Namespace, prefixes: dict[str, str]) -> dict[str, Any]:
    """The cell's round records (``rounds``), or why it has none yet (``waiting``)."""
    run = cell.run(args.runs, prefixes[cell.gripper])
    if args.quick:
        model = shipped_path(SHIPPED)
    else:
        try:
            model = selected_checkpoint(run)
        except ValueError:  # not trained, or not selected yet: stored rounds, if any
            stored = stored_rounds(cell, args) if args.collate_only else None
            return {"rounds": stored, "waiting": None if stored else f"{run.name} (not selected)"}
    config = cell.config(model, args.rounds, args.num_objects, **approach_check(args))
    folder = cell.folder(args.out)
    if args.collate_only:
        rounds = saved_rounds(config, folder)
        return {"rounds": rounds, "waiting": None if rounds else f"{run.name} (not played)"}
    print(f"{cell.gripper} {label(cell.rep, cell.threshold)} seed {cell.seed} on {cell.objects} "
          f"({cell.scene})")  # fmt: skip
    return {"rounds": run_or_reuse(config, folder, parallel_from_args(args)), "waiting": None}


def stored_rounds(cell: Cell, args: argparse.Namespace) -> list[dict] | None:
    """The cell's rounds as stored in its folder (e.g. unpacked from ``--archive``) when its
    training run is not on this machine: the cell's benchmark with the model it recorded,
    whose file is not here to hash again."""
    folder = cell.folder(args.out)
    recorded = recorded_config(folder)
    if recorded is None:
        return None
    config = cell.config(recorded["model"], args.rounds, args.num_objects, **approach_check(args))
    return saved_rounds(config, folder, check_model=False)


def write_archive(path: Path, played: dict[Cell, dict], args: argparse.Namespace) -> None:
    """The collated cells' records (`common.ARCHIVED` files of each cell folder) as one gzipped
    tar, paths relative to ``--out``, byte for byte the same for the same records."""
    folders = (c.folder(args.out) for c, p in played.items() if p["rounds"])
    write_rounds_archive(path, {str(f.relative_to(args.out)): f for f in folders})


def row(played: dict[Cell, dict], gripper: str, rep: str, threshold: bool, objects: str,
        scene: str) -> dict[str, Any]:  # fmt: skip
    """One representation on one object set: the seeds played, the means over them with the
    hierarchical intervals, each seed's summary, and the failure modes pooled over seeds."""
    mine = _played_seeds(played, gripper, rep, threshold, objects, scene)
    result: dict[str, Any] = {"gripper": gripper, "rep": rep, "threshold": threshold,
                              "objects": objects, "scene": scene, "seeds": sorted(mine)}  # fmt: skip
    if not mine:
        return result
    summaries = {seed: summarise(rounds) for seed, rounds in sorted(mine.items())}
    result["ratios"] = seed_ratios([mine[s] for s in sorted(mine)])
    result["per_seed"] = {str(s): {k: summaries[s][k] for k in ("success_ratio", "clear_ratio",
                                                                 "executed", "successes")}
                          for s in summaries}  # fmt: skip
    modes = sum((Counter(s["modes"]) for s in summaries.values()), Counter())
    result["modes"] = {mode: modes[mode] for mode in MODES}
    result["executed"] = sum(s["executed"] for s in summaries.values())
    threshold = get_representation(rep).default_confidence
    if threshold is not None:
        result["confidence"] = confidences([r for runs in mine.values() for r in runs], threshold)
    return result


def _played_seeds(played: dict[Cell, dict], gripper: str, rep: str, threshold: bool,
                  objects: str, scene: str) -> dict[int, list[dict]]:  # fmt: skip
    """The rounds of each training seed whose cell of one representation and object set is
    played."""
    return {c.seed: p["rounds"] for c, p in played.items()
            if (c.gripper, c.rep, c.threshold, c.objects, c.scene)
            == (gripper, rep, threshold, objects, scene) and p["rounds"]}  # fmt: skip


def confidences(rounds: list[dict], threshold: float) -> dict[str, Any]:
    """The confidences of the grasps executed in ``rounds``: how many, how many below
    ``threshold`` (those the confidence threshold would have removed from the ranking's top;
    none where it was on), their median."""
    values = [a["confidence"] for r in rounds for a in r.get("attempts", ())
              if a.get("confidence") is not None]  # fmt: skip
    return {"threshold": threshold, "executed": len(values),
            "below": sum(v < threshold for v in values),
            "median": statistics.median(values) if values else None}  # fmt: skip


def lead(played: dict[Cell, dict], a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any] | None:
    """Row ``a`` minus row ``b`` (same gripper and objects): their runs' `seed_lead`, the change
    of the means over seeds on the rounds every run finished and the number of seed pairings in
    which ``a``'s SR is ahead."""
    if not a["seeds"] or not b["seeds"]:
        return None

    def runs(r: dict[str, Any]) -> list[list[dict]]:
        mine = _played_seeds(played, r["gripper"], r["rep"], r["threshold"], r["objects"],
                             r["scene"])  # fmt: skip
        return [mine[s] for s in r["seeds"]]

    m = seed_lead(runs(a), runs(b))
    return {
        "a": [a["rep"], a["threshold"]], "b": [b["rep"], b["threshold"]],
        "gripper": a["gripper"], "objects": a["objects"], "scene": a["scene"],
        "rounds": m["rounds"], "change": m["change"],
        "ahead": m["ahead"], "pairings": len(m["pairings"]),
    }  # fmt: skip


def leads_of(played: dict[Cell, dict], group: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """`lead` of ``group``'s first row over each other row (rows of one gripper, object set
    and scene), when the first is `ROWS[0]` (`bingham2d`); leads not yet playable are left out."""
    first, *others = group
    if (first["rep"], first["threshold"]) != ROWS[0]:
        return []
    return [m for other in others if (m := lead(played, first, other))]


def _mean(r: dict[str, Any], name: str, seeds: list[int]) -> str:
    """``mean [low, high] (s0 / s1 / s2)`` in %, or – before any seed is played."""
    if "ratios" not in r:
        return "–"
    mean, low, high = (100 * v for v in r["ratios"][name])
    each = " / ".join(f"{100 * r['per_seed'][str(s)][name]:.1f}" if str(s) in r["per_seed"]
                      else "–" for s in seeds)  # fmt: skip
    return f"{mean:.1f} [{low:.1f}, {high:.1f}] ({each})"


def _leads_table(leads: list[dict], with_scene: bool = False) -> list[str]:
    """Markdown rows of ``leads``: `bingham2d` minus each other row, by object set (and scene
    kind where ``with_scene``)."""
    objects = "objects (scene)" if with_scene else "objects"
    rows = [f"| {objects} | `bingham2d` − | SR change | CR change | SR ahead in |",
            "|---|---|---|---|---|"]  # fmt: skip
    for m in leads:
        name = f"{m['objects']} ({m['scene']})" if with_scene else m["objects"]
        rows.append(f"| {name} | {label(*m['b'])} | {percent_change(m['change']['success_ratio'])} | "
                    f"{percent_change(m['change']['clear_ratio'])} | {m['ahead']} of {m['pairings']} |")  # fmt: skip
    return rows


def _confidence_table(rows: list[dict], gripper: str) -> list[str]:
    """Markdown lines: the confidences of the grasps each row with a confidence executed, and
    how many lie below its threshold (what the threshold removes)."""
    if not rows:
        return []
    threshold = rows[0]["confidence"]["threshold"]
    text = ["", f"Confidence of the executed grasps, pooled over seeds ({gripper}): how many the "
            f"confidence threshold ({threshold:g}) removes from the top of the ranking:", "",
            f"| representation | objects | executed | below {threshold:g} | median confidence |",
            "|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        c = r["confidence"]
        below = f"{c['below']} ({c['below'] / c['executed']:.1%})" if c["executed"] else "–"
        median = "–" if c["median"] is None else f"{c['median']:.1f}"
        text.append(f"| {label(r['rep'], r['threshold'])} | {r['objects']} | {c['executed']} | "
                    f"{below} | {median} |")  # fmt: skip
    return text


def markdown(rows: list[dict], leads: list[dict], field: list[dict], field_leads: list[dict],
             args: argparse.Namespace, waiting: list[str]) -> str:  # fmt: skip
    """Table 1 per gripper with the paper's numbers, the leads, the failure modes, the field's
    table with its leads on the sets Table 1 lacks, and the runs still waiting."""
    seeds = list(args.seeds)
    text = []
    for gripper in args.grippers:
        mine = [r for r in rows if r["gripper"] == gripper]
        head = " | ".join(f"{o} SR % | {o} CR %" for o in args.objects)
        paper = " | ".join(f"paper {o} SR / CR" for o in args.objects)
        text += [f"### {gripper}", "",
                 f"Mean over training seeds [95 % interval over seeds and rounds] (seed "
                 f"{' / '.join(map(str, seeds))}), round seeds {round_seeds(args)}:", "",
                 f"| representation | {head} | {paper} |",
                 "|---|" + "---|" * (3 * len(args.objects))]  # fmt: skip
        for rep, threshold in args.rows:
            cells, theirs = [], []
            for objects in args.objects:
                r = next(x for x in mine if (x["rep"], x["threshold"], x["objects"])
                         == (rep, threshold, objects))  # fmt: skip
                cells += [_mean(r, "success_ratio", seeds), _mean(r, "clear_ratio", seeds)]
                ref = PAPER.get((gripper, rep, threshold), {}).get(objects)
                theirs.append(f"{ref[0]} / {ref[1]}" if ref else "–")
            text.append(f"| {label(rep, threshold)} | " + " | ".join(cells + theirs) + " |")
        text += ["", f"`bingham2d` minus each other row on the same rounds ({gripper}): change "
                 "of the means over seeds [95 %, seeds and rounds]; seed pairings in which "
                 "`bingham2d`'s SR is ahead:", ""]  # fmt: skip
        text += _leads_table([m for m in leads if m["gripper"] == gripper])
        text += ["", f"Attempts by failure mode, pooled over seeds ({gripper}; "
                 "`symgrasp.benchmark.failures`):", "",
                 "| representation | objects | " + " | ".join(MODES) + " | wrong yaw / executed |",
                 "|---|---|" + "---|" * (len(MODES) + 1)]  # fmt: skip
        for r in (r for r in mine if "modes" in r):
            share = f"{r['modes']['wrong_yaw'] / r['executed']:.0%}" if r["executed"] else "–"
            text.append(f"| {label(r['rep'], r['threshold'])} | {r['objects']} | "
                        + " | ".join(str(r["modes"][m]) for m in MODES) + f" | {share} |")  # fmt: skip
        text += _confidence_table([r for r in mine if r.get("confidence")], gripper)
        text.append("")
    if not args.field:
        return "\n".join(text) + _waiting(waiting)
    text += [f"### The field's protocol ({args.field_gripper}, VGN's objects)", "",
             f"Mean over training seeds [95 % interval over seeds and rounds], round seeds "
             f"{round_seeds(args)}:", "",
             "| representation | " + " | ".join(f"{o} ({s}) SR % | CR %" for o, s in args.field)
             + " |", "|---|" + "---|" * (2 * len(args.field))]  # fmt: skip
    for rep in args.reps:
        cells = []
        for objects, scene in args.field:
            r = next(
                x for x in field if (x["rep"], x["objects"], x["scene"]) == (rep, objects, scene)
            )
            cells += [_mean(r, "success_ratio", seeds), _mean(r, "clear_ratio", seeds)]
        text.append(f"| `{rep}` | " + " | ".join(cells) + " |")
    for method, numbers, source in PUBLISHED:
        cells = [v or "–" for _, scene in args.field for v in numbers.get(scene, (None, None))]
        text.append(f"| *{method}* ({source}) | " + " | ".join(cells) + " |")
    text += ["", "Rows in italics: published GSR / DR (mean ± SD as reported) on VGN's test "
             "scenes with 5 objects per round, from other simulators and protocols (GIGA: Jiang "
             "et al., RSS 2021, Table I; EGN: Huang et al., ICRA 2023, Table I); sources and "
             "how each protocol differs from ours: `docs/benchmark.md`, \"Published numbers on "
             "VGN's scenes\"."]  # fmt: skip
    if field_leads:
        text += ["", "`bingham2d` minus each other representation on the same rounds, on the "
                 f"field's sets Table 1 does not hold ({args.field_gripper}; the pile's are "
                 "Table 1's above):", ""]  # fmt: skip
        text += _leads_table(field_leads, with_scene=True)
    return "\n".join(text) + "\n" + _waiting(waiting)


def _waiting(waiting: list[str]) -> str:
    if not waiting:
        return ""
    return f"\nWaiting for {len(waiting)} cells of the runs {', '.join(sorted(set(waiting)))}.\n"


def figure(rows: list[dict], path: str | Path, args: argparse.Namespace) -> None:
    """Bars of the mean SR and CR over seeds with their seed-and-round intervals, each seed's
    value as a dot, the paper's as a black tick; one panel per gripper and object set."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grippers, objects = list(args.grippers), list(args.objects)
    fig, axes = plt.subplots(len(grippers), len(objects), figsize=(5.5 * len(objects),
                             3.5 * len(grippers)), sharey=True, squeeze=False)  # fmt: skip
    for (i, gripper), (j, obj) in itertools.product(enumerate(grippers), enumerate(objects)):
        ax = axes[i, j]
        for k, (rep, threshold) in enumerate(args.rows):
            r = next(x for x in rows if (x["gripper"], x["rep"], x["threshold"], x["objects"])
                     == (gripper, rep, threshold, obj))  # fmt: skip
            paper = PAPER.get((gripper, rep, threshold), {}).get(obj)
            for m, (name, colour) in enumerate((("success_ratio", "C0"), ("clear_ratio", "C1"))):
                x = k + (m - 0.5) * 0.38
                if paper:
                    ax.plot([x - 0.17, x + 0.17], [paper[m]] * 2, color="k", lw=2)
                if "ratios" not in r:
                    ax.text(x, 2, "–", ha="center")
                    continue
                mean, low, high = (100 * v for v in r["ratios"][name])
                ax.bar(x, mean, 0.36, color=colour, alpha=0.8, yerr=[[mean - low], [high - mean]],
                       capsize=3, label=name.replace("_", " ") if k == 0 else None)  # fmt: skip
                dots = [100 * s[name] for s in r["per_seed"].values()]
                ax.plot([x] * len(dots), dots, "o", ms=3, color="k", alpha=0.6,
                        label="one training seed" if k == 0 and m == 0 else None)  # fmt: skip
        ax.set_xticks(range(len(args.rows)), [r + ("" if t else "\nno thr.") for r, t in args.rows],
                      fontsize=8)  # fmt: skip
        ax.set_title(f"{gripper}, {obj}")
        ax.set_ylim(0, 100)
        ax.grid(axis="y", alpha=0.3)
    for i in range(len(grippers)):
        axes[i, 0].set_ylabel("%")
    axes[0, 0].plot([], [], color="k", lw=2, label="the paper (its simulator)")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="lower center",
               ncol=4 if len(objects) > 1 else 2, fontsize=9)  # fmt: skip
    fig.suptitle(f"Simulated decluttering, {args.rounds} rounds of {args.num_objects} objects "
                 f"(round seeds {round_seeds(args)})\n"
                 f"mean over training seeds {', '.join(map(str, args.seeds))}; 95 % intervals "
                 "over seeds and rounds", fontsize=10)  # fmt: skip
    fig.tight_layout(rect=(0, 0.05 if len(objects) > 1 else 0.1, 1, 1))
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


OUTPUTS = ("result", "figure", "archive")
"""The files a collation writes whose default names take the first seed (`first_seed_name`)."""


def markers(first_seed: int) -> tuple[str, str]:
    """The markers of ``--docs`` between which the tables of the rounds from ``first_seed`` go:
    ``<!-- declutter-table: begin -->`` … for 0, ``declutter-table-first-seed-F`` else."""
    name = first_seed_name("declutter-table", first_seed)
    return f"<!-- {name}: begin -->", f"<!-- {name}: end -->"


def round_seeds(args: argparse.Namespace) -> str:
    """The round seeds every cell plays, e.g. ``0–99``."""
    return f"{args.first_seed}–{args.first_seed + args.rounds - 1}"


def first_seed_name(name: str, first_seed: int) -> str:
    """``name`` (a file name or a marker) for the cells of ``first_seed``: itself for 0, else
    with ``-first-seed-F`` after its stem: ``declutter_rounds.tar.gz`` →
    ``declutter_rounds-first-seed-100.tar.gz``, ``declutter-table`` →
    ``declutter-table-first-seed-100``."""
    if not first_seed:
        return name
    stem, dot, suffixes = name.partition(".")
    return f"{stem}-first-seed-{first_seed}{dot}{suffixes}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", default="runs", help="folder of the training runs")
    parser.add_argument("--prefix", type=parse_prefix, action="append", default=None,
                        help="GRIPPER=PREFIX: the runs of GRIPPER are PREFIX-REP-sSEED (default: "
                        + " ".join(f"{g}={p}" for g, p in PREFIXES.items()) + ")")  # fmt: skip
    parser.add_argument("--grippers", nargs="+", choices=GRIPPERS, default=list(GRIPPERS),
                        help="Table 1's grippers (default: both)")  # fmt: skip
    parser.add_argument("--reps", nargs="+", choices=REPS, default=list(REPS),
                        help="representations (default: all; bingham2d brings its "
                        "no-threshold row)")  # fmt: skip
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2],
                        help="training seeds (default: 0 1 2)")  # fmt: skip
    parser.add_argument("--objects", nargs="+", default=list(OBJECTS),
                        help="Table 1's object sets, piles (default: %(default)s)")  # fmt: skip
    parser.add_argument("--field", nargs="*", type=parse_field, default=[parse_field(f) for f in FIELD],
                        help="the field's table: OBJECTS:pile|packed …, none for no such "
                        "table (default: " + " ".join(FIELD) + ")")  # fmt: skip
    parser.add_argument("--field-gripper", choices=GRIPPERS, default="franka",
                        help="the field's table's gripper (default: franka, VGN's hand)")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=100, help="rounds per cell (default: 100)")
    parser.add_argument("--num-objects", type=int, default=5, help="objects per round (default: 5)")
    parser.add_argument("--first-seed", type=int, default=0,
                        help="round seed of every cell's first round (default: 0, Table 1's "
                        "rounds 0–99, which have informed choices since; 100: test rounds no "
                        "choice was made on). Another first seed's cells play in folders of "
                        "their own (OBJECTS[-packed]-first-seed-F), and the default names of "
                        "--result, --figure, --archive and the --docs markers get "
                        "-first-seed-F")  # fmt: skip
    add_parallel_options(parser, "rounds")
    parser.set_defaults(workers=2)
    add_mode_options(parser, "play the cells and write nothing (a campaign step per run); an "
                     "error when a cell's run has not been selected",
                     "tabulate the cells already played; play none")  # fmt: skip
    parser.add_argument("--out", default="out/bench/table", help="folder of the cells")
    add_result_option(parser, "declutter")
    parser.add_argument("--figure", default="docs/figures/declutter_comparison.png",
                        help="bar chart path")  # fmt: skip
    parser.add_argument("--docs", default="docs/results.md",
                        help="page whose text between the declutter-table markers is replaced")  # fmt: skip
    parser.add_argument("--archive", default="experiments/results/declutter_rounds.tar.gz",
                        help="the collated cells' rounds as one .tar.gz; unpacked into --out, "
                        "they collate again without the training runs")  # fmt: skip
    add_approach_check(parser)
    args = parse_args(
        parser, outputs=("out", "result", "figure", "docs", "archive"),
        quick={"rounds": 1, "num_objects": 1, "workers": 1, "seeds": [0, 1],
               "grippers": ["robotiq-2f85"], "field_gripper": "robotiq-2f85",
               "objects": ["household-test"], "field": [("household-test", "packed")]},
        also=f"{SHIPPED} for every run", pages=("docs",),
    )  # fmt: skip
    if args.first_seed < 0:
        parser.error(f"--first-seed: expected a round seed ≥ 0, got {args.first_seed}")

    def table1(dest: str) -> Path:  # where this run writes Table 1's file
        return output_path(parser.get_default(dest), args).resolve()

    left = [f"--{dest}" for dest in ("figure", "archive", "docs")
            if Path(getattr(args, dest)).resolve() == table1(dest)]  # fmt: skip
    if Path(args.result).resolve() != table1("result") and left and not args.play_only:
        parser.error(f"--result {args.result} is not Table 1's, but {', '.join(left)} "
                     "would write over Table 1's files: name them too")  # fmt: skip
    for dest in OUTPUTS:  # another first seed's outputs beside Table 1's, never over them
        path, default = Path(getattr(args, dest)), Path(parser.get_default(dest))
        if path.name == default.name:
            setattr(args, dest, str(path.with_name(first_seed_name(path.name, args.first_seed))))
    prefixes = {**PREFIXES, **dict(args.prefix or ())}
    args.rows = [(rep, threshold) for rep, threshold in ROWS if rep in args.reps]

    played = {cell: play(cell, args, prefixes) for cell in grid(args)}
    waiting = [p["waiting"] for p in played.values() if p["waiting"]]
    if args.play_only:
        if waiting:
            raise SystemExit(
                f"error: not played, runs not selected: {', '.join(sorted(set(waiting)))}"
            )
        return
    rows = [row(played, g, rep, threshold, objects, "pile")
            for g in args.grippers for objects in args.objects for rep, threshold in args.rows]  # fmt: skip
    field = [row(played, args.field_gripper, rep, True, objects, scene)
             for objects, scene in args.field for rep in args.reps]  # fmt: skip
    leads = []
    for g, objects in itertools.product(args.grippers, args.objects):
        leads += leads_of(played, [r for r in rows if (r["gripper"], r["objects"]) == (g, objects)])
    held = {(m["gripper"], m["objects"], m["scene"]) for m in leads}
    field_leads = []  # on the field's sets whose leads Table 1 does not hold
    for objects, scene in args.field:
        if (args.field_gripper, objects, scene) not in held:
            group = [r for r in field if (r["objects"], r["scene"]) == (objects, scene)]
            field_leads += leads_of(played, group)
    table = markdown(rows, leads, field, field_leads, args, waiting)
    print(table, end="")
    write_result(
        args.result,
        "Table 1 over training seeds: SR / CR per gripper, object set and representation (mean "
        "over seeds, hierarchical intervals), bingham2d's paired leads, failure modes, and the "
        "field's pile/packed table with bingham2d's paired leads on its packed scenes",
        command_line("PYTHONPATH=src"),
        rows,
        table,
        leads=leads,
        field=field,
        field_leads=field_leads,
        waiting=sorted(set(waiting)),
        rounds=args.rounds,
        num_objects=args.num_objects,
        round_seeds=[args.first_seed, args.first_seed + args.rounds - 1],
        seeds=list(args.seeds),
        prefixes=prefixes,
    )
    figure(rows, args.figure, args)
    update_page(Path(args.docs), *markers(args.first_seed), table)
    write_archive(Path(args.archive), played, args)


if __name__ == "__main__":
    run_main(main)
