"""The code-built hands against MuJoCo Menagerie's reference models (experiments/hands.py, run as
a script): every row of its comparison that has a tolerance holds it, and its probes see what
they probe. Runs where the data folder holds the reference models (``reference/menagerie``; CI
has them); the package itself never loads them."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.scripts import EX_NOINPUT
from symgrasp.objects.folder import DATA_ENV

from .conftest import missing_data

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def measured(shared, tmp_path_factory):
    """The script's result (its cells by hand and model) and its Markdown table."""
    out = tmp_path_factory.mktemp("hands")
    done = subprocess.run(
        [sys.executable, "experiments/hands.py", "--result", str(out / "hands"),
         "--figure", str(out / "hands.png")],
        cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT / "src"), DATA_ENV: str(shared)},
        capture_output=True, text=True,
    )  # fmt: skip
    if done.returncode == EX_NOINPUT:
        missing_data(done.stderr.strip())
    assert done.returncode == 0, done.stderr[-3000:]
    cells = json.loads((out / "hands.json").read_text())["cells"]
    return {(c["hand"], c["model"]): c for c in cells}, (out / "hands.md").read_text()


@pytest.mark.data
def test_within_tolerance_of_the_reference(measured):
    verdicts, hand = [], None  # (hand, row, verdict) of every row of the table
    for line in measured[1].splitlines():
        if line.startswith("**"):
            hand = line.strip("*")
        elif line.startswith("| ") and not line.startswith("| |"):  # a row, not the header
            label, ours, theirs, verdict = (c.strip() for c in line.strip("|").split("|"))
            verdicts.append((hand, f"{label}: symgrasp {ours}, Menagerie {theirs}", verdict))
    assert {hand for hand, _, _ in verdicts} == {"robotiq-2f85", "franka"}
    assert sum(verdict == "yes" for _, _, verdict in verdicts) >= 10
    assert [(hand, row) for hand, row, verdict in verdicts if verdict not in ("yes", "–")] == []


@pytest.mark.data
def test_the_probes_see_what_they_probe(measured):
    """Oracles for the probes themselves: the reference 2F-85 opens 85 mm (its datasheet), its
    pads stay parallel in a pinch and wrap in a power grasp; a rigid jaw's pads do not move
    along the approach axis."""
    reference = measured[0]["robotiq-2f85", "menagerie"]
    assert reference["geometry"]["opening_mm"] == pytest.approx(85, abs=1)
    assert reference["pinch"]["tilt_deg"] < 2 < 20 < reference["power"]["tilt_deg"]
    assert measured[0]["franka", "symgrasp"]["settled_path"] == []  # nothing to compare
