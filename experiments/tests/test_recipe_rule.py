"""experiments/recipe.py, run as a script: its adoption rule (docs/model.md, "The recipe") on
judging rounds known by construction, the options it hands to the final runs, its evidence
table, and the campaign plan that feeds it: every factor's runs are steps, and the recipe
study names every factor's options."""

import json
import os
import re
import shlex
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import pytest

from symgrasp.benchmark.selection import DeclutterValidation, checkpoint_id
from symgrasp.config import JUDGE_SEED, BenchmarkConfig
from symgrasp.detect.pretrained import shipped_path

from .conftest import campaign_steps

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}


def _recipe(*options, columns="100"):
    return subprocess.run([sys.executable, "experiments/recipe.py", *options], cwd=ROOT,
                          env={**ENV, "COLUMNS": columns}, capture_output=True, text=True)  # fmt: skip


@pytest.fixture(scope="module")
def factors():
    """recipe.py's default factors and their runs, as its help states them."""
    usage = " ".join(_recipe("--help", columns="10000").stdout.split())
    listed = re.search(r"runs of robust_training\.toml, (.*?)\)", usage).group(1)
    return {name: runs.split(",") for name, runs in (f.split("=") for f in listed.split())}


ROUNDS = 10
"""Judging rounds of each run, one object each (``--quick``'s size)."""
BASELINE = (4, 8)  # successes, executed grasps over the rounds: SR 50 %, CR 40 %
RUNS = {  # factor: (successes, executed) per training seed
    "both": ((6, 10), (4, 6)),  # SR and CR up, SR up and CR even: adopted
    "one": ((8, 8), (2, 8)),  # far ahead with one seed, behind with the other: not adopted
    "trade": ((6, 16), (6, 16)),  # SR down, CR further up with both seeds: adopted
    "zero": ((4, 4), (4, 8)),  # ahead with one seed, even with the other: not adopted
}
FLAGS = {"both": "--ema 0.999", "one": "--x", "trade": "--batch-size 16 --lr 2e-3", "zero": "--y"}


def _rounds(successes: int, executed: int) -> list[dict]:
    """`ROUNDS` round records of one object from the judging seed with these totals."""
    return [{"seed": JUDGE_SEED + r, "objects": 1, "renderer": "test", "attempts": [],
             "successes": int(r < successes),
             "executed": executed // ROUNDS + (r < executed % ROUNDS)} for r in range(ROUNDS)]  # fmt: skip


@pytest.fixture(scope="module")
def judged(tmp_path_factory):
    """The quick study's result on judging folders written beforehand, one per run (the
    shipped model stands in for every run, so the folders tell them apart)."""
    quick = tmp_path_factory.mktemp("recipe")
    validation = DeclutterValidation(
        objects="household-train", rounds=ROUNDS, seed=JUDGE_SEED, num_objects=1
    )
    checkpoint = shipped_path("bingham2d-robotiq-2f85")
    runs = {("baseline", s): BASELINE for s in (0, 1)}
    runs |= {(f, s): counts[s] for f, counts in RUNS.items() for s in (0, 1)}
    for (factor, seed), counts in runs.items():
        folder = (
            quick
            / "recipe"
            / f"{factor}-s{seed}"
            / f"{checkpoint_id(checkpoint)}-{validation.slug}"
        )
        folder.mkdir(parents=True)
        config = BenchmarkConfig(model=str(checkpoint), **asdict(validation), diagnose=False)
        (folder / "config.json").write_text(json.dumps(config.record()))
        (folder / "rounds.jsonl").write_text(
            "".join(json.dumps(r) + "\n" for r in _rounds(*counts))
        )
    options = ["--quick", str(quick), "--rounds", str(ROUNDS)]
    for factor in ("baseline", *RUNS):
        options += ["--factor", f"{factor}={factor}-s0,{factor}-s1"]
    options += [f"--flags={factor}={flags}" for factor, flags in FLAGS.items()]
    done = _recipe(*options)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "declutter rounds" not in done.stderr  # no round played: every folder read back
    result = json.loads((quick / "recipe.json").read_text())
    return result, (quick / "recipe.md").read_text(), (quick / "recipe.flags").read_text()


def test_a_factor_is_adopted_only_when_its_net_change_is_positive_for_every_seed(judged):
    verdicts, _, flags = judged[0]["verdicts"], judged[1], judged[2]
    assert {f: v["adopted"] for f, v in verdicts.items()} == {
        "both": True, "one": False, "trade": True, "zero": False}  # fmt: skip
    assert verdicts["one"]["mean_sr_change"] == pytest.approx((0.5 - 0.25) / 2)
    assert flags == "--ema 0.999 --batch-size 16 --lr 2e-3\n"  # the adopted ones, in order


def test_the_evidence_table_shows_before_after_and_the_net_change_per_seed(judged):
    row = next(line for line in judged[1].splitlines() if line.startswith("| one | `--x`"))
    assert row == ("| one | `--x` | 0, 1 | 50.0 / 40.0; 50.0 / 40.0 | 100.0 / 80.0; 25.0 / 20.0 "
                   "| +90.0; -45.0 | no |")  # fmt: skip


def test_the_plan_trains_every_factor_and_hands_its_options_to_the_recipe_study(factors):
    steps = campaign_steps("experiments/campaigns/robust_training.toml")
    words = shlex.split(steps["recipe-study"]["run"])
    flags = dict(words[i + 1].split("=", 1) for i, w in enumerate(words) if w == "--flags")
    _, *others = factors
    assert set(flags) == set(others)
    for factor in others:
        for run in factors[factor]:
            seed = re.fullmatch(r".*-s(\d+)", run).group(1)
            assert f" {flags[factor]} --seed {seed} " in steps[run]["run"], run

    def judging(step):  # the options that decide which rounds are played, and where
        words = shlex.split(step["run"])
        return {w: words[i + 1] for i, w in enumerate(words)
                if w in ("--runs", "--rounds", "--seed", "--objects", "--num-objects", "--out")}  # fmt: skip

    for run in (run for runs in factors.values() for run in runs):
        judge = steps[f"judge-{run}"]  # played as soon as the run is selected, read back later
        assert judge["needs"] == [f"select-{run}"] and f"--factor {run}={run} " in judge["run"]
        assert judging(judge) == judging(steps["recipe-study"])
        assert f"judge-{run}" in steps["recipe-study"]["needs"]
    final = [s for name, s in steps.items() if name.startswith("final-")]
    assert final and all("$(cat /root/results/recipe.flags)" in s["run"] for s in final)
    assert all("recipe-study" in s["needs"] for s in final)


def test_flags_must_name_exactly_the_factors(factors):
    every = [f"--flags={f}=--x" for f in list(factors)[1:]]
    typo = _recipe(*every, "--flags", "emma=--ema 0.9")
    assert typo.returncode == 2 and "--flags: emma is not a factor" in typo.stderr
    short = _recipe(*every[1:])
    assert short.returncode == 2 and f"no options for factor(s) {list(factors)[1]}" in short.stderr
