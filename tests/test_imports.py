"""What a robot-side user loads: detection without the simulator."""

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
