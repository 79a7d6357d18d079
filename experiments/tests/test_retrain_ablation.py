"""experiments/retrain_ablation.py, run as a script on a campaign root of fake runs whose rounds
are known by construction: each run selected by the real ``select_checkpoint`` (its declutter
validation replaced by one that writes the constructed rounds where the real one would play
them), so the script must read the *selected* checkpoint's rounds; the val-noise benchmarks laid
out as ``symgrasp bench declutter`` leaves them. Checked: each arm's SR, CR and rounds ended by
none_found, the effects against today and the main effects, the robustness gaps with one draw
of training seeds for both conditions, the runs missing or unusable named with the reason, and
that the campaign plan writes the runs and folders the script reads."""

import itertools
import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from symgrasp.benchmark import selection
from symgrasp.benchmark.runner import MODEL_SHA, summarise
from symgrasp.config import BenchmarkConfig
from symgrasp.digest import file_sha256

from .conftest import campaign_steps

ROOT = Path(__file__).resolve().parents[2]
FINAL_PLANS = tuple(f"experiments/campaigns/{plan}.toml"
                    for plan in ("final", "noback", "retrain_cells", "franka_noback"))  # fmt: skip
ROUNDS, FIRST = 20, 1_000_000
REP = "bingham2d"


def _round(seed, outcomes):
    """A 2-object round whose attempts had ``outcomes``."""
    attempts = [{"outcome": o, "mode": None, "target": None, "planning_s": 0.1} for o in outcomes]
    return {"seed": seed, "objects": 2, "renderer": "test", "attempts": attempts,
            "successes": outcomes.count("success"),
            "executed": sum(o != "none_found" for o in outcomes)}  # fmt: skip


GOOD = ("success", "success")  # both objects lifted
FAIL = ("no_contact", "no_contact")  # two failures in a row
NONE = ("none_found",)  # no grasp found at once


def _rounds(even, odd=None):
    """``ROUNDS`` rounds from seed ``FIRST``: ``even`` in the even ones, ``odd`` (default the
    same) in the odd ones."""
    return [_round(FIRST + i, even if i % 2 == 0 or odd is None else odd) for i in range(ROUNDS)]


ALL, HALF, HALF_NONE, ZERO = _rounds(GOOD), _rounds(GOOD, FAIL), _rounds(GOOD, NONE), _rounds(FAIL)
"""SR / CR 1 / 1; 0.5 / 0.5; 1 / 0.5 with half the rounds ended by none_found; 0 / 0."""
PLAYED = {  # (arm, seed): rounds of the selected checkpoint: clean, noise-side, with table scale
    ("today", 0): (HALF, HALF_NONE, HALF), ("today", 1): (HALF, HALF_NONE, HALF),
    ("dense", 0): (ALL, HALF, ALL), ("dense", 1): (ALL, HALF, ALL),
    ("sensing", 0): (HALF, HALF, HALF), ("sensing", 1): (HALF, HALF, HALF),
    ("both", 0): (ALL, ALL, ALL), ("both", 1): (HALF, HALF, HALF),
    ("calibrated", 0): (ALL, ALL, ALL), ("calibrated", 1): (ALL, HALF, ALL),
    ("wide", 0): (ALL, ALL, ALL), ("wide", 1): (ALL, ALL, HALF),
    ("wide-calibrated", 0): (HALF, ALL, ALL), ("wide-calibrated", 1): (HALF, ALL, ALL),
}  # fmt: skip


