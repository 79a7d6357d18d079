"""symgrasp's code-built hands against MuJoCo Menagerie's reference models →
experiments/results/hands.{json,md} and docs/figures/hands_reference.png.

    PYTHONPATH=src python experiments/hands.py [--reference DIR] [--quick [DIR]]

Every hand is measured by the same probes, in its own model with its own physics options (the
reference models as published), through a frame H that each hand defines alike: origin at the
mounting flange, x the approach axis, z the closing axis pointing at the left finger. What
touches an object is found by rays, never by geom names: rays cast from the centre plane
z = 0 outwards along ±z, seeing only the fingers' collision geoms, give each finger's inner
surface as a depth map over (x, y), from which the opening, the pad and its centre follow; a
ray along −x sees the palm. The probes:

- ``geometry``: the open hand's opening (narrowest gap between the fingers), the pad (the
  patch within 1 mm of a finger's innermost point: its length along x, width along y and
  centre), the fingertip (the farthest x a finger's inner surface reaches) and the palm face,
  hence the finger depth;
- ``closing``: free closing from fully open: opening, pad centre and pad tilt every 10 ms,
  the time to 95 % of the travel, the pad centre's path over the whole opening;
- ``squeeze``: the normal force of each finger on a fixed box 20, 40 and 60 mm wide, centred
  on the open pad, after 1.5 s of closing;
- ``pull-out``: a free 40 mm cylinder (axis along y, gravity off, μ 0.5) held in a fingertip
  pinch (its axis 5 mm inside the fingertip) and in a power grasp (2 mm off the palm),
  pulled out of the hand along +x by a force ramping at 300 N/s until it has moved 10 mm;
  with the pad tilt while held;
- ``tip contact``: a block driven along −x into the open left fingertip at 0.1 m/s, as when a
  fingertip lands on an object during the approach: the force on the finger after 2 and
  10 mm of travel past first contact, and how far the fingertip has then yielded, the pad
  tilted and the gap changed;
- ``silhouette``: the hands' collision geometry seen along y and along z (ray grids), and the
  overlap of ours with the reference's (intersection over union).
The reference models are read from ``--reference`` (default: ``reference/menagerie`` in the data
folder, ``$SYMGRASP_DATA``, where the object sets are) only here: the package never loads them.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
from common import add_result_option
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.objects.folder import DATA_ENV, MissingData, data_folder
from symgrasp.sim.grippers import FRANKA, PREFIX, ROBOTIQ_2F85, GripperSpec
from symgrasp.sim.world import world_xml

GROUPS = {"palm": 1, "left": 2, "right": 3, "left_link": 4, "right_link": 5}
"""Geom groups the probes put each pad's, each finger's other and the palm's collision geoms
into (every other geom goes to group 0), so that a ray sees only what it probes."""
SIDES = ("left", "right")
STEP = 0.001  # ray grid spacing [m]


@dataclass
class Rig:
    """A hand in its own model, with what the probes need to know of it."""

    name: str
    model: mujoco.MjModel
    data: mujoco.MjData
    base: int  # the body H is fixed to
    T_base_hand: np.ndarray  # H in that body's frame (module docstring)
    fingers: dict[str, np.ndarray]  # side → finger collision geom ids
    pad_body: dict[str, int]  # side → the body that carries the pad
    open_ctrl: np.ndarray
    close_ctrl: np.ndarray
    open_qpos: dict[int, float] = field(default_factory=dict)  # qpos address → value
    hold: Callable[[mujoco.MjData, float], None] | None = None  # hold a fraction of the closing

    def reset(self) -> None:
        """The hand fully open and at rest; every object at its initial pose."""
        mujoco.mj_resetData(self.model, self.data)
        for address, value in self.open_qpos.items():
            self.data.qpos[address] = value
        self.data.ctrl[:] = self.open_ctrl
        mujoco.mj_forward(self.model, self.data)
        self.run(0.3)

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / self.model.opt.timestep)):
            mujoco.mj_step(self.model, self.data)

    @property
    def T_world_hand(self) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3] = self.data.xmat[self.base].reshape(3, 3)
        T[:3, 3] = self.data.xpos[self.base]
        return T @ self.T_base_hand

    def to_world(self, p_hand: np.ndarray) -> np.ndarray:
        return self.T_world_hand[:3, :3] @ p_hand + self.T_world_hand[:3, 3]

    def to_hand(self, p_world: np.ndarray) -> np.ndarray:
        return self.T_world_hand[:3, :3].T @ (p_world - self.T_world_hand[:3, 3])


# -- the hands -------------------------------------------------------------------------


@dataclass(frozen=True)
class Body:
    """A test object: a box (half sizes) or a cylinder (radius, half length), its pose in H,
    free (with a mass) or driven as a mocap body."""

    name: str
    kind: str  # "box" | "cylinder"
    size: tuple[float, ...]
    pos: tuple[float, float, float]
    axis_along_y: bool = False  # a cylinder's axis along H's y (else along H's z)
    free: bool = False
    mass: float = 0.1


def _add_bodies(spec: mujoco.MjSpec, T: np.ndarray, bodies: list[Body]) -> None:
    for b in bodies:
        R = T[:3, :3]
        if b.axis_along_y:  # the geom's z axis along H's y
            R = R @ np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]).T
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, R.ravel())
        pos = T[:3, :3] @ np.asarray(b.pos) + T[:3, 3]
        body = spec.worldbody.add_body(name=b.name, pos=pos, quat=quat, mocap=not b.free)
        if b.free:
            body.add_freejoint()
        kind = mujoco.mjtGeom.mjGEOM_BOX if b.kind == "box" else mujoco.mjtGeom.mjGEOM_CYLINDER
        body.add_geom(
            name=b.name, type=kind, size=list(b.size) + [0] * (3 - len(b.size)), mass=b.mass,
            friction=[0.5, 0.005, 0.0001], condim=4,
        )  # fmt: skip


def _probe_groups(
    model: mujoco.MjModel, fingers: dict[str, list[int]], pads: dict[str, int], palm: list[int]
) -> dict[str, np.ndarray]:
    """Move the collidable geoms of each side's pad body, of the rest of its finger bodies and
    of the palm into their GROUPS; the finger geom ids (pad included) per side."""
    collidable = (model.geom_contype | model.geom_conaffinity) > 0
    model.geom_group[:] = 0
    ids = {}
    for side, bodies in fingers.items():
        finger = np.isin(model.geom_bodyid, bodies) & collidable
        pad = (model.geom_bodyid == pads[side]) & collidable
        model.geom_group[finger] = GROUPS[f"{side}_link"]
        model.geom_group[pad] = GROUPS[side]
        ids[side] = np.flatnonzero(finger | pad)
    model.geom_group[np.isin(model.geom_bodyid, palm) & collidable] = GROUPS["palm"]
    return ids


def _descendants(model: mujoco.MjModel, root: int) -> list[int]:
    out = [root]
    for b in range(model.nbody):
        if b not in out and model.body_parentid[b] in out:
            out.append(b)
    return out


def ours(spec: GripperSpec, bodies: list[Body]) -> Rig:
    """symgrasp's hand as the world builds it: a free body welded to a mocap body that holds
    still (an arm holding the hand; H moves with the hand's base)."""
    mj = mujoco.MjSpec.from_string(world_xml([], spec))
    T = np.eye(4)
    T[:3, 3] = (0, 0, 1)  # the hand's TCP where the world builds it (its mocap's pose)
    T[0, 3] -= spec.tcp_offset  # H's origin: the flange, tcp_offset behind the TCP
    _add_bodies(mj, T, bodies)
    m = mj.compile()
    m.opt.gravity[:] = 0
    base = m.body(f"{PREFIX}base").id
    sides = {
        s: [b for b in range(m.nbody) if m.body(b).name.startswith(PREFIX) and m.body(b).name.endswith(s)]
        for s in SIDES
    }  # fmt: skip
    pad = "finger" if spec.kind == "rigid" else "distal"
    pads = {s: m.body(f"{PREFIX}{pad}_{s}").id for s in SIDES}
    fingers = _probe_groups(m, sides, pads, [base])
    open_qpos = {
        int(m.jnt_qposadr[m.joint(j).id]): v for j, v in spec.open_joint_positions().items()
    }
    nu = m.nu
    T_base_hand = np.eye(4)
    T_base_hand[0, 3] = -spec.tcp_offset
    hold = None
    if spec.kind == "underactuated":  # the integrating actuator's state is the drive's set-point
        closed = float(m.jnt_range[m.joint(f"{PREFIX}proximal_left").id][1])

        def hold(d: mujoco.MjData, fraction: float) -> None:
            d.ctrl[:] = 0.0
            d.act[:] = fraction * closed

    return Rig(
        spec.name, m, mujoco.MjData(m), base, T_base_hand, fingers, pads,
        np.full(nu, -spec.close_ctrl), np.full(nu, spec.close_ctrl), open_qpos, hold,
    )  # fmt: skip


def _reference_frame(m: mujoco.MjModel, pads: dict[str, str], open_qpos: dict) -> np.ndarray:
    """H of a reference hand mounted at the world origin approaching along world +z: z from
    the right pad to the left one, open."""
    d = mujoco.MjData(m)
    for joint, value in open_qpos.items():
        d.qpos[m.jnt_qposadr[m.joint(joint).id]] = value
    mujoco.mj_forward(m, d)
    c = d.body(pads["left"]).xpos - d.body(pads["right"]).xpos
    c[2] = 0
    c /= np.linalg.norm(c)
    a = np.array([0.0, 0.0, 1.0])
    T = np.eye(4)
    T[:3, :3] = np.c_[a, np.cross(c, a), c]
    return T


MENAGERIE = Path("reference") / "menagerie"
"""Menagerie's hands, relative to the data folder."""
MODELS = {
    "robotiq-2f85": Path("robotiq_2f85") / "2f85.xml",
    "franka": Path("franka_hand") / "hand.xml",
}
"""Each hand's reference model file in Menagerie's folder."""


def reference_model(name: str, folder: Path) -> Path:
    """The reference model file of hand ``name`` in Menagerie's ``folder``; `MissingData`
    naming it and how to get it when it is not there."""
    path = folder / MODELS[name]
    if not path.is_file():
        raise MissingData(
            f"the reference hands are not in {folder}: {path} does not exist; put MuJoCo "
            "Menagerie's robotiq_2f85/ and franka_hand/ (github.com/google-deepmind/"
            f"mujoco_menagerie) there, point {DATA_ENV} at a folder holding {MENAGERIE}, or pass "
            "--reference"
        )
    return path


def reference(name: str, folder: Path, bodies: list[Body]) -> Rig:
    """Menagerie's hand ``name`` ("robotiq-2f85" or "franka"), its base fixed at the world
    origin, its own physics options kept."""
    if name == "robotiq-2f85":
        pads, base = "{}_pad", ["base_mount", "base"]
        finger_roots = {s: [f"{s}_driver", f"{s}_spring_link"] for s in SIDES}
        open_ctrl, close_ctrl, open_qpos = 0.0, 255.0, {}
    else:
        pads, base = "{}_finger", ["hand"]
        finger_roots = {s: [f"{s}_finger"] for s in SIDES}
        open_ctrl, close_ctrl = 255.0, 0.0
        open_qpos = {"finger_joint1": 0.04, "finger_joint2": 0.04}
    mj = mujoco.MjSpec.from_file(str(reference_model(name, folder)))
    T = _reference_frame(mj.compile(), {s: pads.format(s) for s in SIDES}, open_qpos)
    _add_bodies(mj, T, bodies)
    m = mj.compile()
    m.opt.gravity[:] = 0
    pad_ids = {s: m.body(pads.format(s)).id for s in SIDES}
    fingers = _probe_groups(
        m,
        {s: [b for r in roots for b in _descendants(m, m.body(r).id)] for s, roots in finger_roots.items()},
        pad_ids, [m.body(b).id for b in base],
    )  # fmt: skip

    def hold(d: mujoco.MjData, fraction: float) -> None:  # a position servo: ctrl is the set-point
        d.ctrl[:] = open_ctrl + fraction * (close_ctrl - open_ctrl)

    return Rig(
        f"{name} (Menagerie)", m, mujoco.MjData(m), 0, T, fingers, pad_ids,
        np.full(m.nu, open_ctrl), np.full(m.nu, close_ctrl),
        {int(m.jnt_qposadr[m.joint(j).id]): v for j, v in open_qpos.items()}, hold,
    )  # fmt: skip


# -- what rays see ---------------------------------------------------------------------


def _ray(rig: Rig, origin_h: np.ndarray, direction_h: np.ndarray, *seen: str) -> float:
    """Distance [m] along the ray (in H) to the first geom of the ``seen`` GROUPS, NaN if none."""
    groups = np.zeros(6, np.uint8)
    groups[[GROUPS[s] for s in seen]] = 1
    hit = np.zeros(1, np.int32)
    d = mujoco.mj_ray(
        rig.model, rig.data, rig.to_world(origin_h), rig.T_world_hand[:3, :3] @ direction_h,
        groups, 1, -1, hit,
    )  # fmt: skip
    return float(d) if d >= 0 else float("nan")


START = 0.02
"""Rays for one finger start this far [m] beyond the centre plane, on the other finger's side,
so that a finger that has crossed the plane is still seen."""


def inner_surface(
    rig: Rig, side: str, xs: np.ndarray, ys: np.ndarray, whole_finger: bool = False
) -> np.ndarray:
    """(len(xs), len(ys)) distance [m] of the ``side`` pad's (or whole finger's) inner surface
    from the centre plane, towards that finger (negative once it has crossed the plane), NaN
    where a ray misses it."""
    sign = 1.0 if side == "left" else -1.0
    direction = np.array([0.0, 0.0, sign])
    seen = (side, f"{side}_link") if whole_finger else (side,)
    out = np.full((len(xs), len(ys)), np.nan)
    for i, x in enumerate(xs):
        for j, y in enumerate(ys):
            out[i, j] = _ray(rig, np.array([x, y, -sign * START]), direction, *seen) - START
    return out


def palm_face(rig: Rig) -> float:
    """x [m] of the palm's face on the hand's axis (a ray along −x)."""
    return 0.3 - _ray(rig, np.array([0.3, 0.0, 0.0]), np.array([-1.0, 0, 0]), "palm")


def pad_state(rig: Rig, xs: np.ndarray) -> dict[str, float]:
    """On the line y = 0, past the palm face (what an object can reach): the opening [m]
    between the pads, each pad's contact patch (within 1 mm of its innermost point: centre x,
    length) and innermost z, the fingertip's x; and the narrowest gap between the whole
    fingers and its x (an object deeper than the pads meets that gap)."""
    xs = xs[xs > palm_face(rig)]
    zero = np.array([0.0])
    pad = {s: inner_surface(rig, s, xs, zero)[:, 0] for s in SIDES}
    finger = {s: inner_surface(rig, s, xs, zero, whole_finger=True)[:, 0] for s in SIDES}
    gap = finger["left"] + finger["right"]
    state = {
        "opening": max(0.0, float(np.nanmin(pad["left"] + pad["right"]))),
        "finger_gap": max(0.0, float(np.nanmin(gap))),
        "finger_gap_x": float(xs[np.nanargmin(gap)]),
    }
    for side in SIDES:
        d = pad[side]
        patch = d <= np.nanmin(d) + 1e-3
        state[f"pad_x_{side}"] = float(xs[patch].mean())
        state[f"pad_length_{side}"] = float(xs[patch].max() - xs[patch].min() + STEP)
        state[f"inner_{side}"] = float(np.nanmin(d))
        state[f"tip_{side}"] = float(xs[~np.isnan(finger[side])].max())
    return state


def pad_tilt(rig: Rig, side: str, open_rotation: np.ndarray) -> float:
    """Angle [rad] the pad body has turned since ``open_rotation`` (its 3×3 world rotation)."""
    R = open_rotation.T @ rig.data.xmat[rig.pad_body[side]].reshape(3, 3)
    return float(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))


