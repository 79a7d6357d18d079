"""Package-wide properties: what a robot-side user loads, how files are written."""

import ast
import itertools
import re
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
    "data": {"perception", "sim", "objects", "parallel"},
    "model": {"bingham", "rotation", "perception", "sim", "data"},
    "detect": {"bingham", "rotation", "perception", "sim", "model"},
    "peers": {"bingham", "rotation", "perception", "sim", "objects", "data", "model", "detect"},
    "parallel": set(),
}
"""What each layer below the benchmark may import besides the root modules: the layers to its
left in docs/architecture.md's map, in the map's reading order."""

SYMGRASP_MODULE = re.compile(r"symgrasp(\.[A-Za-z_]\w*)+")
"""A symgrasp module's dotted name."""


def symgrasp_imports(path) -> set[str]:
    """The symgrasp modules or packages (``symgrasp.X``: X) that the file ``path`` imports,
    at module level or inside functions; in a file that imports by name
    (``importlib.import_module``, ``__import__``), every string naming a symgrasp module too,
    whether the call reads it directly or from a table."""
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    if any(_imports_by_name(node) for node in ast.walk(tree)):
        names.update(
            node.value
            for node in ast.walk(tree)
            if isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and SYMGRASP_MODULE.fullmatch(node.value)
        )
    return {name.split(".")[1] for name in names if name.startswith("symgrasp.")}


def _imports_by_name(node: ast.AST) -> bool:
    """Whether ``node`` calls ``import_module`` (``importlib.import_module`` or the name
    imported from it) or ``__import__``."""
    if not isinstance(node, ast.Call):
        return False
    function = node.func
    name = function.attr if isinstance(function, ast.Attribute) else getattr(function, "id", "")
    return name in ("import_module", "__import__")


def test_an_import_by_name_counts_as_an_import(tmp_path):
    """The strings of ``importlib`` imports are read, directly or from a table (the oracle:
    the statements spelled out)."""
    lazy = tmp_path / "lazy.py"
    lazy.write_text(
        "from importlib import import_module\n"
        "_LAZY = {'World': 'symgrasp.sim.world', 'make': 'symgrasp.objects.sets'}\n"
        "def get(name):\n    return import_module(_LAZY[name])\n"
    )
    direct = tmp_path / "direct.py"
    direct.write_text("import importlib\nsets = importlib.import_module('symgrasp.objects.sets')\n")
    dunder = tmp_path / "dunder.py"
    dunder.write_text("detect = __import__('symgrasp.detect')\n")
    spelled = tmp_path / "spelled.py"
    spelled.write_text("import symgrasp.sim.world\nfrom symgrasp.objects import sets\n")
    assert symgrasp_imports(lazy) == symgrasp_imports(spelled) == {"sim", "objects"}
    assert symgrasp_imports(direct) == {"objects"}
    assert symgrasp_imports(dunder) == {"detect"}
    words = tmp_path / "words.py"  # a module name in a file that imports none by name
    words.write_text("NOTE = 'symgrasp.benchmark'\n")
    assert symgrasp_imports(words) == set()


def test_no_layer_imports_one_above_it():
    """The import statements of every module, function-level ones included, and its imports by
    name, follow the map."""
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


ARCHITECTURE = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"

ARROW = "──>"


def _map_and_rows() -> tuple[list[str], dict[str, str]]:
    """docs/architecture.md's map (the lines of its first code block) and its table's rows
    by package (``symgrasp.X``: X, the row's text)."""
    text = ARCHITECTURE.read_text()
    picture = text.split("```")[1].splitlines()
    rows = {m[1]: m[2] for m in re.finditer(r"^\| `symgrasp\.(\w+)` \|(.*)$", text, re.M)}
    return picture, rows


def test_the_architecture_map_is_the_layer_test():
    """The map's layers, in reading order, are `LAYERS`' and each arrow between two of them one
    that `LAYERS` allows; the packages it puts on top are the table's others; its root modules
    are `ROOT_MODULES`."""
    picture, rows = _map_and_rows()
    order, top = [], []
    for line in picture:
        if "──" not in line:  # the ▲ ▼ lines and the root modules
            continue
        chain = []
        for segment in line.split(ARROW):
            words = re.findall(r"\w+", segment.split("(")[0])  # not the comment in brackets
            if "," in segment:
                top += words
            else:
                chain.append(words[0])
        order += chain
        for upstream, downstream in itertools.pairwise(chain):
            assert upstream in LAYERS[downstream], f"{upstream} {ARROW} {downstream}"
    assert order == list(LAYERS)
    assert sorted(top) == sorted(set(rows) - set(LAYERS))
    roots = " ".join(picture).split("root modules, read by every layer:")[1]
    assert sorted(re.findall(r"\w+", roots)) == sorted(ROOT_MODULES)


def test_the_architecture_table_names_every_package_and_module():
    """Every package of src/symgrasp has a row of docs/architecture.md's table, every row a
    package or module that exists; a package's row names each of its modules (`` `name` ``)
    and every module it names (`` `name` (what it holds) ``) exists."""
    import symgrasp

    root = Path(symgrasp.__file__).parent
    _, rows = _map_and_rows()
    packages = {p.parent.name for p in root.glob("*/__init__.py")}
    assert packages <= set(rows)
    assert [
        name for name in rows if not (root / name).is_dir() and not (root / f"{name}.py").exists()
    ] == []
    wrong = []
    for package in sorted(packages):
        folder, text = root / package, rows[package]
        modules = {p.stem for p in folder.glob("*.py")} - {"__init__", "__main__"}
        modules |= {p.parent.name for p in folder.glob("*/__init__.py")}
        named = set(re.findall(r"`(\w+)`", text))
        wrong += [f"{package} row does not name {m}" for m in sorted(modules - named)]
        wrong += [f"{package} row names {m}, which is not one of its modules"
                  for m in re.findall(r"`(\w+)` \(", text) if m not in modules]  # fmt: skip
    assert wrong == []


def test_inside_the_package_only_a_gripper_spec_travels():
    """A gripper's name is resolved once, where it comes in (`get_gripper`, `load_planner`): no
    signature takes a spec or a name."""
    import symgrasp

    root = Path(symgrasp.__file__).parent
    either = re.compile(r"GripperSpec \| str\b|\bstr \| GripperSpec")
    assert [
        str(p.relative_to(root)) for p in root.rglob("*.py") if either.search(p.read_text())
    ] == []


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