def _write_benchmark(folder, config, rounds):
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps(config.record()))
    (folder / "rounds.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rounds))


def _select(run, epochs, monkeypatch, rounds=ROUNDS):
    """``symgrasp select RUN --by declutter`` on ``rounds`` rounds, each checkpoint's declutter
    validation writing ``epochs[name]``'s rounds (as many as there are) where the real one would
    play them."""
    for name in epochs:
        (run / name).write_bytes(f"{run.name} {name}".encode())  # never loaded
    rows = "".join(f"{i + 1},1.0\n" for i in range(len(epochs)))
    (run / "metrics.csv").write_text("epoch,val_total\n" + rows)

    def validate(checkpoint, out, objects, rounds, seed, *, num_objects, scene, mesh_unit,
                 table_clearance, surface_clearance, parallel=None):  # fmt: skip
        config = BenchmarkConfig(model=str(checkpoint), objects=objects, mesh_unit=mesh_unit,
                                 scene=scene, num_objects=num_objects, rounds=rounds, seed=seed,
                                 diagnose=False, table_clearance=table_clearance,
                                 surface_clearance=surface_clearance)  # fmt: skip
        played = epochs[Path(checkpoint).name][:rounds]
        _write_benchmark(Path(out), config, played)
        summary = summarise(played)
        keys = ("rounds", "objects", "executed", "successes", "success_ratio",
                "success_ratio_ci95", "clear_ratio", "clear_ratio_ci95")  # fmt: skip
        return {**{k: summary[k] for k in keys}, "errors": 0, "config": config.record()}

    monkeypatch.setattr(selection, "declutter_validation", validate)
    validation = selection.DeclutterValidation(rounds=rounds)
    return selection.select_checkpoint(run, "declutter", validation=validation, copy=False)


def _val_noise(root, run, rounds, played_by=None, table=False):
    """The val-noise benchmark of ``run``'s best.pt (a file of its own bytes), as ``symgrasp
    bench declutter --noise dex --view side --out ROOT/bench/val-noise/RUN`` leaves it (with
    ``table``: ``--table-scale`` into ``val-noise-table``); the SHA-256 of ``played_by``
    (default best.pt) recorded as what played it."""
    best = run / "best.pt"
    best.write_bytes(f"{run.name} best".encode())
    config = BenchmarkConfig(model=str(best), objects="vgn-pile-train", rounds=ROUNDS, seed=FIRST,
                             noise="dex", view="side", table_scale=table)  # fmt: skip
    folder = root / "bench" / ("val-noise-table" if table else "val-noise") / run.name
    _write_benchmark(folder, config, rounds)
    (folder / MODEL_SHA).write_text((played_by or file_sha256(best)) + "\n")


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """The script's result on a root holding seeds 0 and 1 of every arm (`PLAYED`, each run's
    epoch 2 selected over an epoch 1 that fails every round) and, of seed 2: ``today`` trained
    but not selected, ``dense`` selected and 19 of its 20 noisy rounds played, ``sensing`` not
    trained, ``both`` selected on 10 rounds and validated under noise by a best.pt it no longer
    has; collated with ``--seeds 0 1 2``."""
    root = tmp_path_factory.mktemp("retrain")
    with pytest.MonkeyPatch.context() as monkeypatch:
        for (arm, seed), (clean, noisy, table) in PLAYED.items():
            run = root / "runs" / f"{arm}-{REP}-s{seed}"
            run.mkdir(parents=True)
            chosen = _select(run, {"epoch_001.pt": ZERO, "epoch_002.pt": clean}, monkeypatch)
            assert chosen["chosen"]["checkpoint"] == "epoch_002.pt"
            _val_noise(root, run, noisy)
            _val_noise(root, run, table, table=True)
        (root / "runs" / f"today-{REP}-s2").mkdir()
        dense = root / "runs" / f"dense-{REP}-s2"
        dense.mkdir()
        _select(dense, {"epoch_001.pt": ALL}, monkeypatch)
        _val_noise(root, dense, ALL[:19])
        both = root / "runs" / f"both-{REP}-s2"
        both.mkdir()
        _select(both, {"epoch_001.pt": ALL}, monkeypatch, rounds=10)
        _val_noise(root, both, ALL, played_by="0" * 64)
    done = subprocess.run(
        [sys.executable, "experiments/retrain_ablation.py", "--root", str(root), "--seeds", "0",
         "1", "2", "--rounds", str(ROUNDS), "--result", str(root / "result")],
        cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT / "src")}, capture_output=True,
        text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    table = (root / "result.md").read_text()
    assert table == done.stdout
    return {**json.loads((root / "result.json").read_text()), "table": table}


def _cell(result, arm, condition):
    return next(c for c in result["cells"] if (c["arm"], c["condition"]) == (arm, condition))


def _effect(result, effect, condition):
    return next(
        e for e in result["effects"] if (e["effect"], e["condition"]) == (effect, condition)
    )


def test_each_arm_reads_its_selected_checkpoints_rounds_in_both_conditions(result):
    expected = {  # (arm, condition): (SR, CR), the mean over seeds 0 and 1 (dense clean: 0-2)
        ("today", "clean"): (0.5, 0.5), ("today", "noise-side"): (1.0, 0.5),
        ("dense", "clean"): (1.0, 1.0), ("dense", "noise-side"): (0.5, 0.5),
        ("sensing", "clean"): (0.5, 0.5), ("sensing", "noise-side"): (0.5, 0.5),
        ("both", "clean"): (0.75, 0.75), ("both", "noise-side"): (0.75, 0.75),
    }  # fmt: skip
    for (arm, condition), (sr, cr) in expected.items():
        cell = _cell(result, arm, condition)
        seeds = [0, 1, 2] if (arm, condition) == ("dense", "clean") else [0, 1]
        assert cell["seeds"] == seeds, (arm, condition)
        assert cell["ratios"]["success_ratio"][0] == pytest.approx(sr), (arm, condition)
        assert cell["ratios"]["clear_ratio"][0] == pytest.approx(cr), (arm, condition)
    both = _cell(result, "both", "clean")
    assert both["ratios"]["per_seed_success_ratio"] == [1.0, 0.5]
    low, high = both["ratios"]["success_ratio"][1:]
    assert low <= 0.5 + 1e-9 and high == pytest.approx(1.0)  # the seeds' disagreement is inside


