"""The MuJoCo simulation world: procedural objects, grippers from spec files, scenes, grasp trials.

The gripper specs (`grippers`), contact settings (`physics`) and the grasp protocol
(`protocol`) are plain data that perception and detection read on a robot, so this package
loads MuJoCo (and trimesh) only when one of the simulator's names below is first used.
"""

from importlib import import_module
from typing import Any

from symgrasp.sim.grippers import FRANKA, ROBOTIQ_2F85, GripperSpec, get_gripper, load_gripper

_LAZY = {
    "GraspResult": "symgrasp.sim.execute",
    "Outcome": "symgrasp.sim.execute",
    "execute_grasp": "symgrasp.sim.execute",
    "ObjectSpec": "symgrasp.sim.objects",
    "Part": "symgrasp.sim.objects",
    "large_box": "symgrasp.sim.objects",
    "object_set": "symgrasp.sim.objects",
    "World": "symgrasp.sim.world",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'symgrasp.sim' has no attribute {name!r}")


__all__ = [
    "FRANKA",
    "ROBOTIQ_2F85",
    "GripperSpec",
    "get_gripper",
    "load_gripper",
    *_LAZY,
]
