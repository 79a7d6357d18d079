"""Why the Franka hand fails the large box by approach (issue 36, part 3) →
experiments/results/franka_box.{json,md}.

    SYMGRASP_DATA=DIR OMP_NUM_THREADS=1 PYTHONPATH=src nice -n 10 \\
        python experiments/franka_box.py [--rounds 100] [--trials 20] [--work out/franka_box] \\
        [--models NAME ...] [--no-labels] [--quick [DIR]]

Table 1's Franka large-box cells lose 112–187 attempts each to ``wrong_approach`` (the fingers
closed on nothing at every yaw, `symgrasp.benchmark.failures`), the Robotiq's 6–27. Three
measurements, by physics, not assumption:

- **Replays of the recorded rounds.** Every shipped model (`symgrasp.detect.PRETRAINED`: the
  seed of its Table 1 cell) plays the large-box rounds ``0 … --rounds − 1`` again (they repeat
  those of ``experiments/results/declutter_rounds.tar.gz`` attempt for attempt: checked, and
  counted in the result). Before each executed grasp the world's state is kept; the grasp is
  then replayed from it, instrumented: the TCP in the frame of the box it was aimed at
  (`failures.aimed_object`), how deep below the face the approach enters it lies and how much
  of the pads' length overlaps the box along the approach (the fingertip reach against the
  30 mm box), the closing line through the TCP against the box (which two faces it meets:
  opposite faces, or two faces across an edge), whether the approach moved the box, whether
  the pads touched it while closing (sampled in 20 slices of the closing time) and how far it
  moved then; a wrong approach is also played turned by the 10° steps the diagnosis skips
  (`FINE_YAWS`), and a grasp whose closing line crosses an edge is played again *squared*: the
  same TCP and ``e_y``, its closing axis turned about ``e_y`` onto the nearest box axis
  (`squared`). These are test rounds: looked at, nothing chosen on them.
- **The labels near each grasp** (``bingham2d`` of each hand, unless ``--no-labels``): the
  oracle's labels of the same state (`symgrasp.peers.oracle.OraclePlanner`: the training
  databases moved into the scene and collision-checked), and the smallest rotation angle, up to
  the flip, between the executed grasp and a label whose TCP lies within one voxel of its TCP:
  does the detector reproduce a label there, or propose a grasp no label holds?
- **A lone box lying flat** (`symgrasp.sim.objects.large_box`, on the table at a random
  position and heading), both hands, ``--trials`` trials per setting, each from its own random
  box pose and TCP position along the box's length: the top-down grasp across the 70 mm width
  with the TCP ``d`` below the top face (the fingertip reach), turned about the approach (yaw),
  moved along the closing axis (lateral), and tilted about the box's long axis (on a box lying
  across another, at its overhanging end: `lone_box_trial`), which moves the closing line from
  the two side faces onto a side face and the top face across their edge. Both hands meet the
  same boxes, setting by setting.

Rates carry Wilson 95 % intervals (`common.wilson`). ``--work`` keeps every replayed round and
every sweep setting as it finishes: a killed run resumes where it stopped. ``--quick``: one
round of each ``bingham2d`` model, no labels, one trial on a coarse sweep.
"""

from __future__ import annotations

import argparse
import json
import tarfile
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from common import GRIPPERS, Watched, add_result_option, pad_extent, records_by_seed, wilson
from scripts import command_line, parse_args, run_main, write_result
from tqdm import tqdm

from symgrasp.benchmark.declutter import run_round
from symgrasp.benchmark.failures import aimed_object, turned_about_approach
from symgrasp.data.labels import rotation_angle_up_to_flip, voxel_of
from symgrasp.detect import PRETRAINED, GraspDetector
from symgrasp.objects.sets import resolve
from symgrasp.sim.execute import BLOCKED_ERROR, BLOCKED_FORCE, execute_grasp
from symgrasp.sim.grippers import GripperSpec, get_gripper
from symgrasp.sim.objects import LARGE_BOX_SIZE, large_box
from symgrasp.sim.protocol import PREGRASP_DISTANCE
from symgrasp.sim.world import World
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

ARCHIVE = Path("experiments/results/declutter_rounds.tar.gz")
"""Table 1's recorded rounds, which the replays must repeat."""