def test_rounds_ended_by_none_found_against_issue_36s_ten_percent(result):
    today = _cell(result, "today", "noise-side")["none_found"]
    assert (today["rounds"], today["of"], today["share"]) == (20, 40, 0.5)
    assert today["target"] == "missed"  # half the rounds: the interval lies above 10 %
    dense = _cell(result, "dense", "clean")["none_found"]
    assert (dense["rounds"], dense["of"], dense["target"]) == (0, 60, "met")  # 0 of 60: < 6 %


def test_the_effects_against_today_and_the_main_effects_on_the_same_rounds(result):
    dense = _effect(result, "dense − today", "clean")
    assert dense["change"]["success_ratio"][0] == pytest.approx(0.5)
    assert (dense["ahead"], dense["pairings"], dense["rounds"]) == (6, 6, ROUNDS)  # 3 × 2 seeds
    assert _effect(result, "sensing − today", "clean")["change"]["success_ratio"] == [0.0] * 3
    both = _effect(result, "both − today", "clean")
    assert both["change"]["clear_ratio"][0] == pytest.approx(0.25) and both["ahead"] == 2
    # main effects: the factor's two arms minus the other two, averaged over the other factor
    labels = _effect(result, "labels (main effect)", "clean")["change"]["success_ratio"]
    assert labels[0] == pytest.approx(((1.0 - 0.5) + (0.75 - 0.5)) / 2)
    assert labels[1] <= labels[0] <= labels[2]
    sensing = _effect(result, "sensing (main effect)", "clean")["change"]["clear_ratio"]
    assert sensing[0] == pytest.approx(((0.5 - 0.5) + (0.75 - 1.0)) / 2)
    noisy = _effect(result, "dense − today", "noise-side")["change"]
    assert noisy["success_ratio"][0] == pytest.approx(-0.5)
    assert noisy["clear_ratio"][0] == pytest.approx(0.0)


def test_calibrated_against_its_uncalibrated_twin_and_dense_outside_the_main_effects(result):
    cell = _cell(result, "calibrated", "clean")
    assert cell["table_scaled_images"] and cell["dense_labels"] and cell["sensing"]
    assert not _cell(result, "both", "clean")["table_scaled_images"]
    twin = _effect(result, "calibrated − both", "clean")
    assert twin["change"]["success_ratio"][0] == pytest.approx(1.0 - 0.75)
    assert (twin["ahead"], twin["pairings"]) == (2, 4)  # ahead of both's seed 1, tied with 0
    dense = _effect(result, "calibrated − dense", "noise-side")["change"]["clear_ratio"]
    assert dense[0] == pytest.approx(0.75 - 0.5)
    assert _effect(result, "calibrated − today", "clean")["change"]["clear_ratio"][0] == (
        pytest.approx(0.5)
    )
    # the main effects are the 2 × 2's alone, whatever calibrated did
    assert {e["effect"] for e in result["effects"] if "main" in e["effect"]} == {
        "labels (main effect)",
        "sensing (main effect)",
    }


def test_the_robustness_gap_pairs_each_run_with_itself(result):
    gaps = {g["arm"]: g for g in result["gaps"] if g["condition"] == "noise-side"}
    point, low, high = gaps["dense"]["change"]["clear_ratio"]
    assert point == pytest.approx(-0.5) and low <= point <= high < -0.03
    assert gaps["dense"]["target"] == "missed" and gaps["dense"]["seeds"] == [0, 1]
    # both's seed 0 is far better than its seed 1, in both conditions alike: drawn together,
    # the seeds' difference cancels, so the gap is 0 in every draw (drawn apart it would not be)
    assert gaps["both"]["change"]["success_ratio"] == [0.0] * 3
    assert gaps["both"]["target"] == "met" and gaps["both"]["seeds"] == [0, 1]
    today = gaps["today"]["change"]
    assert today["success_ratio"][0] == pytest.approx(0.5) and today["clear_ratio"][0] == 0
    assert gaps["today"]["per_seed"]["0"]["success_ratio"][0] == pytest.approx(0.5)
    # with the table's depth scale, dense's noisy rounds are its clean ones: no gap, met
    table = {g["arm"]: g for g in result["gaps"] if g["condition"] == "noise-side-table"}
    assert table["dense"]["change"]["clear_ratio"] == [0.0] * 3
    assert table["dense"]["target"] == "met" and table["dense"]["seeds"] == [0, 1]


