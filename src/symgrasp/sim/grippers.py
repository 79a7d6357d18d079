"""The parallel grippers: a `GripperSpec` per hand, and its MuJoCo model built from primitives.

Each hand is a free body whose frame *is* the grasp frame (conventions.md): origin at the
TCP (centre between the open finger pads), ``x`` = approach ``e_x``, ``z`` = closing axis
``e_z``, ``y = z × x``. A mocap body welded to it moves it along any SE(3) trajectory. All
hand geoms sit in :data:`~symgrasp.sim.physics.HAND_GROUP`; hand bodies are gravity
compensated, as an arm would hold them.

Actuation: ``ctrl = +close_ctrl`` on every hand actuator closes, ``-close_ctrl`` opens.

A spec is resolved from a name once, at the edge (`get_gripper`), and carries its own MJCF
(`GripperSpec.hand_xml`) by its ``kind``; its collision boxes for the swept-hand check are
read from that model (`symgrasp.sim.collision.hand_boxes`). This module imports no simulator.
Two kinds are built:

- ``rigid``, the Franka hand (``franka``) — a parallel jaw: two slide joints coupled by an equality (one rack and
  pinion), each pushed by a 70 N motor; max opening 80 mm, 17 × 20 mm pads at the fingertips.
- ``robotiq``, the Robotiq 2F-85 (``robotiq-2f85``) — underactuated two-phalanx fingers, 85 mm max opening, 22 mm wide. Per
  finger: a proximal link on a hinge at the palm; a "parallel-keeping" hinge at its tip,
  tied by an equality to minus the proximal angle, so the pad keeps its orientation (the
  four-bar of the real hand); and a "curl" hinge carrying the pad, held against a stop by a
  pre-loaded spring. One velocity-integrating actuator drives the tendon
  ``proximal + 0.3 · curl``: in free motion its force is small and the spring keeps the pads
  parallel (pinch); when the proximal link is blocked the force grows and the excess curls
  the pad around the object (power grasp). A pad pinching at its tip is pushed against the
  stop and stays parallel.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from symgrasp.names import GRIPPERS
from symgrasp.sim.physics import WELD_SOLREF

PREFIX = "hand_"
"""Name prefix of every hand element; the world finds bodies, joints and actuators by it."""


@dataclass(frozen=True)
class HandXml:
    """MJCF fragments of a hand, to be placed into the world's sections."""

    worldbody: str
    tendon: str
    equality: str
    actuator: str
    contact: str = ""


@dataclass(frozen=True)
class GripperSpec:
    """Dimensions [m] and control conventions of a parallel gripper.

    ``kind``: how the hand is built, ``"rigid"`` (two slide fingers, as the Franka hand) or
    ``"robotiq"`` (the 2F-85's underactuated linkage); ``max_width``: opening between the
    pads; ``finger_depth``: from the palm face to the fingertips (how deep an object can
    enter); ``tcp_offset``: from the wrist flange to the TCP along ``e_x``; ``finger_width``:
    pad extent along ``e_y``; ``tip_beyond_tcp``: how far the fingertips reach past the TCP
    along ``e_x``; ``palm_half``: half-extents of the palm box along ``e_x, e_y, e_z``;
    ``grip_force`` [N] nominal squeeze; ``close_ctrl``: actuator command that closes;
    ``close_time`` [s]: how long closing takes.
    """

    name: str
    kind: Literal["rigid", "robotiq"]
    max_width: float
    finger_depth: float
    tcp_offset: float
    finger_width: float
    tip_beyond_tcp: float
    palm_half: tuple[float, float, float]
    grip_force: float
    close_ctrl: float
    close_time: float
    approach_axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    closing_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def hand_xml(self) -> HandXml:
        """The MJCF fragments of this hand."""
        return _BUILDERS[self.kind](self)

    def open_joint_positions(self) -> dict[str, float]:
        """Finger joint positions [m or rad] of the fully open hand, by joint name."""
        if self.kind == "rigid":
            return {f"{PREFIX}slide_{s}": self.max_width / 2 for s in ("left", "right")}
        joints = ("proximal", "keep", "curl")
        return {f"{PREFIX}{j}_{s}": 0.0 for j in joints for s in ("left", "right")}


FRANKA = GripperSpec(
    name="franka",
    kind="rigid",
    max_width=0.08,
    finger_depth=0.046,
    tcp_offset=0.1034,
    finger_width=0.02,
    tip_beyond_tcp=0.009,
    palm_half=(0.029, 0.03, 0.1),
    grip_force=70.0,
    close_ctrl=1.0,
    close_time=0.2,
)

