"""An interrupted `symgrasp data generate --workers 2`, as real processes: SIGTERM, Ctrl-C, a
killed parent or worker stop every process within seconds, in one line (no traceback), with
a true record of the scenes written; --resume then finishes the same bytes as one run. And
the process pool does not wait for long tasks in flight when SIGTERM unwinds it."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import types
from pathlib import Path

import pytest

import symgrasp
from symgrasp.cli import main
from symgrasp.data.generate import scene_path

TINY = ["--objects", "blocks", "--gripper", "franka", "--pool-size", "2", "--grasps", "40"]
TINY += ["--directions", "8", "--scenes", "40"]
HINT = "; run it again with --resume to continue"


@pytest.fixture(scope="module")
def databases(tmp_path_factory):
    """The tiny pool's object databases (a ``db/`` to copy: a run then only makes scenes)."""
    root = tmp_path_factory.mktemp("intr") / "first"
    main(["data", "generate", *TINY[:-1], "1", "--out", str(root)])
    return root / "db"


def _workers(pid):
    """The pool workers ``pid`` spawned (not multiprocessing's resource tracker)."""
    found = []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            parent = int((proc / "stat").read_text().rsplit(")", 1)[1].split()[1])
            command = (proc / "cmdline").read_bytes()
        except OSError:  # gone meanwhile
            continue
        if parent == pid and b"spawn_main" in command:
            found.append(int(proc.name))
    return found


def _alive(pid):
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"  # a zombie has exited; only its parent's wait is missing


def _as_from_a_terminal():
    """SIGINT handled as a terminal's command has it: a shell's background job (a CI run
    started with ``&``) ignores SIGINT, and an ignored signal is inherited."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(out, databases):
    """``data generate --workers 2`` into ``out`` (databases copied in), in a session of its
    own (a Ctrl-C reaches its group), once its two workers have written a scene; returns the
    process and the workers' pids."""
    shutil.copytree(databases, out / "db")
    env = {**os.environ, "PYTHONPATH": str(Path(symgrasp.__file__).parents[1])}
    argv = ["data", "generate", *TINY, "--workers", "2", "--out", str(out)]
    code = f"from symgrasp.cli import main; main({argv!r})"
    process = subprocess.Popen(
        [sys.executable, "-c", code], env=env, stderr=subprocess.PIPE, text=True,
        start_new_session=True, preexec_fn=_as_from_a_terminal,
    )  # fmt: skip
    deadline = time.monotonic() + 60
    while not scene_path(out, 0).exists():
        assert process.poll() is None, process.communicate()[1]
        assert time.monotonic() < deadline, "no scene written in 60 s"
        time.sleep(0.01)
    workers = [pid for pid in _workers(process.pid) if _alive(pid)]
    assert len(workers) == 2
    return process, workers


def _stopped(process, workers, status):
    """``process``'s stderr, after it exited with ``status`` and ``workers`` within 3 s."""
    stderr = process.communicate(timeout=10)[1]
    assert process.returncode == status, stderr
    deadline = time.monotonic() + 3
    while any(_alive(pid) for pid in workers):
        assert time.monotonic() < deadline, "workers outlived their parent by 3 s"
        time.sleep(0.02)
    assert "Traceback" not in stderr, stderr
    return stderr.strip().splitlines()[-1]


def _on_disk(out):
    return len(list((out / "scenes").glob("scene_*.npz")))


def test_sigterm_stops_the_workers_and_resume_finishes_the_same_bytes(databases, tmp_path):
    out = tmp_path / "killed"
    process, workers = _start(out, databases)
    process.send_signal(signal.SIGTERM)
    assert _stopped(process, workers, 128 + signal.SIGTERM) == f"terminated{HINT}"
    manifest = json.loads((out / "manifest.json").read_text())
    written = [run["scenes"] for run in manifest["generated_with"]]
    assert written == [_on_disk(out)] and 0 < written[0] < 40  # stopped midway, recorded
    main(["data", "generate", *TINY, "--out", str(out), "--resume"])
    whole = tmp_path / "whole"
    shutil.copytree(databases, whole / "db")
    main(["data", "generate", *TINY, "--out", str(whole)])
    for i in range(40):
        assert scene_path(out, i).read_bytes() == scene_path(whole, i).read_bytes()
    resumed = json.loads((out / "manifest.json").read_text())
    assert [run["scenes"] for run in resumed["generated_with"]] == [written[0], 40 - written[0]]


