"""A benchmark folder survives a kill: rounds saved as they finish, --resume plays the missing
ones, a folder of another configuration or an existing one without --resume is refused."""

import json
import os
import random
import signal
import subprocess
import sys
import time
from dataclasses import fields
from pathlib import Path

import pytest

import symgrasp
from symgrasp.benchmark import runner
from symgrasp.benchmark.declutter import Attempt, Round
from symgrasp.benchmark.runner import BenchmarkConfig
from symgrasp.cli import main
from symgrasp.config import PlannerOptions
from symgrasp.names import DECOMPOSITIONS


@pytest.fixture
def played(fake_rounds):
    """Seeds played, in order, by fake rounds: a success on odd seeds, a slip on even ones (so
    the bootstrap sees different rounds), without a simulator or a model."""
    seeds = []

    def fake_round(detector, objects, num_objects, seed, **_):
        seeds.append(seed)
        outcome = "success" if seed % 2 else "slipped"
        return Round(seed, num_objects, "gl", [Attempt(outcome, None, 1, 0, 0.1, num_objects)])

    fake_rounds(fake_round)
    return seeds


def _lines(path):
    return [json.loads(line) for line in Path(path).read_text().splitlines()]


def test_resume_plays_only_the_missing_rounds_once_each_in_seed_order(played, tmp_path):
    config = BenchmarkConfig(rounds=4, seed=10)
    whole = runner.run_benchmark(config, tmp_path / "whole")
    rounds = _lines(tmp_path / "whole" / "rounds.jsonl")
    assert [r["seed"] for r in rounds] == [10, 11, 12, 13] and played == [10, 11, 12, 13]
    part = tmp_path / "part"  # as a killed run with workers leaves it: out of order, a torn line
    runner.run_benchmark(config, part)
    lines = (part / "rounds.jsonl").read_text().splitlines(keepends=True)
    (part / "rounds.jsonl").write_text(lines[2] + lines[0] + lines[3][:25])
    assert runner.saved_rounds(config, part) is None  # unfinished
    del played[:]
    assert runner.run_benchmark(config, part, resume=True) == whole
    assert played == [11, 13]
    assert _lines(part / "rounds.jsonl") == rounds
    assert json.loads((part / "results.json").read_text())["summary"] == whole
    assert runner.run_benchmark(config, part, resume=True) == whole and played == [11, 13]


def test_a_torn_last_line_is_ignored_and_dropped_before_appending(played, tmp_path):
    config = BenchmarkConfig(rounds=2, seed=0)
    runner.run_benchmark(config, tmp_path)
    text = (tmp_path / "rounds.jsonl").read_text()
    (tmp_path / "rounds.jsonl").write_text(text[: len(text) - 10])  # killed mid-line
    assert list(runner.read_rounds(tmp_path / "rounds.jsonl")) == [0]
    assert runner.run_or_reuse(config, tmp_path) == _lines(tmp_path / "rounds.jsonl")
    assert [r["seed"] for r in _lines(tmp_path / "rounds.jsonl")] == [0, 1]
    assert played == [0, 1, 1]


def test_stale_results_beside_an_empty_rounds_file_are_resumed_not_returned(played, tmp_path):
    config = BenchmarkConfig(rounds=3, seed=5)  # a folder that the old, buffered runner left
    (tmp_path / "results.json").write_text(json.dumps({"config": config.record(), "summary": {}}))
    (tmp_path / "rounds.jsonl").write_text("")
    assert runner.saved_rounds(config, tmp_path) is None
    rounds = runner.run_or_reuse(config, tmp_path)
    assert [r["seed"] for r in rounds] == [5, 6, 7] and played == [5, 6, 7]
    assert json.loads((tmp_path / "config.json").read_text()) == config.record()
    assert runner.run_or_reuse(config, tmp_path) == rounds and played == [5, 6, 7]


def test_an_existing_folder_needs_resume_and_the_same_configuration(played, tmp_path, monkeypatch):
    argv = ["bench", "declutter", "--rounds", "2", "--num-objects", "1", "--seed", "3"]
    main([*argv, "--out", str(tmp_path)])
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}

    def no_model(*args, **kwargs):
        raise AssertionError("the folder must be checked before the model loads")

    monkeypatch.setattr("symgrasp.detect.GraspDetector.from_pretrained", no_model)
    guarded = [*argv, "--gripper", "robotiq-2f85", "--out", str(tmp_path)]
    with pytest.raises(SystemExit, match=r"^error: out .* already holds a benchmark; .*--resume"):
        main(guarded)
    with pytest.raises(SystemExit, match=r"another configuration \(its num_objects, seed differ\)"):
        main([*guarded, "--num-objects", "2", "--seed", "4", "--resume"])
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    assert played == [3, 4]
    with pytest.raises(ValueError, match="another configuration"):
        runner.run_or_reuse(BenchmarkConfig(rounds=3, seed=3, num_objects=1), tmp_path)
    (tmp_path / "config.json").unlink()
    (tmp_path / "results.json").unlink()
    with pytest.raises(ValueError, match="unrecorded configuration"):
        runner.run_benchmark(BenchmarkConfig(rounds=2, seed=3), tmp_path, resume=True)