HALF = np.asarray(LARGE_BOX_SIZE) / 2
"""The box's half-extents along its own x (width 70 mm), y (length 200 mm), z (thickness 30 mm)."""

FACES = ("side", "end", "flat")
"""The box's faces by the axis of their normal: the 30 × 200 mm sides, the 30 × 70 mm ends and
the 70 × 200 mm faces it lies on."""

FINE_YAWS = np.radians([a for a in range(10, 180, 10) if a % 30])
"""The turns about the approach axis the diagnosis does not try (it tries every 30°,
`failures.YAW_OFFSETS`), tried on each wrong approach: a hand whose yaw window is narrower than
30° could fall between the diagnosis' turns and be called a wrong approach for a wrong yaw."""

CLOSING_SLICES = 20
"""Closing is replayed in this many equal slices, to see whether the pads touched the box."""

SWEEP_DEPTH = 0.00875
"""The TCP's depth below the top face in the yaw, lateral and tilt sweeps [m]: a voxel layer
of a box lying on the table (top face at 30 mm, voxel centres 1.25, 8.75, 16.25 mm below it),
inside both hands' depth window (the depth sweep)."""

SWEEPS = {
    "depth_mm": np.arange(-15.0, 25.1, 2.5),
    "yaw_deg": np.arange(0.0, 40.1, 5.0),
    "lateral_mm": np.arange(0.0, 10.1, 1.0),
    "tilt_deg": np.arange(0.0, 50.1, 5.0),
}
"""The lone box's settings: each varies one quantity of the top-down grasp across the width
(TCP on the box's centre line at `SWEEP_DEPTH`, closing axis across the width); the tilt on a
box lying across another (`lone_box_trial`)."""


# -- geometry -----------------------------------------------------------------------------


def box_frame(T_world_object: np.ndarray) -> np.ndarray:
    """``T_world_box``: the large box's frame at its centre (the object's origin is at the
    centre of the face it was built lying on)."""
    T = T_world_object.copy()
    T[:3, 3] = T_world_object[:3, :3] @ np.array([0.0, 0.0, HALF[2]]) + T_world_object[:3, 3]
    return T


def closing_chord(p: np.ndarray, e_z: np.ndarray) -> tuple[float, float, int, int] | None:
    """Where the line ``p + t e_z`` (box frame) crosses the box: (t_in, t_out, axis of the face
    entered, axis of the face left), or None when it misses (slab method)."""
    t_in, t_out, a_in, a_out = -np.inf, np.inf, -1, -1
    for a in range(3):
        if abs(e_z[a]) < 1e-12:
            if abs(p[a]) > HALF[a]:
                return None
            continue
        t0, t1 = sorted(((-HALF[a] - p[a]) / e_z[a], (HALF[a] - p[a]) / e_z[a]))
        if t0 > t_in:
            t_in, a_in = t0, a
        if t1 < t_out:
            t_out, a_out = t1, a
    return (t_in, t_out, a_in, a_out) if t_in < t_out else None


def chord_kind(chord: tuple[float, float, int, int] | None) -> str:
    """The faces the closing line meets: ``side-side`` (across the width), ``flat-flat``
    (across the thickness), ``end-end``, two faces across an edge (``end-flat``, ``flat-side``,
    ``end-side``), or ``misses``."""
    if chord is None:
        return "misses"
    return "-".join(sorted((FACES[chord[2]], FACES[chord[3]])))


def across_edge(kind: str) -> bool:
    """Whether the closing line meets two faces at right angles (no antipodal pair)."""
    return kind != "misses" and kind.split("-")[0] != kind.split("-")[1]