def test_missing_and_unusable_runs_are_named_with_the_reason(result):
    missing = {r["run"]: r["missing"] for r in result["runs"]}
    assert missing[f"today-{REP}-s0"] == {"clean": None, "noise-side": None,
                                          "noise-side-table": None}  # fmt: skip
    assert missing[f"today-{REP}-s2"]["clean"] == "not selected"
    assert missing[f"sensing-{REP}-s2"] == {"clean": "not trained", "noise-side": "not played",
                                            "noise-side-table": "not played"}  # fmt: skip
    assert missing[f"dense-{REP}-s2"] == {"clean": None, "noise-side": "19 of 20 rounds played",
                                          "noise-side-table": "not played"}  # fmt: skip
    assert "played another best.pt" in missing[f"both-{REP}-s2"]["noise-side"]
    assert missing[f"both-{REP}-s2"]["clean"] == "holds other rounds (its rounds differ)"
    # dense's seed 2 has clean rounds of its own: the clean cell rests on three seeds
    assert _cell(result, "dense", "clean")["seeds"] == [0, 1, 2]
    assert _cell(result, "dense", "noise-side")["seeds"] == [0, 1]
    missing_line = result["table"].splitlines()[-1]
    assert (
        missing_line.startswith("Missing (20): ") and f"both-{REP}-s2 (noise-side: " in missing_line
    )


def test_a_root_with_nothing_yet_lists_every_run_as_missing(tmp_path):
    done = subprocess.run(
        [sys.executable, "experiments/retrain_ablation.py", "--root", str(tmp_path / "none"),
         "--result", str(tmp_path / "result")],
        cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT / "src")}, capture_output=True,
        text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / "result.json").read_text())
    assert all(c["seeds"] == [] for c in result["cells"]) and len(result["cells"]) == 7 * 3
    assert result["effects"] == [] and result["gaps"] == []
    assert "Missing (42): today-bingham2d-s0 (clean: not trained)" in done.stdout


def test_wide_against_dense_outside_the_main_effects(result):
    cell = _cell(result, "wide", "clean")
    assert cell["tip_offsets"] and cell["dense_labels"] and not cell["sensing"]
    assert not _cell(result, "dense", "clean")["tip_offsets"]
    noisy = _effect(result, "wide − dense", "noise-side")["change"]
    assert noisy["success_ratio"][0] == pytest.approx(1.0 - 0.5)  # ALL against HALF, both seeds
    assert noisy["clear_ratio"][0] == pytest.approx(1.0 - 0.5)
    table = _effect(result, "wide − dense", "noise-side-table")["change"]["clear_ratio"]
    assert table[0] == pytest.approx((1.0 + 0.5) / 2 - 1.0)
    assert {e["effect"] for e in result["effects"] if "main" in e["effect"]} == {
        "labels (main effect)",
        "sensing (main effect)",
    }


def test_sensing_on_top_of_the_wide_labels(result):
    cell = _cell(result, "wide-calibrated", "clean")
    assert all(cell[f] for f in ("dense_labels", "sensing", "tip_offsets"))
    change = {c: _effect(result, "wide-calibrated − wide", c)["change"]
              for c in ("clean", "noise-side", "noise-side-table")}  # fmt: skip
    assert change["clean"]["clear_ratio"][0] == pytest.approx(0.5 - 1.0)
    assert change["noise-side"]["clear_ratio"][0] == pytest.approx(0.0)
    assert change["noise-side-table"]["clear_ratio"][0] == pytest.approx(1.0 - (1.0 + 0.5) / 2)
    gap = next(g for g in result["gaps"] if g["arm"] == "wide-calibrated"
               and g["condition"] == "noise-side")  # fmt: skip
    assert gap["change"]["clear_ratio"][0] == pytest.approx(1.0 - 0.5)


def test_the_campaign_writes_the_runs_and_folders_the_script_reads():
    steps = campaign_steps("experiments/campaigns/retrain.toml")
    for arm in ("today", "dense", "sensing", "both", "calibrated", "wide"):
        for seed in (0, 1):
            run = f"{arm}-{REP}-s{seed}"
            assert f"--out /root/runs/{run}" in steps[run]["run"]
            select = shlex.split(steps[f"select-{run}"]["run"])
            assert select[select.index("--by") + 1] == "declutter"
            assert select[select.index("--rounds") + 1] == "200"  # the script's default
            for step, folder in (
                ("val-noise", "val-noise"),
                ("val-noise-table", "val-noise-table"),
            ):
                noisy = shlex.split(steps[f"{step}-{run}"]["run"])
                value = {flag: noisy[noisy.index(flag) + 1]
                         for flag in ("--model", "--out", "--objects", "--seed", "--rounds",
                                      "--noise", "--view")}  # fmt: skip
                assert value == {"--model": f"/root/runs/{run}/best.pt",
                                 "--out": f"/root/bench/{folder}/{run}",
                                 "--objects": "vgn-pile-train", "--seed": "1000000",
                                 "--rounds": "200", "--noise": "dex", "--view": "side"}  # fmt: skip
                assert ("--table-scale" in noisy) == (step == "val-noise-table")
                assert steps[f"{step}-{run}"]["needs"] == [f"select-{run}"]


