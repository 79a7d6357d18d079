"""The grasp protocol's geometry, shared by the simulated trials and a robot's trajectory.

A grasp is approached along a straight line from a pre-grasp ``PREGRASP_DISTANCE`` back along
its approach axis ``e_x``, closed, and lifted ``LIFT_HEIGHT`` along world +z
(`symgrasp.sim.execute.execute_grasp`, `symgrasp.detect.Grasp.approach_trajectory`).
"""

PREGRASP_DISTANCE = 0.10
"""Pre-grasp offset back along the approach axis [m]."""

LIFT_HEIGHT = 0.30
"""Lift along world +z [m]."""