def geometry(T_world_box: np.ndarray, T_world_tcp: np.ndarray, pad: tuple[float, float]) -> dict:
    """The grasp in the box's frame: the face the approach enters (the one whose outward normal
    is most against ``e_x``), the TCP's depth below it [m], the approach's angle to that face's
    normal [deg], the overlap along ``e_x`` of the pads (``pad``: their extent along ``e_x`` in
    the TCP frame [m]) with the box [m], the closing line's faces and the closing axis' angle in
    the entry face from the nearest box axis [deg]."""
    R = T_world_box[:3, :3].T @ T_world_tcp[:3, :3]
    p = T_world_box[:3, :3].T @ (T_world_tcp[:3, 3] - T_world_box[:3, 3])
    e_x, e_z = R[:, 0], R[:, 2]
    normals = np.concatenate([np.eye(3), -np.eye(3)])
    k = int(np.argmin(normals @ e_x))
    n, axis = normals[k], k % 3
    corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T * HALF
    along = (corners - p) @ e_x
    in_face = e_z - (e_z @ n) * n
    others = [a for a in range(3) if a != axis]
    yaw = min(
        np.degrees(np.arccos(min(1.0, abs(in_face[a]) / max(np.linalg.norm(in_face), 1e-12))))
        for a in others
    )
    return {
        "entry_face": FACES[axis],
        "depth": float(HALF[axis] - p @ n),
        "approach_tilt_deg": float(np.degrees(np.arccos(np.clip(-(n @ e_x), -1.0, 1.0)))),
        "pad_overlap": float(min(pad[1], along.max()) - max(pad[0], along.min())),
        "chord": chord_kind(closing_chord(p, e_z)),
        "yaw_deg": float(yaw),
        "tcp_in_box": [float(v) for v in p],
    }


def squared(T_world_box: np.ndarray, T_world_tcp: np.ndarray) -> np.ndarray:
    """``T_world_tcp`` turned about its own ``e_y`` (same TCP, same ``e_y``) until its closing
    axis lies on the box axis nearest to it in the plane ⊥ ``e_y``: from a TCP inside the box
    the closing line then meets two opposite faces."""
    R = T_world_box[:3, :3].T @ T_world_tcp[:3, :3]
    e_y, e_z = R[:, 1], R[:, 2]
    axes = np.eye(3) - np.outer(np.eye(3) @ e_y, e_y)
    lengths = np.linalg.norm(axes, axis=1)
    a = int(np.argmax(np.abs(axes @ e_z) / np.maximum(lengths, 1e-12)))
    new_z = axes[a] / lengths[a] * np.sign(axes[a] @ e_z)
    T = T_world_tcp.copy()
    T[:3, :3] = T_world_box[:3, :3] @ np.c_[np.cross(e_y, new_z), e_y, new_z]
    return T


# -- the instrumented trial ---------------------------------------------------------------


def closing(world: World, T: np.ndarray, aimed: int) -> dict[str, Any]:
    """`symgrasp.sim.execute.execute_grasp`'s steps up to the end of closing (pre-grasp,
    guarded approach, close), watched: how it ended there (``pregrasp_collision``,
    ``approach_collision``, ``holds_something`` or ``no_contact``), how far the approach and the
    closing moved box ``aimed`` [m], whether the hand touched it while closing."""
    pregrasp = T.copy()
    pregrasp[:3, 3] -= PREGRASP_DISTANCE * T[:3, 0]
    world.set_hand_pose(pregrasp)
    if world.hand_in_collision():
        return {"replayed": "pregrasp_collision"}
    start = world.object_poses()[aimed][:3, 3]
    lag = world.move_hand(T, duration=0.25, stop_force=BLOCKED_FORCE)
    approached = world.object_poses()[aimed][:3, 3]
    row: dict[str, Any] = {"box_moved_approach": float(np.linalg.norm(approached - start))}
    if lag > BLOCKED_ERROR:
        return {**row, "replayed": "approach_collision"}
    touched = False
    for _ in range(CLOSING_SLICES):
        world.actuate(close=True, duration=world.gripper.close_time / CLOSING_SLICES)
        touched |= aimed in world.objects_in_hand()
    closed = world.object_poses()[aimed][:3, 3]
    return {
        **row,
        "touched_closing": touched,
        "box_moved_closing": float(np.linalg.norm(closed - approached)),
        "opening": float(world.finger_opening()),
        "replayed": "holds_something" if world.objects_in_hand() else "no_contact",
    }


# -- replays of the recorded rounds -------------------------------------------------------


def label_angle(poses: np.ndarray, T: np.ndarray) -> float | None:
    """The smallest rotation angle [deg], up to the flip, between ``T`` and the label ``poses``
    (L, 4, 4) whose TCP voxel is within one voxel of ``T``'s; None without such a label."""
    near = np.all(np.abs(voxel_of(poses[:, :3, 3]) - voxel_of(T[None, :3, 3])) <= 1, axis=1)
    if not near.any():
        return None
    return float(np.degrees(rotation_angle_up_to_flip(T[:3, :3], poses[near, :3, :3]).min()))