def finger_forces(rig: Rig, body: str) -> dict[str, float]:
    """Normal force [N] between each finger and the test object ``body``."""
    target = rig.model.body(body).id
    forces = dict.fromkeys(SIDES, 0.0)
    wrench = np.zeros(6)
    for i, c in enumerate(rig.data.contact[: rig.data.ncon]):
        for a, b in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
            if rig.model.geom_bodyid[b] != target:
                continue
            for side in SIDES:
                if a in rig.fingers[side]:
                    mujoco.mj_contactForce(rig.model, rig.data, i, wrench)
                    forces[side] += float(wrench[0])
    return forces


# -- the probes ------------------------------------------------------------------------

XS = np.arange(0.0, 0.26, STEP)  # along the approach axis from the flange [m]


def geometry(build) -> dict[str, float]:
    rig = build([])
    rig.reset()
    state = pad_state(rig, XS)
    ys = np.arange(-0.03, 0.03 + STEP / 2, STEP / 2)
    widths = []
    for side in SIDES:
        x = state[f"pad_x_{side}"]
        row = inner_surface(rig, side, np.array([x]), ys)[0]
        widths.append(float(np.sum(row <= state[f"inner_{side}"] + 1e-3) * STEP / 2))
    palm = palm_face(rig)
    tip = (state["tip_left"] + state["tip_right"]) / 2
    return {
        "opening_mm": 1e3 * state["opening"],
        "pad_length_mm": 1e3 * (state["pad_length_left"] + state["pad_length_right"]) / 2,
        "pad_width_mm": 1e3 * float(np.mean(widths)),
        "pad_centre_x_mm": 1e3 * (state["pad_x_left"] + state["pad_x_right"]) / 2,
        "tip_x_mm": 1e3 * tip,
        "palm_face_x_mm": 1e3 * palm,
        "finger_depth_mm": 1e3 * (tip - palm),
        "tip_beyond_pad_centre_mm": 1e3 * (tip - (state["pad_x_left"] + state["pad_x_right"]) / 2),
        "finger_gap_mm": 1e3 * state["finger_gap"],
        "finger_gap_x_mm": 1e3 * state["finger_gap_x"],
    }


