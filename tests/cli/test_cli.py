"""The ``symgrasp`` command line: options shared between sub-commands parse the same way."""

import pytest

from symgrasp.cli import build_parser
from symgrasp.cli.fields import config_from_args
from symgrasp.cli.model import _TRAIN_PREFIXES
from symgrasp.cli.options import confidence_threshold
from symgrasp.config import (
    BenchmarkConfig,
    DatabaseConfig,
    LossWeights,
    NetworkConfig,
    SceneConfig,
    TrainConfig,
    ValidityLoss,
)
from symgrasp.fields import field_docs

DETECT = ["detect", "--model", "m.pt", "--depth", "d.npy", "--intrinsic", "k.json",
          "--extrinsic", "t.json", "--out", "o"]  # fmt: skip
DECLUTTER = ["bench", "declutter", "--model", "m.pt", "--out", "o"]


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    """The files DETECT and DECLUTTER read, existing (the parser checks that), in the current
    folder."""
    monkeypatch.chdir(tmp_path)
    for name in ("m.pt", "d.npy", "k.json", "t.json"):
        (tmp_path / name).touch()


@pytest.mark.parametrize("command", [DETECT, DECLUTTER], ids=["detect", "declutter"])
@pytest.mark.parametrize(
    ("extra", "expected"),
    [([], None), (["--confidence", "7.5"], 7.5), (["--no-confidence"], 0.0)],
)
def test_confidence_options_map_to_the_detector_threshold(command, extra, expected, inputs):
    args = build_parser().parse_args([*command, *extra])
    assert confidence_threshold(args) == expected


@pytest.mark.parametrize("command", [DETECT, DECLUTTER], ids=["detect", "declutter"])
def test_confidence_and_no_confidence_are_exclusive(command, capsys, inputs):
    with pytest.raises(SystemExit):
        build_parser().parse_args([*command, "--confidence", "3", "--no-confidence"])
    assert "not allowed with argument" in capsys.readouterr().err


def test_depth_scale_is_parsed_for_the_detector_which_checks_its_range(inputs, capsys):
    assert build_parser().parse_args([*DETECT, "--depth-scale", "1.03"]).depth_scale == 1.03
    assert build_parser().parse_args(DETECT).depth_scale is None
    with pytest.raises(SystemExit):
        build_parser().parse_args([*DETECT, "--depth-scale", "-1"])
    assert "--depth-scale" in capsys.readouterr().err


@pytest.mark.parametrize("given", [True, False])
def test_approach_check_reaches_the_detector_of_detect_and_serve(given, inputs):
    from symgrasp.cli.detect import load_detector

    for command in ([*DETECT[:1], *DETECT[3:]], ["serve"]):  # the shipped default model
        args = build_parser().parse_args(command + ["--approach-check"] * given)
        assert load_detector(args).approach_check is given


def test_building_the_parser_loads_neither_torch_nor_mujoco():
    import subprocess
    import sys

    code = (
        "import sys; from symgrasp.cli import build_parser; build_parser(); "
        "print(' '.join(m for m in ('torch', 'mujoco', 'trimesh', 'numpy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == []


@pytest.mark.parametrize(
    ("command", "cls"),
    [
        (["data", "generate", "--out", "o"], SceneConfig),
        (["bench", "declutter", "--out", "o"], BenchmarkConfig),
    ],
    ids=["data generate", "bench declutter"],
)
def test_options_left_out_give_the_configurations_defaults(command, cls):
    assert config_from_args(cls, build_parser().parse_args(command)) == cls()


def test_train_options_build_the_whole_configuration():
    argv = ["train", "--data", "d", "--out", "r", "--rep", "rotmat6d", "--no-augment",
            "--widths", "4", "8", "16", "32", "--weight-score", "0.5"]  # fmt: skip
    config = config_from_args(
        TrainConfig, build_parser().parse_args(argv), prefixes=_TRAIN_PREFIXES
    )
    expected = TrainConfig(
        "d", "r", NetworkConfig("rotmat6d", (4, 8, 16, 32)), augment=False,
        loss_weights=LossWeights(score=0.5),
    )  # fmt: skip
    assert config == expected


def test_train_recipe_options_reach_the_configuration():
    argv = ["train", "--data", "d", "--out", "r", "--schedule", "onecycle", "--warmup", "0.3",
            "--min-lr", "1e-6", "--ema", "0.999", "--weight-decay", "0.01", "--validity-loss",
            "focal", "--focal-gamma", "1.5", "--focal-alpha", "0.25", "--train-scenes", "900",
            "--keep-every", "5"]  # fmt: skip
    config = config_from_args(
        TrainConfig, build_parser().parse_args(argv), prefixes=_TRAIN_PREFIXES
    )
    expected = TrainConfig(
        "d", "r", schedule="onecycle", warmup=0.3, min_lr=1e-6, ema=0.999, weight_decay=0.01,
        validity=ValidityLoss("focal", 1.5, 0.25), train_scenes=900, keep_every=5,
    )  # fmt: skip
    assert config == expected
    defaults = config_from_args(
        TrainConfig, build_parser().parse_args(argv[:5]), prefixes=_TRAIN_PREFIXES
    )
    assert defaults == TrainConfig("d", "r")


def test_nested_options_reach_the_database_and_its_policy_applies():
    args = build_parser().parse_args(["data", "generate", "--out", "o", "--grasps", "1000"])
    database = config_from_args(SceneConfig, args).database
    assert (database.grasps, database.max_candidates) == (1000, 4000)  # max(2000, 4 · grasps)
    assert DatabaseConfig().max_candidates == 2000


@pytest.mark.parametrize(
    "cls",
    [
        SceneConfig,
        DatabaseConfig,
        TrainConfig,
        LossWeights,
        NetworkConfig,
        ValidityLoss,
        BenchmarkConfig,
    ],
)
def test_every_configuration_field_is_documented(cls):
    import dataclasses

    assert set(field_docs(cls)) == {f.name for f in dataclasses.fields(cls)}


def test_unknown_names_are_refused_with_the_known_ones(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["data", "generate", "--out", "o", "--objects", "kitchen"])
    assert "household-train" in capsys.readouterr().err