def replay_round(model: GraspDetector, oracle: Any, seed: int, objects: Any) -> dict[str, Any]:
    """Round ``seed`` of the large box played by ``model`` with every executed grasp replayed
    instrumented (`closing`, `geometry`, `label_angle` when ``oracle``); a grasp across an edge
    also `squared` and played from the same state, a wrong approach also at `FINE_YAWS`."""
    watched, pad, rows = Watched(model, oracle), pad_extent(model.gripper), []

    def observe(world: World, points: np.ndarray, candidates: list, attempt: Any) -> None:
        if attempt.grasp is None:
            return
        T = attempt.grasp.pose
        start = watched.world()
        aimed = aimed_object(start, T)
        row = {"outcome": attempt.outcome, "mode": attempt.mode}
        row |= geometry(box_frame(start.object_poses()[aimed]), T, pad)
        if oracle is not None:
            row["label_angle_deg"] = label_angle(watched.labels, T)
        if across_edge(row["chord"]):
            moved = squared(box_frame(start.object_poses()[aimed]), T)
            row["squared_turn_deg"] = float(
                np.degrees(np.arccos(np.clip(moved[:3, 2] @ T[:3, 2], -1.0, 1.0)))
            )
            row["squared_outcome"] = execute_grasp(
                watched.world(), moved, remove=False
            ).outcome.value
        if attempt.mode == "wrong_approach":
            row["fine_yaws_that_hold"] = [
                round(float(np.degrees(a)))
                for a in FINE_YAWS
                if execute_grasp(
                    watched.world(), turned_about_approach(T, float(a)), remove=False
                ).success
            ]
        rows.append(row | closing(start, T, aimed))

    record = run_round(watched, objects, 5, seed=seed, observer=observe)
    return {"seed": seed, "attempts": [[a.outcome, a.mode] for a in record.attempts], "rows": rows}


def recorded_cell(model: GraspDetector) -> dict[int, list[list[str]]]:
    """The recorded large-box rounds of ``model``'s Table 1 cell: seed → [outcome, mode] per
    attempt; empty when the archive is not there."""
    if not ARCHIVE.exists():
        return {}
    rep, seed = model.info["representation"], model.info["config"]["seed"]
    cell = f"{model.gripper.name}/{rep}/s{seed}/large-box/rounds.jsonl"
    with tarfile.open(ARCHIVE) as tar:
        lines = tar.extractfile(cell).read().decode().splitlines()
    rounds = [json.loads(line) for line in lines if line.strip()]
    return {r["seed"]: [[a["outcome"], a["mode"]] for a in r["attempts"]] for r in rounds}


def replays(name: str, rounds: int, labels: bool, work: Path) -> list[dict[str, Any]]:
    """Rounds ``0 … rounds − 1`` of shipped model ``name`` on the large box, from
    ``work/replay-NAME.jsonl`` where already played, the rest played and appended."""
    from symgrasp.peers.oracle import OraclePlanner

    path = work / f"replay-{name}.jsonl"
    done = records_by_seed(path)
    todo = [s for s in range(rounds) if s not in done]
    if todo:
        model = GraspDetector.from_pretrained(name, device="cpu")
        oracle = OraclePlanner(model.gripper) if labels else None
        objects = resolve("large-box")
        with path.open("a") as out:
            for seed in tqdm(todo, desc=name, unit="round"):
                record = replay_round(model, oracle, seed, objects)
                out.write(json.dumps(record) + "\n")
                out.flush()
                done[seed] = record
    return [done[s] for s in range(rounds)]


def rate(k: int, n: int) -> dict[str, Any]:
    """k of n with its share and Wilson 95 % interval [%]."""
    k, n = int(k), int(n)
    return {"k": k, "n": n, "percent": 100 * k / n if n else float("nan"), "ci95": wilson(k, n)}


