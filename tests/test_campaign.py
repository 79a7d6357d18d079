"""experiments/campaign.py, run as a script: a plan's steps run in dependency order within the
cores, resume by their done markers, run again when their command changes, and a bad plan is one
clear line."""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGN = ROOT / "experiments" / "campaign.py"
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}


def _campaign(action, plans, root, *options):
    """``campaign.py ACTION PLAN… --root ROOT OPTIONS…`` in its own process."""
    return subprocess.run(
        [sys.executable, str(CAMPAIGN), action, *map(str, plans), "--root", str(root), *options],
        env=ENV, capture_output=True, text=True,
    )  # fmt: skip


def _status(plans, root):
    """Each step's state, as ``status`` prints it."""
    done = _campaign("status", plans, root)
    assert done.returncode == 0, done.stderr
    return dict(line.split(maxsplit=1) for line in done.stdout.splitlines())


def _plan(tmp_path, text, name="plan.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _step(name, code, needs=(), cores=1):
    run = f"{sys.executable} -c '{code}'"  # a TOML multi-line literal string: quotes as they are
    return (f'[[step]]\nname = "{name}"\ncores = {cores}\nneeds = {list(needs)!r}\n'
            f"run = '''{run}'''\n")  # fmt: skip


def test_steps_run_after_their_needs_and_a_changed_command_runs_again(tmp_path):
    log = tmp_path / "order.txt"
    append = 'import time; time.sleep({}); open("{{root}}/order.txt", "a").write("{}")'
    text = "".join([
        _step("slow", append.format(0.5, "s")),
        _step("fast", append.format(0, "f")),
        _step("last", append.format(0, "l"), needs=["slow", "fast"], cores=2),
    ])  # fmt: skip
    plan = _plan(tmp_path, text)
    assert _campaign("run", [plan], tmp_path, "--cores", "2").returncode == 0
    assert log.read_text() == "fsl"  # slow and fast side by side, last after both
    assert _status([plan], tmp_path) == {n: "done" for n in ("slow", "fast", "last")}
    assert _campaign("run", [plan], tmp_path, "--cores", "2").returncode == 0
    assert log.read_text() == "fsl"  # done: nothing ran again
    changed = _plan(tmp_path, text.replace('"l"', '"L"'))
    assert _campaign("run", [changed], tmp_path, "--cores", "2").returncode == 0
    assert log.read_text() == "fslL"


def test_show_prints_the_steps_with_their_vars_filled_in(tmp_path):
    text = ('[vars]\nout = "{root}/out"\n[[step]]\nname = "a"\ncores = 2\nrun = "make {out}"\n'
            '[[step]]\nname = "b"\nneeds = ["a"]\nrun = "use {out}"\n')  # fmt: skip
    done = _campaign("show", [_plan(tmp_path, text)], tmp_path)
    assert done.returncode == 0, done.stderr
    assert [json.loads(line) for line in done.stdout.splitlines()] == [
        {"name": "a", "cores": 2, "needs": [], "run": f"make {tmp_path}/out"},
        {"name": "b", "cores": 1, "needs": ["a"], "run": f"use {tmp_path}/out"},
    ]


def test_a_var_written_over_lines_is_one_command(tmp_path):
    # A line break in a [vars] value used to reach the shell and end the command there, so
    # the options on the next line ran as a command of their own.
    text = (f'[vars]\nwrite = """{sys.executable} -c \'import sys; open(sys.argv[1], "w")'
            f'.write(sys.argv[2])\'\n  {{root}}/out.txt"""\n'
            '[[step]]\nname = "a"\nrun = "{write} second-line"\n')  # fmt: skip
    plan = _plan(tmp_path, text)
    assert "\n" not in json.loads(_campaign("show", [plan], tmp_path).stdout)["run"]
    assert _campaign("run", [plan], tmp_path, "--cores", "1").returncode == 0
    assert (tmp_path / "out.txt").read_text() == "second-line"


def test_one_core_runs_steps_one_at_a_time_and_a_failure_holds_its_dependants(tmp_path):
    text = "".join([
        _step("broken", "raise SystemExit(2)"),
        _step("after", 'open("{root}/after.txt", "w")', needs=["broken"]),
        _step("other", 'open("{root}/other.txt", "w")'),
        _step("big", "pass", cores=2),
    ])  # fmt: skip
    plan = _plan(tmp_path, text)
    done = _campaign("run", [plan], tmp_path, "--cores", "1")
    assert "broken: failed (exit 2)" in done.stdout
    assert done.returncode == 1 and done.stderr.strip().startswith("not done: broken, after, big")
    state = _status([plan], tmp_path)
    assert state["broken"].startswith("failed: exit 2") and state["other"] == "done"
    assert state["after"] == state["big"] == "to do"  # big never fits in one core
    assert not (tmp_path / "after.txt").exists()
    assert (tmp_path / "failed" / "broken").read_text().startswith("exit 2")


def test_a_second_plan_file_uses_the_first_ones_vars_and_steps(tmp_path):
    touch = "import sys; open(sys.argv[1], sys.argv[2])"
    first = _plan(tmp_path, f"[vars]\npy = '''{sys.executable} -c '{touch}' '''\n"
                  '[[step]]\nname = "make"\nrun = "{py} {root}/a w"\n', "first.toml")  # fmt: skip
    second = _plan(tmp_path, '[[step]]\nname = "use"\nneeds = ["make"]\nrun = "{py} {root}/a r"\n',
                   "second.toml")  # fmt: skip
    assert _campaign("run", [first, second], tmp_path, "--cores", "1").returncode == 0
    assert _status([first, second], tmp_path) == {"make": "done", "use": "done"}
    reversed_ = _campaign("run", [second, first], tmp_path)  # the first file's vars come after
    assert reversed_.returncode == 1
    assert "step 'use' uses 'py', which [vars] does not" in reversed_.stderr
    again = _plan(tmp_path, '[vars]\npy = "python3"\n', "again.toml")
    twice = _campaign("run", [first, again], tmp_path)
    assert f"plan {again}: var 'py' is already defined by {first}" in twice.stderr


@pytest.mark.parametrize(
    "text, message",
    [
        ('[[step]]\nname = "a"\n', "needs 'name' and 'run'"),
        ('[[step]]\nname = "a"\nrun = "x"\nwhen = 1\n', "may have 'cores', 'needs'"),
        ('[[step]]\nname = "a"\nrun = "{nowhere}"\n', "uses 'nowhere', which [vars]"),
        ('[[step]]\nname = "a"\nrun = "x"\nneeds = ["b"]\n[[step]]\nname = "b"\nrun = "x"\n',
         "needs ['b'], which are not steps listed before it"),
        ('[[step]]\nname = "a"\nrun = "x"\n[[step]]\nname = "a"\nrun = "y"\n', "names repeat"),
        ("[[step]\n", "plan.toml"),
    ],
)  # fmt: skip
def test_a_bad_plan_is_one_line_naming_the_file_and_step(tmp_path, text, message):
    done = _campaign("run", [_plan(tmp_path, text)], tmp_path)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and message in done.stderr
    assert done.stderr.startswith(f"error: plan {tmp_path}")


def test_status_tells_a_running_step_from_one_whose_driver_died(tmp_path):
    release = tmp_path / "release"
    until = f'lambda: os.path.exists("{release}")'
    plan = _plan(tmp_path, _step("wait", f"import os, time; [time.sleep(0.05) for _ in iter({until}, True)]"))  # fmt: skip
    driver = subprocess.Popen(
        [sys.executable, str(CAMPAIGN), "run", str(plan), "--root", str(tmp_path), "--cores", "1"],
        env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        for _ in range(400):
            if (tmp_path / "running" / "wait").exists():
                break
            time.sleep(0.05)
        assert _status([plan], tmp_path)["wait"].startswith("running since")
        second = _campaign("run", [plan], tmp_path, "--cores", "1")  # a second driver, same root
        assert second.returncode == 1 and "'wait' is still running" in second.stderr
    finally:
        release.touch()
        driver.wait(timeout=60)
    assert _status([plan], tmp_path) == {"wait": "done"}
    assert not (tmp_path / "running" / "wait").exists()

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()  # a process id that no longer runs: a driver killed with its step
    again = _plan(tmp_path, _step("again", "pass"), "again.toml")
    marker = tmp_path / "running" / "again"
    marker.write_text(f"{gone.pid} - 2026-01-01T00:00:00+00:00\n")
    assert _status([again], tmp_path)["again"].startswith("stopped")
    # a process id in use again, by another process (after a restart): not the step either
    marker.write_text(f"{os.getpid()} old-boot:1 2026-01-01T00:00:00+00:00\n")
    assert _status([again], tmp_path)["again"].startswith("stopped")
    assert _campaign("run", [again], tmp_path, "--cores", "1").returncode == 0
    assert _status([again], tmp_path) == {"again": "done"}


def test_a_malformed_running_marker_is_one_line_naming_the_file(tmp_path):
    plan = _plan(tmp_path, _step("step", "pass"))
    (tmp_path / "running").mkdir()
    (tmp_path / "running" / "step").write_text("12345\n")  # written by an older driver
    done = _campaign("status", [plan], tmp_path)
    assert done.returncode == 1 and done.stderr.count("\n") == 1
    assert "running marker" in done.stderr and "step holds '12345'" in done.stderr
