"""The names a user can pass, defined without importing what they name.

The command line offers them as choices before any heavy module loads (``symgrasp --help``
answers without torch or MuJoCo); each package resolves a name once, at the edge
(`symgrasp.rotation.get`, `symgrasp.sim.get_gripper`, `symgrasp.sim.object_set`, …), and
implements exactly these (tests check it).
"""

REPRESENTATIONS = ("bingham2d", "rotmat6d", "rotmat6d_naive", "quaternion", "bingham3d")
"""Rotation representations (`symgrasp.rotation`)."""

GRIPPERS = ("franka", "robotiq-2f85")
"""Built-in grippers (`symgrasp.sim.grippers`)."""

OBJECT_SETS = ("household-train", "household-test", "large-box", "blocks")
"""Named object sets (`symgrasp.sim.objects`)."""

SCENES = ("pile", "packed")
"""Scene kinds (`symgrasp.sim.world`)."""

PRETRAINED = ("bingham2d-robotiq-2f85", "bingham2d-franka")
"""Models shipped with the package (`symgrasp.detect.pretrained`)."""
