"""The analysis figures: percentile approximation, analysis scenes, statistics, files, CLI."""

import json

import numpy as np
import pytest
import torch

from symgrasp import analysis
from symgrasp.analysis import (
    FLAT_CYLINDER,
    LONG_BOX,
    SampledAxes,
    choose_layer,
    continuity_statistics,
    parse_model_specs,
    percentile_row,
    render_depth,
    slice_layer,
)
from symgrasp.cli import build_parser, main
from symgrasp.model.checkpoint import save_checkpoint
from symgrasp.model.network import GraspNet, NetworkConfig
from symgrasp.perception import TSDFVolume
from symgrasp.workspace import VOXEL_SIZE


@pytest.fixture(scope="module")
def checkpoints(tmp_path_factory):
    """Untrained checkpoints of the four representations of Table 1 (validity ≈ 0.01
    everywhere)."""
    root = tmp_path_factory.mktemp("models")
    torch.manual_seed(0)
    paths = {}
    for rep in ("bingham2d", "rotmat6d", "quaternion", "bingham3d"):
        net = GraspNet(NetworkConfig(rep))
        paths[rep] = root / f"{rep}.pt"
        save_checkpoint(paths[rep], {
            "representation": rep,
            "gripper": "robotiq-2f85",
            "network": {"representation": rep, "widths": [8, 16, 32, 64], "features": 16},
            "model": net.state_dict(),
        })  # fmt: skip
    return paths


@pytest.mark.parametrize("lam", [(-200.0, -200.0, 0.0), (-1000.0, -1000.0, 0.0)])
@pytest.mark.parametrize("axis", [0, 1])
def test_percentile_approximation_matches_monte_carlo_for_concentrated_shapes(lam, axis):
    row = percentile_row(lam, axis, samples=20_000, repeats=3, seed=0)
    assert row.lam == lam and row.axis == axis
    assert abs(row.relative_difference) < 0.03
    assert 0 < row.mc_std_deg < 0.05 * row.mc_mean_deg
    expected = np.degrees(2 * 1.8213863677184496 / np.sqrt(-lam[axis]))  # 2 erf⁻¹(0.99)/√κ
    assert row.approx_deg == pytest.approx(expected, rel=1e-9)


def test_percentiles_command_writes_table_json_and_picture(tmp_path, capsys):
    main(["figures", "percentiles", "--samples", "20000", "--repeats", "3", "--seed", "5",
          "--out", str(tmp_path)])  # fmt: skip
    record = json.loads((tmp_path / "bingham_percentiles.json").read_text())
    assert record["command"] == (
        f"symgrasp figures percentiles --samples 20000 --repeats 3 --seed 5 --out {tmp_path}"
    )
    rows = record["rows"]
    assert len(rows) == 2 * len(analysis.SHAPES)
    assert {(tuple(r["lam"]), r["axis"]) for r in rows} >= {((-50.0, -10.0, 0.0), 0)}
    assert set(rows[0]) == {
        "lam", "axis", "approx_deg", "mc_mean_deg", "mc_std_deg", "relative_difference"
    }  # fmt: skip
    table = (tmp_path / "bingham_percentiles.md").read_text()
    assert len(table.splitlines()) == 2 + len(rows) and "| (-50, -10, 0) | 1 |" in table
    assert (tmp_path / "bingham_percentiles.png").stat().st_size > 20_000
    assert "| (-1000, -1000, 0) | 2 |" in capsys.readouterr().out


def test_scene_puts_the_box_top_at_11_cm_over_its_footprint():
    depth, intrinsic, T_world_camera = render_depth((LONG_BOX,))
    volume = TSDFVolume()
    volume.integrate(depth, intrinsic, T_world_camera)
    points = volume.point_cloud().numpy()
    raised = points[points[:, 2] > 0.06]  # above the table top (z = 0.05 m)
    assert len(raised) > 100
    assert np.all(LONG_BOX.footprint_distance(raised[:, :2]) < 1.5 * VOXEL_SIZE)
    over_centre = raised[np.abs(raised[:, :2] - 0.15).max(1) < 0.02]
    assert over_centre[:, 2].max() == pytest.approx(0.11, abs=VOXEL_SIZE)
    assert slice_layer(0.057) == 7


def test_auto_height_picks_the_layer_with_the_most_valid_voxels_over_all_models():
    first, second = torch.zeros(40, 40, 40), torch.zeros(40, 40, 40)
    first[:3, 0, 12] = 0.9  # 3 valid voxels at k = 12
    second[:2, 0, 5] = second[:2, 1, 12] = 0.6  # 2 at k = 5, 2 more at k = 12
    outputs = [{"validity": first}, {"validity": second}]
    assert choose_layer(None, outputs, 0.5) == 12
    assert choose_layer(None, outputs[1:], 0.5) == 5  # ties go to the lower layer
    assert choose_layer(0.057, outputs, 0.5) == 7
    with pytest.raises(ValueError, match="--height"):
        choose_layer(0.31, outputs, 0.5)