def summarise_model(name: str, records: list[dict[str, Any]], recorded: dict) -> dict[str, Any]:
    """What a model's replays say: agreement with the recorded rounds, its wrong approaches by
    what happened at closing and by the faces the closing line meets, success by those faces."""
    rows = [row for r in records for row in r["rows"]]
    same = sum(recorded.get(r["seed"]) == r["attempts"] for r in records)
    wrong = [r for r in rows if r["mode"] == "wrong_approach"]
    depth = np.array([r["depth"] for r in wrong]) * 1000
    overlap = np.array([r["pad_overlap"] for r in wrong]) * 1000
    chords: dict[str, dict[str, Any]] = {}
    for kind in sorted({r["chord"] for r in rows}):
        of = [r for r in rows if r["chord"] == kind]
        chords[kind] = {
            "executed": len(of),
            "success": rate(sum(r["mode"] == "success" for r in of), len(of)),
            "wrong_approach": sum(r["mode"] == "wrong_approach" for r in of),
        }
    closing_agrees = sum(
        (r["outcome"] == "no_contact") == (r.get("replayed") == "no_contact")
        and (r["outcome"] == "approach_collision") == (r.get("replayed") == "approach_collision")
        for r in rows
    )
    summary = {
        "model": name,
        "rounds": len(records),
        "rounds_as_recorded": same if recorded else None,
        "replays_as_played": rate(closing_agrees, len(rows)),
        "executed": len(rows),
        "modes": dict(Counter(r["mode"] for r in rows)),
        "wrong_approach": rate(len(wrong), len(rows)),
        "wrong_approach_touched_closing": rate(
            sum(r.get("touched_closing", 0) for r in wrong), len(wrong)
        ),
        "wrong_approach_held_at_a_10deg_turn": rate(
            sum(bool(r.get("fine_yaws_that_hold")) for r in wrong), len(wrong)
        ),
        "wrong_approach_box_pushed_away_5mm": rate(
            sum(r.get("box_moved_approach", 0) > 0.005 for r in wrong), len(wrong)
        ),
        "wrong_approach_across_edge": rate(sum(across_edge(r["chord"]) for r in wrong), len(wrong)),
        "wrong_approach_line_misses_box": rate(
            sum(r["chord"] == "misses" for r in wrong), len(wrong)
        ),
        "wrong_approach_depth_mm_p10_50_90": np.percentile(depth, [10, 50, 90]).tolist()
        if len(depth)
        else [],
        "wrong_approach_pad_overlap_mm_p10_50_90": np.percentile(overlap, [10, 50, 90]).tolist()
        if len(overlap)
        else [],
        "across_edge_executed": rate(sum(across_edge(r["chord"]) for r in rows), len(rows)),
        "across_edge_tcp_within_30mm_of_an_end": rate(
            sum(abs(r["tcp_in_box"][1]) > HALF[1] - 0.03 for r in rows if across_edge(r["chord"])),
            sum(across_edge(r["chord"]) for r in rows),
        ),
        "across_edge_success": rate(
            sum(r["mode"] == "success" for r in rows if across_edge(r["chord"])),
            sum(across_edge(r["chord"]) for r in rows),
        ),
        "across_edge_squared_success": rate(
            sum(r.get("squared_outcome") == "success" for r in rows if across_edge(r["chord"])),
            sum(across_edge(r["chord"]) for r in rows),
        ),
        "wrong_approach_squared_success": rate(
            sum(r.get("squared_outcome") == "success" for r in wrong if across_edge(r["chord"])),
            sum(across_edge(r["chord"]) for r in wrong),
        ),
        "across_edge_squared_outcomes": dict(
            Counter(r["squared_outcome"] for r in rows if across_edge(r["chord"]))
        ),
        "squared_turn_deg_p50": float(
            np.median([r["squared_turn_deg"] for r in rows if "squared_turn_deg" in r])
        )
        if any("squared_turn_deg" in r for r in rows)
        else None,
        "chords": chords,
    }
    angles = [r["label_angle_deg"] for r in rows if "label_angle_deg" in r]
    if angles:
        edge = [r for r in rows if across_edge(r["chord"]) and "label_angle_deg" in r]
        summary["labels"] = {
            "executed_with_a_label_within_a_voxel": rate(
                sum(a is not None for a in angles), len(angles)
            ),
            "across_edge_with_a_label_within_a_voxel_and_20deg": rate(
                sum(r["label_angle_deg"] is not None and r["label_angle_deg"] < 20 for r in edge),
                len(edge),
            ),
            "other_with_a_label_within_a_voxel_and_20deg": rate(
                sum(
                    r["label_angle_deg"] is not None and r["label_angle_deg"] < 20
                    for r in rows
                    if not across_edge(r["chord"]) and "label_angle_deg" in r
                ),
                sum(not across_edge(r["chord"]) and "label_angle_deg" in r for r in rows),
            ),
        }
    return summary


