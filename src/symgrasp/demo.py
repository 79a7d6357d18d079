"""What ``make demo`` runs: the shipped detector clears a simulated pile, attempt by attempt.

A random pile of household objects falls on the table; before every attempt one depth image
is rendered and the shipped ``bingham2d`` model proposes grasps; the best one whose approach
is free is executed in MuJoCo (`symgrasp.benchmark.declutter.run_round`). The round ends when
the table is clear or two grasps fail in a row. Each attempt is printed and drawn
(``attempt_NN.png``: the observed points and the top grasps coloured by score, the executed
one thick), and ``demo.html`` collects them with the round's success and clear ratios.
"""

from __future__ import annotations

import base64
import html
import json
import time
from pathlib import Path

import numpy as np

from symgrasp.benchmark.declutter import Attempt, Round, run_round, save_attempt_png
from symgrasp.detect import Grasp, GraspDetector
from symgrasp.folders import PICTURES, writes_folder
from symgrasp.names import DECOMPOSITIONS, demo_model
from symgrasp.objects.sets import resolve
from symgrasp.sim import World
from symgrasp.sim.grippers import get_gripper


@writes_folder(PICTURES)
def run_demo(
    out: str | Path = "out/demo",
    seed: int = 0,
    gripper: str = "robotiq-2f85",
    objects: str = "household-test",
    num_objects: int = 5,
    model: str | None = None,
    mesh_unit: str = "auto",
    decomposition: str = DECOMPOSITIONS[0],
) -> Round:
    """Play one declutter round and write its pictures, ``demo.html`` and ``summary.json``
    (bare meshes of ``objects`` read in ``mesh_unit`` and cut by the preset ``decomposition``). ``gripper``: a built-in's name, whose
    shipped model plays unless ``model`` is given, or a spec file (then ``model`` is needed).
    ``out`` holds pictures only, and is held for the call (`symgrasp.folders`)."""
    start = time.perf_counter()
    out = Path(out)
    name = model or demo_model(gripper)
    detector = GraspDetector.from_pretrained(name, device="cpu", gripper=get_gripper(gripper))
    pictures: list[Path] = []
    print(f"model {name} ({detector.representation.name}, {detector.gripper.name}); seed {seed}")

    def observe(world: World, points: np.ndarray, grasps: list[Grasp], attempt: Attempt) -> None:
        n = len(pictures) + 1
        outcome = attempt.outcome
        if attempt.mode == "wrong_yaw":  # symgrasp.benchmark.failures
            outcome += " → wrong yaw (turned about its approach, it would succeed)"
        line = f"attempt {n}: {outcome}"
        if attempt.grasp is not None:
            g = attempt.grasp
            line += f"  (score {g.score:.2f}, confidence {_fmt(g.confidence)}, "
            line += f"{attempt.rejected} colliding skipped, planning {attempt.planning_s:.2f} s)"
        print(line)
        title = f"attempt {n}: {outcome} ({attempt.objects_before} objects)"
        pictures.append(
            save_attempt_png(
                out / f"attempt_{n:02d}.png", points, grasps, attempt, detector.gripper, title
            )
        )

    source = resolve(objects, mesh_unit, decomposition)
    record = run_round(detector, source, num_objects, seed, observer=observe)
    summary = {
        "model": name,
        "gripper": detector.gripper.name,
        "objects": objects,
        "seed": seed,
        "objects_presented": record.objects,
        "attempts": [a.outcome for a in record.attempts],
        "modes": [a.mode for a in record.attempts],
        "successes": record.successes,
        "success_ratio": record.success_ratio,
        "clear_ratio": record.clear_ratio,
        "seconds": time.perf_counter() - start,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    _write_html(out / "demo.html", summary, record, pictures)
    print(
        f"success ratio {record.success_ratio:.0%} ({record.successes}/{record.executed}), "
        f"clear ratio {record.clear_ratio:.0%} ({record.successes}/{record.objects}) "
        f"in {summary['seconds']:.0f} s; pictures and demo.html in {out}"
    )
    return record


def _fmt(value: float | None) -> str:
    return "–" if value is None else f"{value:.0f}"


def _write_html(path: Path, summary: dict, record: Round, pictures: list[Path]) -> None:
    """A self-contained page: the round's numbers and every attempt's picture inline."""
    rows = "".join(
        f"<tr><td>{i + 1}</td><td>{html.escape(a.outcome)}</td>"
        f"<td>{'' if a.grasp is None else f'{a.grasp.score:.2f}'}</td>"
        f"<td>{_fmt(None if a.grasp is None else a.grasp.confidence)}</td>"
        f"<td>{a.planning_s:.2f}</td></tr>"
        for i, a in enumerate(record.attempts)
    )
    figures = "".join(
        f'<figure><img src="data:image/png;base64,{base64.b64encode(p.read_bytes()).decode()}">'
        f"<figcaption>{html.escape(p.name)}</figcaption></figure>"
        for p in pictures
    )
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>symgrasp demo</title>
<style>body{{font-family:sans-serif;margin:2em}}img{{max-width:100%}}
td,th{{padding:2px 10px;text-align:left}}</style></head><body>
<h1>symgrasp demo: {html.escape(summary["model"])} on {html.escape(summary["objects"])}</h1>
<p>seed {summary["seed"]}: {summary["objects_presented"]} objects, {record.executed} grasps
executed, {record.successes} succeeded. Success ratio {record.success_ratio:.0%}, clear ratio
{record.clear_ratio:.0%}, {summary["seconds"]:.0f} s.</p>
<table><tr><th>attempt</th><th>outcome</th><th>score</th><th>confidence</th>
<th>planning [s]</th></tr>{rows}</table>{figures}</body></html>"""
    path.write_text(page)
