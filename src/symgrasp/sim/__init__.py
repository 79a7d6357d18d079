"""The MuJoCo simulation world: procedural objects, the two grippers, scenes, grasp trials."""

import os

# MuJoCo picks its OpenGL backend when it is first imported; on a headless machine EGL is
# the one that can work. An explicit MUJOCO_GL in the environment wins.
os.environ.setdefault("MUJOCO_GL", "egl")

from symgrasp.sim.execute import GraspResult, Outcome, execute_grasp
from symgrasp.sim.grippers import FRANKA, GRIPPERS, ROBOTIQ_2F85, GripperSpec, get_gripper
from symgrasp.sim.objects import OBJECT_SETS, ObjectSpec, Part, large_box, object_set
from symgrasp.sim.world import TABLE_HEIGHT, WORKSPACE_SIZE, World, make_scene

__all__ = [
    "FRANKA",
    "GRIPPERS",
    "OBJECT_SETS",
    "ROBOTIQ_2F85",
    "TABLE_HEIGHT",
    "WORKSPACE_SIZE",
    "GraspResult",
    "GripperSpec",
    "ObjectSpec",
    "Outcome",
    "Part",
    "World",
    "execute_grasp",
    "get_gripper",
    "large_box",
    "make_scene",
    "object_set",
]
