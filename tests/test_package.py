"""Package-wide properties: what a robot-side user loads, how files are written."""

import subprocess
import sys


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
