"""experiments/campaign.py, run as a script: a plan's steps run in dependency order within the
cores, resume by their done markers, run again when their command changes, outlive their root
through the bank, and a bad plan is one clear line."""

import hashlib
import io
import json
import os
import random
import subprocess
import sys
import tarfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
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


def _banked_status(plan, root, bank, *options):
    done = _campaign("status", [plan], root, "--bank", bank, *options)
    assert done.returncode == 0, done.stderr
    return dict(line.split(maxsplit=1) for line in done.stdout.splitlines())


def _files(folder):
    """Every file under ``folder``: relative name → bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}  # fmt: skip


def _members(archive):
    """The files of a tar archive: name → bytes."""
    with tarfile.open(archive) as opened:
        return {m.name: opened.extractfile(m).read() for m in opened if m.isfile()}


def _tar_gz(path, members):
    """A tar.gz at ``path`` of ``members`` (name → bytes), as the stored rounds are."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with tarfile.open(path, "w:gz") as archive:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            archive.addfile(info, io.BytesIO(data))


def test_a_fresh_root_takes_kept_steps_back_from_the_bank_and_runs_nothing_again(tmp_path):
    log, bank, first = tmp_path / "log.txt", tmp_path / "bank", tmp_path / "first"
    plan = _plan(tmp_path, _chain(log))
    assert _campaign("run", [plan], first, "--bank", bank).returncode == 0
    assert log.read_text() == "DTSR"
    (first / "report" / "s0" / "note.log").write_text("not kept")
    # one archive for each step that keeps something, and the index
    assert sorted(_files(bank)) == ["index.json", "step-report.tar.xz", "step-select.tar.xz"]
    index = json.loads((bank / "index.json").read_text())
    assert sorted(index["steps"]) == ["data", "report", "select", "train"]
    assert index["archives"] == {name: hashlib.sha256((bank / name).read_bytes()).hexdigest()
                                 for name in ("step-report.tar.xz", "step-select.tar.xz")}  # fmt: skip
    record = index["steps"]["select"]
    shown = [json.loads(line) for line in _campaign("show", [plan], first).stdout.splitlines()]
    assert record["run"] == shown[2]["run"].replace(str(first), "{root}")
    assert record["plan"] == "plan" and shown[2]["keep"] == ["runs/s0/best.txt"]
    digest = hashlib.sha256(b"scenes model best").hexdigest()
    assert record["files"] == {"runs/s0/best.txt": {"sha256": digest, "in": "step-select.tar.xz"}}
    assert _members(bank / "step-select.tar.xz") == {
        "select/runs/s0/best.txt": b"scenes model best"
    }
    assert index["steps"]["data"]["files"] == {}

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
    _tar_gz(bank / "step-report.tar.xz", {"report/report/s0/table.md": b"edited"})
    done = _campaign("run", [plan], tmp_path / "b", "--bank", bank)
    assert done.returncode == 0, done.stderr
    assert (
        "step-report.tar.xz is missing or not the file its index names; report is not "
        "restored" in done.stdout
    )
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
    assert not (tmp_path / "bank" / "index.json").exists()


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


def _outputs(tmp_path):
    """A step's outputs that a bank stores differently: bytes of every value (random ones, which
    compression cannot shorten), an empty file, rounds that a results archive holds byte for
    byte, a checkpoint that a shipped model is, and one that nothing else holds."""
    draw = random.Random(0)
    outputs = {
        "bench/a/noise.bin": draw.randbytes(3000),
        "bench/a/every-byte.bin": bytes(range(256)) * 4,
        "bench/a/empty.txt": b"",
        "bench/a/rounds.jsonl": b'{"seed": 0, "cleared": 3}\n' * 50,
        "runs/s0/shipped.pt": draw.randbytes(500),
        "runs/s0/best.pt": draw.randbytes(500),
    }
    _tar_gz(tmp_path / "results" / "table_rounds.tar.gz",
            {"robotiq/s0/rounds.jsonl": outputs["bench/a/rounds.jsonl"]})  # fmt: skip
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "shipped.pt").write_bytes(outputs["runs/s0/shipped.pt"])
    source = tmp_path / "outputs"
    for name, data in outputs.items():
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        (source / name).write_bytes(data)
    copies = ("--copies", str(tmp_path / "results" / "*.tar.gz"), str(tmp_path / "models" / "*"))
    return outputs, source, copies