def closing(build, duration: float = 1.5, every: float = 0.01) -> dict:
    rig = build([])
    rig.reset()
    open_rotation = {s: rig.data.xmat[rig.pad_body[s]].reshape(3, 3).copy() for s in SIDES}
    rig.data.ctrl[:] = rig.close_ctrl
    path = []
    for k in range(round(duration / every) + 1):
        if k:
            rig.run(every)
        s = pad_state(rig, XS)
        path.append({
            "t": round(k * every, 4), "opening_mm": 1e3 * s["opening"],
            "pad_x_mm": 1e3 * (s["pad_x_left"] + s["pad_x_right"]) / 2,
            "tilt_deg": float(np.degrees(np.mean([pad_tilt(rig, sd, open_rotation[sd]) for sd in SIDES]))),
        })  # fmt: skip
    w = np.array([p["opening_mm"] for p in path])
    travel = w[0] - w[-1]
    t95 = next(p["t"] for p in path if w[0] - p["opening_mm"] >= 0.95 * travel)
    xs = np.array([p["pad_x_mm"] for p in path])
    return {
        "closing_time_95_s": t95,
        "closed_opening_mm": float(w[-1]),
        "pad_x_shift_mm": float(xs[-1] - xs[0]),
        "pad_x_range_mm": float(xs.max() - xs.min()),
        "max_tilt_deg": float(max(p["tilt_deg"] for p in path)),
        "path": path,
    }


