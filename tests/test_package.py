"""Package-wide properties: what a robot-side user loads, how files are written."""

import subprocess
import sys
from pathlib import Path

import pytest


def loaded_after(statement: str) -> set[str]:
    """Top-level modules loaded by ``statement`` in a fresh interpreter."""
    code = f"import sys; {statement}; print(' '.join(sorted({{m.split('.')[0] for m in sys.modules}})))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_detection_does_not_load_the_simulator():
    loaded = loaded_after("import symgrasp.detect, symgrasp.perception, symgrasp.workspace")
    assert "torch" in loaded  # the oracle: the statement did import the detector
    assert "mujoco" not in loaded
    assert "trimesh" not in loaded


def test_gripper_specs_do_not_load_the_simulator():
    loaded = loaded_after("from symgrasp.sim import get_gripper; get_gripper('franka')")
    assert "mujoco" not in loaded


def test_simulator_names_load_on_first_use():
    loaded = loaded_after("from symgrasp.sim import World")
    assert "mujoco" in loaded


def test_the_package_renames_written_files_in_one_place():
    """Every atomic write goes through `symgrasp.atomic` (`write_atomic`, `move_into_place`)."""
    from pathlib import Path

    import symgrasp

    root = Path(symgrasp.__file__).parent
    renaming = sorted(
        str(p.relative_to(root))
        for p in root.rglob("*.py")
        if "os.replace(" in p.read_text() or "os.rename(" in p.read_text()
    )
    assert renaming == ["atomic.py"]


def test_an_interrupted_write_leaves_the_old_file_and_no_temporary(tmp_path):
    import pytest

    from symgrasp.atomic import write_atomic

    path = write_atomic(tmp_path / "a.txt", lambda f: f.write("old"), "w")

    def fail(file):
        file.write("half")
        raise RuntimeError("killed")

    with pytest.raises(RuntimeError):
        write_atomic(path, fail, "w")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_write_csv_takes_every_key_in_first_seen_order(tmp_path):
    import csv

    from symgrasp.atomic import write_csv

    path = write_csv(tmp_path / "t.csv", [{"a": 1, "b": 2}, {"b": 3, "c": 4}])
    with open(path, newline="") as file:
        rows = list(csv.DictReader(file))
    assert list(rows[0]) == ["a", "b", "c"]
    assert rows == [{"a": "1", "b": "2", "c": ""}, {"a": "", "b": "3", "c": "4"}]


ROOT_MODULES = {
    "arguments",
    "atomic",
    "config",
    "device",
    "digest",
    "fields",
    "folders",
    "gl_backend",
    "names",
    "rates",
    "workspace",
}
"""The small root modules every layer reads (docs/architecture.md); they read only each other."""

LAYERS = {
    "bingham": set(),
    "rotation": {"bingham"},
    "perception": set(),
    "sim": {"perception"},
    "objects": {"sim", "parallel"},
    "parallel": set(),
    "data": {"perception", "sim", "objects", "parallel"},
    "model": {"bingham", "rotation", "perception", "sim", "data"},
    "detect": {"bingham", "rotation", "perception", "sim", "model"},
    "peers": {"bingham", "rotation", "perception", "sim", "objects", "data", "model", "detect"},
}
"""What each layer below the benchmark may import besides the root modules: the layers to its
left in docs/architecture.md's map."""


def symgrasp_imports(path) -> set[str]:
    """The symgrasp modules or packages (``symgrasp.X``: X) that the file ``path`` imports,
    at module level or inside functions."""
    import ast

    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return {name.split(".")[1] for name in names if name.startswith("symgrasp.")}


def test_no_layer_imports_one_above_it():
    """The import statements of every module, function-level ones included, follow the map."""
    from pathlib import Path

    import symgrasp

    root = Path(symgrasp.__file__).parent
    wrong = []
    for path in sorted(root.rglob("*.py")):
        layer = path.relative_to(root).parts[0].removesuffix(".py")
        if layer in ROOT_MODULES:
            allowed = ROOT_MODULES
        elif layer in LAYERS:
            allowed = ROOT_MODULES | LAYERS[layer] | {layer}
        else:
            continue  # benchmark, analysis, demo and the command line sit on top
        wrong += [f"{path.relative_to(root)} imports symgrasp.{name}"
                  for name in symgrasp_imports(path) - allowed]  # fmt: skip
    assert wrong == []


def test_training_loads_neither_the_simulator_nor_the_benchmark():
    loaded = loaded_after("import symgrasp.model, symgrasp.model.train, symgrasp.model.metrics")
    assert "torch" in loaded  # the oracle: the statement did import the trainer
    assert "mujoco" not in loaded
    code = "import sys, symgrasp.model.train; print('symgrasp.benchmark' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("name", ["mps", "meta", "xla", "bogus", "cuda:x"])
def test_a_device_symgrasp_does_not_run_on_is_refused_naming_the_choices(name):
    from symgrasp.device import resolve_device

    with pytest.raises(ValueError, match="device must be 'auto', 'cpu' or 'cuda"):
        resolve_device(name)
    assert resolve_device("cpu").type == "cpu"


def test_the_version_is_written_once():
    """pyproject.toml reads the version from ``symgrasp.__version__``: the installed metadata,
    datasets' manifests and checkpoints all say the same."""
    import importlib.metadata

    import symgrasp

    assert importlib.metadata.version("symgrasp") == symgrasp.__version__
    pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
    assert 'attr = "symgrasp.__version__"' in pyproject.read_text()
