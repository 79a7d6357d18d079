"""Output folders (`symgrasp.folders`): every command that writes one refuses an empty or blank
path and a folder of someone else's files, and holds its folder for the run, so that a second
writer is refused at once and the folder is left as it was; a killed run's lock holds nothing.
Names from user data that become file names are refused when they could leave their folder."""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from bad_input_cases import MODEL, detect_argv, make_files

import symgrasp
from symgrasp.cli import build_parser, main
from symgrasp.cli.options import input_folder, output_folder_path, output_path
from symgrasp.detect.pretrained import shipped_path
from symgrasp.folders import LOCK, Outputs, check_file_name, output_folder

TINY_DATASET = ["--objects", "blocks", "--gripper", "franka", "--pool-size", "1", "--grasps", "5",
                "--directions", "4"]  # fmt: skip
"""Options of a dataset made in a second or two."""


def _commands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    """Every (command words, parser) under ``parser``."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield (*path, name), sub
                yield from _commands(sub, (*path, name))


def _output_actions():
    """{command: [its actions whose value names what it writes]}: every ``--out``, and the
    positional folders and files written into (their names in `POSITIONAL_OUTPUTS`)."""
    found = {}
    for words, parser in _commands(build_parser()):
        actions = [
            a for a in parser._actions
            if "--out" in a.option_strings or (words, a.dest) in POSITIONAL_OUTPUTS
        ]  # fmt: skip
        if actions:
            found[" ".join(words)] = actions
    return found


POSITIONAL_OUTPUTS = {
    (("export",), "out"): (["export", str(shipped_path(MODEL)), "{}"], "argument out"),
    (("select",), "run_dir"): (["select", "{}", "--by", "val_loss"], "argument RUN_DIR"),
    (("data", "inspect"), "root"): (["data", "inspect", "{}"], "argument root"),
    (("objects", "fetch"), "data"): (
        ["objects", "fetch", "vgn", "--data", "{}"],
        "argument --data",
    ),
}
"""The outputs that are not ``--out``: (command, dest) → (argv with ``{}`` for the path, how
the parser names it)."""


def test_every_output_is_typed_as_an_output_path():
    """The list the next test plays is every command's output, and each is checked alike: a
    folder written into as a folder path, a file as a file path, a folder read and reported
    into (a dataset, a run) as an existing folder."""
    outputs = _output_actions()
    assert set(outputs) == {
        "demo", "sim show", "gripper show", "data generate", "data relabel", "data inspect", "data show",
        "figures percentiles", "figures continuity", "figures distribution", "train", "select",
        "detect", "export", "bench declutter", "objects inspect", "objects fetch",
    }  # fmt: skip
    for command, actions in outputs.items():
        kinds = {a.type for a in actions}
        assert kinds <= {output_path, output_folder_path, input_folder}, command
        assert (input_folder in kinds) == (command in ("data inspect", "select")), command


def _argv(command: str, path: str) -> tuple[list[str], str]:
    """The argv of ``command`` writing ``path``, and how the parser names that argument."""
    for (words, _), (argv, named) in POSITIONAL_OUTPUTS.items():
        if " ".join(words) == command:
            return [a.format(path) for a in argv], named
    return [*command.split(), "--out", path], "argument --out"


@pytest.mark.parametrize("path", ["", " ", "\t"])
@pytest.mark.parametrize("command", sorted(_output_actions()))
def test_an_empty_or_blank_output_path_is_refused(command, path, tmp_path, monkeypatch, capsys):
    """``--out ''`` would write into the current folder, ``--out ' '`` into a folder named by
    a space: refused by the parser, in one line naming the option, before anything is made."""
    monkeypatch.chdir(tmp_path)
    argv, named = _argv(command, path)
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    message = capsys.readouterr().err.strip()
    assert exit_.value.code == 2
    assert len(message.splitlines()) == 1, message
    assert f"{named}: must name a path, got {path!r}" in message
    assert os.listdir(tmp_path) == []


# -- one writer per folder ----------------------------------------------------------------


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


WRITERS = {
    "data generate": lambda out, d: ["data", "generate", *TINY_DATASET, "--scenes", "1", "--out", out],
    "data inspect": lambda out, d: ["data", "inspect", out, "--validate", "0"],
    "bench declutter": lambda out, d: ["bench", "declutter", "--rounds", "1", "--num-objects", "1", "--out", out],
    "train": lambda out, d: ["train", "--data", str(d), "--out", out],
    "select": lambda out, d: ["select", out, "--by", "val_loss"],
    "demo": lambda out, d: ["demo", "--num-objects", "1", "--out", out],
    "sim show": lambda out, d: ["sim", "show", "--n", "1", "--out", out],
    "figures percentiles": lambda out, d: ["figures", "percentiles", "--samples", "10", "--repeats", "1", "--out", out],
    "detect": lambda out, d: [*detect_argv(d)[:-1], out],
    "objects fetch": lambda out, d: ["objects", "fetch", "vgn", "--data", out, "--url", "file:///nothing"],
}  # fmt: skip
"""Each command that holds its folder, as argv writing ``out`` (files of `make_files` in ``d``)."""


@pytest.mark.parametrize("command", WRITERS)
def test_a_second_writer_is_refused_and_the_folder_left_as_it_was(
    command, tmp_path, wide_jaw, capsys
):
    """While this process holds the folder (as a running command does), the command is refused
    at once in one line naming the folder and the holder, and changes nothing in it."""
    files = make_files(tmp_path, wide_jaw)
    out = tmp_path / "held"
    with output_folder(out, None):
        before = _snapshot(out)
        with pytest.raises(SystemExit) as exit_:
            main(WRITERS[command](str(out), files))
        assert _snapshot(out) == before
    message = str(exit_.value.code)
    assert len(message.splitlines()) == 1, message
    assert f"{out} is being written by process {os.getpid()}" in message
    assert not out.exists()  # the holder made it, wrote nothing and removed it


def _holder(folder: Path) -> subprocess.Popen:
    """A process that holds ``folder`` until its stdin closes; returns once it holds it."""
    code = (
        "import sys; from symgrasp.folders import output_folder\n"
        f"with output_folder({str(folder)!r}, None):\n"
        "    print('held', flush=True); sys.stdin.read()"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(symgrasp.__file__).parents[1])}
    process = subprocess.Popen(
        [sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env
    )
    assert process.stdout.readline() == b"held\n"
    return process


def test_a_dataset_held_by_another_process_is_refused_then_resumed_after_it_is_killed(tmp_path):
    """The issue's two runs into one folder: the second, seed 1, is refused while another
    process holds the dataset; that process is killed (its lock file stays behind, holding
    nothing) and the dataset resumes and finishes as one seed's, the lock file gone."""
    out = tmp_path / "d"
    main(["data", "generate", *TINY_DATASET, "--scenes", "1", "--out", str(out)])
    holder = _holder(out)
    before = _snapshot(out)
    with pytest.raises(SystemExit, match=f"being written by process {holder.pid}"):
        main(["data", "generate", *TINY_DATASET, "--scenes", "2", "--seed", "1", "--resume",
              "--out", str(out)])  # fmt: skip
    assert _snapshot(out) == before
    holder.send_signal(signal.SIGKILL)
    holder.wait()
    assert (out / LOCK).read_text() == f"{holder.pid}\n"  # left behind by the kill
    main(["data", "generate", *TINY_DATASET, "--scenes", "2", "--resume", "--out", str(out)])
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["seed"] == 0 and manifest["scene_ids"] == [0, 1]
    assert not (out / LOCK).exists()


