"""The executors' contract on the local backends: every argument once, results as they finish,
a task that raises recorded as a `Failure`, never retried; generation records failed scenes
and a resumed run makes them."""

import json
import math

import pytest

from symgrasp.cli import main
from symgrasp.config import DatabaseConfig, ParallelConfig, SceneConfig
from symgrasp.parallel import Failure, Job, TasksFailed, open_executor, torch_threads
from symgrasp.parallel.base import bounded


@pytest.mark.parametrize("workers", [1, 2])
def test_every_argument_once_and_a_raising_task_is_a_failure(workers):
    with open_executor(ParallelConfig(workers=workers)) as executor:
        assert executor.workers == workers and executor.in_process == (workers == 1)
        results = list(executor.map(Job(math.sqrt), [4, -1, 9, 16, 25], "sqrt"))
    assert sorted(arg for arg, _ in results) == [-1, 4, 9, 16, 25]
    if workers == 1:  # in process: in argument order
        assert [arg for arg, _ in results] == [4, -1, 9, 16, 25]
    values = dict(results)
    assert {a: values[a] for a in (4, 9, 16, 25)} == {4: 2.0, 9: 3.0, 16: 4.0, 25: 5.0}
    failure = values[-1]
    assert isinstance(failure, Failure) and failure.error == "ValueError: math domain error"
    assert "Traceback" in failure.traceback and "math domain error" in failure.traceback


def test_bounded_keeps_at_most_limit_in_flight_and_yields_each_once():
    in_flight, most = set(), 0

    def submit(arg):
        nonlocal most
        in_flight.add(arg)
        most = max(most, len(in_flight))
        return arg

    def wait(handles):
        done = max(handles)  # out of submission order
        in_flight.discard(done)
        return [done]

    pairs = list(bounded(range(10), submit, wait, limit=3))
    assert sorted(arg for arg, _ in pairs) == list(range(10)) and most == 3
    assert all(arg == handle for arg, handle in pairs)


TINY = ["--objects", "blocks", "--gripper", "franka", "--pool-size", "2", "--grasps", "40"]
TINY += ["--directions", "8", "--scenes", "4"]


def test_a_failing_scene_is_recorded_the_others_written_and_resume_makes_it(tmp_path, monkeypatch):
    from symgrasp.data import generate

    main(["data", "generate", *TINY, "--out", str(tmp_path / "whole")])
    real = generate.make_scene_record

    def fails_on_scene_2(scene_id, *args):
        if scene_id == 2:
            raise RuntimeError("no pile for this seed")
        return real(scene_id, *args)

    out = tmp_path / "part"
    monkeypatch.setattr(generate, "make_scene_record", fails_on_scene_2)
    config = SceneConfig(
        object_set="blocks",
        gripper="franka",
        pool_size=2,
        database=DatabaseConfig(grasps=40, directions=8),
    )  # the same as TINY
    with pytest.raises(TasksFailed, match=r"1 of 4 scenes failed \(scene 2: RuntimeError"):
        generate.generate(out, config, scenes=4)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["scene_ids"] == [0, 1, 3]
    [failed] = manifest["failed"]
    assert failed["scene"] == 2 and failed["seed"] == 0
    assert "no pile for this seed" in failed["traceback"]
    monkeypatch.setattr(generate, "make_scene_record", real)
    main(["data", "generate", *TINY, "--out", str(out), "--resume"])
    resumed = json.loads((out / "manifest.json").read_text())
    whole = json.loads((tmp_path / "whole" / "manifest.json").read_text())
    assert [run["scenes"] for run in resumed.pop("generated_with")] == [3, 1]
    assert [run["scenes"] for run in whole.pop("generated_with")] == [4]
    assert "failed" not in resumed and resumed == whole


def test_the_cli_reports_failed_tasks_in_one_line(tmp_path, monkeypatch, capsys):
    from symgrasp.data import generate

    def always_fails(*args):
        raise RuntimeError("broken simulator")

    monkeypatch.setattr(generate, "make_scene_record", always_fails)
    with pytest.raises(SystemExit, match=r"^error: 4 of 4 scenes failed .*--resume") as exit_:
        main(["data", "generate", *TINY, "--out", str(tmp_path)])
    assert len(str(exit_.value.code).splitlines()) == 1


def test_torch_threads_holds_a_task_to_its_threads_and_restores_the_callers():
    import torch

    before = torch.get_num_threads()
    with pytest.raises(ZeroDivisionError), torch_threads(1):
        assert torch.get_num_threads() == 1
        1 / 0  # noqa: B018 (a task that raises restores them too)
    assert torch.get_num_threads() == before
