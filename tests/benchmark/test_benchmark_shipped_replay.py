"""Every shipped model replays the rounds of the Table 1 cell it comes from
(experiments/results/declutter_rounds.tar.gz): a cell of docs/results.md reproduced without
training, with the round's scene, grasps and outcomes the same."""

import json
import tarfile
from pathlib import Path

import pytest

from symgrasp.benchmark.declutter import run_round
from symgrasp.benchmark.runner import round_record
from symgrasp.detect import PRETRAINED, GraspDetector
from symgrasp.objects.folder import DATA_ENV
from symgrasp.objects.sets import resolve

ROOT = Path(__file__).resolve().parents[2]
ARCHIVE = ROOT / "experiments" / "results" / "declutter_rounds.tar.gz"


@pytest.mark.parametrize("name", PRETRAINED)
def test_a_shipped_model_replays_the_first_round_of_its_table_cell(name, monkeypatch, vgn_data):
    monkeypatch.setenv(DATA_ENV, str(vgn_data))
    detector = GraspDetector.from_pretrained(name, device="cpu")
    rep, seed = detector.info["representation"], detector.info["config"]["seed"]
    cell = f"{detector.gripper.name}/{rep}/s{seed}/vgn-pile-test/rounds.jsonl"
    with tarfile.open(ARCHIVE) as tar:
        stored = json.loads(tar.extractfile(cell).readline())
    assert stored["seed"] == 0
    played = round_record(run_round(detector, resolve("vgn-pile-test"), 5, seed=0))
    assert [(a["outcome"], a["mode"], a["target"]) for a in played["attempts"]] == [
        (a["outcome"], a["mode"], a["target"]) for a in stored["attempts"]
    ]
    assert [a["score"] for a in played["attempts"]] == pytest.approx(
        [a["score"] for a in stored["attempts"]], abs=1e-5
    )
