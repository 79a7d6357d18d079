"""The workspace: the cube a detector sees, its voxel grid and the table inside it.

World frame = workspace frame (``docs/conventions.md``): the workspace is the cube
``[0, WORKSPACE_SIZE]³`` m cut into ``RESOLUTION³`` voxels (the detector's 40³ TSDF), and the
table top is the plane ``z = TABLE_HEIGHT`` inside it, so the volume sees the table as VGN's
does. Every trained model has seen this geometry and no other. This module imports nothing:
perception and detection read it without loading the simulator.
"""

WORKSPACE_SIZE = 0.30
"""Edge of the cubic workspace [m]."""

RESOLUTION = 40
"""Voxels per workspace edge (the network's input grid)."""

VOXEL_SIZE = WORKSPACE_SIZE / RESOLUTION
"""Edge of one voxel [m] (7.5 mm)."""

TABLE_HEIGHT = 0.05
"""Height of the table top above the workspace floor [m]."""