# Robotiq geometry: proximal link length, pivot offset from the centre plane, pad length,
# and how far the pad face stands inward of the link (so pads, not links, pinch).
_R_LINK, _R_PIVOT, _R_PAD, _R_INSET = 0.05, 0.0125, 0.035, 0.006
_R_PALM_AHEAD = 0.006  # the palm face stands this far past the proximal pivots, as the 2F-85's base
_R_OPEN = float(np.arcsin((0.0425 + _R_INSET - _R_PIVOT) / _R_LINK))  # link angle, fully open
_R_CLOSED = float(np.arcsin((_R_INSET - _R_PIVOT) / _R_LINK))  # pads touching
_R_PIVOT_X = -(_R_LINK * np.cos(_R_OPEN) + _R_PAD / 2)  # puts the open pad centre at the TCP
_R_CURL_RATIO = 0.3  # tendon = proximal + ratio · curl
_R_LEVER = 0.06  # distance from the proximal pivot to the pad centre along e_x [m]

ROBOTIQ_2F85 = GripperSpec(
    name="robotiq-2f85",
    kind="robotiq",
    max_width=0.085,
    finger_depth=float(_R_PAD / 2 - _R_PIVOT_X - _R_PALM_AHEAD),
    tcp_offset=0.145,
    finger_width=0.022,
    tip_beyond_tcp=_R_PAD / 2,
    palm_half=(0.035, 0.035, 0.05),
    grip_force=60.0,
    close_ctrl=2.5,
    close_time=0.6,
)


_SPECS = {spec.name: spec for spec in (FRANKA, ROBOTIQ_2F85)}


def get_gripper(gripper: GripperSpec | str) -> GripperSpec:
    """The spec of ``gripper``: a spec as it is, or the built-in one of that name (one of
    `symgrasp.names.GRIPPERS`). Call it once, where a name comes in."""
    if isinstance(gripper, GripperSpec):
        return gripper
    if gripper not in _SPECS:
        raise ValueError(f"gripper must be one of {', '.join(GRIPPERS)}, got {gripper!r}")
    return _SPECS[gripper]


def _quat_y(angle: float) -> str:
    return f"{np.cos(angle / 2):.6f} 0 {np.sin(angle / 2):.6f} 0"


def _hand_root(palm_half: tuple[float, float, float], palm_x: float, fingers: str) -> str:
    """A free, gravity-compensated hand body with its palm, and its mocap target."""
    half = " ".join(f"{h:.4f}" for h in palm_half)
    return f"""
    <body name="{PREFIX}target" mocap="true" pos="0 0 1"/>
    <body name="{PREFIX}base" pos="0 0 1" gravcomp="1">
      <freejoint name="{PREFIX}free"/>
      <geom name="{PREFIX}palm" class="hand" type="box" size="{half}" pos="{palm_x:.4f} 0 0"
            mass="0.7"/>
      {fingers}
    </body>"""


def _weld() -> str:
    return f'<weld body1="{PREFIX}target" body2="{PREFIX}base" solref="{WELD_SOLREF}"/>'


# Franka finger: a pad at the fingertip, the finger behind it set back from the pad's face
# (as the real finger and MuJoCo Menagerie's model: a 17 mm pad, the finger 7-15 mm back).
_F_PAD, _F_SETBACK, _F_THICK = 0.017, 0.007, 0.005


def _rigid_finger(spec: GripperSpec, side: str, sign: int) -> str:
    pad_x = spec.tip_beyond_tcp - _F_PAD / 2
    body_half = (spec.finger_depth - _F_PAD) / 2
    body_x = spec.tip_beyond_tcp - _F_PAD - body_half
    return f"""
      <body name="{PREFIX}finger_{side}" gravcomp="1">
        <joint name="{PREFIX}slide_{side}" type="slide" axis="0 0 {sign}"
               range="0 {spec.max_width / 2}" damping="300" armature="0.5"/>
        <geom name="{PREFIX}pad_{side}" class="finger" type="box" mass="0.01"
              size="{_F_PAD / 2:.4f} {spec.finger_width / 2} {_F_THICK}"
              pos="{pad_x:.4f} 0 {sign * _F_THICK}"/>
        <geom name="{PREFIX}finger_{side}" class="finger" type="box" mass="0.01"
              size="{body_half:.4f} {spec.finger_width / 2} {_F_THICK}"
              pos="{body_x:.4f} 0 {sign * (_F_THICK + _F_SETBACK)}"/>
      </body>"""


