"""A planner defined outside the package, as a user writes one: grasp the highest point seen,
straight down, closing along world x (docs/benchmark.md, "Any planner")."""

import numpy as np

from symgrasp.detect import Grasp, Observation
from symgrasp.workspace import TABLE_HEIGHT


def top_down(observation: Observation) -> list[Grasp]:
    points = observation.points()  # what the cameras saw inside the workspace [m]
    points = points[points[:, 2] > TABLE_HEIGHT + 0.01]  # not the table
    if not len(points):
        return []
    top = points[np.argmax(points[:, 2])]
    pose = np.eye(4)
    pose[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # e_x down, e_z along world x
    pose[:3, 3] = top - (0, 0, 0.015)  # the TCP 1.5 cm below the top
    return [Grasp(pose, score=float(top[2]))]


not_a_planner = 42
"""What a name must not be: neither a function nor a planner."""