def settled_path(build, steps: int = 16) -> list[dict[str, float]]:
    """The pads over the whole opening, quasi-statically: the drive held at ``steps`` fractions
    of its stroke, each settled for 0.5 s (hands whose drive cannot be held: empty)."""
    rig = build([])
    if rig.hold is None:
        return []
    rig.reset()
    open_rotation = {s: rig.data.xmat[rig.pad_body[s]].reshape(3, 3).copy() for s in SIDES}
    path = []
    for fraction in np.linspace(0.0, 1.0, steps):
        rig.hold(rig.data, float(fraction))
        rig.run(0.5)
        state = pad_state(rig, XS)
        path.append({
            "opening_mm": 1e3 * state["opening"],
            "pad_x_mm": 1e3 * (state["pad_x_left"] + state["pad_x_right"]) / 2,
            "tilt_deg": float(np.degrees(np.mean([pad_tilt(rig, sd, open_rotation[sd]) for sd in SIDES]))),
        })  # fmt: skip
    return path


def squeeze(build, pad_x: float, widths=(0.02, 0.04, 0.06)) -> dict[str, float]:
    out = {}
    for w in widths:
        rig = build([Body("block", "box", (0.012, 0.03, w / 2), (pad_x, 0.0, 0.0))])
        rig.reset()
        rig.data.ctrl[:] = rig.close_ctrl
        rig.run(1.5)
        forces = finger_forces(rig, "block")
        out[f"{round(w * 1e3)}mm_N"] = float(np.mean(list(forces.values())))
    return out


