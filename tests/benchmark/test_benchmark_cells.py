"""`symgrasp.benchmark.cells`: one folder and one benchmark configuration per cell, the same for
every script that reads it (the campaign's test steps play cells that the Table 1 collation
reads back, so a change here would replay them all)."""

from pathlib import Path

import pytest

from symgrasp.benchmark.cells import Cell
from symgrasp.config import BenchmarkConfig


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
    assert dict(ablation.config("m.pt").options) == {"confidence_threshold": 0.0}
    assert packed.folder("o") == Path("o/franka/rotmat6d/s1/vgn-packed-test-packed")
    assert packed.config("m.pt").scene == "packed" and packed.config("m.pt").options == ()


@pytest.mark.parametrize(("fields", "message"), [
    ({"scene": "heap"}, "scene must be one of"),
    ({"seed": -1}, "training seed ≥ 0"),
])  # fmt: skip
def test_bad_cells_are_refused_naming_the_field(fields, message):
    with pytest.raises(ValueError, match=message):
        Cell(**{"gripper": "franka", "rep": "bingham2d", "seed": 0, "objects": "x", **fields})
