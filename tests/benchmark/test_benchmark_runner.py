"""The declutter benchmark's bookkeeping: pooled ratios, bootstrap intervals, crashed rounds
(a run with any stops, naming the first; --resume plays them again), an object set missing
before any round is played."""

import json

import numpy as np
import pytest

from symgrasp.benchmark import runner
from symgrasp.benchmark.runner import BenchmarkConfig, markdown_table, pooled_ratio, summarise
from symgrasp.config import PlannerOptions
from symgrasp.objects.folder import DATA_ENV, MissingData
from symgrasp.parallel import TasksFailed


def _round(seed, objects, outcomes, modes=None, targets=None):
    modes = modes or [None] * len(outcomes)
    targets = targets or [None] * len(outcomes)
    return {
        "seed": seed,
        "objects": objects,
        "renderer": "gl",
        "successes": outcomes.count("success"),
        "executed": sum(o != "none_found" for o in outcomes),
        "attempts": [
            {"outcome": o, "mode": m, "target": t, "planning_s": 0.1 * (i + 1)}
            for i, (o, m, t) in enumerate(zip(outcomes, modes, targets, strict=True))
        ],
    }


def _no_constant(name):
    raise AssertionError(f"{name} in a file that must be strict JSON")


def test_ratios_pool_all_rounds_and_the_interval_brackets_them():
    rounds = [
        _round(0, 5, ["success"] * 5),
        _round(1, 4, ["success", "slipped", "success", "none_found"]),
        _round(2, 5, ["no_contact", "approach_collision"], ["wrong_approach", "wrong_yaw"]),
        {"seed": 3, "error": "RuntimeError: unstable"},
    ]
    s = summarise(rounds)
    assert s["success_ratio"] == pytest.approx(7 / 10)  # 7 successes in 10 executed grasps
    assert s["clear_ratio"] == pytest.approx(7 / 14)
    assert s["errors"] == [{"seed": 3, "error": "RuntimeError: unstable"}]
    assert s["renderers"] == ["gl"]
    assert s["outcomes"]["success"] == 7 and s["outcomes"]["none_found"] == 1
    assert s["modes"] == {"wrong_yaw": 1, "wrong_approach": 1}  # undiagnosed rounds not counted
    ordered = summarise([_round(0, 2, ["slipped", "success"], ["slip", "success"])])["modes"]
    assert list(ordered) == ["success", "slip"]  # report order
    for name in ("success_ratio", "clear_ratio"):
        lo, hi = s[f"{name}_ci95"]
        assert 0 <= lo <= s[name] <= hi <= 1 and hi - lo > 0.1  # 3 rounds: a wide interval
    assert summarise(rounds) == s  # seeded bootstrap
    row = markdown_table(s, BenchmarkConfig(rounds=4)).splitlines()[2]
    assert "70.0 [" in row and "50.0 [" in row and row.endswith("| 1 |")


def test_a_ratio_of_nothing_counted_is_undefined():
    assert pooled_ratio(np.array([1.0, 2.0]), np.array([2.0, 2.0])) == 0.75
    assert np.isnan(pooled_ratio(np.zeros(0), np.zeros(0)))
    assert np.isnan(pooled_ratio(np.zeros(3), np.zeros(3)))  # no grasp executed: SR undefined
    by_row = pooled_ratio(np.array([[1.0, 1.0], [0.0, 0.0]]), np.array([[2.0, 2.0], [0.0, 0.0]]))
    assert by_row[0] == 0.5 and np.isnan(by_row[1])
    none = summarise([{"seed": 0, "error": "RuntimeError: unstable"}])
    assert np.isnan(none["success_ratio"]) and np.isnan(none["clear_ratio"])
    assert np.isnan(none["success_ratio_ci95"]).all()


def test_attempts_are_counted_per_aimed_at_family():
    rounds = [
        _round(
            0,
            3,
            ["success", "no_contact", "success"],
            ["success", "wrong_yaw", "success"],
            ["box", "box", "sphere"],
        ),
        _round(1, 2, ["slipped", "none_found"], ["slip", "none_found"], ["box", None]),
        _round(2, 1, ["success"]),  # an older record: no targets
    ]
    assert summarise(rounds)["families"] == {
        "box": {"executed": 3, "successes": 1, "wrong_yaw": 1},
        "sphere": {"executed": 1, "successes": 1, "wrong_yaw": 0},
    }