def pull_out(build, x: float, rate: float = 300.0, cap: float = 300.0) -> dict[str, float]:
    """The force [N] that pulls a held 40 mm cylinder 10 mm out of the hand (+x); pad tilt."""
    rig = build(
        [Body("can", "cylinder", (0.02, 0.03), (x, 0.0, 0.0), axis_along_y=True, free=True)]
    )
    rig.reset()
    open_rotation = {s: rig.data.xmat[rig.pad_body[s]].reshape(3, 3).copy() for s in SIDES}
    rig.data.ctrl[:] = rig.close_ctrl
    rig.run(1.5)
    b = rig.model.body("can").id
    held = bool(sum(finger_forces(rig, "can").values()) > 0)
    tilt = float(np.degrees(np.mean([pad_tilt(rig, s, open_rotation[s]) for s in SIDES])))
    start = rig.to_hand(rig.data.xpos[b].copy())
    pull = rig.T_world_hand[:3, :3] @ np.array([1.0, 0, 0])
    force, dt = 0.0, rig.model.opt.timestep
    while held and force < cap:
        force += rate * dt
        rig.data.xfrc_applied[b, :3] = force * pull
        mujoco.mj_step(rig.model, rig.data)
        if np.linalg.norm(rig.to_hand(rig.data.xpos[b]) - start) > 0.01:
            break
    return {"held": held, "pull_out_N": min(force, cap) if held else 0.0, "tilt_deg": tilt,
            "x_mm": 1e3 * x}  # fmt: skip


