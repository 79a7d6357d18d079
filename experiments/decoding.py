"""Decoding past the thresholds and past a refused approach → experiments/results/decoding.{json,md}.

    PYTHONPATH=src python experiments/decoding.py [--rounds 200] [--seed 3000000]
        [--out out/decoding] [--workers 2] [--quick [DIR]]

The shipped detectors are sure when they grasp and then stop: most rounds end with nothing
found, either because no voxel passes the validity threshold or because the benchmark's
approach check (`symgrasp.benchmark.declutter.first_free`) refused every candidate. Two decoding
options of `symgrasp.detect.GraspDetector` use what the network already predicts, and this
script measures each on training-object rounds (``vgn-pile-train`` piles for the Robotiq hand,
``vgn-packed-train`` packed scenes for the Franka hand; round seeds from ``--seed``, off the test
seeds), every arm paired with the shipped model at the library's defaults on the same rounds:

- ``fallbacks``: after each voxel's grasp, other rotations of the same voxel, tried when its
  approach is refused: draws of the predicted Bingham most probable first (``bingham2d``), and
  for ``rotmat6d`` the control a user would try, the yaw turned about e_x in even steps;
- ``validity_floor``: forced decoding, the voxels between the floor and the threshold ranked
  after those above it;
- both, and the Robotiq `bingham2d` under the paper's protocol (the first grasp executed
  unchecked), where a fallback is never reached and forced decoding alone can act;
- the Franka `bingham2d` under a real sensor's view (GIGA's side view, ``dex`` noise, the
  table's depth scale, the paper's protocol, forced decoding on): the detector's own approach
  check (``approach_check``) off, on, and on with ``fallbacks`` 8, the question behind
  docs/detect.md's advice for a real sensor.

Per arm: SR and CR with 95 % intervals, the change of each from the arm's baseline (paired
bootstrap over rounds), rounds ended with nothing found, and the executed grasps that were a
fallback (rescued: their voxel's own grasp was refused) or forced (validity under the threshold)
with their success ratio (Wilson 95 %). Last, whether fallbacks help `bingham2d` more than the
yaw-turn control helps `rotmat6d` (the difference of the two paired changes, one bootstrap).
One training seed per model (the shipped one): the rows say what the decoding does for these
models, not how representations compare. A cell whose folder already holds the same
configuration's rounds is read, not rerun (`runner.run_or_reuse`); ``--quick`` plays one round
of one object per arm.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from common import add_decoding_options, wilson, write_rounds_archive
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.benchmark.compare import paired_change, percent_change
from symgrasp.benchmark.runner import (
    BenchmarkConfig,
    percent_with_interval,
    run_or_reuse,
    summarise,
)
from symgrasp.benchmark.seeds import common_rounds, seed_contrast
from symgrasp.config import DEFAULT_VALIDITY, PlannerOptions
from symgrasp.parallel.options import parallel_from_args

FALLBACKS = 8
FLOOR = 0.02
ROBOTIQ = {"model": "bingham2d-robotiq-2f85", "objects": "vgn-pile-train"}
FRANKA = {"model": "bingham2d-franka", "objects": "vgn-packed-train", "scene": "packed"}
ROTMAT = {"model": "rotmat6d-robotiq-2f85", "objects": "vgn-pile-train"}
SENSOR = {**FRANKA, "protocol": "paper", "noise": "dex", "view": "side", "table_scale": True}

ARMS: dict[str, tuple[dict[str, Any], dict[str, Any], str]] = {
    # name: (what plays, its decoding options, the arm it is paired with)
    "robotiq-base": (ROBOTIQ, {}, ""),
    "robotiq-fb8": (ROBOTIQ, {"fallbacks": FALLBACKS}, "robotiq-base"),
    "robotiq-floor02": (ROBOTIQ, {"validity_floor": FLOOR}, "robotiq-base"),
    "robotiq-fb8-floor02": (
        ROBOTIQ,
        {"validity_floor": FLOOR, "fallbacks": FALLBACKS},
        "robotiq-base",
    ),
    "franka-packed-base": (FRANKA, {}, ""),
    "franka-packed-fb8": (FRANKA, {"fallbacks": FALLBACKS}, "franka-packed-base"),
    "franka-packed-floor02": (FRANKA, {"validity_floor": FLOOR}, "franka-packed-base"),
    "franka-packed-fb8-floor02": (
        FRANKA,
        {"validity_floor": FLOOR, "fallbacks": FALLBACKS},
        "franka-packed-base",
    ),
    "robotiq-rotmat6d-base": (ROTMAT, {}, ""),
    "robotiq-rotmat6d-fb8": (ROTMAT, {"fallbacks": FALLBACKS}, "robotiq-rotmat6d-base"),
    "robotiq-paper-base": ({**ROBOTIQ, "protocol": "paper"}, {}, ""),
    "robotiq-paper-floor02": (
        {**ROBOTIQ, "protocol": "paper"},
        {"validity_floor": FLOOR},
        "robotiq-paper-base",
    ),
    # a real sensor's view, the paper's protocol: the detector's own approach check or none
    "sensor-nocheck": (SENSOR, {"validity_floor": FLOOR}, ""),
    "sensor-check": (SENSOR, {"validity_floor": FLOOR, "approach_check": True}, "sensor-nocheck"),
    "sensor-check-fb8": (
        SENSOR,
        {"validity_floor": FLOOR, "fallbacks": FALLBACKS, "approach_check": True},
        "sensor-nocheck",
    ),
}
CONTROL = (("robotiq-fb8", "robotiq-base"), ("robotiq-rotmat6d-fb8", "robotiq-rotmat6d-base"))
"""(bingham2d with fallbacks, without) and (rotmat6d with its yaw-turn control, without)."""


def config(arm: str, rounds: int, seed: int, num_objects: int) -> BenchmarkConfig:
    """The benchmark of ``arm``: what ``symgrasp bench declutter --no-operating-point`` with the
    arm's options records."""
    plays, options, _ = ARMS[arm]
    return BenchmarkConfig(
        **plays, rounds=rounds, seed=seed, num_objects=num_objects,
        options=PlannerOptions(**options),
    )  # fmt: skip


