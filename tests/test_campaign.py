"""benchmarks/campaign.py: a plan's steps run in dependency order within the cores, resume by
their done markers, run again when their command changes, and a bad plan is one clear line."""

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import campaign


def _plan(tmp_path, text):
    path = tmp_path / "plan.toml"
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
    steps = campaign.read_plan([_plan(tmp_path, text)], tmp_path)
    assert campaign.run(steps, tmp_path, cores=2) == {n: "done" for n in ("fast", "slow", "last")}
    assert log.read_text() == "fsl"  # slow and fast side by side, last after both
    assert campaign.run(steps, tmp_path, cores=2) == {n: "done" for n in ("slow", "fast", "last")}
    assert log.read_text() == "fsl"  # done: nothing ran again
    changed = campaign.read_plan([_plan(tmp_path, text.replace('"l"', '"L"'))], tmp_path)
    campaign.run(changed, tmp_path, cores=2)
    assert log.read_text() == "fslL"


def test_a_var_written_over_lines_is_one_command(tmp_path):
    # A line break in a [vars] value used to reach the shell and end the command there, so
    # the options on the next line ran as a command of their own.
    text = (f'[vars]\nwrite = """{sys.executable} -c \'import sys; open(sys.argv[1], "w")'
            f'.write(sys.argv[2])\'\n  {{root}}/out.txt"""\n'
            '[[step]]\nname = "a"\nrun = "{write} second-line"\n')  # fmt: skip
    steps = campaign.read_plan([_plan(tmp_path, text)], tmp_path)
    assert "\n" not in steps[0].run
    assert campaign.run(steps, tmp_path, cores=1) == {"a": "done"}
    assert (tmp_path / "out.txt").read_text() == "second-line"


def test_one_core_runs_steps_one_at_a_time_and_a_failure_holds_its_dependants(tmp_path):
    text = "".join([
        _step("broken", "raise SystemExit(2)"),
        _step("after", 'open("{root}/after.txt", "w")', needs=["broken"]),
        _step("other", 'open("{root}/other.txt", "w")'),
        _step("big", "pass", cores=2),
    ])  # fmt: skip
    outcome = campaign.run(campaign.read_plan([_plan(tmp_path, text)], tmp_path), tmp_path, cores=1)
    assert outcome["broken"] == "failed (exit 2)" and outcome["other"] == "done"
    assert outcome["after"].startswith("waiting") and not (tmp_path / "after.txt").exists()
    assert outcome["big"].startswith("waiting")  # never fits in one core
    assert (tmp_path / "failed" / "broken").read_text().startswith("exit 2")


def test_a_second_plan_file_uses_the_first_ones_vars_and_steps(tmp_path):
    touch = "import sys; open(sys.argv[1], sys.argv[2])"
    first = tmp_path / "first.toml"
    first.write_text(f"[vars]\npy = '''{sys.executable} -c '{touch}' '''\n"
                     '[[step]]\nname = "make"\nrun = "{py} {root}/a w"\n')  # fmt: skip
    second = tmp_path / "second.toml"
    second.write_text('[[step]]\nname = "use"\nneeds = ["make"]\nrun = "{py} {root}/a r"\n')
    steps = campaign.read_plan([first, second], tmp_path)
    assert [(s.name, s.plan) for s in steps] == [("make", first), ("use", second)]
    assert campaign.run(steps, tmp_path, cores=1) == {"make": "done", "use": "done"}
    with pytest.raises(SystemExit, match=r"step 'use' uses 'py', which \[vars\] does not"):
        campaign.read_plan([second, first], tmp_path)  # the first file's vars come after
    again = tmp_path / "again.toml"
    again.write_text('[vars]\npy = "python3"\n')
    with pytest.raises(SystemExit, match=f"plan {again}: var 'py' is already defined by {first}"):
        campaign.read_plan([first, again], tmp_path)


@pytest.mark.parametrize(
    "text, message",
    [
        ('[[step]]\nname = "a"\n', "needs 'name' and 'run'"),
        ('[[step]]\nname = "a"\nrun = "x"\nwhen = 1\n', "may have 'cores', 'needs'"),
        ('[[step]]\nname = "a"\nrun = "{nowhere}"\n', "uses 'nowhere', which \\[vars\\]"),
        ('[[step]]\nname = "a"\nrun = "x"\nneeds = ["b"]\n[[step]]\nname = "b"\nrun = "x"\n',
         "needs \\['b'\\], which are not steps listed before it"),
        ('[[step]]\nname = "a"\nrun = "x"\n[[step]]\nname = "a"\nrun = "y"\n', "names repeat"),
        ("[[step]\n", "plan .*plan.toml"),
    ],
)  # fmt: skip
def test_a_bad_plan_is_one_line_naming_the_file_and_step(tmp_path, text, message):
    with pytest.raises(SystemExit, match=message):
        campaign.read_plan([_plan(tmp_path, text)], tmp_path)


def test_status_tells_a_running_step_from_one_whose_driver_died(tmp_path):
    release = tmp_path / "release"
    until = f'lambda: os.path.exists("{release}")'
    text = _step("wait", f"import os, time; [time.sleep(0.05) for _ in iter({until}, True)]")
    steps = campaign.read_plan([_plan(tmp_path, text)], tmp_path)
    driver = threading.Thread(target=campaign.run, args=(steps, tmp_path, 1))
    driver.start()
    try:
        for _ in range(200):
            if (tmp_path / "running" / "wait").exists():
                break
            time.sleep(0.05)
        assert campaign.status(steps, tmp_path)["wait"].startswith("running since")
        with pytest.raises(SystemExit, match="'wait' is still running"):
            campaign.run(steps, tmp_path, cores=1)  # a second driver on the same root
    finally:
        release.touch()
        driver.join()
    assert campaign.status(steps, tmp_path) == {"wait": "done"}
    assert not (tmp_path / "running" / "wait").exists()

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()  # a process id that no longer runs: a driver killed with its step
    again = campaign.read_plan([_plan(tmp_path, _step("again", "pass"))], tmp_path)
    marker = tmp_path / "running" / "again"
    marker.write_text(f"{gone.pid} {campaign._identity(gone.pid)} 2026-01-01T00:00:00+00:00\n")
    assert campaign.status(again, tmp_path)["again"].startswith("stopped")
    # a process id in use again, by another process (after a restart): not the step either
    marker.write_text(f"{os.getpid()} old-boot:1 2026-01-01T00:00:00+00:00\n")
    assert campaign.status(again, tmp_path)["again"].startswith("stopped")
    assert campaign.run(again, tmp_path, cores=1) == {"again": "done"}


def test_a_malformed_running_marker_is_one_line_naming_the_file(tmp_path):
    steps = campaign.read_plan([_plan(tmp_path, _step("step", "pass"))], tmp_path)
    (tmp_path / "running").mkdir()
    (tmp_path / "running" / "step").write_text("12345\n")  # written by an older driver
    with pytest.raises(SystemExit, match=r"running marker .*step holds '12345'"):
        campaign.status(steps, tmp_path)