def tip_contact(build, geometry_: dict[str, float], travel=(0.002, 0.01)) -> dict[str, float]:
    """A block driven along −x into the open left fingertip (module docstring)."""
    tip, inner = geometry_["tip_x_mm"] / 1e3, geometry_["opening_mm"] / 2e3
    half, speed = 0.03, 0.1
    start = np.array([tip + 0.005 + half, 0.0, inner + 0.003 + half])  # covers the left tip only
    rig = build([Body("block", "box", (half, half, half), tuple(start))])
    rig.reset()
    before = pad_state(rig, XS)
    open_rotation = rig.data.xmat[rig.pad_body["left"]].reshape(3, 3).copy()
    mocap = rig.model.body_mocapid[rig.model.body("block").id]
    dt, out, advance, contact = rig.model.opt.timestep, {}, 0.0, None
    while advance < 0.005 + max(travel) + 1e-9:
        advance += speed * dt
        rig.data.mocap_pos[mocap] = rig.to_world(start - np.array([advance, 0.0, 0.0]))
        mujoco.mj_step(rig.model, rig.data)
        force = finger_forces(rig, "block")["left"]
        if contact is None and force > 0:
            contact = advance
        for t in travel:
            if (
                contact is not None
                and f"force_{t * 1e3:g}mm_N" not in out
                and advance - contact >= t
            ):
                out[f"force_{t * 1e3:g}mm_N"] = force
    after = pad_state(rig, XS)
    return {
        **out,
        "tip_yield_mm": 1e3 * (before["tip_left"] - after["tip_left"]),
        "pad_tilt_deg": float(np.degrees(pad_tilt(rig, "left", open_rotation))),
        "gap_change_mm": 1e3 * (after["inner_left"] - before["inner_left"]),
    }


def silhouettes(build) -> dict[str, np.ndarray]:
    """Boolean masks of the open hand's collision geometry (fingers and palm) seen along y
    (over x, z) and along z (over x, y), on a 2 mm grid."""
    rig = build([])
    rig.reset()
    xs = np.arange(-0.02, 0.26, 0.002)
    zs = np.arange(-0.09, 0.09, 0.002)
    masks = {}
    for name, axis, across in (("side", 1, 2), ("front", 2, 1)):
        mask = np.zeros((len(xs), len(zs)), bool)
        direction = np.zeros(3)
        direction[axis] = 1.0
        for i, x in enumerate(xs):
            for j, z in enumerate(zs):
                origin = np.zeros(3)
                origin[0], origin[across], origin[axis] = x, z, -0.3
                mask[i, j] = _ray(rig, origin, direction, *GROUPS) < 0.6  # NaN: a miss
        masks[name] = mask
    masks["extent"] = np.array([xs[0], xs[-1], zs[0], zs[-1]])
    return masks


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def measure(build, quick: bool) -> dict:
    g = geometry(build)
    result = {"geometry": g, "closing": closing(build, duration=0.2 if quick else 1.5)}
    if quick:
        return result
    result["settled_path"] = settled_path(build)
    result["squeeze"] = squeeze(build, g["pad_centre_x_mm"] / 1e3)
    result["pinch"] = pull_out(build, g["tip_x_mm"] / 1e3 - 0.005)
    result["power"] = pull_out(build, g["palm_face_x_mm"] / 1e3 + 0.022)
    result["power_over_pinch"] = result["power"]["pull_out_N"] / max(
        result["pinch"]["pull_out_N"], 1e-9
    )
    result["tip_contact"] = tip_contact(build, g)
    return result