def test_footprints_measure_horizontal_distance():
    xy = np.array([[0.15, 0.15], [0.15, 0.20], [0.28, 0.15], [0.15, 0.30]])
    np.testing.assert_allclose(LONG_BOX.footprint_distance(xy), [0, 0.02, 0.03, 0.12], atol=1e-12)
    on_cylinder = np.array([[0.15, 0.25], [0.15, 0.20]])
    np.testing.assert_allclose(
        FLAT_CYLINDER.footprint_distance(on_cylinder), [0, 0.015], atol=1e-12
    )


def test_continuity_statistic_sees_flips_only_with_sign_and_mode_averaging_off_y():
    valid = np.zeros((40, 40), dtype=bool)
    valid[10:30, 15:20] = True
    e_z = np.zeros((40, 40, 3))
    e_z[..., 1] = 1.0
    e_z[20:] *= -1  # +y for i < 20, −y beyond: a flip between i = 19 and 20
    flipped = continuity_statistics(e_z, valid, sign_invariant=False)
    assert flipped["valid_voxels"] == 100 and flipped["neighbour_pairs"] == 19 * 5 + 20 * 4
    assert flipped["neighbour_flip_fraction"] == pytest.approx(5 / 175)
    assert flipped["neighbour_angle_deg_median"] == 0 and flipped["off_y_deg_median"] == 0
    symmetric = continuity_statistics(e_z, valid, sign_invariant=True)
    assert symmetric["neighbour_flip_fraction"] == 0 and symmetric["neighbour_angle_deg_p90"] == 0
    e_z[..., :2] = np.sqrt(0.5)  # 45° off the ±y line: an output between the modes
    assert continuity_statistics(e_z, valid, False)["off_y_deg_median"] == pytest.approx(45)
    empty = continuity_statistics(e_z, np.zeros_like(valid), True)
    assert empty["valid_voxels"] == 0 and empty["neighbour_angle_deg_median"] is None


def test_spread_is_zero_at_a_point_mass_and_45_degrees_for_a_uniform_azimuth():
    azimuth = np.linspace(0, np.pi, 1000, endpoint=False)
    uniform = np.stack([np.cos(azimuth), np.sin(azimuth), 0 * azimuth], -1)
    mode = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    samples = np.stack([np.tile(-mode[:1], (1000, 1)), uniform])
    axes = SampledAxes(np.zeros((2, 2)), samples, mode, np.ones(2))
    np.testing.assert_allclose(axes.spread_deg(), [0, 45], atol=0.1)


def test_continuity_command_draws_a_panel_per_model(checkpoints, tmp_path):
    models = [word for rep, path in checkpoints.items() for word in ("--model", f"{rep}={path}")]
    main(["figures", "continuity", *models, "--validity", "0", "--out", str(tmp_path)])
    record = json.loads((tmp_path / "rotation_continuity.json").read_text())
    assert record["layer"] == 7 and "--model bingham2d=" in record["command"]
    assert set(record["models"]) == set(checkpoints)
    for rep, stats in record["models"].items():
        assert stats["representation"] == rep and stats["valid_voxels"] == 40 * 40
        assert stats["sign_invariant"] == (rep == "bingham2d")
        assert stats["neighbour_angle_deg_median"] is not None and "off_y_deg_median" in stats
    assert (tmp_path / "rotation_continuity.png").stat().st_size > 20_000


def test_distribution_command_reports_each_object(checkpoints, tmp_path):
    main(["figures", "distribution", "--model", str(checkpoints["bingham2d"]), "--samples", "5",
          "--height", "auto", "--validity", "0", "--out", str(tmp_path)])  # fmt: skip
    record = json.loads((tmp_path / "rotation_distribution.json").read_text())
    assert record["samples"] == 5 and record["valid_voxels"] == 40 * 40
    assert record["height"] is None and record["layer"] == 0  # all layers full: the lowest
    assert "--height auto --validity 0.0" in record["command"]
    assert set(record["objects"]) == {"box", "cylinder"}
    for stats in record["objects"].values():
        assert stats["voxels"] > 0 and stats["mean_confidence"] > 0
        assert 0 <= stats["mean_spread_deg"] <= 90
    assert (tmp_path / "rotation_distribution.png").stat().st_size > 20_000
    with pytest.raises(SystemExit, match="error: --model: a 'rotmat6d' model"):
        main(["figures", "distribution", "--model", str(checkpoints["rotmat6d"]),
              "--validity", "0", "--out", str(tmp_path)])  # fmt: skip


def test_model_specs_are_label_equals_path(tmp_path):
    checkpoint = tmp_path / "b.pt"
    checkpoint.touch()  # the parser checks that the file exists, not what it holds
    args = build_parser().parse_args(
        ["figures", "continuity", "--model", f"bingham2d={checkpoint}"]
    )
    assert parse_model_specs(args.model) == {"bingham2d": str(checkpoint)}
    assert parse_model_specs(["ours=x=1.pt", "rotmat6d=y.pt"]) == {
        "ours": "x=1.pt", "rotmat6d": "y.pt"
    }  # fmt: skip
    for bad in (["runs/best.pt"], ["=a.pt"], ["a=b.pt", "a=c.pt"]):
        with pytest.raises(ValueError, match="--model"):
            parse_model_specs(bad)
    with pytest.raises(SystemExit):
        main(["figures", "continuity", "--model", "best.pt"])  # refused by the parser