def test_what_collisions_struck_is_counted_once_per_attempt_and_kind():
    first = _round(0, 3, ["approach_collision", "pregrasp_collision", "success"])
    hits = [["table", "neighbour"], ["neighbour"], []]
    for attempt, hit in zip(first["attempts"], hits, strict=True):
        attempt["struck"] = hit
    rounds = [first, _round(1, 2, ["approach_collision"])]  # an older record: nothing struck
    struck = summarise(rounds)["struck"]
    assert struck == {"table": 1, "neighbour": 2} and list(struck) == ["table", "neighbour"]
    assert summarise([_round(2, 1, ["success"])])["struck"] == {}


def test_the_objects_left_on_the_table_are_counted_per_family_most_often_left_first():
    rounds = [
        {**_round(0, 3, ["success", "none_found"]), "presented": ["box", "box", "banana"],
         "left": ["box", "banana"]},
        {**_round(1, 2, ["success", "success"]), "presented": ["box", "cup"], "left": []},
        {**_round(2, 2, ["none_found"]), "presented": ["banana", "cup"], "left": ["banana", "cup"]},
        _round(3, 4, ["success"]),  # an older record: no families presented or left
    ]  # fmt: skip
    left = summarise(rounds)["left_on_table"]
    assert left == {"banana": {"presented": 2, "left": 2}, "cup": {"presented": 2, "left": 1},
                    "box": {"presented": 3, "left": 1}}  # fmt: skip
    assert list(left) == ["banana", "cup", "box"]  # 2/2, then 1/2 before 1/3


def test_bootstrap_interval_shrinks_like_one_over_sqrt_rounds():
    rng = np.random.default_rng(0)

    def rounds(n):
        return [_round(i, 5, ["success" if rng.random() < 0.7 else "slipped" for _ in range(5)])
                for i in range(n)]  # fmt: skip

    width = {n: np.diff(summarise(rounds(n))["success_ratio_ci95"])[0] for n in (25, 400)}
    assert 2.5 < width[25] / width[400] < 6  # √16 = 4
    # binomial check: 25 rounds × 5 grasps at p = 0.7 → ±1.96·√(p(1−p)/125) ≈ ±0.08
    assert 0.1 < width[25] < 0.25


def test_a_crashing_round_is_recorded_and_the_benchmark_goes_on(fake_rounds, tmp_path):
    def fake_round(detector, objects, num_objects, seed, **_):
        if seed == 11:
            raise RuntimeError("simulation unstable")
        from symgrasp.benchmark.declutter import Round

        return Round(seed, num_objects, "gl")

    fake_rounds(fake_round)
    config = BenchmarkConfig(rounds=3, seed=10)
    expected = "1 of the 3 rounds in .* failed; the first \\(seed 11\\): RuntimeError: simulation"
    with pytest.raises(TasksFailed, match=expected):
        runner.run_benchmark(config, tmp_path)
    lines = [json.loads(x) for x in (tmp_path / "rounds.jsonl").read_text().splitlines()]
    assert [x["seed"] for x in lines] == [10, 11, 12]
    assert "simulation unstable" in lines[1]["traceback"]
    results = json.loads((tmp_path / "results.json").read_text())  # written, and marked
    assert results["config"]["seed"] == 10
    assert results["summary"]["rounds"] == 3 and results["summary"]["errors"][0]["seed"] == 11
    table, note = (tmp_path / "results.md").read_text().split("\n\n")
    assert table.endswith("| 1 |")  # the errors column
    assert note == (
        "**Not a result: 1 of the 3 rounds failed** (the first, seed 11: RuntimeError: "
        "simulation unstable); SR and CR are over the 2 that finished only. `--resume` plays "
        "the failed rounds again.\n"
    )
    with pytest.raises(TasksFailed, match=expected):  # read back, not taken for a result
        runner.run_or_reuse(config, tmp_path)


def test_a_summary_never_averages_over_failed_rounds():
    done = [_round(0, 2, ["success", "slipped"]), _round(2, 2, ["success"])]
    failed = {"seed": 1, "error": "RuntimeError: boom", "traceback": ""}
    with_failure, without = summarise([done[0], failed, done[1]]), summarise(done)
    assert with_failure["rounds"] == 3 and with_failure["errors"] == [
        {"seed": 1, "error": "RuntimeError: boom"}
    ]
    for key in ("success_ratio", "clear_ratio", "executed", "successes", "objects"):
        assert with_failure[key] == without[key]


