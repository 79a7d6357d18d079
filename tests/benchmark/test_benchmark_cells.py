"""`symgrasp.benchmark.cells`: one folder and one benchmark configuration per cell, the same for
every script that reads it (the campaign's test steps play cells that the Table 1 collation
reads back, so a change here would replay them all)."""

import json
from dataclasses import asdict
from pathlib import Path

import pytest

from symgrasp.benchmark.cells import Cell
from symgrasp.benchmark.runner import check_out
from symgrasp.config import BenchmarkConfig, PlannerOptions


def test_a_pile_cell_keeps_the_layout_and_configuration_the_campaign_played(tmp_path):
    model = tmp_path / "runs" / "final-bingham2d-s2" / "best.pt"
    cell = Cell("robotiq-2f85", "bingham2d", 2, "vgn-pile-test")
    assert cell.run(tmp_path / "runs", "final") == model.parent
    assert cell.folder("bench") == Path("bench/robotiq-2f85/bingham2d/s2/vgn-pile-test")
    assert cell.config(model) == BenchmarkConfig(
        model=str(model.resolve()), objects="vgn-pile-test", num_objects=5, rounds=100
    )


def test_the_ablation_and_packed_cells_have_folders_and_options_of_their_own():
    ablation = Cell("franka", "bingham2d", 0, "large-box", threshold=False)
    packed = Cell("franka", "rotmat6d", 1, "vgn-packed-test", scene="packed")
    assert ablation.folder("o") == Path("o/franka/bingham2d-noconf/s0/large-box")
    assert ablation.config("m.pt").options == PlannerOptions(confidence_threshold=0.0)
    assert packed.folder("o") == Path("o/franka/rotmat6d/s1/vgn-packed-test-packed")
    assert (
        packed.config("m.pt").scene == "packed"
        and packed.config("m.pt").options == PlannerOptions()
    )


def test_another_first_seed_plays_its_own_rounds_in_a_folder_of_its_own(tmp_path):
    table1 = Cell("robotiq-2f85", "bingham2d", 2, "vgn-pile-test")
    untouched = Cell("robotiq-2f85", "bingham2d", 2, "vgn-pile-test", first_seed=100)
    assert Cell("robotiq-2f85", "bingham2d", 2, "vgn-pile-test", first_seed=0) == table1
    assert untouched.folder("o") == Path("o/robotiq-2f85/bingham2d/s2/vgn-pile-test-first-seed-100")
    config = untouched.config("m.pt")
    assert (config.seed, config.rounds) == (100, 100)  # round seeds 100-199
    assert asdict(config) == {**asdict(table1.config("m.pt")), "seed": 100}
    # a folder of Table 1's rounds refuses to be resumed with the other first seed's
    folder = table1.folder(tmp_path)
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps(table1.config("m.pt").record()))
    check_out(table1.config("m.pt"), folder, resume=True)
    with pytest.raises(ValueError, match=r"its seed differ"):
        check_out(untouched.config("m.pt"), folder, resume=True)


@pytest.mark.parametrize(("fields", "message"), [
    ({"scene": "heap"}, "scene must be one of"),
    ({"seed": -1}, "training seed ≥ 0"),
    ({"first_seed": -1}, "round seed ≥ 0"),
])  # fmt: skip
def test_bad_cells_are_refused_naming_the_field(fields, message):
    with pytest.raises(ValueError, match=message):
        Cell(**{"gripper": "franka", "rep": "bingham2d", "seed": 0, "objects": "x", **fields})