HANDS = {"robotiq-2f85": ROBOTIQ_2F85, "franka": FRANKA}
LENGTH_TOLERANCE_MM = 5.0
"""Lengths agree when within 5 mm: two thirds of the detector's 7.5 mm voxel, below what it
resolves."""
DATASHEET_SQUEEZE_N = {"robotiq-2f85": (20.0, 235.0), "franka": (70.0, 70.0)}
"""Grip force per the makers' datasheets: the 2F-85's is adjustable over this range; the
Franka hand's continuous force is 70 N (140 N peak). The reference models are position
servos whose squeeze is a gain setting (the Franka's kp of 100 N/m gives about 1 N)."""

ROWS = (  # label, how to read it from a cell, compared with the reference by
    ("opening [mm]", lambda c: c["geometry"]["opening_mm"], "length"),
    ("pad length along e_x [mm]", lambda c: c["geometry"]["pad_length_mm"], "length"),
    ("pad width along e_y [mm]", lambda c: c["geometry"]["pad_width_mm"], "length"),
    ("open pad centre, from the flange [mm]", lambda c: c["geometry"]["pad_centre_x_mm"], "length"),
    ("fingertip, from the flange [mm]", lambda c: c["geometry"]["tip_x_mm"], "length"),
    ("palm face, from the flange [mm]", lambda c: c["geometry"]["palm_face_x_mm"], "length"),
    ("finger depth (palm face → tip) [mm]", lambda c: c["geometry"]["finger_depth_mm"], "length"),
    ("narrowest gap between the open fingers [mm]", lambda c: c["geometry"]["finger_gap_mm"], "info"),
    ("pad centre's travel along e_x, open → closed (settled) [mm]",
     lambda c: c["settled_path"][-1]["pad_x_mm"] - c["settled_path"][0]["pad_x_mm"] if c["settled_path"] else 0.0, "length"),
    ("closing time, free, to 95 % [s]", lambda c: c["closing"]["closing_time_95_s"], "info"),
    ("squeeze per pad, 20 / 40 / 60 mm block [N]", lambda c: tuple(c["squeeze"].values()), "datasheet"),
    ("pad tilt in a fingertip pinch [°]", lambda c: c["pinch"]["tilt_deg"], "parallel"),
    ("pad tilt in a power grasp [°]", lambda c: c["power"]["tilt_deg"], "info"),
    ("pull-out, fingertip pinch [N]", lambda c: c["pinch"]["pull_out_N"], "info"),
    ("pull-out, power grasp [N]", lambda c: c["power"]["pull_out_N"], "info"),
    ("power / pinch pull-out", lambda c: c["power_over_pinch"], "stronger"),
    ("fingertip pushed 2 mm / 10 mm along −e_x: force [N]",
     lambda c: (c["tip_contact"]["force_2mm_N"], c["tip_contact"].get("force_10mm_N", 0.0)), "info"),
    ("… then: fingertip yielded [mm], pad tilted [°]",
     lambda c: (c["tip_contact"]["tip_yield_mm"], c["tip_contact"]["pad_tilt_deg"]), "info"),
    ("collision silhouette overlap with the reference, side / front (IoU)",
     lambda c: (c["iou_side"], c["iou_front"]), "info"),
)  # fmt: skip


def _fmt(value) -> str:
    if isinstance(value, tuple):
        return " / ".join(_fmt(v) for v in value)
    return (
        f"{value:.2f}"
        if abs(value) < 10
        else f"{value:.0f}"
        if abs(value) >= 100
        else f"{value:.1f}"
    )


def verdict(kind: str, hand: str, ours, ref) -> str:
    """Whether ``ours`` is within the stated tolerance of the reference ``ref`` (or the
    datasheet): "yes", "no", or "–" where the row is only reported."""
    if kind == "length":
        return "yes" if abs(ours - ref) <= LENGTH_TOLERANCE_MM else "no"
    if kind == "datasheet":
        low, high = DATASHEET_SQUEEZE_N[hand]
        return "yes" if all(low - 5 <= f <= high + 5 for f in ours) else "no"
    if kind == "parallel":
        return "yes" if ours < 2.0 else "no"
    if kind == "stronger":
        return "yes" if ours >= 1.0 else "no"
    return "–"


def table(cells: list[dict]) -> str:
    by = {(c["hand"], c["model"]): c for c in cells}
    lines = []
    for hand in HANDS:
        ours, ref = by[(hand, "symgrasp")], by[(hand, "menagerie")]
        lines += [
            f"**{hand}**",
            "",
            "| | symgrasp | Menagerie | within tolerance |",
            "|---|---|---|---|",
        ]
        for label, read, kind in ROWS:
            if kind in ("parallel",) and hand == "franka":
                continue
            a, b = read(ours), read(ref)
            lines.append(f"| {label} | {_fmt(a)} | {_fmt(b)} | {verdict(kind, hand, a, b)} |")
        lines.append("")
    return "\n".join(lines)