def test_ctrl_c_to_the_group_is_one_line_and_stops_the_workers(databases, tmp_path):
    process, workers = _start(tmp_path / "out", databases)
    os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C: parent and workers
    assert _stopped(process, workers, 128 + signal.SIGINT) == f"interrupted{HINT}"


def test_a_killed_parent_takes_its_workers_with_it(databases, tmp_path):
    process, workers = _start(tmp_path / "out", databases)
    process.send_signal(signal.SIGKILL)  # no handler runs: the kernel kills the workers
    _stopped(process, workers, -signal.SIGKILL)


def test_a_killed_worker_is_one_error_line_with_the_hint(databases, tmp_path):
    out = tmp_path / "out"
    process, workers = _start(out, databases)
    os.kill(workers[0], signal.SIGKILL)
    line = _stopped(process, workers, 1)
    assert line.startswith("error: a worker process died") and line.endswith(HINT), line
    manifest = json.loads((out / "manifest.json").read_text())
    assert [run["scenes"] for run in manifest["generated_with"]] == [_on_disk(out)]


def test_sigterm_does_not_wait_for_the_tasks_in_flight(tmp_path):
    code = (
        "import signal, sys, time\n"
        "from symgrasp.cli import Terminated, _terminate\n"
        "from symgrasp.parallel.base import Job\n"
        "from symgrasp.parallel.local import ProcessPool\n"
        "signal.signal(signal.SIGTERM, _terminate)\n"
        "try:\n"
        "    with ProcessPool(2) as pool:\n"
        "        list(pool.map(Job(time.sleep), [60] * 4, 'sleeps'))\n"
        "except Terminated:\n"
        "    sys.exit(143)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(symgrasp.__file__).parents[1])}
    process = subprocess.Popen([sys.executable, "-c", code], env=env, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 30
    while len(workers := _workers(process.pid)) < 2:
        assert time.monotonic() < deadline, "no workers in 30 s"
        time.sleep(0.05)
    time.sleep(1)  # both in a 60 s task
    start = time.monotonic()
    process.send_signal(signal.SIGTERM)
    process.communicate(timeout=10)
    assert process.returncode == 143 and time.monotonic() - start < 5
    assert not any(_alive(pid) for pid in workers)


def test_ctrl_c_while_the_workers_start_is_no_traceback_of_theirs(tmp_path):
    # The workers ignore SIGINT from their initializer on; a Ctrl-C while they still import
    # what it needs (here a setup whose module takes 3 s, as torch can) must not print a
    # KeyboardInterrupt of theirs either.
    (tmp_path / "slow_to_import.py").write_text("import time\ntime.sleep(3)\ndef setup(): pass\n")
    code = (
        "import sys, time\n"
        "import slow_to_import\n"
        "from symgrasp.parallel.base import Job\n"
        "from symgrasp.parallel.local import ProcessPool\n"
        "try:\n"
        "    with ProcessPool(2) as pool:\n"
        "        list(pool.map(Job(time.sleep, slow_to_import.setup), [60] * 4, 'sleeps'))\n"
        "except KeyboardInterrupt:\n"
        "    sys.exit(130)\n"
    )
    path = os.pathsep.join([str(Path(symgrasp.__file__).parents[1]), str(tmp_path)])
    process = subprocess.Popen(
        [sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": path},
        stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=_as_from_a_terminal,
    )  # fmt: skip
    deadline = time.monotonic() + 30
    while len(workers := _workers(process.pid)) < 2:
        assert time.monotonic() < deadline, "no workers in 30 s"
        time.sleep(0.01)
    time.sleep(1.5)  # both past Python's start, inside the 3 s import
    os.killpg(process.pid, signal.SIGINT)
    _stopped(process, workers, 130)


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (["data", "generate", "--out", "x"], f"interrupted{HINT}"),
        (["data", "inspect", "x"], "interrupted"),
    ],
)
def test_ctrl_c_hints_resume_only_where_a_command_has_it(argv, line, monkeypatch, capsys, tmp_path):
    import symgrasp.cli as cli

    monkeypatch.chdir(tmp_path)
    (tmp_path / "x").mkdir()  # data inspect reads an existing folder

    def interrupted(args):
        raise KeyboardInterrupt

    parsed = cli.build_parser().parse_args(argv)
    parsed.run = interrupted
    parser = types.SimpleNamespace(parse_args=lambda argv: parsed)
    monkeypatch.setattr(cli, "build_parser", lambda: parser)
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 130 and capsys.readouterr().err.strip() == line
