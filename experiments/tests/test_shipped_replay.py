"""Every shipped model replays the first attempt of its Table 1 cell's first round
(experiments/results/declutter_rounds.tar.gz): the model file is the one docs/results.md
measured, with the scene, the chosen grasp's score and its outcome the same (played with the
approach check's rule of those cells, `runner.PLAYED_BEFORE`).

Only the first attempt: the later ones carry the physics of the earlier ones and the CPU's
float rounding along, and on another processor a near-tied candidate or one at the validity
threshold can go the other way. Measured on an AVX2 AMD EPYC (2026-11-27): the first
attempts of all eight models as recorded (scores within 2e-7); later in the round, rotmat6d
(Robotiq) chose another grasp of the same object at its fourth attempt (score 0.834 for
0.839) and bingham3d (Robotiq) found three candidates for two at its last and tried one. On a
lent H100 machine's Intel Xeon with torch 2.11 (2026-11-27) the first attempts' scenes,
targets, candidates and outcomes were as recorded and four Robotiq scores moved by 3e-5 to
1.4e-4, hence the tolerance: below what another training seed of the same model moves (the
archive's first scores of one representation's seeds differ by 2.9e-3 or more). A
benchmark is reproducible on one machine (same seed, same result), not bit for bit across
processors (docs/results.md says so of the H100 machine's rounds)."""

import json
import tarfile
from pathlib import Path

import pytest

from symgrasp.benchmark.declutter import run_round
from symgrasp.benchmark.runner import PLAYED_BEFORE, round_record
from symgrasp.detect import PRETRAINED, GraspDetector
from symgrasp.objects.folder import DATA_ENV
from symgrasp.objects.sets import resolve

ROOT = Path(__file__).resolve().parents[2]
ARCHIVE = ROOT / "experiments" / "results" / "declutter_rounds.tar.gz"


@pytest.mark.parametrize("name", PRETRAINED)
def test_a_shipped_model_replays_the_first_round_of_its_table_cell(name, monkeypatch, vgn_data):
    monkeypatch.setenv(DATA_ENV, str(vgn_data))
    # the cells were played at the library's defaults, before the model cards' operating points
    detector = GraspDetector.from_pretrained(name, device="cpu", operating_point=False)
    rep, seed = detector.info["representation"], detector.info["config"]["seed"]
    cell = f"{detector.gripper.name}/{rep}/s{seed}/vgn-pile-test/rounds.jsonl"
    with tarfile.open(ARCHIVE) as tar:
        stored = json.loads(tar.extractfile(cell).readline())
    assert stored["seed"] == 0
    played = round_record(  # with the approach check the cells were played with
        run_round(detector, resolve("vgn-pile-test"), 5, seed=0, max_attempts=1, **PLAYED_BEFORE)
    )  # fmt: skip
    first, recorded = played["attempts"][0], stored["attempts"][0]
    for key in ("outcome", "mode", "target", "candidates", "rejected"):
        assert first[key] == recorded[key], key
    assert first["score"] == pytest.approx(recorded["score"], abs=5e-4)
