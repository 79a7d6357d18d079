"""The parallel grippers: a `GripperSpec` per hand, read from a small TOML file, and its MuJoCo
model built from primitives.

Each hand is a free body whose frame *is* the grasp frame (conventions.md): origin at the
TCP (centre between the open finger pads), ``x`` = approach ``e_x``, ``z`` = closing axis
``e_z``, ``y = z × x``. A mocap body welded to it moves it along any SE(3) trajectory. All
hand geoms sit in :data:`~symgrasp.sim.physics.HAND_GROUP`; hand bodies are gravity
compensated, as an arm would hold them.

Actuation: ``ctrl = +close_ctrl`` on every hand actuator closes, ``-close_ctrl`` opens.

A spec file holds the hand's dimensions [m], force [N] and closing time [s] at its top level
and its fingers' mechanism in a ``[fingers]`` table whose keys depend on ``kind``
(docs/sim.md, "Your own gripper", documents every key). The built-in hands are such files,
shipped in ``gripper_specs/``. A spec is resolved from a name, a file or a stored record once,
at the edge (`get_gripper`), is checked whole when it is made (a `ValueError` names the file
and the key), and carries its own MJCF (`GripperSpec.hand_xml`); its collision boxes for the
swept-hand check are read from that model (`symgrasp.sim.collision.hand_boxes`). This module
imports no simulator. Two kinds are built:

- ``rigid`` (the Franka hand, ``franka``) — a parallel jaw: two slide joints coupled by an
  equality (one rack and pinion), each pushed by a ``grip_force`` motor; each finger is a pad
  at the fingertip and, behind it down to the palm face, a box set back from the pad's face.
- ``underactuated`` (the Robotiq 2F-85, ``robotiq-2f85``) — two-phalanx fingers. Per finger:
  a proximal link on a hinge at the palm; a "parallel-keeping" hinge at its tip, tied by an
  equality to minus the proximal angle, so the pad keeps its orientation (the four-bar of the
  real hand); and a "curl" hinge carrying the pad, held against a stop by a pre-loaded
  spring. One velocity-integrating actuator drives the tendon ``proximal + curl_ratio ·
  curl``: in free motion its force is small and the spring keeps the pads parallel (pinch);
  when the proximal link is blocked the force grows and the excess curls the pad around the
  object (power grasp). A pad pinching at its tip is pushed against the stop and stays
  parallel.
"""

from __future__ import annotations

import difflib
import re
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from symgrasp.fields import field_docs
from symgrasp.names import GRIPPER_SPEC_SUFFIX, GRIPPERS
from symgrasp.sim.physics import WELD_SOLREF

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - the same parser, as a package
    import tomli as tomllib

PREFIX = "hand_"
"""Name prefix of every hand element; the world finds bodies, joints and actuators by it."""

SPEC_FOLDER = Path(__file__).with_name("gripper_specs")
"""The built-in hands' spec files, ``<name>.toml`` for each name of `symgrasp.names.GRIPPERS`."""

NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
"""A gripper's name: it appears in file names (grasp database caches), so no spaces or slashes."""


def _number(unit: str, high: float, low: float = 0.0, strict: bool = True) -> Any:
    """A numeric field of a spec: in [low, high] ((low, high] where ``strict``), in ``unit``
    ("" for a ratio)."""
    return field(metadata={"unit": unit, "low": low, "high": high, "strict": strict})


LENGTH = 1.0
"""Largest length a spec may give [m]: anything longer is a hand outside a 0.3 m workspace
(or millimetres written where metres are meant)."""


def _check_numbers(obj: Any, prefix: str = "") -> None:
    """Check every `_number` field of the dataclass ``obj`` (stored as float), naming the key
    as the file writes it (``prefix`` + field name)."""
    for f in fields(obj):
        if "unit" not in f.metadata:
            continue
        value, m = getattr(obj, f.name), f.metadata
        key, unit = prefix + f.name, m["unit"]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{key} must be a number{f' [{unit}]' if unit else ''}, got {value!r}")
        above = value > m["low"] if m["strict"] else value >= m["low"]
        if not (above and value <= m["high"]):  # NaN fails too
            bracket = "(" if m["strict"] else "["
            raise ValueError(
                f"{key} must be in {bracket}{m['low']:g}, {m['high']:g}]{f' {unit}' if unit else ''}"
                f", got {value!r}"
            )
        object.__setattr__(obj, f.name, float(value))


