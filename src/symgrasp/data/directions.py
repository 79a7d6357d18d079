"""Fixed disturbance directions and the look-up of a score for any direction.

The gravity-rejection score of a grasp is measured for ``K`` near-uniform directions in the
object frame (a Fibonacci sphere); a scene asks for the score along its own gravity
direction, expressed in the object frame, and gets an interpolation of the nearest ones.
"""

from __future__ import annotations

import numpy as np


def fibonacci_directions(k: int) -> np.ndarray:
    """``k`` near-uniform unit vectors on S², (k, 3); the same ``k`` gives the same set."""
    if k < 4:
        raise ValueError(f"k must be at least 4 directions, got {k}")
    i = np.arange(k) + 0.5
    z = 1.0 - 2.0 * i / k
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z**2)
    return np.c_[r * np.cos(phi), r * np.sin(phi), z]


def interpolate(values: np.ndarray, directions: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Values (..., K) given at ``directions`` (K, 3), read at unit ``query`` (3,) → (...).

    Inverse-angle weighting of the three directions nearest to ``query``: exact at a stored
    direction, continuous in between.
    """
    nearest, angle = _nearest(directions, query)
    if len(nearest) == 1:
        return values[..., nearest[0]]
    w = 1.0 / angle
    return values[..., nearest] @ (w / w.sum())


def interpolation_support(directions: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Indices of the ``directions`` (K, 3) that `interpolate` reads at ``query`` (3,): the
    three nearest, or the one it lies on."""
    return _nearest(directions, query)[0]


def _nearest(directions: np.ndarray, query: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q = np.asarray(query, dtype=float)
    if q.shape != (3,) or np.linalg.norm(q) == 0:
        raise ValueError(f"query must be a non-zero 3-vector, got shape {q.shape}")
    q = q / np.linalg.norm(q)
    angle = np.arccos(np.clip(directions @ q, -1.0, 1.0))
    nearest = np.argsort(angle)[:3]
    if angle[nearest[0]] < 1e-9:
        nearest = nearest[:1]
    return nearest, angle[nearest]
