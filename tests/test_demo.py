"""The `symgrasp` command and the demo behind `make demo`."""

from __future__ import annotations

import json

import pytest

from symgrasp.cli import build_parser, main


def test_demo_writes_picture_and_recovers_its_distributions(tmp_path, capsys):
    main(["demo", "--out", str(tmp_path), "--seed", "3"])
    assert (tmp_path / "bingham.png").stat().st_size > 10_000
    summary = json.loads((tmp_path / "summary.json").read_text())
    for entry in summary["distributions"]:
        assert entry["fitted_mode_error_deg"] < 3.0
    assert str(tmp_path / "bingham.png") in capsys.readouterr().out


def test_every_option_has_help():
    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.dest == "command")
    for name, sub in subparsers.choices.items():
        assert sub.description, name
        for action in sub._actions:
            assert action.help, f"{name} {action.dest}"


def test_unknown_command_fails():
    with pytest.raises(SystemExit):
        main(["fly"])