def _quat_y(angle: float) -> str:
    return f"{np.cos(angle / 2):.6f} 0 {np.sin(angle / 2):.6f} 0"


@dataclass(frozen=True)
class RigidFingers:
    """The ``[fingers]`` table of a ``rigid`` hand: two slide fingers, each a pad at the
    fingertip and, behind it down to the palm face, a box set back from the pad's face (the
    Franka hand's finger touches with its fingertip pad only)."""

    kind: ClassVar[str] = "rigid"

    depth: float = _number("m", LENGTH)
    """From the palm face to the fingertips along e_x: how deep an object can enter [m]."""
    tip_beyond_tcp: float = _number("m", LENGTH, strict=False)
    """How far the fingertips reach past the TCP along e_x [m]."""
    pad_length: float = _number("m", LENGTH)
    """Pad extent along e_x, from the fingertip; equal to depth for a finger that is all pad
    [m]."""
    setback: float = _number("m", LENGTH, strict=False)
    """How far the finger behind the pad stands back from the pad's face along e_z; 0 for a
    flush finger [m]."""

    def __post_init__(self) -> None:
        _check_numbers(self, "fingers.")
        if self.tip_beyond_tcp >= self.depth:
            raise ValueError(
                f"fingers.tip_beyond_tcp ({self.tip_beyond_tcp:g} m) must be less than "
                f"fingers.depth ({self.depth:g} m): the TCP lies between the pads"
            )
        if self.pad_length > self.depth:
            raise ValueError(
                f"fingers.pad_length ({self.pad_length:g} m) must be at most fingers.depth "
                f"({self.depth:g} m): the pad is part of the finger"
            )

    def check(self, spec: GripperSpec) -> None:
        """Checks that need the whole spec (none for rigid fingers)."""

    def finger_depth(self, spec: GripperSpec) -> float:
        return self.depth

    def tip_beyond_tcp_of(self, spec: GripperSpec) -> float:
        return self.tip_beyond_tcp

    def close_ctrl(self) -> float:
        return 1.0  # the motors' ctrlrange is ±1: full force

    def open_joint_positions(self, spec: GripperSpec) -> dict[str, float]:
        return {f"{PREFIX}slide_{s}": spec.max_width / 2 for s in ("left", "right")}

    def hand_xml(self, spec: GripperSpec) -> HandXml:
        """Two slide fingers, each pushed by a ``grip_force`` motor and coupled by an equality:
        the palm's face is at the fingers' root."""
        palm_x = self.tip_beyond_tcp - self.depth - spec.palm_half[0]
        fingers = self._finger(spec, "left", 1) + self._finger(spec, "right", -1)
        motors = "".join(
            f'<motor name="{PREFIX}drive_{side}" joint="{PREFIX}slide_{side}" '
            f'gear="{-spec.grip_force}" ctrlrange="-1 1"/>'
            for side in ("left", "right")
        )
        equality = _weld() + (
            f'<joint joint1="{PREFIX}slide_right" joint2="{PREFIX}slide_left" '
            f'polycoef="0 1 0 0 0"/>'
        )
        return HandXml(_hand_root(spec.palm_half, palm_x, fingers), "", equality, motors)

    def _finger(self, spec: GripperSpec, side: str, sign: int) -> str:
        half_thick, half_width = spec.pad_thickness / 2, spec.pad_width / 2
        pad_half = self.pad_length / 2
        rest_half = (self.depth - self.pad_length) / 2
        mass = 0.01 if rest_half > 0 else 0.02  # 20 g a finger
        rest = (
            f"""
        <geom name="{PREFIX}finger_{side}" class="finger" type="box" mass="0.01"
              size="{rest_half:.4f} {half_width} {half_thick}"
              pos="{self.tip_beyond_tcp - self.pad_length - rest_half:.4f} 0 {sign * (half_thick + self.setback):.4f}"/>"""
            if rest_half > 0
            else ""
        )
        return f"""
      <body name="{PREFIX}finger_{side}" gravcomp="1">
        <joint name="{PREFIX}slide_{side}" type="slide" axis="0 0 {sign}"
               range="0 {spec.max_width / 2}" damping="300" armature="0.5"/>
        <geom name="{PREFIX}pad_{side}" class="finger" type="box" mass="{mass}"
              size="{pad_half:.4f} {half_width} {half_thick}"
              pos="{self.tip_beyond_tcp - pad_half:.4f} 0 {sign * half_thick}"/>{rest}
      </body>"""


