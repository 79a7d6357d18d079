"""experiments/validity_sweep.py, run as a script: each model's own threshold is the one with
the largest SR + CR on the choosing rounds, the lower one on a tie, never a cell that executed no
grasp; and without the object sets it plays it stops with one line naming the missing set."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.scripts import EX_NOINPUT
from symgrasp.config import DEFAULT_VALIDITY, JUDGE_SEED, BenchmarkConfig, PlannerOptions
from symgrasp.objects.folder import DATA_ENV

ROOT = Path(__file__).resolve().parents[2]
MODELS = ("bingham2d-robotiq-2f85", "rotmat6d-robotiq-2f85")
"""The models ``--quick`` sweeps, at validity 0.04 and the default, one round of one object."""


def _sweep(quick: Path, data: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "experiments/validity_sweep.py", "--quick", str(quick)], cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src"), DATA_ENV: str(data)},
        capture_output=True, text=True,
    )  # fmt: skip


def _store(quick: Path, model: str, objects: str, seed: int, validity: float, counts) -> None:
    """The quick sweep's cell folder of ``model`` on ``objects`` at ``validity`` as a finished
    benchmark of one round that had ``counts`` = (successes, executed): the sweep reads it."""
    config = BenchmarkConfig(model=model, objects=objects, num_objects=1, rounds=1, seed=seed,
                             diagnose=False, options=PlannerOptions(validity_threshold=validity))  # fmt: skip
    folder = quick / "validity_sweep" / model / objects / str(validity)
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps(config.record()))
    successes, executed = counts
    record = {"seed": seed, "objects": 1, "renderer": "test", "successes": successes,
              "executed": executed, "attempts": []}  # fmt: skip
    (folder / "rounds.jsonl").write_text(json.dumps(record) + "\n")


@pytest.mark.parametrize(
    "choosing, own",
    [
        # bingham2d: at 0.04 no grasp executed (SR undefined), so the default, though worse
        # than nothing; rotmat6d: SR + CR tie, so the lower threshold
        ({MODELS[0]: ((0, 0), (0, 1)), MODELS[1]: ((1, 2), (1, 2))}, (DEFAULT_VALIDITY, 0.04)),
        # the larger SR + CR, whichever threshold it is
        ({MODELS[0]: ((1, 1), (0, 1)), MODELS[1]: ((0, 1), (1, 1))}, (0.04, DEFAULT_VALIDITY)),
    ],
)  # fmt: skip
def test_own_threshold_maximises_sr_plus_cr_lower_on_a_tie_and_never_an_empty_cell(
    tmp_path, choosing, own
):
    for model in MODELS:
        for validity, counts in zip((0.04, DEFAULT_VALIDITY), choosing[model], strict=True):
            _store(tmp_path, model, "vgn-pile-train", JUDGE_SEED, validity, counts)
            _store(tmp_path, model, "vgn-pile-test", 0, validity, (1, 1))
    done = _sweep(tmp_path, tmp_path / "no-data")  # every cell is read back: no object is needed
    assert done.returncode == 0, done.stderr[-3000:]
    rows = json.loads((tmp_path / "validity_sweep.json").read_text())["cells"]
    assert tuple({r["model"]: r["own"] for r in rows}[m] for m in MODELS) == own


def test_without_the_object_sets_it_stops_with_one_line(tmp_path):
    done = _sweep(tmp_path / "quick", tmp_path / "empty")
    assert done.returncode == EX_NOINPUT, done.stderr[-3000:]
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert done.stderr.startswith("error: object set vgn-pile-train is not in the data folder")
