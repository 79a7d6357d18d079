"""benchmarks/declutter_table.py's statistics from cells whose rounds are known by
construction: each seed's ratios, the failure modes pooled over seeds, bingham2d's lead
counted over every pairing of training seeds on the same rounds, stored rounds that collate
again without the training runs, and the README quoting the stored table."""

import argparse
import dataclasses
import json
import sys
import tarfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import declutter_table as table

from symgrasp.benchmark.cells import Cell


def _rounds(outcomes):
    """Round records, one per entry of ``outcomes`` (seed i), each a list of attempt outcomes
    and modes of one 5-object round."""
    rounds = []
    for seed, attempts in enumerate(outcomes):
        records = [{"outcome": o, "mode": m, "target": None, "planning_s": 0.1}
                   for o, m in attempts]  # fmt: skip
        rounds.append({"seed": seed, "objects": 5, "renderer": "test", "attempts": records,
                       "successes": sum(o == "success" for o, _ in attempts),
                       "executed": sum(o != "none_found" for o, _ in attempts)})  # fmt: skip
    return rounds


HIT, YAW = ("success", None), ("no_contact", "wrong_yaw")


@pytest.fixture
def played():
    """bingham2d grasps 2 of 2 in every round for seeds 0 and 1, 0 of 2 for seed 2; rotmat6d
    grasps 1 of 2 (one wrong yaw) in every round for every seed: bingham2d is ahead in the 6
    pairings of its seeds 0 and 1 and behind in the 3 of its seed 2."""
    good, bad, half = [[HIT, HIT]] * 20, [[YAW, YAW]] * 20, [[HIT, YAW]] * 20
    cells = {}
    for seed, rounds in enumerate((good, good, bad)):
        cells[Cell("franka", "bingham2d", seed, "large-box")] = {"rounds": _rounds(rounds)}
    for seed in range(3):
        cells[Cell("franka", "rotmat6d", seed, "large-box")] = {"rounds": _rounds(half)}
    return cells


def test_each_seed_its_ratio_and_the_modes_pooled_over_seeds(played):
    row = table.row(played, "franka", "bingham2d", True, "large-box", "pile")
    assert row["seeds"] == [0, 1, 2]
    assert [row["per_seed"][s]["success_ratio"] for s in "012"] == [1.0, 1.0, 0.0]
    assert row["ratios"]["success_ratio"][0] == pytest.approx(2 / 3)
    assert row["ratios"]["clear_ratio"][0] == pytest.approx(2 / 3 * 2 / 5)
    assert row["modes"]["wrong_yaw"] == 40 and row["executed"] == 120
    empty = table.row(played, "franka", "quaternion", True, "large-box", "pile")
    assert empty["seeds"] == [] and "ratios" not in empty


def test_the_lead_counts_every_pairing_of_seeds_on_the_same_rounds(played):
    rows = [table.row(played, "franka", rep, True, "large-box", "pile")
            for rep in ("bingham2d", "rotmat6d")]  # fmt: skip
    lead = table.lead(played, *rows)
    assert (lead["ahead"], lead["pairings"], lead["rounds"]) == (6, 9, 20)
    change, low, high = lead["change"]["success_ratio"]
    assert change == pytest.approx(2 / 3 - 1 / 2)
    assert low < 0 < high  # one seed of three is worse in every round: the seed decides


def _store(cell, out, rounds, model):
    """A cell folder as `run_benchmark` leaves it: its configuration and its rounds."""
    folder = cell.folder(out)
    folder.mkdir(parents=True)
    config = cell.config(model, rounds=len(rounds), num_objects=5)
    (folder / "config.json").write_text(json.dumps(dataclasses.asdict(config)))
    (folder / "rounds.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rounds))


def test_stored_rounds_collate_again_without_the_runs_and_archive_byte_for_byte(tmp_path):
    cells = {Cell("franka", "bingham2d", 0, "large-box"): _rounds([[HIT, YAW]] * 4),
             Cell("franka", "rotmat6d", 0, "large-box"): _rounds([[YAW]] * 4),
             Cell("franka", "rotmat6d", 1, "large-box"): _rounds([[HIT]] * 3)}  # fmt: skip
    for cell, rounds in cells.items():
        _store(cell, tmp_path / "played", rounds, tmp_path / "runs" / "gone.pt")
    args = argparse.Namespace(runs=tmp_path / "no-runs", out=tmp_path / "played", rounds=4,
                              num_objects=5, quick=None, collate_only=True)  # fmt: skip
    played = {cell: table.play(cell, args, table.PREFIXES) for cell in cells}
    short = Cell("franka", "rotmat6d", 1, "large-box")  # 3 of the 4 rounds: waits
    assert played[short] == {"rounds": None, "waiting": "final-franka-rotmat6d-s1 (not selected)"}
    assert all(played[c]["rounds"] == cells[c] for c in cells if c != short)

    table.write_archive(tmp_path / "a.tar.gz", played, args)
    with tarfile.open(tmp_path / "a.tar.gz") as tar:
        assert len(tar.getnames()) == 4  # config and rounds of the two complete cells
        tar.extractall(tmp_path / "unpacked", filter="data")
    args.out = tmp_path / "unpacked"
    again = {cell: table.play(cell, args, table.PREFIXES) for cell in cells}
    assert again == played
    table.write_archive(tmp_path / "b.tar.gz", again, args)
    assert (tmp_path / "a.tar.gz").read_bytes() == (tmp_path / "b.tar.gz").read_bytes()


def _quoted(value: float, signed: bool) -> str:
    """``value`` (a ratio) as the docs print it: percent, one decimal, U+2212 for minus."""
    return (f"{100 * value:+.1f}" if signed else f"{100 * value:.1f}").replace("-", "−")


def test_the_readme_headline_quotes_the_stored_table():
    """The README's Table 1 sentence is written by hand: it must quote the collated numbers
    (benchmarks/results/declutter.json), so recollating without rewriting it fails here."""
    root = Path(__file__).resolve().parents[1]
    stored = json.loads((root / "benchmarks/results/declutter.json").read_text())
    readme = " ".join((root / "README.md").read_text().split())
    cell = next(c for c in stored["cells"] if (c["gripper"], c["rep"], c["threshold"], c["objects"])
                == ("robotiq-2f85", "bingham2d", True, "vgn-pile-test"))  # fmt: skip
    mean, low, high = (_quoted(v, False) for v in cell["ratios"]["success_ratio"])
    assert f"{mean} % [{low}, {high}]" in readme
    for gripper in ("robotiq-2f85", "franka"):
        lead = next(m for m in stored["leads"] if m["gripper"] == gripper
                    and m["b"] == ["rotmat6d", True] and m["objects"] == "vgn-pile-test")  # fmt: skip
        change, low, high = (_quoted(v, True) for v in lead["change"]["success_ratio"])
        assert f"{change} [{low}, {high}]" in readme, gripper