def figure(cells: list[dict], masks: dict, path: str) -> None:
    """Per hand: the collision silhouettes of ours over the reference's, seen along e_y and
    along e_z, and the pad centre over the opening (settled)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(HANDS), 3, figsize=(13, 4.2 * len(HANDS)))
    for row, hand in zip(axes, HANDS, strict=True):
        for ax, view, across in ((row[0], "side", "e_z (closing)"), (row[1], "front", "e_y")):
            ours, ref = masks[(hand, "symgrasp")], masks[(hand, "menagerie")]
            x0, x1, z0, z1 = ours["extent"]
            image = np.zeros((*ours[view].T.shape, 3)) + 1.0
            image[ref[view].T] = (0.55, 0.75, 0.95)
            image[ours[view].T] = (0.95, 0.6, 0.45)
            image[ours[view].T & ref[view].T] = (0.5, 0.5, 0.5)
            ax.imshow(image, origin="lower", extent=(1e3 * x0, 1e3 * x1, 1e3 * z0, 1e3 * z1))
            ax.set(xlabel="e_x from the flange [mm]", ylabel=f"{across} [mm]",
                   title=f"{hand}, seen along {'e_y' if view == 'side' else 'e_z'}")  # fmt: skip
        ax = row[2]
        measured = {c["model"]: c for c in cells if c["hand"] == hand}
        settled = all(c["settled_path"] for c in measured.values())
        for model, style in (("symgrasp", "o-"), ("menagerie", "s--")):
            path_ = measured[model]["settled_path" if settled else "closing"]
            path_ = path_ if settled else path_["path"]
            ax.plot(
                [p["opening_mm"] for p in path_], [p["pad_x_mm"] for p in path_], style, label=model
            )
        how = "drive held, settled" if settled else "free closing"
        ax.set(xlabel="opening [mm]", ylabel="pad centre, e_x from the flange [mm]",
               title=f"{hand}: pad centre, {how}")  # fmt: skip
        low, high = ax.get_ylim()
        ax.set_ylim(min(low, (low + high) / 2 - 10), max(high, (low + high) / 2 + 10))
        ax.legend()
    fig.suptitle("collision geometry of the open hands: grey both, orange symgrasp only, "
                 "blue Menagerie only", fontsize=10)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reference", type=Path, default=None,
                        help="folder holding Menagerie's robotiq_2f85/ and franka_hand/ (default: "
                        f"{MENAGERIE} in the data folder, ${DATA_ENV})")  # fmt: skip
    add_result_option(parser, "hands")
    parser.add_argument(
        "--figure",
        default="docs/figures/hands_reference.png",
        help="the picture of both hands beside their references (default: %(default)s)",
    )
    args = parse_args(
        parser, outputs=("result", "figure"), quick={}, also="geometry and 0.2 s of closing only"
    )
    args.reference = args.reference or data_folder() / MENAGERIE
    for name in HANDS:  # before any hand is measured
        reference_model(name, args.reference)
    cells, masks = [], {}
    for name, spec in HANDS.items():
        for source, build in (
            ("symgrasp", lambda bodies, spec=spec: ours(spec, bodies)),
            ("menagerie", lambda bodies, name=name: reference(name, args.reference, bodies)),
        ):
            print(f"{name}, {source}", flush=True)
            cells.append({"hand": name, "model": source, **measure(build, bool(args.quick))})
            if not args.quick:
                masks[(name, source)] = silhouettes(build)
    if args.quick:
        write_result(
            args.result,
            "hands against Menagerie",
            command_line("PYTHONPATH=src"),
            cells,
        )
        return
    for c in cells:
        theirs = masks[(c["hand"], "menagerie")]
        for view in ("side", "front"):
            c[f"iou_{view}"] = iou(masks[(c["hand"], c["model"])][view], theirs[view])
    markdown = table(cells)
    print(markdown)
    figure(cells, masks, args.figure)
    write_result(args.result, "hands against Menagerie", command_line("PYTHONPATH=src"),
                 cells, markdown, tolerance_mm=LENGTH_TOLERANCE_MM)  # fmt: skip


if __name__ == "__main__":
    run_main(main)