# -- the lone box -------------------------------------------------------------------------


def lone_box_grasp(setting: str, value: float, along: float) -> np.ndarray:
    """``T_box_tcp`` of the lone box's top-down grasp across its width, ``along`` [m] from the
    middle of its length, with ``setting`` (a key of `SWEEPS`) at ``value``."""
    depth = value / 1000 if setting == "depth_mm" else SWEEP_DEPTH
    yaw = np.radians(value) if setting == "yaw_deg" else 0.0
    lateral = value / 1000 if setting == "lateral_mm" else 0.0
    tilt = np.radians(value) if setting == "tilt_deg" else 0.0
    e_x = np.array([0.0, 0.0, -1.0])
    e_z = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    R = np.c_[e_x, np.cross(e_z, e_x), e_z]
    c, s = np.cos(tilt), np.sin(tilt)
    R = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]]) @ R  # about the box's long axis y
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.array([0.0, along, HALF[2] - depth]) + lateral * R[:, 2]
    return T


def lone_box_trial(gripper: GripperSpec, setting: str, value: float, rng: np.random.Generator):
    """One trial of the lone box: the box lying flat at a random position and heading, the
    grasp of (``setting``, ``value``) at a random point of its length; the protocol's outcome
    (``success`` only when the box grasped at is the one lifted) and, for a hand that closed on
    nothing, whether its pads touched the box on the way.

    The tilt is played on a box lying across a second one, at its overhanging end (50–80 mm
    from its middle): on the table a tilted hand's lower finger meets the table first, and in
    the piles the grasps across an edge are those of boxes lying on others."""
    heading = rng.uniform(-np.pi, np.pi)
    T_support = np.eye(4)
    T_support[:2, :2] = [[np.cos(heading), -np.sin(heading)],
                         [np.sin(heading), np.cos(heading)]]  # fmt: skip
    T_support[:3, 3] = [*(WORKSPACE_SIZE / 2 + rng.uniform(-0.03, 0.03, 2)), TABLE_HEIGHT]
    poses = [T_support]
    along = rng.uniform(-0.06, 0.06)
    if setting == "tilt_deg":
        T_top = T_support.copy()
        T_top[:3, :3] = T_support[:3, :3] @ [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
        T_top[2, 3] += LARGE_BOX_SIZE[2]
        poses.append(T_top)
        along = rng.choice([-1, 1]) * rng.uniform(0.05, 0.08)
    world = World([large_box(f"large_box_{i}") for i in range(len(poses))], np.array(poses),
                  gripper=gripper)  # fmt: skip
    world.step(0.1)
    target = len(poses) - 1
    start = world.snapshot()
    T = box_frame(world.object_poses()[target]) @ lone_box_grasp(setting, value, along)
    result = execute_grasp(world, T, remove=False)
    outcome = result.outcome.value
    if result.success and result.object_index != target:
        outcome = "lifted_the_other_box"
    touched = None
    if outcome == "no_contact":
        world.restore(start)
        touched = bool(closing(world, T, target).get("touched_closing"))
    return outcome, touched


def sweep(hand: str, trials: int, grid: dict[str, np.ndarray], work: Path) -> dict[str, Any]:
    """Every setting of ``grid`` for ``hand``, ``trials`` trials each (seeded by the setting and
    its value, so both hands meet the same boxes), kept in ``work/sweep-HAND-TRIALS.json`` as
    each finishes."""
    path = work / f"sweep-{hand}-{trials}.json"
    done = json.loads(path.read_text()) if path.exists() else {}
    gripper = get_gripper(hand)
    todo = [(s, float(v)) for s, values in grid.items() for v in values if f"{s}={v:g}" not in done]
    for setting, value in tqdm(todo, desc=f"lone box, {hand}", unit="setting"):
        # the same box poses for both hands: their rates are paired
        rng = np.random.default_rng([list(SWEEPS).index(setting), round(value * 10) + 1000])
        results = [lone_box_trial(gripper, setting, value, rng) for _ in range(trials)]
        outcomes = Counter(o for o, _ in results)
        done[f"{setting}={value:g}"] = {
            "setting": setting,
            "value": value,
            "success": rate(outcomes["success"], trials),
            "outcomes": dict(outcomes),
            "no_contact_touched": sum(bool(t) for _, t in results),
        }
        path.write_text(json.dumps(done, indent=1))
    return done


# -- the report ---------------------------------------------------------------------------


def pct(r: dict[str, Any]) -> str:
    """A rate as ``% [Wilson 95 %] (k/n)``."""
    lo, hi = r["ci95"]
    return f"{r['percent']:.0f} [{abs(lo):.0f}, {hi:.0f}] ({r['k']}/{r['n']})"


def table(models: list[dict[str, Any]], sweeps: dict[str, dict], trials: int) -> str:
    text = [
        "Replays of the large-box rounds (shipped models; % [Wilson 95 %] (k/n)):",
        "",
        "| model | rounds as recorded | executed | wrong approach | … pads touched the box "
        "while closing | … closing line across an edge | … line misses the box | … held at a "
        "10° turn | … TCP depth below the entry face, mm (p10/50/90) | … pad overlap with the "
        "box, mm (p50) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for m in models:
        depth = "/".join(f"{v:.0f}" for v in m["wrong_approach_depth_mm_p10_50_90"]) or "–"
        overlap = m["wrong_approach_pad_overlap_mm_p10_50_90"]
        text.append(
            f"| `{m['model']}` | {m['rounds_as_recorded']} of {m['rounds']} | {m['executed']} | "
            f"{pct(m['wrong_approach'])} | {pct(m['wrong_approach_touched_closing'])} | "
            f"{pct(m['wrong_approach_across_edge'])} | "
            f"{pct(m['wrong_approach_line_misses_box'])} | "
            f"{pct(m['wrong_approach_held_at_a_10deg_turn'])} | {depth} | {overlap[1]:.0f} |"
            if overlap
            else f"| `{m['model']}` | {m['rounds_as_recorded']} of {m['rounds']} | "
            f"{m['executed']} | {pct(m['wrong_approach'])} | – | – | – | – | – | – |"
        )
    text += [
        "",
        "Grasps whose closing line crosses an edge, as played and squared (the same TCP and "
        "e_y, the closing axis turned about e_y onto the nearest box axis, played from the "
        "same state):",
        "",
        "| model | executed across an edge | success as played | success squared | wrong "
        "approaches that hold squared | median turn | outcomes squared |",
        "|---|---|---|---|---|---|---|",
    ]
    for m in models:
        turn = m["squared_turn_deg_p50"]
        text.append(
            f"| `{m['model']}` | {pct(m['across_edge_executed'])} | "
            f"{pct(m['across_edge_success'])} | {pct(m['across_edge_squared_success'])} | "
            f"{pct(m['wrong_approach_squared_success'])} | "
            + (f"{turn:.0f}°" if turn is not None else "–")
            + " | "
            + ", ".join(f"{o} {c}" for o, c in sorted(m["across_edge_squared_outcomes"].items()))
            + " |"
        )
    kinds = sorted({k for m in models for k in m["chords"]})
    text += [
        "",
        "Success by the faces the closing line through the TCP meets (executed grasps of each "
        "hand's models pooled; success % [Wilson 95 %] (k/n), wrong approaches):",
        "",
        "| faces | " + " | ".join(GRIPPERS) + " |",
        "|---|" + "---|" * len(GRIPPERS),
    ]
    for kind in kinds:
        cells = []
        for hand in GRIPPERS:
            of = [m["chords"][kind] for m in models if hand in m["model"] and kind in m["chords"]]
            k = sum(c["success"]["k"] for c in of)
            n = sum(c["executed"] for c in of)
            wa = sum(c["wrong_approach"] for c in of)
            cells.append(f"{pct(rate(k, n))}, {wa}" if n else "–")
        text.append(f"| {kind} | " + " | ".join(cells) + " |")
    labelled = [m for m in models if "labels" in m]
    if labelled:
        text += [
            "",
            "The oracle's labels of the same state near each executed grasp (a label whose TCP is "
            "within one voxel):",
            "",
            "| model | any label | across an edge: a label within 20° | other grasps: a label "
            "within 20° |",
            "|---|---|---|---|",
        ]
        for m in labelled:
            lab = m["labels"]
            text.append(
                f"| `{m['model']}` | {pct(lab['executed_with_a_label_within_a_voxel'])} | "
                f"{pct(lab['across_edge_with_a_label_within_a_voxel_and_20deg'])} | "
                f"{pct(lab['other_with_a_label_within_a_voxel_and_20deg'])} |"
            )
    names = {"depth_mm": "TCP depth below the top face [mm]", "yaw_deg": "yaw [deg]",
             "lateral_mm": "TCP off the centre line along the closing axis [mm]",
             "tilt_deg": "tilt about the box's long axis [deg]"}  # fmt: skip
    for setting, title in names.items():
        values = sorted({r["value"] for s in sweeps.values() for r in s.values()
                         if r["setting"] == setting})  # fmt: skip
        if not values:
            continue
        text += [
            "",
            f"A lone box lying flat, top-down across its width: {title} (success % [Wilson 95 %] "
            f"of {trials}; outcomes of the failures)",
            "",
            f"| {setting} | " + " | ".join(GRIPPERS) + " |",
            "|---|" + "---|" * len(GRIPPERS),
        ]
        for value in values:
            cells = []
            for hand in GRIPPERS:
                r = sweeps[hand].get(f"{setting}={value:g}")
                if r is None:
                    cells.append("–")
                    continue
                lo, hi = r["success"]["ci95"]
                fails = ", ".join(
                    f"{o} {c}" for o, c in sorted(r["outcomes"].items()) if o != "success"
                )
                cells.append(f"{r['success']['percent']:.0f} [{abs(lo):.0f}, {hi:.0f}]"
                             + (f" ({fails})" if fails else ""))  # fmt: skip
            text.append(f"| {value:g} | " + " | ".join(cells) + " |")
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=100,
                        help="large-box rounds (seeds 0…) replayed per model (default: %(default)s)")  # fmt: skip
    parser.add_argument("--models", nargs="+", default=list(PRETRAINED),
                        help="shipped models replayed (default: all of them)")  # fmt: skip
    parser.add_argument("--no-labels", action="store_true",
                        help="skip the oracle's labels near each grasp of the bingham2d models")  # fmt: skip
    parser.add_argument("--trials", type=int, default=20,
                        help="lone-box trials per setting and hand (default: %(default)s)")  # fmt: skip
    parser.add_argument("--work", default="out/franka_box",
                        help="folder of the finished rounds and settings, for resuming "
                        "(default: %(default)s)")  # fmt: skip
    add_result_option(parser, "franka_box")
    args = parse_args(
        parser,
        outputs=("result", "work"),
        quick={
            "rounds": 1,
            "models": ["bingham2d-franka", "bingham2d-robotiq-2f85"],
            "no_labels": True,
            "trials": 1,
        },
        also="every fourth lone-box setting",
    )
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    models = []
    for name in args.models:
        records = replays(name, args.rounds, not args.no_labels and "bingham2d" in name, work)
        recorded = recorded_cell(GraspDetector.from_pretrained(name, device="cpu"))
        models.append(summarise_model(name, records, recorded))
    grid = {s: v[::4] if args.quick else v for s, v in SWEEPS.items()}
    sweeps = {hand: sweep(hand, args.trials, grid, work) for hand in GRIPPERS}
    text = table(models, sweeps, args.trials)
    print(text)
    write_result(
        args.result,
        "why the Franka hand fails the large box by approach: replays and a lone box",
        command_line("SYMGRASP_DATA=DIR OMP_NUM_THREADS=1 PYTHONPATH=src nice -n 10"),
        models,
        text,
        rounds=args.rounds,
        trials=args.trials,
        sweep_depth_m=SWEEP_DEPTH,
        pads={hand: pad_extent(get_gripper(hand)) for hand in GRIPPERS},
        sweeps=sweeps,
    )


if __name__ == "__main__":
    run_main(main)
