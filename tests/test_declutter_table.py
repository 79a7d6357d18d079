"""benchmarks/declutter_table.py's statistics from cells whose rounds are known by
construction: each seed's ratios, the failure modes pooled over seeds, and bingham2d's lead
counted over every pairing of training seeds on the same rounds."""

import sys
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