def test_the_final_plan_validates_each_arm_as_stage_1_did():
    """experiments/campaigns/final.toml: its bingham2d arms are selected and validated under noise
    as retrain.toml's (the same rounds, so that they read against stage 1's numbers), and the
    calibrated images differ from the wide data in the sensing alone (same scenes, labels and
    databases: a paired ablation). Both by the approach check's rule of stage 1 (the default
    before 2026-11-27), which final.toml names."""
    steps = campaign_steps("experiments/campaigns/final.toml")
    stage1 = campaign_steps("experiments/campaigns/retrain.toml")
    for arm in ("wide", "wide-calibrated"):
        for seed in (0, 1):
            run = f"{arm}-{REP}-s{seed}"
            dense = f"dense-{REP}-s{seed}"
            for step in ("select", "val-noise-table"):
                final = shlex.split(steps[f"{step}-{run}"]["run"])
                for option in ("--table-clearance", "--surface-clearance"):
                    i = final.index(option)
                    assert final[i + 1] == "-0.002"
                    del final[i : i + 2]
                assert final == shlex.split(stage1[f"{step}-{dense}"]["run"].replace(dense, run))
    wide = shlex.split(steps["data-wide"]["run"])
    calibrated = shlex.split(steps["data-wide-calibrated"]["run"].split("&&")[-1])
    assert calibrated[: len(wide) - 2] == wide[:-2] and wide[-2:] == ["--out", "/root/data/wide"]
    assert calibrated[-2:] == ["--out", "/root/data/wide-calibrated"]
    extra = calibrated[len(wide) - 2 : -2]
    assert {"--noise", "dex", "--table-scale"} <= set(extra) and "--seed" not in extra


def test_every_final_run_is_judged_on_the_rounds_no_checkpoint_was_chosen_by():
    """final.toml: each of the eight final runs plays the judging rounds (training objects from
    round seed 2 000 000, which the selections never see) with its selected best.pt."""
    steps = campaign_steps("experiments/campaigns/final.toml")
    judged = {n.removeprefix("judge-") for n in steps if n.startswith("judge-")}
    assert len(judged) == 8
    for run in judged:
        assert steps[f"judge-{run}"]["needs"] == [f"select-{run}"]
        flags = shlex.split(steps[f"judge-{run}"]["run"])
        value = {f: flags[flags.index(f) + 1] for f in ("--model", "--objects", "--seed",
                                                       "--rounds", "--out")}  # fmt: skip
        assert value == {"--model": f"/root/runs/{run}/best.pt", "--objects": "vgn-pile-train",
                         "--seed": "2000000", "--rounds": "400",
                         "--out": f"/root/bench/judge/{run}"}  # fmt: skip
        select = shlex.split(steps[f"select-{run}"]["run"])
        assert "--seed" not in select  # the selections' own rounds, from 1 000 000


def _same_commands_on_other_data(steps, arm, ablation, data, reps):
    """Each run of ``ablation`` (seeds 0 and 1 of ``reps``) is trained, selected and judged by
    ``arm``'s very commands, its data folder ``data[1]`` for ``data[0]``."""
    for rep, seed in itertools.product(reps, (0, 1)):
        for prefix in ("", "select-", "judge-"):
            theirs = steps[f"{prefix}{arm}-{rep}-s{seed}"]["run"]
            theirs = theirs.replace(f"{arm}-", f"{ablation}-").replace(
                f"/root/data/{data[0]} ", f"/root/data/{data[1]} "
            )
            assert shlex.split(steps[f"{prefix}{ablation}-{rep}-s{seed}"]["run"]) == shlex.split(
                theirs
            )


