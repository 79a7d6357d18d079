"""A round is the same bytes wherever it is played: on this process's threads or a worker's,
on a loaded machine, rendered as the folder's rounds were (a resume elsewhere is refused)."""

import json

import pytest
import torch

from symgrasp.benchmark import runner
from symgrasp.benchmark.declutter import Round
from symgrasp.benchmark.runner import BenchmarkConfig
from symgrasp.config import ParallelConfig


def _float32_sum() -> float:
    """A reduction torch splits over its threads: its rounding depends on their number."""
    return torch.rand(1_000_003, generator=torch.Generator().manual_seed(0)).sum().item()


def test_a_round_runs_on_one_thread_whatever_the_caller_s_and_the_caller_keeps_its_own(
    fake_rounds, caller_threads, tmp_path
):
    seen = []

    def fake_round(detector, objects, num_objects, seed, **_):
        seen.append((torch.get_num_threads(), _float32_sum()))
        return Round(seed, num_objects, "gl")

    fake_rounds(fake_round)
    sums = {}
    for threads in (1, 2):
        caller_threads(threads)
        sums[threads] = _float32_sum()
        runner.run_benchmark(BenchmarkConfig(rounds=2), tmp_path / f"threads-{threads}")
        assert torch.get_num_threads() == threads  # the caller's setting, restored
    assert sums[1] != sums[2]  # the oracle: threads change this sum's rounding ...
    assert seen == [(runner.ROUND_THREADS, sums[1])] * 4  # ... but not inside a round


def test_rounds_are_the_same_in_process_and_on_two_workers_under_load(
    tmp_path, cpu_hog, caller_threads, without_timings
):
    config = BenchmarkConfig(rounds=2, num_objects=2, seed=3)
    caller_threads(2)  # rounds played here once took this process's two threads, workers one
    runner.run_benchmark(config, tmp_path / "here")
    runner.run_benchmark(config, tmp_path / "workers", parallel=ParallelConfig(workers=2))
    assert cpu_hog.poll() is None, "the machine was not loaded to the end"
    rounds, results = {}, {}
    for name in ("here", "workers"):
        lines = (tmp_path / name / "rounds.jsonl").read_text().splitlines()
        rounds[name] = [json.dumps(without_timings(json.loads(line))) for line in lines]
        results[name] = without_timings(json.loads((tmp_path / name / "results.json").read_text()))
    assert rounds["here"] == rounds["workers"]
    assert results["here"] == results["workers"]
    played = [json.loads(line) for line in rounds["here"]]
    assert sum(len(r["attempts"]) for r in played) >= 3  # grasps to compare, not empty rounds
    assert {r["renderer"] for r in played} == {runner.local_renderer()}  # what a resume checks


def test_a_resume_where_depth_is_rendered_otherwise_is_refused(fake_rounds, monkeypatch, tmp_path):
    fake_rounds(lambda detector, objects, num_objects, seed, **_: Round(seed, num_objects, "gl"))
    monkeypatch.setattr(runner, "local_renderer", lambda: "gl")
    config = BenchmarkConfig(rounds=3, seed=0)
    runner.run_benchmark(config, tmp_path)
    runner.check_out(config, tmp_path, resume=True)  # rendered here as there: resumes
    monkeypatch.setattr(runner, "local_renderer", lambda: "raycast")
    refused = (
        f"out {tmp_path} holds rounds rendered by gl, but depth images here come from the "
        "raycast renderer .*; resume where the gl renderer works, or choose another out"
    )
    with pytest.raises(ValueError, match=refused):
        runner.check_out(config, tmp_path, resume=True)
    with pytest.raises(ValueError, match=refused):
        runner.run_benchmark(config, tmp_path, resume=True)
    # only finished rounds say how the benchmark renders
    failed = [{"seed": s, "error": "RuntimeError: x", "traceback": ""} for s in range(3)]
    (tmp_path / "rounds.jsonl").write_text("".join(json.dumps(r) + "\n" for r in failed))
    runner.check_out(config, tmp_path, resume=True)


def test_a_worker_that_would_render_otherwise_fails_its_rounds(fake_rounds, monkeypatch):
    fake_rounds(lambda detector, objects, num_objects, seed, **_: Round(seed, num_objects, "gl"))
    runner._init_worker(BenchmarkConfig(), ".")
    monkeypatch.setattr(runner, "local_renderer", lambda: "raycast")
    refused = "on this worker come from the raycast renderer, the benchmark's from gl"
    with pytest.raises(RuntimeError, match=refused):
        runner._played_round("gl", 0)
    assert runner._played_round("raycast", 0)["seed"] == 0
