"""Rotation representations for learning grasp detection, behind one interface.

``get(name)`` returns a `Representation` with ``name``, ``channels``, ``loss(pred, R_gt, mask)``,
``decode(pred)`` → `Decoded` (rotation, confidence) and, for the distributions, ``sample``:

=================  ========  ============================================================
name               channels  what it is
=================  ========  ============================================================
``bingham2d``      9         Ko et al. (2024): 2D Bingham over e_z + approach vector e_x
``rotmat6d``       6         Zhou et al. (2019) e_x, e_z; loss minimised over the flip
``rotmat6d_naive`` 6         the same without the flip minimum (ablation)
``quaternion``     4         VGN's (x, y, z, w); loss minimised over the flip
``bingham3d``      10        Sato et al. (2023): Bingham on S³ over quaternions
=================  ========  ============================================================

Rotations are grasp frames R = [e_x e_y e_z] (approach, e_z × e_x, closing axis) and a grasp is
the same as its flip R·diag(1, −1, −1); see ``docs/conventions.md`` and ``docs/rotation.md``.
"""

from symgrasp.names import REPRESENTATIONS
from symgrasp.rotation.base import Decoded, Representation
from symgrasp.rotation.bingham2d import PAPER_CONFIDENCE_THRESHOLD, Bingham2D
from symgrasp.rotation.bingham3d import Bingham3D
from symgrasp.rotation.geometry import (
    flip,
    flip_quaternion,
    gram_schmidt,
    matrix_to_quaternion,
    quaternion_to_matrix,
)
from symgrasp.rotation.quaternion import Quaternion
from symgrasp.rotation.rotmat6d import RotMat6D, RotMat6DNaive

_REPRESENTATIONS: dict[str, Representation] = {
    r.name: r for r in (Bingham2D(), RotMat6D(), RotMat6DNaive(), Quaternion(), Bingham3D())
}

NAMES = REPRESENTATIONS
"""The names `get` knows (`symgrasp.names.REPRESENTATIONS`)."""


def get(name: str) -> Representation:
    """The representation called ``name`` (one of `NAMES`)."""
    try:
        return _REPRESENTATIONS[name]
    except KeyError:
        raise ValueError(
            f"unknown rotation representation {name!r}; known: {', '.join(NAMES)}"
        ) from None


__all__ = [
    "NAMES",
    "PAPER_CONFIDENCE_THRESHOLD",
    "Bingham2D",
    "Bingham3D",
    "Decoded",
    "Quaternion",
    "Representation",
    "RotMat6D",
    "RotMat6DNaive",
    "flip",
    "flip_quaternion",
    "get",
    "gram_schmidt",
    "matrix_to_quaternion",
    "quaternion_to_matrix",
]