def _copying(source, log, letter):
    """A step's code: copy the files under ``source`` into the root, append ``letter`` to ``log``."""
    return ('import shutil; shutil.copytree("' + str(source) + '", "{root}", dirs_exist_ok=True); '
            'open("' + str(log) + '", "a").write("' + letter + '")')  # fmt: skip


def test_a_bank_stores_each_kept_file_once_and_a_fresh_root_gets_the_same_bytes(tmp_path):
    outputs, source, copies = _outputs(tmp_path)
    log, bank = tmp_path / "log.txt", tmp_path / "bank"
    text = (_step("bench", _copying(source, log, "B"), keep=["bench/**"])
            + _step("train", _copying(source, log, "T"), keep=["runs/s0/*.pt"]))  # fmt: skip
    plan = _plan(tmp_path, text)
    done = _campaign("run", [plan], tmp_path / "a", "--cores", "1", "--bank", bank, *copies)
    assert done.returncode == 0, done.stderr
    index = json.loads((bank / "index.json").read_text())
    digest = {name: hashlib.sha256(data).hexdigest() for name, data in outputs.items()}
    # the rounds and the shipped checkpoint where their copies are, the other checkpoint by its
    # hash alone, the rest in the step's archive
    assert index["steps"]["bench"]["files"]["bench/a/rounds.jsonl"] == {
        "sha256": digest["bench/a/rounds.jsonl"], "in": "../results/table_rounds.tar.gz",
        "member": "robotiq/s0/rounds.jsonl"}  # fmt: skip
    assert index["steps"]["train"]["files"] == {
        "runs/s0/best.pt": {"sha256": digest["runs/s0/best.pt"]},
        "runs/s0/shipped.pt": {"sha256": digest["runs/s0/shipped.pt"], "in": "../models/shipped.pt"},
    }  # fmt: skip
    assert sorted(_files(bank)) == ["index.json", "step-bench.tar.xz"]
    stored = ("bench/a/empty.txt", "bench/a/every-byte.bin", "bench/a/noise.bin")
    assert _members(bank / "step-bench.tar.xz") == {f"bench/{n}": outputs[n] for n in stored}
    with tarfile.open(bank / "step-bench.tar.xz") as archive:  # nothing of the machine in it
        assert {(m.mtime, m.uid, m.gid, m.uname, m.gname, m.mode) for m in archive} == {
            (0, 0, 0, "", "", 0o644)}  # fmt: skip

    fresh = tmp_path / "b"  # a replaced machine: every banked file back, byte for byte
    assert _banked_status(plan, fresh, bank) == {
        "bench": "banked: the next run restores it",
        "train": "banked without its checkpoints: runs again only if a step to run needs it",
    }
    done = _campaign("run", [plan], fresh, "--bank", bank, *copies)
    assert done.returncode == 0, done.stderr
    assert log.read_text() == "BT"  # nothing ran again
    assert _files(fresh / "bench") == {n.removeprefix("bench/"): d for n, d in outputs.items()
                                       if n.startswith("bench/")}  # fmt: skip
    assert not (fresh / "runs").exists()

    # a new step needs the checkpoint: the step that made it runs again, its bytes checked
    later = _plan(tmp_path, text + _step("play", "pass", needs=["train"]), "later.toml")
    done = _campaign("run", [later], fresh, "--bank", bank, *copies)
    assert done.returncode == 0, done.stderr
    assert log.read_text() == "BTT"
    assert "train's runs/s0/best.pt is the checkpoint its earlier record names" in done.stdout

    unpacked = tmp_path / "unpacked"  # a reader's copy: each step's files in its own folder
    done = _campaign("unpack", [], tmp_path, "--bank", bank, "--out", unpacked)
    assert done.returncode == 0, done.stderr
    assert _files(unpacked) == {f"bench/{n}": d for n, d in outputs.items() if n.startswith("bench/")} | {
        "train/runs/s0/shipped.pt": outputs["runs/s0/shipped.pt"]}  # fmt: skip
    assert (
        f"train: runs/s0/best.pt is not banked (a checkpoint, SHA-256 {digest['runs/s0/best.pt']})"
        in done.stdout
    )


