"""experiments/campaign.py, run as a script: a plan's steps run in dependency order within the
cores, resume by their done markers, run again when their command changes, outlive their root
through the bank, and a bad plan is one clear line."""

import hashlib
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


def _step(name, code, needs=(), cores=1, keep=()):
    run = f"{sys.executable} -c '{code}'"  # a TOML multi-line literal string: quotes as they are
    return (f'[[step]]\nname = "{name}"\ncores = {cores}\nneeds = {list(needs)!r}\n'
            f"keep = {list(keep)!r}\nrun = '''{run}'''\n")  # fmt: skip


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
        {"name": "a", "cores": 2, "needs": [], "keep": [], "run": f"make {tmp_path}/out"},
        {"name": "b", "cores": 1, "needs": ["a"], "keep": [], "run": f"use {tmp_path}/out"},
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
        ('[[step]]\nname = "a"\nrun = "x"\nkeep = ["/etc/x"]\n', "not a path under the root"),
        ('[[step]]\nname = "a"\nrun = "x"\nkeep = ["../x"]\n', "not a path under the root"),
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


def _chain(log):
    """A dataset, a training run, its selection (kept) and a report (kept); each step appends its
    letter to ``log``, outside every root."""
    write = (
        'import pathlib; p = pathlib.Path("{{root}}/{path}"); p.parent.mkdir(parents=True, '
        'exist_ok=True); p.write_text({text}); open("' + str(log) + '", "a").write("{letter}")'
    )
    return "".join([
        _step("data", write.format(path="data/scenes.txt", text='"scenes"', letter="D")),
        _step("train", write.format(path="runs/s0/last.txt",
              text='open("{root}/data/scenes.txt").read() + " model"', letter="T"),
              needs=["data"]),
        _step("select", write.format(path="runs/s0/best.txt",
              text='open("{root}/runs/s0/last.txt").read() + " best"', letter="S"),
              needs=["train"], keep=["{root}/runs/s0/best.txt"]),
        _step("report", write.format(path="report/s0/table.md",
              text='open("{root}/runs/s0/best.txt").read() + " table"', letter="R"),
              needs=["select"], keep=["report/**", "!**/*.log"]),
    ])  # fmt: skip


def _banked_status(plan, root, bank):
    done = _campaign("status", [plan], root, "--bank", bank)
    assert done.returncode == 0, done.stderr
    return dict(line.split(maxsplit=1) for line in done.stdout.splitlines())


def test_a_fresh_root_takes_kept_steps_back_from_the_bank_and_runs_nothing_again(tmp_path):
    log, bank, first = tmp_path / "log.txt", tmp_path / "bank", tmp_path / "first"
    plan = _plan(tmp_path, _chain(log))
    assert _campaign("run", [plan], first, "--bank", bank).returncode == 0
    assert log.read_text() == "DTSR"
    (first / "report" / "s0" / "note.log").write_text("not kept")
    assert sorted(p.relative_to(bank).as_posix() for p in bank.rglob("*") if p.is_file()) == [
        "data/record.json", "report/files/report/s0/table.md", "report/record.json",
        "select/files/runs/s0/best.txt", "select/record.json", "train/record.json",
    ]  # fmt: skip
    record = json.loads((bank / "select" / "record.json").read_text())
    shown = [json.loads(line) for line in _campaign("show", [plan], first).stdout.splitlines()]
    assert record["run"] == shown[2]["run"].replace(str(first), "{root}")
    assert shown[2]["keep"] == ["runs/s0/best.txt"]
    assert record["files"] == {"runs/s0/best.txt": hashlib.sha256(b"scenes model best").hexdigest()}

    second = tmp_path / "second"  # the machine was replaced: a new, empty root
    assert _status([plan], second) == dict.fromkeys(("data", "train", "select", "report"), "to do")
    assert _banked_status(plan, second, bank) == {
        "data": "banked: runs again only if a step to run needs it",
        "train": "banked: runs again only if a step to run needs it",
        "select": "banked: the next run restores it",
        "report": "banked: the next run restores it",
    }
    done = _campaign("run", [plan], second, "--bank", bank)
    assert done.returncode == 0, done.stderr
    assert log.read_text() == "DTSR"  # nothing ran again
    assert "select: restored from" in done.stdout and "report: restored from" in done.stdout
    for kept in ("runs/s0/best.txt", "report/s0/table.md"):
        assert (second / kept).read_bytes() == (first / kept).read_bytes()
    assert not (second / "data").exists() and not (second / "report" / "s0" / "note.log").exists()
    assert _banked_status(plan, second, bank)["report"] == "done"