def test_the_noback_arm_is_the_wide_arm_without_the_back_spread():
    """noback.toml: its data is final.toml's wide data relabelled with the same spread less its
    back move, and its runs are trained, selected and judged by the wide runs' very commands
    (recipe, rounds, the old approach rule) on that data: an ablation of the back spread alone."""
    steps = campaign_steps("experiments/campaigns/final.toml", "experiments/campaigns/noback.toml")
    relabel = shlex.split(steps["data-wide-noback"]["run"])
    generate = shlex.split(steps["data-wide"]["run"])

    def spread(flags: list[str]) -> list[float]:
        i = flags.index("--label-spread")
        return [float(v) for v in flags[i + 1 : i + 5]]

    assert relabel[:4] == ["symgrasp", "data", "relabel", "/root/data/wide"]
    assert steps["data-wide-noback"]["needs"] == ["data-wide"]
    assert spread(generate)[0] > 0 and spread(relabel) == [0.0, *spread(generate)[1:]]
    _same_commands_on_other_data(steps, "wide", "noback", ("wide", "wide-noback"), [REP])


def test_the_franka_noback_arm_is_the_dense_franka_arm_without_the_back_spread():
    """noback.toml: the Franka's arm relabels final.toml's Franka data with the Robotiq arm's
    spread, and trains, selects and judges bingham2d (and, in franka_noback.toml, rotmat6d) by
    the dense Franka runs' very commands on it."""
    steps = campaign_steps(*FINAL_PLANS)
    relabel = shlex.split(steps["data-franka-noback"]["run"])
    robotiq = shlex.split(steps["data-wide-noback"]["run"])
    assert relabel[:4] == ["symgrasp", "data", "relabel", "/root/data/franka-dense"]
    assert relabel[4:] == [*robotiq[4:-3], "--out", "/root/data/franka-noback", "--resume"]
    assert steps["data-franka-noback"]["needs"] == ["data-franka"]
    _same_commands_on_other_data(steps, "dense-franka", "noback-franka",
                                 ("franka-dense", "franka-noback"), ["bingham2d", "rotmat6d"])  # fmt: skip


def test_the_shipped_models_are_judged_on_the_retrained_runs_rounds():
    """noback.toml: each hand's shipped bingham2d plays the judging rounds by the runs' judging
    command, the model named instead of a run's best.pt, into the folder judge.py --shipped reads."""
    steps = campaign_steps("experiments/campaigns/final.toml", "experiments/campaigns/noback.toml")
    run = "wide-bingham2d-s0"
    judge = steps[f"judge-{run}"]["run"]
    for name in ("bingham2d-robotiq-2f85", "bingham2d-franka"):
        shipped = judge.replace(f"/root/runs/{run}/best.pt", name).replace(
            f"judge/{run}", f"judge/shipped-{name}"
        )
        assert shlex.split(steps[f"judge-shipped-{name}"]["run"]) == shlex.split(shipped)
        assert steps[f"judge-shipped-{name}"]["keep"] == [f"bench/judge/shipped-{name}/**"]


def test_the_franka_data_takes_the_offset_range_its_recorded_decision_chose():
    """final.toml: the Franka's data keeps today's offset range (no --offset), as the committed
    decision on the oracle's two readings says, where the Robotiq's takes the wide one."""
    steps = campaign_steps("experiments/campaigns/final.toml")
    decision = (ROOT / "experiments/results/franka_offset_decision.md").read_text()
    assert "today" in decision and "85.4" in decision and "79.4" in decision
    assert "--offset" not in steps["data-franka"]["run"]
    assert "--offset -0.03 0.03" in steps["data-wide"]["run"]
    for name, step in steps.items():
        if "--gripper franka" in step["run"] and name.startswith("dense-franka"):
            assert step["needs"] == ["data-franka"]


