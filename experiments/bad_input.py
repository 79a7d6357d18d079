"""Bad input as a user meets it → experiments/results/bad_input.{json,md}.

    PYTHONPATH=src python experiments/bad_input.py [--timeout 120] [--quick [DIR]]

Plays every command-line case of the library's bad-input tables (tests/bad_input_cases.py, which
``tests/test_bad_input.py`` runs in-process) as a real ``symgrasp`` process with a time limit, calls
every API case, and sorts each outcome the way the probes that found these defects did: a *clear
error* (non-zero exit, one line that names the argument or file, no traceback), a *traceback*, an
*unclear* message (one that does not name what was wrong), a *silent* run (exit 0) or a *hang* (the
time limit).
The valid inputs that give no grasp for a visible cause (the tables ``WARNED_*``) are played
too: a *clear warning* (exit 0 and one ``warning:`` line naming the cause; a `NoGraspWarning`)
is what they should end with, a run without one is *silent*.
The seconds of each case show whether it was checked before any work started: a bad argument
(`ARGUMENTS`) before the command imports torch or MuJoCo, a bad file (`FILES`) when it is read.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

from common import add_result_option
from scripts import ROOT, command_line, parse_args, run_main, write_result

CASES = ROOT / "tests" / "bad_input_cases.py"
"""The library's bad-input tables, written once beside the test that guarantees them and read
here from there."""

WIDE_JAW = ROOT / "tests" / "wide-jaw.toml"
"""The tests' made-up 110 mm jaw, a spec file whose lines the bad gripper specs replace: read
here as data, the one file, so the cases play alike in the test and here."""

OUTCOMES = ("clear error", "clear warning", "unclear", "traceback", "silent", "hang")


def command_line_case(
    argv: list[str], named: str, timeout: float, folder: Path, warned: bool = False
) -> tuple[str, float, str]:
    """(outcome, seconds, the message's last line) of ``symgrasp ARGV`` in its own process,
    ``folder`` (the cases' files) first on its path, where a user's planners are imported from;
    ``warned``: a case that should exit 0 with one ``warning:`` line naming ``named``."""
    path = os.pathsep.join(filter(None, (str(folder), os.environ.get("PYTHONPATH"))))
    program = "import sys; from symgrasp.cli import main; main(sys.argv[1:])"
    start = time.perf_counter()
    try:
        done = subprocess.run(
            [sys.executable, "-c", program, *argv],
            capture_output=True, text=True, timeout=timeout,
            env={**os.environ, "PYTHONPATH": path},
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return "hang", time.perf_counter() - start, ""
    seconds = time.perf_counter() - start
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    message = lines[-1] if lines else ""
    if "Traceback" in done.stderr:
        outcome = "traceback"
    elif warned and done.returncode == 0 and lines:
        clear = len(lines) == 1 and message.startswith("warning:") and named in message
        outcome = "clear warning" if clear else "unclear"
    elif done.returncode == 0:
        outcome = "silent"
    elif len(lines) == 1 and named in message and "error" in message:
        outcome = "clear error"
    else:
        outcome = "unclear"
    return outcome, seconds, message


def api_case(call, named: str, detector, warned: bool = False) -> tuple[str, float, str]:
    """(outcome, seconds, message) of one bad API call; ``warned``: a call that should return
    no grasp with one `NoGraspWarning` naming ``named``."""
    from symgrasp.detect import NoGraspWarning

    start = time.perf_counter()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = call(detector)
        said = [str(w.message) for w in caught if issubclass(w.category, NoGraspWarning)]
        if warned and said:
            clear = result == [] and len(said) == 1 and named in said[0]
            return "clear warning" if clear else "unclear", time.perf_counter() - start, said[0]
    except (ValueError, TypeError) as error:
        outcome = "clear error" if named in str(error) else "unclear"
        return outcome, time.perf_counter() - start, str(error).splitlines()[0]
    except Exception as error:  # the probe records what a user would meet
        return "traceback", time.perf_counter() - start, f"{type(error).__name__}: {error}"
    return "silent", time.perf_counter() - start, ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--timeout", type=float, default=120.0, help="seconds before a case is a hang"
    )
    parser.add_argument(
        "--cases", type=int, default=0, help="play only the first N of each table (0: all)"
    )
    add_result_option(parser, "bad_input")
    args = parse_args(parser, outputs=("result",), quick={"cases": 2})

    from symgrasp.detect import GraspDetector

    spec = importlib.util.spec_from_file_location("bad_input_cases", CASES)
    cases = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cases)
    detector = GraspDetector.from_pretrained(cases.MODEL, device="cpu")
    limit = args.cases or None
    cells = []
    with tempfile.TemporaryDirectory() as folder:
        files = cases.make_files(Path(folder), WIDE_JAW)
        for kind, table, warned in (("command line, arguments", cases.ARGUMENTS, False),
                                     ("command line, files", cases.FILES, False),
                                     ("command line, planners", cases.PLANNERS, False),
                                     ("command line, no grasp", cases.WARNED_CLI, True)):  # fmt: skip
            for case, (argv, named) in list(table.items())[:limit]:
                outcome, seconds, message = command_line_case(
                    argv(files), named, args.timeout, files, warned
                )
                cells.append({"kind": kind, "case": case, "outcome": outcome,
                              "seconds": round(seconds, 2), "message": message})  # fmt: skip
                print(f"{outcome:13s} {seconds:6.2f} s  symgrasp {case}", flush=True)
        for kind, table, warned in (("API", cases.API, False),
                                     ("API, no grasp", cases.WARNED_API, True)):  # fmt: skip
            for case, (call, named) in list(table.items())[:limit]:
                outcome, seconds, message = api_case(call, named, detector, warned)
                cells.append({"kind": kind, "case": case, "outcome": outcome,
                              "seconds": round(seconds, 3), "message": message})  # fmt: skip
                print(f"{outcome:13s} {seconds:6.3f} s  {case}", flush=True)

    counts = {
        kind: {o: sum(c["kind"] == kind and c["outcome"] == o for c in cells) for o in OUTCOMES}
        for kind in dict.fromkeys(c["kind"] for c in cells)
    }
    slowest = {kind: max(c["seconds"] for c in cells if c["kind"] == kind) for kind in counts}
    rows = [
        f"| {kind} | {sum(n.values())} | "
        + " | ".join(str(n[o]) for o in OUTCOMES)
        + f" | {slowest[kind]:.2f} |"
        for kind, n in counts.items()
    ]
    table = (
        "| cases | played | " + " | ".join(OUTCOMES) + " | slowest [s] |\n"
        "|---|---|" + "---|" * len(OUTCOMES) + "---|\n" + "\n".join(rows) + "\n\n"
        "| kind | case | outcome | s | message |\n|---|---|---|---|---|\n"
        + "".join(
            f"| {c['kind']} | {c['case']} | {c['outcome']} | {c['seconds']} | "
            f"{c['message'].replace('|', '/')} |\n"
            for c in cells
        )
    )
    print(table.split("\n\n")[0])
    write_result(args.result, "bad input", command_line("PYTHONPATH=src"),
                 cells, table, counts=counts, slowest_seconds=slowest, timeout_s=args.timeout)  # fmt: skip


if __name__ == "__main__":
    run_main(main)
