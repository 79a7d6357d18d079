"""A detected grasp and the motion that executes it."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from symgrasp.sim.grippers import GripperSpec
from symgrasp.sim.protocol import LIFT_HEIGHT, PREGRASP_DISTANCE


def T_flange_tcp(gripper: GripperSpec) -> np.ndarray:
    """The TCP's pose (4, 4) in the wrist flange's frame of the hand ``gripper``: the TCP lies
    ``tcp_offset`` [m] ahead of the flange along e_x, the approach; the flange frame's axes are
    the grasp frame's [e_x approach, e_y, e_z closing] (a robot's flange frame usually has its z
    along the approach: docs/serve.md turns one into the other)."""
    return _T_flange_tcp(gripper.tcp_offset)


def _T_flange_tcp(tcp_offset: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = tcp_offset
    return T


@dataclass(frozen=True)
class Grasp:
    """One 6-DoF grasp proposed by a planner (`symgrasp.detect.planner`).

    Attributes:
        pose: ``T_world_tcp`` (4, 4), rotation [e_x approach, e_y, e_z closing axis]
            (docs/conventions.md); `GraspDetector` puts the TCP at the centre of its voxel.
        score: the planner's ranking score, higher is better (`GraspDetector`: predicted
            gravity-rejection score, label units ≈ [0, 1], docs/data.md; VGN: its quality).
        validity: `GraspDetector`: predicted probability that the voxel holds a valid grasp;
            None for planners without one.
        confidence: Bingham confidence (λ₃ − λ₂) + (λ₃ − λ₁) of the closing axis for the
            Bingham representations, None for the others.
        voxel: index ``(i, j, k)`` of the voxel in the 40³ grid it was read from, None for
            planners without a grid.
        fallback: 0 for the rotation the planner decoded; i ≥ 1 for the voxel's i-th fallback,
            another rotation of the same voxel tried after the approach of those before it was
            refused (`GraspDetector`'s ``fallbacks``: a draw of its Bingham distribution, or the
            yaw turned about e_x for a point estimate).
        opening_width: [m] how far the hand should open before its approach: twice the
            farthest distance along e_z from the TCP of what the object fills between the open
            fingers (its seen surface and what the TSDF holds behind it), plus a margin, capped
            at the hand's ``max_width``; ``max_width`` when nothing lies between them
            (`symgrasp.detect.width`). None where the planner did not measure it.
        object_width: [m] the extent along e_z of the object's seen surface between the open
            fingers, short of its width where a side was not seen (`symgrasp.detect.width`);
            None where none lies there or the planner did not measure it.
        tcp_offset: [m] the hand's ``tcp_offset`` (`GripperSpec`): how far the TCP lies ahead
            of the wrist flange along e_x, which `flange_pose` reads; None where the planner
            did not say.
        cut: the hand, approaching from the pre-grasp or closed, meets depth points above the
            workspace's top or past its sides, on an object the cube cuts
            (`GraspDetector`'s ``cut_objects="flag"``, `symgrasp.detect.limits`); False for a
            grasp not checked.
    """

    pose: np.ndarray
    score: float
    validity: float | None = None
    confidence: float | None = None
    voxel: tuple[int, int, int] | None = None
    fallback: int = 0
    opening_width: float | None = None
    object_width: float | None = None
    tcp_offset: float | None = None
    cut: bool = False

    @property
    def position(self) -> np.ndarray:
        """The TCP position (3,) [m]."""
        return self.pose[:3, 3]

    @property
    def approach(self) -> np.ndarray:
        """The approach axis e_x (3,)."""
        return self.pose[:3, 0]

    @property
    def closing_axis(self) -> np.ndarray:
        """The closing axis e_z (3,) (its sign is arbitrary: the gripper is symmetric)."""
        return self.pose[:3, 2]

    def flange_pose(self) -> np.ndarray:
        """``T_world_flange`` (4, 4): the wrist flange's pose, ``tcp_offset`` behind the TCP
        along e_x with the grasp frame's axes, where a robot's arm holds the hand. ValueError
        when the planner gave no ``tcp_offset`` (then ``pose @ inv(T_flange_tcp(gripper))``)."""
        if self.tcp_offset is None:
            raise ValueError(
                "this grasp has no tcp_offset (its planner did not give its hand's); "
                "T_world_flange = grasp.pose @ np.linalg.inv(T_flange_tcp(gripper))"
            )
        return self.pose @ np.linalg.inv(_T_flange_tcp(self.tcp_offset))

    def record(self) -> dict[str, Any]:
        """The grasp as plain JSON data (``grasps.json``, the grasp server's answers): the
        poses and widths to the µm, scores to 4 decimals, the confidence to 2; null where the
        planner did not give one."""
        return {
            "T_world_tcp": np.round(self.pose, 6).tolist(),
            "score": round(self.score, 4),
            "validity": None if self.validity is None else round(self.validity, 4),
            "confidence": None if self.confidence is None else round(self.confidence, 2),
            "voxel": None if self.voxel is None else list(self.voxel),
            "fallback": self.fallback,
            "opening_width": _micrometres(self.opening_width),
            "object_width": _micrometres(self.object_width),
            "T_world_flange": (
                None if self.tcp_offset is None else np.round(self.flange_pose(), 6).tolist()
            ),
            "cut": self.cut,
        }

    def transformed(self, T_frame_world: np.ndarray) -> Grasp:
        """The same grasp with its pose in another frame: ``T_frame_world @ pose``, e.g.
        ``T_base_workspace`` to take a grasp detected on a fitted table
        (`symgrasp.perception.fit_table`) to the robot's base (the flange pose follows). Scores,
        the voxel and the widths stay."""
        T = np.asarray(T_frame_world, dtype=float)
        if T.shape != (4, 4):
            raise ValueError(f"T_frame_world must be 4×4, got shape {T.shape}")
        return replace(self, pose=T @ self.pose)

    def approach_trajectory(
        self, pregrasp_distance: float = PREGRASP_DISTANCE, lift_height: float = LIFT_HEIGHT
    ) -> np.ndarray:
        """The paper's motion (Sec. 4.4), as ``T_world_tcp`` waypoints (3, 4, 4): the
        pre-grasp ``pregrasp_distance`` back along e_x, the grasp, and the lift
        ``lift_height`` up along world +z. Close the gripper between the 2nd and 3rd."""
        if pregrasp_distance < 0 or lift_height < 0:
            raise ValueError(
                "pregrasp_distance and lift_height must be ≥ 0 [m], "
                f"got {pregrasp_distance}, {lift_height}"
            )
        pregrasp, lift = self.pose.copy(), self.pose.copy()
        pregrasp[:3, 3] -= pregrasp_distance * self.approach
        lift[2, 3] += lift_height
        return np.stack([pregrasp, self.pose, lift])


def _micrometres(length: float | None) -> float | None:
    return None if length is None else round(length, 6)
