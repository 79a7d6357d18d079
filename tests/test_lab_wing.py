"""The library and its tests stand without the lab: no file under tests/ names the lab's folder
(the lab's tests live in it, experiments/tests), and the installed package holds no lab helper
(the scripts' helper and the bad-input tables live outside src/)."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAB = "experiments"


def test_no_library_test_names_the_lab():
    naming = [
        str(path.relative_to(ROOT))
        for path in (ROOT / "tests").rglob("*")
        if path.is_file() and path != Path(__file__) and "__pycache__" not in path.parts
        and LAB in path.read_text(errors="replace")
    ]  # fmt: skip
    assert naming == []


def test_the_package_holds_no_lab_helper():
    package = ROOT / "src" / "symgrasp"
    assert (package / "__init__.py").is_file()  # the package is where this test looks
    assert not (package / "scripts.py").exists()
    assert not (package / "bad_input.py").exists()