def _rigid_xml(spec: GripperSpec) -> HandXml:
    """A rigid parallel jaw (the Franka hand: 0.2 m palm along the closing axis, two 70 N
    slide fingers): the palm's face is at the fingers' root."""
    palm_x = spec.tip_beyond_tcp - spec.finger_depth - spec.palm_half[0]
    fingers = _rigid_finger(spec, "left", 1) + _rigid_finger(spec, "right", -1)
    motors = "".join(
        f'<motor name="{PREFIX}drive_{side}" joint="{PREFIX}slide_{side}" '
        f'gear="{-spec.grip_force}" ctrlrange="-1 1"/>'
        for side in ("left", "right")
    )
    equality = _weld() + (
        f'<joint joint1="{PREFIX}slide_right" joint2="{PREFIX}slide_left" polycoef="0 1 0 0 0"/>'
    )
    return HandXml(_hand_root(spec.palm_half, palm_x, fingers), "", equality, motors)


def _robotiq_finger(spec: GripperSpec, side: str, sign: int) -> str:
    thick = 0.004
    return f"""
      <body name="{PREFIX}proximal_{side}" pos="{_R_PIVOT_X:.5f} 0 {sign * _R_PIVOT}"
            quat="{_quat_y(-sign * _R_OPEN)}" gravcomp="1">
        <joint name="{PREFIX}proximal_{side}" axis="0 {sign} 0"
               range="0 {_R_OPEN - _R_CLOSED:.4f}" damping="0.01" armature="0.01"/>
        <geom name="{PREFIX}link_{side}" class="finger" type="box" mass="0.02"
              size="{_R_LINK / 2} {spec.finger_width / 2} {thick}"
              pos="{_R_LINK / 2} 0 {sign * thick}"/>
        <body name="{PREFIX}keep_{side}" pos="{_R_LINK} 0 0" quat="{_quat_y(sign * _R_OPEN)}"
              gravcomp="1">
          <joint name="{PREFIX}keep_{side}" axis="0 {sign} 0" armature="0.002"/>
          <geom class="finger" type="sphere" size="0.002" mass="0.002" contype="0"
                conaffinity="0"/>
          <body name="{PREFIX}distal_{side}" gravcomp="1">
            <joint name="{PREFIX}curl_{side}" axis="0 {sign} 0" range="0 1.3" stiffness="0.5"
                   springref="-1.0" damping="0.3" armature="0.002"/>
            <geom name="{PREFIX}pad_{side}" class="finger" type="box" mass="0.02"
                  size="{_R_PAD / 2} {spec.finger_width / 2} 0.003"
                  pos="{_R_PAD / 2} 0 {sign * (0.003 - _R_INSET)}"/>
          </body>
        </body>
      </body>"""


def _robotiq_xml(spec: GripperSpec) -> HandXml:
    """The Robotiq 2F-85 with passive compliance (see the module docstring)."""
    palm_x = _R_PIVOT_X + _R_PALM_AHEAD - spec.palm_half[0]
    fingers = _robotiq_finger(spec, "left", 1) + _robotiq_finger(spec, "right", -1)
    sides = ("left", "right")
    tendon = "".join(
        f'<fixed name="{PREFIX}drive_{s}"><joint joint="{PREFIX}proximal_{s}" coef="1"/>'
        f'<joint joint="{PREFIX}curl_{s}" coef="{_R_CURL_RATIO}"/></fixed>'
        for s in sides
    )
    # Integrating actuator: ctrl is the speed of the set-point, so the squeeze only builds
    # up once the finger is blocked (this is what lets the spring keep the pads parallel).
    kp, torque = 30.0, spec.grip_force * _R_LEVER
    actuator = "".join(
        f'<general name="{PREFIX}drive_{s}" tendon="{PREFIX}drive_{s}" dyntype="integrator" '
        f'gainprm="{kp}" biastype="affine" biasprm="0 {-kp} -0.3" actlimited="true" '
        f'actrange="0 1.3" ctrlrange="{-spec.close_ctrl} {spec.close_ctrl}" '
        f'forcelimited="true" forcerange="{-torque} {torque}"/>'
        for s in sides
    )
    equality = _weld() + "".join(
        f'<joint joint1="{PREFIX}keep_{s}" joint2="{PREFIX}proximal_{s}" polycoef="0 -1 0 0 0"/>'
        for s in sides
    )
    equality += (
        f'<joint joint1="{PREFIX}proximal_right" joint2="{PREFIX}proximal_left" '
        f'polycoef="0 1 0 0 0"/>'
    )
    # the pad overlaps its own proximal link at the joint, as the real hinge does
    exclude = "".join(
        f'<exclude body1="{PREFIX}proximal_{s}" body2="{PREFIX}distal_{s}"/>' for s in sides
    )
    root = _hand_root(spec.palm_half, palm_x, fingers)
    return HandXml(root, tendon, equality, actuator, exclude)


_BUILDERS = {"rigid": _rigid_xml, "robotiq": _robotiq_xml}
