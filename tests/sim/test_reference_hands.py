"""The code-built hands against MuJoCo Menagerie's reference models (benchmarks/hands.py): every
row of the comparison that has a tolerance holds it. Runs where the tests' shared data holds the
reference models (conftest's `menagerie`; CI has them); the package itself never loads them."""

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
hands = pytest.importorskip("hands")


@pytest.fixture(scope="module", params=list(hands.HANDS))
def measured(request, menagerie):
    name = request.param
    spec = hands.HANDS[name]
    ours = hands.measure(lambda bodies: hands.ours(spec, bodies), quick=False)
    reference = hands.measure(lambda bodies: hands.reference(name, menagerie, bodies), quick=False)
    return name, ours, reference


@pytest.mark.parametrize("row", [r for r in hands.ROWS if r[2] != "info"], ids=lambda r: r[0])
def test_within_tolerance_of_the_reference(measured, row):
    name, ours, reference = measured
    label, read, kind = row
    if kind == "parallel" and name == "franka":
        pytest.skip("rigid fingers have no pad hinge")
    assert hands.verdict(kind, name, read(ours), read(reference)) == "yes", (
        f"{name}: {label}: symgrasp {read(ours)}, Menagerie {read(reference)}"
    )


def test_the_probes_see_what_they_probe(menagerie):
    """Oracles for the probes themselves: the reference 2F-85 opens 85 mm (its datasheet), its
    pads stay parallel in a pinch and wrap in a power grasp; a rigid jaw's pads do not move
    along the approach axis."""
    build = lambda bodies: hands.reference("robotiq-2f85", menagerie, bodies)  # noqa: E731
    geometry = hands.geometry(build)
    assert geometry["opening_mm"] == pytest.approx(85, abs=1)
    pinch = hands.pull_out(build, geometry["tip_x_mm"] / 1e3 - 0.005)
    power = hands.pull_out(build, geometry["palm_face_x_mm"] / 1e3 + 0.022)
    assert pinch["tilt_deg"] < 2 < 20 < power["tilt_deg"]
    path = hands.settled_path(lambda bodies: hands.ours(hands.HANDS["franka"], bodies))
    assert path == []  # a motor-driven jaw cannot be held part-way: nothing to compare