def test_a_changed_copy_is_not_taken_for_the_banked_file(tmp_path):
    _, source, copies = _outputs(tmp_path)
    log, bank = tmp_path / "log.txt", tmp_path / "bank"
    plan = _plan(tmp_path, _step("bench", _copying(source, log, "B"), keep=["bench/**"]))
    assert _campaign("run", [plan], tmp_path / "a", "--bank", bank, *copies).returncode == 0
    _tar_gz(tmp_path / "results" / "table_rounds.tar.gz", {"robotiq/s0/rounds.jsonl": b"other"})
    done = _campaign("run", [plan], tmp_path / "b", "--bank", bank, *copies)
    assert done.returncode == 0, done.stderr
    assert (
        "table_rounds.tar.gz is missing or not the file its index names; bench is not "
        "restored" in done.stdout
    )
    assert log.read_text() == "BB"  # run again, and banked with its rounds in its archive now
    assert "bench/bench/a/rounds.jsonl" in _members(bank / "step-bench.tar.xz")


def test_pack_merges_a_plans_step_archives_into_the_same_bytes_on_any_machine(tmp_path):
    outputs, source, copies = _outputs(tmp_path)
    log, banks = tmp_path / "log.txt", (tmp_path / "bank1", tmp_path / "bank2")
    text = "".join(_step(f"bench-{n}", _copying(source, log, "B"), keep=[f"bench/a/*.{n}"])
                   for n in ("bin", "txt"))  # fmt: skip
    plan = _plan(tmp_path, text)
    for number, bank in enumerate(banks):  # two roots, two banks, banked at other times
        root = tmp_path / f"r{number}"
        done = _campaign("run", [plan], root, "--cores", "1", "--bank", bank, *copies)
        assert done.returncode == 0, done.stderr
        assert sorted(_files(bank)) == [
            "index.json",
            *(f"step-bench-{n}.tar.xz" for n in ("bin", "txt")),
        ]
        done = _campaign("pack", [], tmp_path, "--bank", bank, *copies)
        assert done.returncode == 0, done.stderr
        assert sorted(_files(bank)) == ["index.json", "plan-plan.tar.xz"]
    assert (banks[0] / "plan-plan.tar.xz").read_bytes() == (
        banks[1] / "plan-plan.tar.xz"
    ).read_bytes()
    packed = _files(banks[0])
    assert _campaign("pack", [], tmp_path, "--bank", banks[0], *copies).returncode == 0
    assert _files(banks[0]) == packed  # packed again: the same bytes

    # split in parts of at most 2 kB where each member allows it (the noise is 3 kB)
    done = _campaign("pack", [], tmp_path, "--bank", banks[1], *copies, "--split-mb", "0.002")
    assert done.returncode == 0, done.stderr
    parts = sorted(set(_files(banks[1])) - {"index.json"})
    assert parts == [f"plan-plan-{n}.tar.xz" for n in range(1, len(parts) + 1)] and len(parts) > 1

    # the noise is now in a results archive too: the next pack leaves it out of the bank
    _tar_gz(
        tmp_path / "results" / "noise_rounds.tar.gz", {"noise.bin": outputs["bench/a/noise.bin"]}
    )
    assert _campaign("pack", [], tmp_path, "--bank", banks[0], *copies).returncode == 0
    assert "bench-bin/bench/a/noise.bin" not in _members(banks[0] / "plan-plan.tar.xz")
    for bank in banks:
        fresh = tmp_path / f"fresh-{bank.name}"
        assert _campaign("run", [plan], fresh, "--bank", bank, *copies).returncode == 0
        assert _files(fresh / "bench") == {n.removeprefix("bench/"): d for n, d in outputs.items()
                                           if n.startswith("bench/a/") and n != "bench/a/rounds.jsonl"}  # fmt: skip
    assert log.read_text() == "BB" * 2  # nothing ran again


def test_pack_and_unpack_need_a_bank_and_a_bad_index_is_one_line(tmp_path):
    no_bank = _campaign("pack", [], tmp_path)
    assert no_bank.returncode == 2 and "pack takes --bank DIR and no plan" in no_bank.stderr
    empty = _campaign("unpack", [], tmp_path, "--bank", tmp_path)
    assert empty.returncode == 2 and f"--bank: {tmp_path} holds no index.json" in empty.stderr
    (tmp_path / "index.json").write_text('{"steps": {}}')
    bad = _campaign("pack", [], tmp_path, "--bank", tmp_path)
    assert bad.returncode == 1 and len(bad.stderr.strip().splitlines()) == 1
    assert (
        f"{tmp_path}/index.json is not a valid campaign bank index: it lacks the key "
        "'archives'" in bad.stderr
    )