def test_a_folder_recorded_before_the_clearances_was_played_with_the_old_rule(
    fake_rounds, tmp_path
):
    """Rounds are played with the configuration's clearances; a folder whose config.json
    predates the fields played −0.002 for both (`runner.PLAYED_BEFORE`): a resume with the new
    defaults is refused naming them, one with −0.002 reuses the folder."""
    given = []

    def fake_round(detector, objects, num_objects, seed, table_clearance, surface_clearance, **_):
        given.append((table_clearance, surface_clearance))
        return Round(seed, num_objects, "gl", [Attempt("success", None, 1, 0, 0.1, num_objects)])

    fake_rounds(fake_round)
    old = BenchmarkConfig(rounds=2, seed=0, table_clearance=-0.002, surface_clearance=-0.002)
    rounds = runner.run_or_reuse(old, tmp_path)
    assert given == [(-0.002, -0.002)] * 2
    recorded = json.loads((tmp_path / "config.json").read_text())
    del recorded["table_clearance"], recorded["surface_clearance"]
    (tmp_path / "config.json").write_text(json.dumps(recorded))
    assert runner.recorded_config(tmp_path)["table_clearance"] == -0.002
    assert runner.recorded_config(tmp_path)["surface_clearance"] == -0.002
    refused = r"another configuration \(its surface_clearance, table_clearance differ\)"
    with pytest.raises(ValueError, match=refused):
        runner.run_or_reuse(BenchmarkConfig(rounds=2, seed=0), tmp_path)
    with pytest.raises(ValueError, match=r"\(its surface_clearance differ\)"):
        runner.run_or_reuse(BenchmarkConfig(rounds=2, seed=0, table_clearance=-0.002), tmp_path)
    assert runner.run_or_reuse(old, tmp_path) == rounds and len(given) == 2


def _run_and_kill(argv, out, delay):
    """Run ``argv`` in a process and SIGKILL it ``delay`` s after one more round than ``out``
    held at the start is in its rounds.jsonl (unless it finished first); return the text the
    kill left in rounds.jsonl."""
    env = {**os.environ, "PYTHONPATH": str(Path(symgrasp.__file__).parents[1])}
    code = f"from symgrasp.cli import main; main({[*argv, '--out', str(out)]!r})"
    rounds = out / "rounds.jsonl"
    before = rounds.read_text().count("\n") if rounds.exists() else 0
    with open(out.parent / f"{out.name}.log", "a") as log:
        process = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=log, stderr=log)
    deadline = time.monotonic() + 120
    while process.poll() is None and not (
        rounds.exists() and rounds.read_text().count("\n") > before
    ):
        assert time.monotonic() < deadline, "no round finished in 120 s"
        time.sleep(0.02)
    time.sleep(delay)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert rounds.exists(), (out.parent / f"{out.name}.log").read_text()
    return rounds.read_text()


def test_killed_benchmarks_resume_to_the_uninterrupted_result(
    tmp_path, without_timings, cpu_hog, caller_threads
):
    # rounds played on a loaded machine, in fresh processes (torch's threads: one per core)
    # and in this one, given one thread: the same rounds
    caller_threads(1)
    argv = ["bench", "declutter", "--rounds", "4", "--num-objects", "1", "--seed", "3"]
    out, delays = tmp_path / "killed", random.Random(0)
    saved = []
    for kill in range(2):  # killed at random moments: between rounds, inside one, mid-write
        text = _run_and_kill([*argv, *(["--resume"] if kill else [])], out, delays.uniform(0, 1))
        saved += [json.loads(line) for line in text[: text.rfind("\n") + 1].splitlines()]
    assert saved and {r["seed"] for r in saved} <= {3, 4, 5, 6}
    main([*argv, "--resume", "--out", str(out)])
    main([*argv, "--out", str(tmp_path / "whole")])
    resumed, whole = (_lines(tmp_path / name / "rounds.jsonl") for name in ("killed", "whole"))
    assert all(r in resumed for r in saved)  # kept as they were (timings too), not replayed
    assert without_timings(resumed) == without_timings(whole)
    results = [json.loads((tmp_path / n / "results.json").read_text()) for n in ("killed", "whole")]
    assert without_timings(results[0]) == without_timings(results[1])
    assert cpu_hog.poll() is None, "the machine was not loaded to the end"


