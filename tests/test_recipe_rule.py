"""benchmarks/recipe.py's adoption rule (docs/model.md, "The recipe"), the options it hands to
the final runs, and the campaign plan that feeds it: every factor's runs are steps, and the
recipe study names every factor's options."""

import os
import shlex
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import campaign
import recipe

ROOT = Path(__file__).resolve().parents[1]


def _cell(factor, seed, sr, cr):
    return {"factor": factor, "seed": seed, "sr_change": [sr, sr - 0.1, sr + 0.1],
            "cr_change": [cr, cr - 0.1, cr + 0.1]}  # fmt: skip


def test_a_factor_is_adopted_only_when_its_net_change_is_positive_for_every_seed():
    cells = [
        {"factor": "baseline", "seed": 0}, {"factor": "baseline", "seed": 1},
        _cell("both", 0, 0.02, 0.01), _cell("both", 1, 0.01, 0.00),
        _cell("one", 0, 0.10, 0.10), _cell("one", 1, -0.02, 0.01),
        _cell("trade", 0, -0.01, 0.05), _cell("trade", 1, -0.03, 0.04),
        _cell("zero", 0, 0.02, -0.02), _cell("zero", 1, 0.05, 0.0),
    ]  # fmt: skip
    verdicts = recipe.verdict(cells, "baseline")
    assert {f: v["adopted"] for f, v in verdicts.items()} == {
        "both": True, "one": False, "trade": True, "zero": False}  # fmt: skip
    assert abs(verdicts["one"]["mean_sr_change"] - 0.04) < 1e-12
    flags = {"both": "--ema 0.999", "one": "--x", "trade": "--batch-size 16 --lr 2e-3",
             "zero": "--y"}  # fmt: skip
    assert recipe.adopted_flags(verdicts, flags) == "--ema 0.999 --batch-size 16 --lr 2e-3"
    assert recipe.adopted_flags({"one": verdicts["one"]}, flags) == ""


def test_the_plan_trains_every_factor_and_hands_its_options_to_the_recipe_study():
    steps = {s.name: s for s in campaign.read_plan(
        [ROOT / "benchmarks" / "campaigns" / "robust_training.toml"], Path("/root"))}  # fmt: skip
    words = shlex.split(steps["recipe-study"].run)
    flags = dict(recipe.parse_flags(words[i + 1]) for i, w in enumerate(words) if w == "--flags")
    _, *factors = recipe.FACTORS
    assert set(flags) == set(factors)
    for factor in factors:
        for run in recipe.FACTORS[factor]:
            assert run in steps, run
            assert f" {flags[factor]} --seed {recipe.training_seed(run)} " in steps[run].run

    def judging(step):  # the options that decide which rounds are played, and where
        words = shlex.split(step.run)
        return {w: words[i + 1] for i, w in enumerate(words)
                if w in ("--runs", "--rounds", "--seed", "--objects", "--num-objects", "--out")}  # fmt: skip

    for run in (run for runs in recipe.FACTORS.values() for run in runs):
        judge = steps[f"judge-{run}"]  # played as soon as the run is selected, read back later
        assert judge.needs == (f"select-{run}",) and f"--factor {run}={run} " in judge.run
        assert judging(judge) == judging(steps["recipe-study"])
        assert f"judge-{run}" in steps["recipe-study"].needs
    final = [s for name, s in steps.items() if name.startswith("final-")]
    assert final and all("$(cat /root/results/recipe.flags)" in s.run for s in final)
    assert all("recipe-study" in s.needs for s in final)


def test_flags_must_name_exactly_the_factors(tmp_path):
    def run(*flags):
        return subprocess.run([sys.executable, "benchmarks/recipe.py", *flags], cwd=ROOT,
                              env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
                              capture_output=True, text=True)  # fmt: skip

    every = [f"--flags={f}=--x" for f in list(recipe.FACTORS)[1:]]
    typo = run(*every, "--flags", "emma=--ema 0.9")
    assert typo.returncode == 2 and "--flags: emma is not a factor" in typo.stderr
    short = run(*every[1:])
    assert short.returncode == 2 and "no options for factor(s) cosine" in short.stderr


def test_the_evidence_table_shows_before_after_and_the_net_change_per_seed():
    cells = [
        {"factor": "baseline", "seed": 0, "sr": 0.80, "cr": 0.40},
        {"factor": "baseline", "seed": 1, "sr": 0.78, "cr": 0.45},
        {**_cell("ema", 0, 0.02, 0.01), "sr": 0.82, "cr": 0.41},
        {**_cell("ema", 1, -0.03, 0.01), "sr": 0.75, "cr": 0.46},
    ]
    verdicts = recipe.verdict(cells, "baseline")
    verdicts["ema"]["flags"] = "--ema 0.999"
    row = recipe.evidence(cells, verdicts, "baseline").strip().splitlines()[-1]
    assert row == ("| ema | `--ema 0.999` | 0, 1 | 80.0 / 40.0; 78.0 / 45.0 | 82.0 / 41.0; "
                   "75.0 / 46.0 | +3.0; -2.0 | no |")  # fmt: skip