def test_the_lock_is_taken_once_per_folder_and_released(tmp_path):
    out = tmp_path / "a" / "b"
    with output_folder(out, None) as held:
        assert held == out and (out / LOCK).read_text() == f"{os.getpid()}\n"
        with pytest.raises(ValueError, match=f"out {out} is being written by process"):
            with output_folder(out, None):  # not re-entrant: one holder, even in one process
                pass
        (out / "result.txt").write_text("written")
    assert os.listdir(out) == ["result.txt"]  # written into: kept, without the lock file
    with output_folder(tmp_path / "a" / "c", None):
        pass
    assert os.listdir(tmp_path / "a") == ["b"]  # made and left empty: removed again
    with pytest.raises(RuntimeError), output_folder(out, None):
        raise RuntimeError("a crash inside the run")
    with output_folder(out, None):  # released by the exception
        pass


# -- a folder of someone else's files -------------------------------------------------------


def test_bench_refuses_a_folder_of_the_users_own_results(tmp_path):
    """A user's results.md and model.sha256 are a benchmark's names but not a benchmark (no
    config.json): refused before the model loads, and left as they were."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "results.md").write_text("my table")
    (out / "model.sha256").write_text("my hash")
    before = _snapshot(out)
    with pytest.raises(SystemExit, match=r"not a benchmark \(model.sha256, results.md\)"):
        main(["bench", "declutter", "--rounds", "1", "--out", str(out)])
    assert _snapshot(out) == before


def test_outputs_account_for_their_record_kinds_and_hidden_entries(tmp_path):
    outputs = Outputs("a thing", kinds=("*.png", "cache"), record=("record.json",))
    (tmp_path / "a.png").write_bytes(b"")
    (tmp_path / "cache").mkdir()
    (tmp_path / ".DS_Store").write_bytes(b"")
    (tmp_path / ".x.123.tmp").write_bytes(b"")
    assert outputs.foreign(tmp_path) == []
    (tmp_path / "notes.txt").write_text("mine")
    assert outputs.foreign(tmp_path) == ["notes.txt"]
    (tmp_path / "record.json").write_text("{}")  # its own earlier output: its to check
    assert outputs.foreign(tmp_path) == []
    assert outputs.foreign(tmp_path / "missing") == []


# -- names that become file names -----------------------------------------------------------


@pytest.mark.parametrize("name", ["../../../x", "a/b", "a\\b", "..", ".", "", "a\nb", "a\x00b"])
def test_a_name_that_would_leave_its_folder_is_refused(name):
    with pytest.raises(ValueError, match="object's name must be one file name"):
        check_file_name(name, "object's name")


@pytest.mark.parametrize("name", ["chips_can", "My Mug (1)", "a..b", "tasse-à-café"])
def test_a_name_of_one_file_passes(name):
    assert check_file_name(name) == name


def test_a_urdf_whose_name_leaves_the_folder_is_refused_naming_the_file(tmp_path, wide_jaw):
    from symgrasp.objects.urdf import load_urdf
    from symgrasp.sim import ObjectSpec, Part

    make_files(tmp_path, wide_jaw)
    urdf = tmp_path / "escaping" / "thing.urdf"
    with pytest.raises(ValueError, match=f"{urdf}: the robot's name must be one file name"):
        load_urdf(urdf)
    with pytest.raises(ValueError, match="name must be one file name"):  # the API, too
        ObjectSpec("../x", "box", (Part("box", (0.01, 0.01, 0.01)),), 0.1, 0.5)
