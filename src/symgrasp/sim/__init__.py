"""The MuJoCo simulation world: procedural objects, the two grippers, scenes, grasp trials."""

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
