"""The ``symgrasp`` command line: options shared between sub-commands parse the same way."""

import pytest

from symgrasp.cli import _confidence_threshold, build_parser

DETECT = ["detect", "--model", "m.pt", "--depth", "d.npy", "--intrinsic", "k.json",
          "--extrinsic", "t.json", "--out", "o"]  # fmt: skip
DECLUTTER = ["bench", "declutter", "--model", "m.pt", "--out", "o"]


@pytest.mark.parametrize("command", [DETECT, DECLUTTER], ids=["detect", "declutter"])
@pytest.mark.parametrize(
    ("extra", "expected"),
    [([], None), (["--confidence", "7.5"], 7.5), (["--no-confidence"], 0.0)],
)
def test_confidence_options_map_to_the_detector_threshold(command, extra, expected):
    args = build_parser().parse_args([*command, *extra])
    assert _confidence_threshold(args) == expected


@pytest.mark.parametrize("command", [DETECT, DECLUTTER], ids=["detect", "declutter"])
def test_confidence_and_no_confidence_are_exclusive(command, capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args([*command, "--confidence", "3", "--no-confidence"])
    assert "not allowed with argument" in capsys.readouterr().err