def test_a_model_file_overwritten_by_other_weights_is_refused_not_reused(played, tmp_path):
    # A run selected again writes other weights to the same best.pt: the rounds its folder
    # holds were played by the old weights and must not be taken for the new ones.
    from symgrasp.detect.pretrained import shipped_path

    model = tmp_path / "best.pt"
    model.write_bytes(shipped_path("bingham2d-robotiq-2f85").read_bytes())
    config = BenchmarkConfig(model=str(model), rounds=2)
    out = tmp_path / "cell"
    runner.run_benchmark(config, out)
    assert len(runner.saved_rounds(config, out)) == 2
    model.write_bytes(shipped_path("bingham2d-franka").read_bytes())
    del played[:]
    for call in (lambda: runner.saved_rounds(config, out),
                 lambda: runner.run_benchmark(config, out, resume=True)):  # fmt: skip
        with pytest.raises(ValueError, match=f"out {out} holds rounds of another model file"):
            call()
    assert played == []
    (out / runner.MODEL_SHA).unlink()  # a folder from before the record: taken as it is
    assert len(runner.saved_rounds(config, out)) == 2


STORED_OPTIONS = {
    "decoding": [["validity_floor", 0.02], ["fallbacks", 8], ["approach_check", True]],
    "oracle": [
        ["gripper", "robotiq-2f85"],
        ["grasps", 20],
        ["directions", 4],
        ["offset", [-0.02, 0.03]],
    ],
    "no threshold": [["confidence_threshold", 0.0]],
    "none": [],
}
"""Planner options as benchmark folders recorded them while they were untyped (name, value)
pairs (the stored rounds archives of the lab hold such folders)."""


@pytest.mark.parametrize("kind", STORED_OPTIONS)
def test_typed_options_are_recorded_as_the_pairs_folders_hold(played, tmp_path, kind):
    stored = STORED_OPTIONS[kind]
    model = "oracle" if kind == "oracle" else BenchmarkConfig.model
    options = PlannerOptions(**{k: tuple(v) if isinstance(v, list) else v for k, v in stored})
    config = BenchmarkConfig(model=model, rounds=2, options=options)
    old = {f.name: getattr(config, f.name) for f in fields(config)}
    text = json.dumps({**old, "options": stored}, indent=1) + "\n"  # the untyped writer's
    runner.run_benchmark(config, tmp_path / "new")
    assert (tmp_path / "new" / "config.json").read_text() == text
    folder = tmp_path / "old"  # a folder of the untyped days: its rounds are reused, not played
    folder.mkdir()
    (folder / "config.json").write_text(text)
    (folder / "rounds.jsonl").write_text((tmp_path / "new" / "rounds.jsonl").read_text())
    assert runner.run_or_reuse(config, folder) == _lines(folder / "rounds.jsonl")
    assert played == [0, 1]


def test_a_folder_recorded_before_the_decomposition_presets_reads_as_coacd(played, tmp_path):
    """Bare meshes were cut by CoACD before the presets: a config.json without the key reads
    ``coacd`` where the objects may hold bare meshes, so a resume with the new default is
    refused naming it and one with ``coacd`` reuses the rounds; a named set (VGN's URDFs, the
    procedural sets) decomposes nothing and reads as the default, its stored rounds reused."""
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (meshes / "cup.obj").write_text("v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nv 0 0 0.05\nf 1 2 3\n")
    for objects, before in ((str(meshes), "coacd"), ("vgn-pile-test", DECOMPOSITIONS[0])):
        folder = tmp_path / "bench" / Path(objects).name
        folder.mkdir(parents=True)
        config = BenchmarkConfig(objects=objects, rounds=2, decomposition=before)
        recorded = config.record()
        del recorded["decomposition"]  # as written before the field
        (folder / "config.json").write_text(json.dumps(recorded))
        (folder / "rounds.jsonl").write_text(  # failed rounds: no renderer to agree with here
            "".join(json.dumps({"seed": s, "error": "x"}) + "\n" for s in (0, 1))
        )
        assert runner.recorded_config(folder)["decomposition"] == before
        runner.check_out(config, folder, resume=True)
        assert len(runner.saved_rounds(config, folder)) == 2
        if before != DECOMPOSITIONS[0]:
            now = BenchmarkConfig(objects=objects, rounds=2)
            with pytest.raises(ValueError, match=r"another configuration \(its decomposition"):
                runner.check_out(now, folder, resume=True)
            assert runner.saved_rounds(now, folder) is None
    assert played == []