def test_resume_plays_failed_rounds_again_and_keeps_one_record_per_seed(fake_rounds, tmp_path):
    broken = {11, 12}

    def fake_round(detector, objects, num_objects, seed, **_):
        if seed in broken:
            raise RuntimeError(f"object set incomplete in round {seed}")
        from symgrasp.benchmark.declutter import Attempt, Round

        return Round(seed, num_objects, "gl", [Attempt("success", None, 1, 0, 0.1, 1)])

    fake_rounds(fake_round)
    config = BenchmarkConfig(rounds=4, seed=10)
    with pytest.raises(TasksFailed, match=r"2 of the 4 rounds .* \(seed 11\): RuntimeError"):
        runner.run_benchmark(config, tmp_path)
    broken.clear()  # the cause fixed (the data fetched)
    summary = runner.run_benchmark(config, tmp_path, resume=True)
    lines = [json.loads(x) for x in (tmp_path / "rounds.jsonl").read_text().splitlines()]
    assert [x["seed"] for x in lines] == [10, 11, 12, 13]
    assert not any("error" in x for x in lines)
    assert summary["errors"] == [] and summary["successes"] == 4
    assert [r["seed"] for r in runner.saved_rounds(config, tmp_path)] == [10, 11, 12, 13]


def test_a_later_finished_record_of_a_seed_wins_over_a_failed_one(tmp_path):
    path = tmp_path / "rounds.jsonl"
    failed, finished = {"seed": 3, "error": "E", "traceback": ""}, _round(3, 1, ["success"])
    path.write_text("".join(json.dumps(r) + "\n" for r in (failed, finished, failed)))
    assert runner.read_rounds(path) == {3: finished}


def test_a_benchmark_whose_every_round_failed_stops_naming_the_first_error(fake_rounds, tmp_path):
    def failing_round(detector, objects, num_objects, seed, **_):
        raise RuntimeError(f"no object in round {seed}")

    fake_rounds(failing_round)
    config = BenchmarkConfig(rounds=2, seed=10)
    expected = "every one of the 2 rounds in .* failed; the first \\(seed 10\\): RuntimeError: no object in round 10"
    with pytest.raises(TasksFailed, match=expected):
        runner.run_benchmark(config, tmp_path)
    assert len((tmp_path / "rounds.jsonl").read_text().splitlines()) == 2  # recorded all the same
    results = json.loads((tmp_path / "results.json").read_text(), parse_constant=_no_constant)
    summary = results["summary"]  # no ratio: null in strict JSON, no NaN
    assert summary["success_ratio"] is None and summary["clear_ratio_ci95"] == [None, None]
    assert summary["planning_s_median"] is None and summary["rounds"] == 2
    row, note = (tmp_path / "results.md").read_text().splitlines()[2::2]
    assert row == "| bingham2d-robotiq-2f85 | household-test | 2 | — | — | 0 | 2 |"
    assert note.startswith("**Not a result: every one of the 2 rounds failed** (the first, seed 10")
    assert note.endswith("; no ratio. `--resume` plays the failed rounds again.")
    with pytest.raises(TasksFailed, match=expected):  # read back, not taken for a result
        runner.run_or_reuse(config, tmp_path)


def test_a_missing_object_set_stops_the_benchmark_before_any_round(monkeypatch, tmp_path):
    monkeypatch.setenv(DATA_ENV, str(tmp_path / "no-data"))
    monkeypatch.setattr(runner, "_init_worker", lambda *args: pytest.fail("a worker started"))
    config = BenchmarkConfig(objects="vgn-pile-train", rounds=2)
    with pytest.raises(MissingData, match="object set vgn-pile-train is not in the data folder"):
        runner.run_benchmark(config, tmp_path / "b")
    assert not (tmp_path / "b" / "config.json").exists()


def test_bad_configuration_is_refused():
    with pytest.raises(ValueError, match="rounds"):
        BenchmarkConfig(rounds=0)


def test_cli_writes_results_modes_and_pictures_and_guards_the_model(tmp_path, capsys):
    from symgrasp.cli import main

    argv = ["bench", "declutter", "--rounds", "2", "--num-objects", "2", "--seed", "3"]
    main([*argv, "--pictures", "--out", str(tmp_path)])
    result = json.loads((tmp_path / "results.json").read_text())
    rounds = [json.loads(x) for x in (tmp_path / "rounds.jsonl").read_text().splitlines()]
    assert sum(result["summary"]["modes"].values()) == sum(len(r["attempts"]) for r in rounds)
    drawn = sorted((tmp_path / "pictures").rglob("attempt_*.png"))
    assert len(drawn) == sum(len(r["attempts"]) for r in rounds) > 0
    assert "failure modes" in capsys.readouterr().out
    with pytest.raises(SystemExit, match="--rep rotmat6d, but --model"):
        main([*argv, "--rep", "rotmat6d", "--out", str(tmp_path / "x")])
    with pytest.raises(SystemExit, match="--gripper franka"):
        main([*argv, "--gripper", "franka", "--out", str(tmp_path / "x")])
    with pytest.raises(SystemExit):
        main([*argv, "--validity", "2", "--out", str(tmp_path / "x")])
    assert "argument --validity: must be a number in [0, 1], got '2'" in capsys.readouterr().err