def test_the_bank_keeps_what_the_collations_read_each_file_by_one_step(tmp_path, monkeypatch):
    """The final plans under --bank: a root holding what every step writes (a
    run's checkpoints, its selection records, each benchmark's rounds, each Table 1 cell on
    both round-seed ranges, each robustness condition) has each file the reports read kept by
    exactly one step, the one that wrote it, and no checkpoint but best.pt kept."""
    monkeypatch.syspath_prepend(str(ROOT / "experiments"))  # as it runs: its neighbours by name
    import campaign

    shown = campaign_steps(*FINAL_PLANS)
    steps = [campaign.Step(s["name"], s["run"], Path("plan"), s["cores"], tuple(s["needs"]),
                           tuple(s["keep"])) for s in shown.values()]  # fmt: skip
    writer = {}  # file under the root → the step that writes it
    hands = {"wide": "robotiq-2f85", "wide-calibrated": "robotiq-2f85", "noback": "robotiq-2f85",
             "dense-franka": "franka", "noback-franka": "franka"}  # fmt: skip
    for name in shown:
        if not name.startswith("select-"):
            continue
        run = name.removeprefix("select-")
        for file in ("best.pt", "selection.json", "selection.csv",
                     "selection/declutter/v1/epoch_001-ab12/rounds.jsonl"):  # fmt: skip
            writer[f"runs/{run}/{file}"] = name
        for file in ("epoch_001.pt", "last.pt"):
            writer[f"runs/{run}/{file}"] = None  # the training's: not kept
    for name, step in shown.items():
        words = shlex.split(step["run"])
        if words[:3] == ["symgrasp", "bench", "declutter"]:
            out = Path(words[words.index("--out") + 1]).relative_to("/root")
            writer[f"{out}/rounds.jsonl"] = writer[f"{out}/summary.json"] = name
        out = words[words.index("--out") + 1] if "--out" in words else None
        if name.startswith("cells-"):
            prefix, rep, seed = next((p, *name.removeprefix(f"cells-{p}-").split("-s", 1))
                                     for p in ("dense-franka", "noback-franka", "wide") if name.startswith(f"cells-{p}-"))  # fmt: skip
            seed, late = seed.split("-", 1) if "-" in seed else (seed, "")
            for rep_folder in (rep, f"{rep}-noconf"):
                for objects in ("vgn-pile-test", "large-box", "vgn-packed-test-packed"):
                    folder = f"{objects}-{late}" if late else objects
                    base = f"{Path(out).relative_to('/root')}/{hands[prefix]}/{rep_folder}/s{seed}/{folder}"
                    writer[f"{base}/rounds.jsonl"] = name
        if name.startswith("robustness-") and "--play-only" in words:
            model = Path(words[words.index("--models") + 1])
            prefix, rep, seed = model.parent.name.rsplit("-", 2)
            objects = {"vgn-pile-test:pile": "vgn-pile-test",
                       "vgn-packed-test:packed": "vgn-packed-test-packed"}[words[words.index("--sets") + 1]]  # fmt: skip
            for condition in ("clean", "noise", "side-view"):
                writer[f"{Path(out).relative_to('/root')}/{hands[prefix]}/{rep}/{seed}/"
                       f"{objects}-first-seed-100/{condition}/rounds.jsonl"] = name  # fmt: skip
    for file in writer:
        (tmp_path / file).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / file).write_text(file)
    for data in ("wide", "franka-dense", "wide-calibrated", "wide-noback", "franka-noback"):
        (tmp_path / f"data/{data}/scenes/scene_000000.npz").parent.mkdir(parents=True)
        (tmp_path / f"data/{data}/scenes/scene_000000.npz").write_text("scene")
    (tmp_path / "data/wide/card.json").write_text("card")
    (tmp_path / "data/wide/card.png").write_text("card")
    kept_by = {}
    for step in steps:
        if step.keep:
            for file in campaign.kept_files(step, tmp_path):
                assert file not in kept_by, f"{file}: kept by {kept_by[file]} and {step.name}"
                kept_by[file] = step.name
    for file, name in writer.items():
        assert kept_by.get(file) == name, file
    assert not any(f.startswith("data/") for f in kept_by if not f.startswith("data/wide/card"))
    for name, step in shown.items():  # what a later step or the report reads is kept
        if name.startswith(("select-", "judge-", "val-noise", "cells-")) or (
            name.startswith("robustness-") and "--play-only" in step["run"]
        ):
            assert step["keep"], name


# each collation of Table 1 cells: its step, and each training run's data (prefix → dataset)
COLLATIONS = {
    "retrained": {"wide": "wide", "dense-franka": "franka-dense"},  # retrain_cells.toml's
    "retrained-final": {"wide": "wide", "noback-franka": "franka-noback"},  # franka_noback.toml's
}