def executed(rounds: list[dict], which) -> dict[str, Any]:
    """The executed attempts for which ``which(attempt)`` holds: how many, how many succeeded,
    their success ratio and its Wilson 95 % interval [%]."""
    chosen = [a for r in rounds for a in r["attempts"] if a["outcome"] != "none_found" and which(a)]
    hits = sum(a["outcome"] == "success" for a in chosen)
    return {"executed": len(chosen), "successes": hits,
            "success_ratio": [100 * hits / len(chosen), *wilson(hits, len(chosen))]
            if chosen else None}  # fmt: skip


def arm_cell(arm: str, rounds: list[dict], baseline: list[dict] | None, seed: int) -> dict:
    plays, options, paired_with = ARMS[arm]
    threshold = options.get("validity_threshold", DEFAULT_VALIDITY)
    summary = {k: v for k, v in summarise(rounds, seed).items() if k != "families"}
    nothing = sum(bool(r["attempts"]) and r["attempts"][-1]["outcome"] == "none_found"
                  for r in rounds)  # fmt: skip
    return {
        "arm": arm, **plays, "options": options, "paired_with": paired_with or None,
        "summary": summary, "ended_with_nothing_found": nothing,
        "fallbacks_executed": executed(rounds, lambda a: (a.get("fallback") or 0) > 0),
        "forced_executed": executed(
            rounds, lambda a: a.get("validity") is not None and a["validity"] < threshold
        ),
        "change": None if baseline is None else paired_change(*common_rounds(rounds, baseline)),
    }  # fmt: skip


def _rate(part: dict[str, Any]) -> str:
    if not part["executed"]:
        return "0"
    mid, low, high = part["success_ratio"]
    return f"{part['executed']} ({part['successes']} held: {mid:.0f} [{low:.0f}, {high:.0f}] %)"


def markdown(cells: list[dict], control: dict[str, list[float]] | None) -> str:
    text = ["| arm | model | objects | SR % [95 % CI] | CR % [95 % CI] | SR change | CR change "
            "| rounds ended with nothing found | fallbacks executed | forced executed |",
            "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for c in cells:
        s, change = c["summary"], c["change"]
        sr = "–" if change is None else percent_change(change["success_ratio"])
        cr = "–" if change is None else percent_change(change["clear_ratio"])
        protocol = " (paper's protocol)" if c.get("protocol") == "paper" else ""
        text.append(
            f"| {c['arm']}{protocol} | {c['model']} | {c['objects']} | "
            f"{percent_with_interval(s, 'success_ratio')} | "
            f"{percent_with_interval(s, 'clear_ratio')} | {sr} | {cr} | "
            f"{c['ended_with_nothing_found']} of {s['rounds']} | {_rate(c['fallbacks_executed'])} "
            f"| {_rate(c['forced_executed'])} |"
        )
    if control is not None:
        text += ["", "Fallbacks' change for `bingham2d` minus the yaw-turn control's change for "
                 "`rotmat6d` (Robotiq, the same rounds, one bootstrap): SR "
                 f"{percent_change(control['success_ratio'])}, CR "
                 f"{percent_change(control['clear_ratio'])}, SR + CR "
                 f"{percent_change(control['sr_plus_cr'])}."]  # fmt: skip
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_decoding_options(parser, "decoding", "arm")
    args = parse_args(
        parser,
        outputs=("out", "result"),
        quick={"rounds": 1, "num_objects": 1, "workers": 1},
        also="every arm",
    )
    played = {}
    for arm in ARMS:
        print(f"{arm}: {ARMS[arm][1] or 'the library defaults'}")
        cfg = config(arm, args.rounds, args.seed, args.num_objects)
        played[arm] = run_or_reuse(cfg, Path(args.out) / arm, parallel_from_args(args))
    cells = [arm_cell(arm, played[arm], played.get(ARMS[arm][2]), args.seed) for arm in ARMS]
    (b2d, b2d_base), (r6d, r6d_base) = CONTROL
    runs = common_rounds(played[b2d], played[b2d_base], played[r6d], played[r6d_base])
    control = seed_contrast([[run] for run in runs], [1, -1, -1, 1], ["b", "b", "r", "r"])
    control = {k: v for k, v in control.items() if all(map(math.isfinite, v))} or None
    table = markdown(cells, control)
    print(table)
    write_rounds_archive(
        Path(args.result).with_name(Path(args.result).name + "_rounds.tar.gz"),
        {arm: Path(args.out) / arm for arm in ARMS},
    )
    write_result(
        args.result,
        "declutter SR / CR of the shipped models with fallbacks past a refused approach and "
        "forced decoding, each arm paired with the library's defaults on the same training-object "
        "rounds",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        control=control,
        rounds=args.rounds,
        seed=args.seed,
        num_objects=args.num_objects,
        fallbacks=FALLBACKS,
        validity_floor=FLOOR,
    )


if __name__ == "__main__":
    run_main(main)