def test_cli_thresholds_reach_the_detector(tmp_path):
    from symgrasp.cli import main
    from symgrasp.detect.pretrained import shipped_operating_point

    argv = ["bench", "declutter", "--rounds", "1", "--num-objects", "1", "--seed", "3"]
    main([*argv, "--no-confidence", "--validity", "0.3", "--out", str(tmp_path)])
    options = json.loads((tmp_path / "results.json").read_text())["config"]["options"]
    # the given options over the model card's operating point, recorded whole
    card = shipped_operating_point(BenchmarkConfig.model)
    assert dict(options) == {**card, "confidence_threshold": 0.0, "validity_threshold": 0.3}
    config = BenchmarkConfig(options=PlannerOptions(**dict(options)))
    runner._init_worker(config, tmp_path)
    detector = runner._WORKER["planner"]
    assert detector.validity_threshold == 0.3 and detector.confidence_threshold == 0.0
    assert detector.validity_floor == card.get("validity_floor")
    main([*argv, "--no-operating-point", "--fallbacks", "2", "--out", str(tmp_path / "plain")])
    options = json.loads((tmp_path / "plain" / "results.json").read_text())["config"]["options"]
    assert dict(options) == {"fallbacks": 2}


def test_a_finished_benchmark_is_reused_and_another_configuration_is_refused(fake_rounds, tmp_path):
    played = []

    def fake_round(detector, objects, num_objects, seed, **_):
        from symgrasp.benchmark.declutter import Round

        played.append(seed)
        return Round(seed, num_objects, "gl")

    fake_rounds(fake_round)
    config = BenchmarkConfig(rounds=2, seed=5)
    assert runner.saved_rounds(config, tmp_path) is None
    first = runner.run_or_reuse(config, tmp_path)
    assert [r["seed"] for r in first] == [5, 6] and played == [5, 6]
    assert runner.run_or_reuse(config, tmp_path) == first and played == [5, 6]  # read back
    other = BenchmarkConfig(rounds=2, seed=5, objects="large-box")
    assert runner.saved_rounds(other, tmp_path) is None
    with pytest.raises(ValueError, match="another configuration"):
        runner.run_or_reuse(other, tmp_path)
    runner.run_or_reuse(other, tmp_path / "other")
    assert played == [5, 6, 5, 6]


def test_the_sensing_reaches_the_rounds_is_recorded_and_resume_refuses_another(
    fake_rounds, tmp_path
):
    from dataclasses import replace

    from symgrasp.benchmark.declutter import Round
    from symgrasp.benchmark.sensing import Sensor

    sensors = []

    def fake_round(detector, objects, num_objects, seed, sensor, **_):
        sensors.append(sensor)
        return Round(seed, num_objects, "gl")

    fake_rounds(fake_round)
    config = BenchmarkConfig(rounds=2, noise="dex", view="circle", views=6)
    runner.run_benchmark(config, tmp_path)
    assert sensors == [Sensor("dex", "circle", 6)] * 2
    recorded = json.loads((tmp_path / "config.json").read_text())
    assert (recorded["noise"], recorded["view"], recorded["views"]) == ("dex", "circle", 6)
    runner.check_out(config, tmp_path, resume=True)  # the same: resumes
    with pytest.raises(ValueError, match=r"its noise, views differ"):
        runner.check_out(replace(config, noise="none", views=3), tmp_path, resume=True)
    # a folder from before the sensing was recorded played the defaults: it resumes as theirs
    old = tmp_path / "old"
    runner.run_benchmark(BenchmarkConfig(rounds=2), old)
    stored = json.loads((old / "config.json").read_text())
    for key in ("noise", "view", "views"):
        del stored[key]
    (old / "config.json").write_text(json.dumps(stored))
    assert runner.saved_rounds(BenchmarkConfig(rounds=2), old, check_model=False) is not None
    with pytest.raises(ValueError, match=r"its noise differ"):
        runner.check_out(BenchmarkConfig(rounds=2, noise="dex"), old, resume=True)