@pytest.mark.parametrize("collation", COLLATIONS)
def test_every_final_run_plays_both_round_seed_ranges_before_their_collations(collation, tmp_path):
    """The final plans: the runs a collation waits for (the script's own answer on no runs,
    with the plan's options) are trained on their data, each selected, then played on round
    seeds 0-99 and 100-199 before the collations of both ranges."""
    steps = campaign_steps(*FINAL_PLANS)
    words = shlex.split(steps[collation]["run"])
    words = words[words.index("experiments/declutter_table.py") :]
    for flag, path in (("--runs", "runs"), ("--out", "cells"), ("--result", "table"),
                       ("--figure", "figure.png"), ("--archive", "rounds.tar.gz"),
                       ("--docs", "page.md")):  # fmt: skip
        words[words.index(flag) + 1] = str(tmp_path / path)
    (tmp_path / "page.md").write_text(
        "<!-- declutter-table: begin -->\n<!-- declutter-table: end -->\n"
    )
    done = subprocess.run([sys.executable, *words], cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT / "src")})  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    waiting = {
        w.removesuffix(" (not selected)")
        for w in json.loads((tmp_path / "table.json").read_text())["waiting"]
    }
    assert len(waiting) == 8  # 2 hands, bingham2d and rotmat6d, training seeds 0 and 1
    for run in waiting:
        prefix, rep, seed = next((p, *run.removeprefix(f"{p}-").rsplit("-s", 1))
                                 for p in COLLATIONS[collation] if run.startswith(f"{p}-"))  # fmt: skip
        assert steps[f"select-{run}"]["needs"] == [run]
        assert f"--out /root/runs/{run}" in steps[run]["run"]
        assert f"--data /root/data/{COLLATIONS[collation][prefix]} " in steps[run]["run"]
        for suffix, first in (("", None), ("-first-seed-100", "100")):
            cells = steps[f"cells-{run}{suffix}"]
            assert cells["needs"] == [f"select-{run}"]
            assert f"cells-{run}{suffix}" in steps[f"{collation}{suffix}"]["needs"]
            flags = shlex.split(cells["run"])
            assert flags[flags.index("--reps") + 1] == rep
            assert flags[flags.index("--seeds") + 1] == seed
            assert ("--first-seed" in flags) == (first is not None)
            if first:
                assert flags[flags.index("--first-seed") + 1] == first
    assert "--first-seed 100" in steps[f"{collation}-first-seed-100"]["run"]
    assert "--first-seed" not in steps[collation]["run"]


def _links(run: str) -> dict[str, str]:
    """The links ``ln -sfn TARGET LINK`` in a step's command: link → the path it points to."""
    words = shlex.split(run)
    return {words[i + 3]: os.path.normpath(Path(words[i + 3]).parent / words[i + 2])
            for i, w in enumerate(words) if w == "ln"}  # fmt: skip


def test_the_final_collations_read_each_hand_where_its_final_runs_played():
    """franka_noback.toml: each final collation reads both hands through links in the folder
    it collates (--out, and --baselines for the robustness), the Robotiq's to where
    retrain_cells.toml's wide runs played and the Franka's to where franka_noback.toml's
    noback-franka runs played (the --out and --baselines of the steps it waits for)."""
    steps = campaign_steps(*FINAL_PLANS)
    for name in ("retrained-final", "retrained-final-first-seed-100", "robustness-retrained-final"):
        words, links = shlex.split(steps[name]["run"]), _links(steps[name]["run"])
        for flag in ("--out", "--baselines") if name.startswith("robustness") else ("--out",):
            read = words[words.index(flag) + 1]
            for hand, prefix in (("robotiq-2f85", "wide-"), ("franka", "noback-franka-")):
                played = {shlex.split(steps[n]["run"])[shlex.split(steps[n]["run"]).index(flag) + 1]
                          for n in steps[name]["needs"] if prefix in n}  # fmt: skip
                assert len(played) == 1, (name, hand, played)
                assert links[f"{read}/{hand}"] == f"{played.pop()}/{hand}", (name, flag, hand)


def test_every_final_run_plays_the_robustness_conditions_after_its_unseen_cells():
    """The final plans' robustness steps: each final run (the runs of the final cells'
    collation) plays VGN's pile and packed test scenes once, on round seeds 100-199 after its
    Table 1 cells there (whose clean rounds they pair with: --baselines is its cells' --out),
    and the final collation waits for all of them and collates those eight runs."""
    steps = campaign_steps(*FINAL_PLANS)
    collation = shlex.split(steps["robustness-retrained-final"]["run"])
    models = collation[collation.index("--models") + 1 : collation.index("--docs")]
    runs = {Path(m).parent.name for m in models}
    assert len(models) == len(runs) == 8
    finals = steps["retrained-final-first-seed-100"]["needs"]
    assert runs == {n.removeprefix("cells-").removesuffix("-first-seed-100") for n in finals}
    assert collation[collation.index("--first-seed") + 1] == "100"
    played = []
    for name in steps["robustness-retrained-final"]["needs"]:
        flags = shlex.split(steps[name]["run"])
        assert "--play-only" in flags and steps[name]["cores"] == 1
        (model,) = flags[flags.index("--models") + 1 : flags.index("--sets")]
        run = Path(model).parent.name
        assert model in models
        assert set(steps[name]["needs"]) == {f"select-{run}", f"cells-{run}-first-seed-100"}
        cells = shlex.split(steps[f"cells-{run}-first-seed-100"]["run"])
        assert flags[flags.index("--first-seed") + 1] == "100"
        assert flags[flags.index("--baselines") + 1] == cells[cells.index("--out") + 1]
        played.append((run, flags[flags.index("--sets") + 1]))
    assert sorted(played) == sorted(
        (run, s) for run in runs for s in ("vgn-pile-test:pile", "vgn-packed-test:packed")
    )
