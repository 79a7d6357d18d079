"""``--decomposition``: one option, defined once, on every command that cuts bare meshes, and
what it names reaches the object set's resolution of the benchmark's workers and of data
generation (the resolution stubbed: no mesh is cut)."""

import argparse
from pathlib import Path

import symgrasp
from symgrasp.benchmark import runner
from symgrasp.cli import build_parser
from symgrasp.cli.fields import config_from_args
from symgrasp.config import BenchmarkConfig, SceneConfig
from symgrasp.data import scenes
from symgrasp.names import DECOMPOSITIONS
from symgrasp.objects.sets import ObjectSource


def _commands(parser, name="symgrasp"):
    """Every command's name and its flags."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, subparser in action.choices.items():
                yield from _commands(subparser, f"{name} {sub}")
    yield name, {flag for action in parser._actions for flag in action.option_strings}


def test_the_options_are_defined_once_and_offered_wherever_bare_meshes_are_read():
    package = Path(symgrasp.__file__).parent
    defining = [p for p in package.rglob("*.py") if '"--decomposition"' in p.read_text()]
    assert defining == [package / "cli" / "options.py"]
    commands = dict(_commands(build_parser()))
    taking = {name for name, flags in commands.items() if "--objects" in flags}
    assert all("--mesh-unit" in commands[name] for name in taking), taking
    inspect = build_parser().parse_args(["objects", "inspect", "blocks", "--mesh-unit", "cm"])
    assert inspect.mesh_unit == "cm"
    reading = {name: flags for name, flags in commands.items() if "--mesh-unit" in flags}
    assert set(reading) >= {
        "symgrasp demo",
        "symgrasp sim show",
        "symgrasp objects inspect",
        "symgrasp data generate",
        "symgrasp bench declutter",
    }
    # select's declutter validation plays the default parts (symgrasp.benchmark.selection)
    without = {name for name, flags in reading.items() if "--decomposition" not in flags}
    assert without == {"symgrasp select"}


def test_the_preset_given_reaches_resolve_from_bench_and_data_generate(tmp_path, monkeypatch):
    resolved = []

    def fake_resolve(objects, mesh_unit="auto", decomposition=DECOMPOSITIONS[0]):
        resolved.append((objects, decomposition))
        return ObjectSource("household-train")  # built in code: nothing to cut

    monkeypatch.setattr(runner, "resolve", fake_resolve)
    monkeypatch.setattr(runner, "load_planner", lambda *args, **kwargs: None)
    monkeypatch.setattr(runner, "_WORKER", {})
    monkeypatch.setattr(scenes, "resolve", fake_resolve)
    parser = build_parser()
    bench = parser.parse_args(
        ["bench", "declutter", "--out", str(tmp_path / "b"), "--objects", "vgn-pile-test",
         "--decomposition", "coacd"]
    )  # fmt: skip
    runner._init_worker(config_from_args(BenchmarkConfig, bench), tmp_path / "b")
    data = parser.parse_args(
        ["data", "generate", "--out", str(tmp_path / "d"), "--objects", "vgn-pile-train",
         "--decomposition", "coacd-fast", "--pool-size", "1"]
    )  # fmt: skip
    scenes.scene_pool(config_from_args(SceneConfig, data))
    assert resolved == [("vgn-pile-test", "coacd"), ("vgn-pile-train", "coacd-fast")]
    plain = parser.parse_args(["data", "generate", "--out", str(tmp_path / "d")])
    assert config_from_args(SceneConfig, plain).decomposition == DECOMPOSITIONS[0]