@dataclass(frozen=True)
class LinkageFingers:
    """The ``[fingers]`` table of an ``underactuated`` hand: per finger a proximal link on a
    palm pivot, a parallel-keeping hinge and a spring-loaded curl hinge carrying the pad (the
    module docstring tells how they move)."""

    kind: ClassVar[str] = "underactuated"

    pad_length: float = _number("m", LENGTH)
    """Pad extent along e_x; the TCP is at the open pads' centre [m]."""
    link_length: float = _number("m", LENGTH)
    """Proximal link, from its pivot at the palm to the pad's hinge [m]."""
    link_thickness: float = _number("m", LENGTH)
    """Proximal link extent along e_z [m]."""
    pivot_offset: float = _number("m", LENGTH, strict=False)
    """Distance of the proximal pivots from the hand's centre plane along e_z [m]."""
    pad_inset: float = _number("m", LENGTH, strict=False)
    """How far a pad face stands inward of its link, so that pads, not links, pinch [m]."""
    curl_ratio: float = _number("", 10.0)
    """The drive tendon is proximal angle + curl_ratio · curl angle (no unit)."""
    lever: float = _number("m", LENGTH)
    """From the proximal pivot to the pad centre along e_x: grip_force · lever is the drive's
    torque limit [m]."""
    closing_speed: float = _number("rad/s", 100.0)
    """Speed of the drive's set-point while closing (the actuator command that closes)
    [rad/s]."""
    palm_ahead: float = _number("m", LENGTH, strict=False)
    """How far the palm face stands past the proximal pivots along e_x (the 2F-85's base
    does); 0 puts it at the pivots [m]."""

    def __post_init__(self) -> None:
        _check_numbers(self, "fingers.")

    def _sine(self, width: float) -> float:
        """sin of the link angle that puts the pad faces ``width`` apart."""
        return (width / 2 + self.pad_inset - self.pivot_offset) / self.link_length

    def check(self, spec: GripperSpec) -> None:
        """The links must reach: open to ``max_width`` and closed until the pads touch."""
        if self._sine(spec.max_width) >= 1:
            need = spec.max_width / 2 + self.pad_inset - self.pivot_offset
            raise ValueError(
                f"fingers.link_length ({self.link_length:g} m) cannot open the pads to "
                f"max_width ({spec.max_width:g} m): it must be longer than max_width / 2 + "
                f"pad_inset − pivot_offset = {need:g} m"
            )
        if self._sine(0.0) <= -1:
            raise ValueError(
                f"fingers.pivot_offset ({self.pivot_offset:g} m) is more than link_length "
                f"({self.link_length:g} m) beyond pad_inset: the pads could never touch"
            )

    def _angles(self, spec: GripperSpec) -> tuple[float, float, float]:
        """The link angle open and closed (pads touching), and the pivots' x in the TCP frame
        (it puts the open pad centre at the TCP)."""
        opened = float(np.arcsin(self._sine(spec.max_width)))
        closed = float(np.arcsin(self._sine(0.0)))
        pivot_x = -(self.link_length * np.cos(opened) + self.pad_length / 2)
        return opened, closed, pivot_x

    def finger_depth(self, spec: GripperSpec) -> float:
        return float(self.pad_length / 2 - self._angles(spec)[2] - self.palm_ahead)

    def tip_beyond_tcp_of(self, spec: GripperSpec) -> float:
        return self.pad_length / 2

    def close_ctrl(self) -> float:
        return self.closing_speed

    def open_joint_positions(self, spec: GripperSpec) -> dict[str, float]:
        joints = ("proximal", "keep", "curl")
        return {f"{PREFIX}{j}_{s}": 0.0 for j in joints for s in ("left", "right")}

    def hand_xml(self, spec: GripperSpec) -> HandXml:
        """The linkage with passive compliance (see the module docstring)."""
        palm_x = self._angles(spec)[2] + self.palm_ahead - spec.palm_half[0]
        fingers = self._finger(spec, "left", 1) + self._finger(spec, "right", -1)
        sides = ("left", "right")
        tendon = "".join(
            f'<fixed name="{PREFIX}drive_{s}"><joint joint="{PREFIX}proximal_{s}" coef="1"/>'
            f'<joint joint="{PREFIX}curl_{s}" coef="{self.curl_ratio}"/></fixed>'
            for s in sides
        )
        # Integrating actuator: ctrl is the speed of the set-point, so the squeeze only builds
        # up once the finger is blocked (this is what lets the spring keep the pads parallel).
        kp, torque, speed = 30.0, spec.grip_force * self.lever, self.closing_speed
        actuator = "".join(
            f'<general name="{PREFIX}drive_{s}" tendon="{PREFIX}drive_{s}" dyntype="integrator" '
            f'gainprm="{kp}" biastype="affine" biasprm="0 {-kp} -0.3" actlimited="true" '
            f'actrange="0 1.3" ctrlrange="{-speed} {speed}" '
            f'forcelimited="true" forcerange="{-torque} {torque}"/>'
            for s in sides
        )
        equality = _weld() + "".join(
            f'<joint joint1="{PREFIX}keep_{s}" joint2="{PREFIX}proximal_{s}" '
            f'polycoef="0 -1 0 0 0"/>'
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

    def _finger(self, spec: GripperSpec, side: str, sign: int) -> str:
        opened, closed, pivot_x = self._angles(spec)
        link, pad, inset = self.link_length, self.pad_length, self.pad_inset
        thick, pad_half = self.link_thickness / 2, spec.pad_thickness / 2
        return f"""
      <body name="{PREFIX}proximal_{side}" pos="{pivot_x:.5f} 0 {sign * self.pivot_offset}"
            quat="{_quat_y(-sign * opened)}" gravcomp="1">
        <joint name="{PREFIX}proximal_{side}" axis="0 {sign} 0"
               range="0 {opened - closed:.4f}" damping="0.01" armature="0.01"/>
        <geom name="{PREFIX}link_{side}" class="finger" type="box" mass="0.02"
              size="{link / 2} {spec.pad_width / 2} {thick}"
              pos="{link / 2} 0 {sign * thick}"/>
        <body name="{PREFIX}keep_{side}" pos="{link} 0 0" quat="{_quat_y(sign * opened)}"
              gravcomp="1">
          <joint name="{PREFIX}keep_{side}" axis="0 {sign} 0" armature="0.002"/>
          <geom class="finger" type="sphere" size="0.002" mass="0.002" contype="0"
                conaffinity="0"/>
          <body name="{PREFIX}distal_{side}" gravcomp="1">
            <joint name="{PREFIX}curl_{side}" axis="0 {sign} 0" range="0 1.3" stiffness="0.5"
                   springref="-1.0" damping="0.3" armature="0.002"/>
            <geom name="{PREFIX}pad_{side}" class="finger" type="box" mass="0.02"
                  size="{pad / 2} {spec.pad_width / 2} {pad_half}"
                  pos="{pad / 2} 0 {sign * (pad_half - inset)}"/>
          </body>
        </body>
      </body>"""


Fingers = RigidFingers | LinkageFingers
"""A hand's finger mechanism, one class per ``kind``."""

_FINGERS: dict[str, type[RigidFingers] | type[LinkageFingers]] = {
    cls.kind: cls for cls in (RigidFingers, LinkageFingers)
}

KINDS = tuple(_FINGERS)
"""The values of a spec's ``kind``."""


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
    """A parallel gripper: the keys of its spec file (lengths [m], force [N], time [s]), with
    its ``kind`` given by its ``fingers``. Checked whole when made: a ValueError names the key.
    """

    name: str
    """Identifies the hand in models, datasets and cache file names: letters, digits, '-', '_'
    and '.'."""
    max_width: float = _number("m", LENGTH)
    """Opening between the pads of the open hand [m]."""
    pad_width: float = _number("m", LENGTH)
    """Pad extent along e_y, across the closing plane [m]."""
    pad_thickness: float = _number("m", LENGTH)
    """Pad extent along the closing axis e_z [m]."""
    palm_size: tuple[float, float, float]
    """The palm box's extents along e_x, e_y, e_z [m]; its face is at the fingers' root."""
    tcp_offset: float = _number("m", LENGTH)
    """From the wrist flange to the TCP along e_x (where a robot holds the hand) [m]."""
    grip_force: float = _number("N", 10_000.0)
    """Squeeze of each finger (underactuated: at the pads' lever) [N]."""
    close_time: float = _number("s", 10.0)
    """How long closing the hand takes in a grasp trial [s]."""
    fingers: Fingers
    """The finger mechanism, the ``[fingers]`` table; its class is the spec's ``kind``."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not NAME_PATTERN.fullmatch(self.name):
            raise ValueError(
                f"name must be 1 to 64 letters, digits, '-', '_' or '.' (it names files), "
                f"got {self.name!r}"
            )
        if not isinstance(self.fingers, RigidFingers | LinkageFingers):
            raise ValueError(
                f"fingers must be RigidFingers or LinkageFingers, got {self.fingers!r}"
            )
        size = self.palm_size
        if not isinstance(size, list | tuple) or len(size) != 3:
            raise ValueError(f"palm_size must be 3 lengths [m] along e_x, e_y, e_z, got {size!r}")
        for axis, value in enumerate(size):
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"palm_size[{axis}] must be a number [m], got {value!r}")
            if not 0 < value <= LENGTH:
                raise ValueError(f"palm_size[{axis}] must be in (0, {LENGTH:g}] m, got {value!r}")
        object.__setattr__(self, "palm_size", tuple(float(v) for v in size))
        _check_numbers(self)
        if self.pad_width > self.palm_size[1]:
            raise ValueError(
                f"pad_width ({self.pad_width:g} m) is wider than the palm (palm_size[1] = "
                f"{self.palm_size[1]:g} m)"
            )
        span = self.max_width + 2 * self.pad_thickness
        if span > self.palm_size[2]:
            raise ValueError(
                f"max_width ({self.max_width:g} m) does not fit the palm: the open pads span "
                f"max_width + 2 · pad_thickness = {span:g} m > palm_size[2] = "
                f"{self.palm_size[2]:g} m"
            )
        self.fingers.check(self)

    # -- what the kind decides ---------------------------------------------------------

    @property
    def kind(self) -> str:
        """How the hand is built: one of `KINDS`."""
        return self.fingers.kind

    @property
    def palm_half(self) -> tuple[float, float, float]:
        """Half-extents of the palm box along ``e_x, e_y, e_z`` [m]."""
        x, y, z = self.palm_size
        return (x / 2, y / 2, z / 2)

    @property
    def finger_depth(self) -> float:
        """From the palm face to the fingertips of the open hand along e_x [m]."""
        return self.fingers.finger_depth(self)

    @property
    def tip_beyond_tcp(self) -> float:
        """How far the open fingertips reach past the TCP along e_x [m]."""
        return self.fingers.tip_beyond_tcp_of(self)

    @property
    def close_ctrl(self) -> float:
        """The actuator command that closes (its negative opens)."""
        return self.fingers.close_ctrl()

    def hand_xml(self) -> HandXml:
        """The MJCF fragments of this hand."""
        return self.fingers.hand_xml(self)

    def open_joint_positions(self) -> dict[str, float]:
        """Finger joint positions [m or rad] of the fully open hand, by joint name."""
        return self.fingers.open_joint_positions(self)

    # -- the file ----------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The spec as its file's keys (what models and datasets store; `from_dict` reads it)."""
        top = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "fingers"}
        top["palm_size"] = list(self.palm_size)
        return {"name": self.name, "kind": self.kind, **top, "fingers": asdict(self.fingers)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "gripper spec") -> GripperSpec:
        """The spec whose file's keys are ``data``; a ValueError names ``source`` and the key
        that is missing, unknown or out of range."""
        try:
            return cls._from_dict(data)
        except ValueError as err:
            raise ValueError(f"{source}: {err}") from None

    @classmethod
    def _from_dict(cls, data: Mapping[str, Any]) -> GripperSpec:
        if not isinstance(data, Mapping):
            raise ValueError(f"expected a table of keys, got {type(data).__name__}")
        top = [f.name for f in fields(cls) if f.name != "fingers"]
        docs = {**field_docs(cls), "kind": f"how the hand is built: {' or '.join(KINDS)}"}
        _check_keys(data, ["kind", *top, "fingers"], "", docs)
        kinds = " or ".join(repr(k) for k in KINDS)
        if data["kind"] not in _FINGERS:
            raise ValueError(f"kind must be {kinds}, got {data['kind']!r}")
        fingers_cls = _FINGERS[data["kind"]]
        table = data["fingers"]
        if not isinstance(table, Mapping):
            raise ValueError(f"fingers must be a table ([fingers]), got {table!r}")
        names = [f.name for f in fields(fingers_cls)]
        _check_keys(table, names, "fingers.", field_docs(fingers_cls))
        return cls(**{k: data[k] for k in top}, fingers=fingers_cls(**table))