def test_a_banked_step_that_keeps_nothing_runs_again_when_a_new_step_needs_it(tmp_path):
    log, bank = tmp_path / "log.txt", tmp_path / "bank"
    text = _chain(log)
    assert _campaign("run", [_plan(tmp_path, text)], tmp_path / "a", "--bank", bank).returncode == 0
    seed1 = _step("train-s1", 'open("{root}/data/scenes.txt").read(); open("' + str(log)
                  + '", "a").write("1")', needs=["data"])  # fmt: skip
    done = _campaign("run", [_plan(tmp_path, text + seed1)], tmp_path / "b", "--bank", bank)
    assert done.returncode == 0, done.stderr
    assert log.read_text() == "DTSR" + "D1"  # the dataset again, for the new run alone


def test_the_bank_refuses_an_altered_copy_and_a_changed_command(tmp_path):
    log, bank = tmp_path / "log.txt", tmp_path / "bank"
    text = _chain(log)
    plan = _plan(tmp_path, text)
    assert _campaign("run", [plan], tmp_path / "a", "--bank", bank).returncode == 0
    (bank / "report" / "files" / "report" / "s0" / "table.md").write_text("edited")
    done = _campaign("run", [plan], tmp_path / "b", "--bank", bank)
    assert done.returncode == 0, done.stderr
    assert "is missing or not the file its record names; report is not restored" in done.stdout
    assert log.read_text() == "DTSR" + "R"  # the report again, on the restored selection
    assert (tmp_path / "b" / "report" / "s0" / "table.md").read_text() == "scenes model best table"
    changed = _plan(tmp_path, text.replace('" best"', '" best!"'))
    assert _campaign("run", [changed], tmp_path / "c", "--bank", bank).returncode == 0
    # the changed selection and what it needs; the report, its command unchanged, comes back
    # from the bank, as it would stay done in a root that was kept
    assert log.read_text() == "DTSRR" + "DTS"


def test_a_keep_pattern_that_matches_nothing_fails_its_step(tmp_path):
    text = "".join([
        _step("made", 'open("{root}/a.txt", "w")', keep=["b/*.txt"]),
        _step("after", 'open("{root}/after.txt", "w")', needs=["made"]),
    ])  # fmt: skip
    done = _campaign("run", [_plan(tmp_path, text)], tmp_path / "root", "--bank", tmp_path / "bank")
    assert done.returncode == 1
    assert "made: failed (step 'made' keeps 'b/*.txt', which matches no file under" in done.stdout
    assert not (tmp_path / "root" / "after.txt").exists()
    assert not (tmp_path / "bank" / "made").exists()


def test_first_runs_the_named_steps_before_the_others_and_their_needs_still_hold(tmp_path):
    append = 'open("{{root}}/order.txt", "a").write("{}")'
    text = "".join([
        _step("a", append.format("a")),
        _step("b-one", append.format("1")),
        _step("c", append.format("c")),
        _step("b-two", append.format("2"), needs=["c"]),
    ])  # fmt: skip
    plan = _plan(tmp_path, text)
    done = _campaign("run", [plan], tmp_path, "--cores", "1", "--first", "b-*")
    assert done.returncode == 0, done.stderr
    # one core: b-one before a; b-two, named too, still waits for the c it needs
    assert (tmp_path / "order.txt").read_text() == "1ac2"
    unknown = _campaign("run", [plan], tmp_path, "--first", "d*")
    assert unknown.returncode == 2 and "--first: 'd*' names no step of the plan" in unknown.stderr