def _check_keys(data: Mapping[str, Any], known: list[str], prefix: str, docs: dict) -> None:
    """Raise ValueError naming the first unknown key of ``data`` (with the nearest known one),
    else the first missing one (with what it means)."""
    for key in data:
        if key not in known:
            near = difflib.get_close_matches(str(key), known, n=1)
            hint = f"; did you mean {prefix}{near[0]}?" if near else ""
            raise ValueError(f"unknown key {prefix}{key}{hint} (known: {', '.join(known)})")
    for key in known:
        if key not in data:
            what = docs[key][0].lower() + docs[key][1:].removesuffix(".")
            raise ValueError(f"missing key {prefix}{key} ({what})")


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


def load_gripper(path: str | Path) -> GripperSpec:
    """The spec in the TOML file ``path``; a ValueError names the file and the bad key."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"{path}: not a TOML file ({err})") from None
    return GripperSpec.from_dict(data, source=str(path))


_SPECS = {name: load_gripper(SPEC_FOLDER / f"{name}.toml") for name in GRIPPERS}

FRANKA = _SPECS["franka"]
"""The Franka hand (``gripper_specs/franka.toml``)."""

ROBOTIQ_2F85 = _SPECS["robotiq-2f85"]
"""The Robotiq 2F-85 (``gripper_specs/robotiq-2f85.toml``)."""


def is_spec_file(text: str) -> bool:
    """Whether ``text`` names a spec file rather than a built-in gripper (by its suffix)."""
    return text.lower().endswith(GRIPPER_SPEC_SUFFIX)


def same_name_note(a: GripperSpec, b: GripperSpec) -> str:
    """What tells two different specs apart in a message when their names do not: a note for
    two specs of one name (say, a model made before a built-in hand's dimensions changed)."""
    return " (another spec of the same name: its dimensions differ)" if a.name == b.name else ""


def get_gripper(gripper: str | Path | Mapping[str, Any]) -> GripperSpec:
    """The spec of ``gripper``: a built-in's name (one of `symgrasp.names.GRIPPERS`); a
    ``.toml`` spec file; or a spec's `GripperSpec.to_dict`, as models and datasets store it.
    Call it once, where a gripper comes in (a command's option, a stored record): every
    function inside the package takes the `GripperSpec`.

    A file may not take a built-in's name with other dimensions: models and datasets name
    their gripper, and ``franka`` must mean one hand.
    """
    if isinstance(gripper, Mapping):
        return GripperSpec.from_dict(gripper, source="the stored gripper spec")
    if isinstance(gripper, str) and gripper in _SPECS:
        return _SPECS[gripper]
    if isinstance(gripper, Path) or (isinstance(gripper, str) and is_spec_file(gripper)):
        spec = load_gripper(gripper)
        if spec.name in _SPECS and spec != _SPECS[spec.name]:
            raise ValueError(
                f"{gripper}: name {spec.name!r} is a built-in gripper's, whose spec differs; "
                "give your gripper its own name"
            )
        return spec
    raise ValueError(
        f"gripper must be one of {', '.join(GRIPPERS)} or a .toml spec file, got {gripper!r}"
    )
