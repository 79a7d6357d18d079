"""The simulated world: a table, a 0.30 m cubic workspace, objects and one hand (MuJoCo).

World frame = workspace frame (`symgrasp.workspace`): the workspace is ``[0, 0.3]³`` and the
table top is the plane ``z = TABLE_HEIGHT`` inside it.

:class:`World` is the backend interface that grasp execution and perception use; a Drake
world would implement the same methods. Its model is rebuilt from MJCF whenever the set of
objects changes (an object removed, the pile's walls taken away), carrying the other
objects' poses and velocities over.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from symgrasp.sim.grippers import PREFIX, GripperSpec
from symgrasp.sim.objects import ObjectSpec
from symgrasp.sim.physics import HAND_GROUP, HIDDEN_GROUP, option_xml
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

PARK_POSITION = (0.15, 0.15, 1.0)
"""Where the idle hand waits, far above the workspace [m]."""

PILE_BOX_HALF = 0.1
"""Inner half-width of the bottomless box a pile is dropped into [m]."""


_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


@dataclass(frozen=True)
class Snapshot:
    """A `World`'s simulation state at one instant (`World.snapshot`)."""

    model: mujoco.MjModel
    state: np.ndarray


def pose_to_qpos(T: np.ndarray) -> np.ndarray:
    """4×4 pose → MuJoCo free-joint ``[x, y, z, qw, qx, qy, qz]``."""
    x, y, z, w = Rotation.from_matrix(T[:3, :3]).as_quat()
    return np.r_[T[:3, 3], w, x, y, z]


def qpos_to_pose(q: np.ndarray) -> np.ndarray:
    """MuJoCo free-joint ``[x, y, z, qw, qx, qy, qz]`` → 4×4 pose."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat([q[4], q[5], q[6], q[3]]).as_matrix()
    T[:3, 3] = q[:3]
    return T


def _table_xml() -> str:
    c = WORKSPACE_SIZE / 2
    # Collision: a plane, a half-space that nothing can be pushed through; hidden, because
    # MuJoCo's renderer and ray caster disagree on a plane's finite extent. Looks: a box.
    return (
        f'<geom name="table" class="table" type="plane" size="0.5 0.5 0.01" '
        f'pos="{c} {c} {TABLE_HEIGHT}" group="{HIDDEN_GROUP}" rgba="0 0 0 0"/>'
        f'<geom name="table_top" class="table" type="box" size="0.5 0.5 0.02" '
        f'pos="{c} {c} {TABLE_HEIGHT - 0.02}" contype="0" conaffinity="0"/>'
    )


def _walls_xml(half: float = PILE_BOX_HALF, height: float = 0.25) -> str:
    """A bottomless box around the workspace centre that holds a pile while it falls."""
    c, t = WORKSPACE_SIZE / 2, 0.005
    z = TABLE_HEIGHT + height / 2
    walls = [
        (c + half + t, c, t, half + 2 * t),
        (c - half - t, c, t, half + 2 * t),
        (c, c + half + t, half + 2 * t, t),
        (c, c - half - t, half + 2 * t, t),
    ]
    return "".join(
        f'<geom name="wall_{i}" type="box" size="{sx} {sy} {height / 2}" pos="{x} {y} {z}" '
        f'rgba="1 1 1 0.2" group="{HIDDEN_GROUP}"/>'
        for i, (x, y, sx, sy) in enumerate(walls)
    )


def _object_xml(index: int, spec: ObjectSpec) -> str:
    return f"""
    <body name="obj_{index}">
      <freejoint name="obj_{index}"/>
      {spec.geoms_xml(f"obj_{index}")}
    </body>"""


def world_xml(
    objects: Sequence[ObjectSpec], gripper: GripperSpec | None, walls: bool = False
) -> str:
    """The complete MJCF of a world."""
    hand = gripper.hand_xml() if gripper is not None else None
    body = "".join(_object_xml(i, o) for i, o in enumerate(objects))
    assets = "".join(o.assets_xml(f"obj_{i}") for i, o in enumerate(objects))
    light = '<light pos="0.15 0.15 1.5" dir="0 0 -1" directional="true"/>'
    return f"""
<mujoco model="symgrasp_world">
  {option_xml()}
  <asset>{assets}</asset>
  <worldbody>
    {light}
    {_table_xml()}
    {_walls_xml() if walls else ""}
    {body}
    {hand.worldbody if hand else ""}
  </worldbody>
  <tendon>{hand.tendon if hand else ""}</tendon>
  <equality>{hand.equality if hand else ""}</equality>
  <actuator>{hand.actuator if hand else ""}</actuator>
  <contact>{hand.contact if hand else ""}</contact>
</mujoco>"""


class World:
    """A MuJoCo world with objects on a table and, optionally, one hand.

    Args:
        objects: the objects, in order; object ``i`` is body ``obj_i``.
        poses: (n, 4, 4) initial ``T_world_object``; default: all at the workspace centre.
        gripper: the hand to include, or None for no hand.
        walls: include the removable walls used to drop a pile.
    """

    def __init__(
        self,
        objects: Sequence[ObjectSpec] = (),
        poses: np.ndarray | None = None,
        gripper: GripperSpec | None = None,
        walls: bool = False,
    ) -> None:
        self.objects = list(objects)
        self.gripper = gripper
        self.walls = walls
        if poses is None:
            poses = np.tile(np.eye(4), (len(self.objects), 1, 1))
            poses[:, :3, 3] = (WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2, TABLE_HEIGHT)
        poses = np.asarray(poses, dtype=float)
        if poses.shape != (len(self.objects), 4, 4):
            raise ValueError(
                f"poses must have shape ({len(self.objects)}, 4, 4), got {poses.shape}"
            )
        qpos = np.stack([pose_to_qpos(T) for T in poses]) if len(poses) else np.zeros((0, 7))
        self._build(qpos, np.zeros((len(self.objects), 6)))

    # -- model --------------------------------------------------------------------------

    def _build(self, obj_qpos: np.ndarray, obj_qvel: np.ndarray) -> None:
        self.model = mujoco.MjModel.from_xml_string(
            world_xml(self.objects, self.gripper, self.walls)
        )
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._obj_body = np.array(
            [m.body(f"obj_{i}").id for i in range(len(self.objects))], dtype=int
        )
        jnt = [m.joint(f"obj_{i}").id for i in range(len(self.objects))]
        self._obj_qadr = np.array([m.jnt_qposadr[j] for j in jnt], dtype=int)
        self._obj_vadr = np.array([m.jnt_dofadr[j] for j in jnt], dtype=int)
        # geom id -> object index (-1 for table, walls and hand)
        self._geom_object = np.full(m.ngeom, -1)
        for i, b in enumerate(self._obj_body):
            self._geom_object[m.geom_bodyid == b] = i
        self._hand_geom = m.geom_group == HAND_GROUP
        self._hand_body = m.body(f"{PREFIX}base").id if self.gripper is not None else -1
        for i in range(len(self.objects)):
            self.data.qpos[self._obj_qadr[i] : self._obj_qadr[i] + 7] = obj_qpos[i]
            self.data.qvel[self._obj_vadr[i] : self._obj_vadr[i] + 6] = obj_qvel[i]
        if self.gripper is not None:
            T = np.eye(4)
            T[:3, 3] = PARK_POSITION
            self.set_hand_pose(T)
        mujoco.mj_forward(m, self.data)

    def _object_states(self) -> tuple[np.ndarray, np.ndarray]:
        qpos = np.array([self.data.qpos[a : a + 7] for a in self._obj_qadr]).reshape(-1, 7)
        qvel = np.array([self.data.qvel[a : a + 6] for a in self._obj_vadr]).reshape(-1, 6)
        return qpos, qvel

    def rebuild(self, keep: Sequence[int] | None = None, walls: bool | None = None) -> None:
        """Rebuild the model keeping objects ``keep`` (default all) with their states, and the
        hand; ``walls`` (default: unchanged) adds or removes the pile walls."""
        keep = list(range(len(self.objects))) if keep is None else list(keep)
        qpos, qvel = self._object_states()
        self.objects = [self.objects[i] for i in keep]
        if walls is not None:
            self.walls = walls
        self._build(qpos[keep], qvel[keep])

    def remove_object(self, index: int) -> None:
        """Remove object ``index`` (e.g. after it was grasped); the others keep their states."""
        if not 0 <= index < len(self.objects):
            raise ValueError(f"index must be in [0, {len(self.objects)}), got {index}")
        self.rebuild([i for i in range(len(self.objects)) if i != index])

    def snapshot(self) -> Snapshot:
        """The complete simulation state (MuJoCo's integration state: time, positions,
        velocities, actuators, controls, applied forces, mocap targets and the solver's warm
        start), for `restore`: a trial run from a restored state repeats bit for bit."""
        state = np.empty(mujoco.mj_stateSize(self.model, _STATE))
        mujoco.mj_getState(self.model, self.data, state, _STATE)
        return Snapshot(self.model, state)

    def restore(self, snapshot: Snapshot) -> None:
        """Return to the state a `snapshot` of this model took (not across a `rebuild`)."""
        if snapshot.model is not self.model:
            raise ValueError(
                "snapshot was taken of another model (objects were removed or the world was "
                "rebuilt since); take a new one"
            )
        mujoco.mj_setState(self.model, self.data, snapshot.state, _STATE)
        mujoco.mj_forward(self.model, self.data)

    # -- objects ------------------------------------------------------------------------

    def object_poses(self) -> np.ndarray:
        """``T_world_object`` of every object, (n, 4, 4)."""
        qpos, _ = self._object_states()
        return np.stack([qpos_to_pose(q) for q in qpos]) if len(qpos) else np.zeros((0, 4, 4))

    def object_positions(self) -> np.ndarray:
        """Object origins in the world, (n, 3) [m]."""
        return self.data.xpos[self._obj_body].copy().reshape(-1, 3)

    @property
    def timestep(self) -> float:
        """Physics step [s]."""
        return float(self.model.opt.timestep)

    def step(self, duration: float) -> None:
        """Advance the simulation by ``duration`` seconds."""
        mujoco.mj_step(
            self.model, self.data, nstep=max(1, round(duration / self.model.opt.timestep))
        )

    def apply_force(self, index: int, force: np.ndarray) -> None:
        """Apply a constant world-frame ``force`` [N] at object ``index``'s centre of mass."""
        self.data.xfrc_applied[self._obj_body[index]] = np.r_[force, 0.0, 0.0, 0.0]

    def set_gravity(self, gravity: np.ndarray) -> None:
        """Set the gravity vector [m/s²] (e.g. zero for a free-floating pull-out test)."""
        self.model.opt.gravity[:] = gravity

    def moving_objects(self, linear: float = 5e-3, angular: float = 0.1) -> list[int]:
        """Indices of the objects moving at ``linear`` [m/s] or ``angular`` [rad/s] or faster."""
        _, qvel = self._object_states()
        fast = (np.linalg.norm(qvel[:, :3], axis=1) >= linear) | (
            np.linalg.norm(qvel[:, 3:], axis=1) >= angular
        )
        return [int(i) for i in np.flatnonzero(fast)]

    def at_rest(self, linear: float = 5e-3, angular: float = 0.1) -> bool:
        """Whether every object moves slower than ``linear`` [m/s] and ``angular`` [rad/s]."""
        return not self.moving_objects(linear, angular)

    def settle(self, max_time: float = 2.0, check_every: float = 0.05) -> float:
        """Simulate until all objects are at rest or ``max_time`` [s]; returns the time taken."""
        t = 0.0
        while t < max_time:
            self.step(check_every)
            t += check_every
            if self.at_rest():
                break
        return t

    def objects_touching(self, index: int) -> list[int]:
        """Indices of the other objects that object ``index`` touches now, sorted."""
        touching = set()
        for c in self.data.contact[: self.data.ncon]:
            a, b = self._geom_object[c.geom1], self._geom_object[c.geom2]
            if a == index and b >= 0 and b != index:
                touching.add(int(b))
            if b == index and a >= 0 and a != index:
                touching.add(int(a))
        return sorted(touching)

    def outside_workspace(self) -> list[int]:
        """Indices of objects whose origin left the workspace or fell below the table."""
        p = self.object_positions()
        out = (
            (p[:, 0] < 0)
            | (p[:, 0] > WORKSPACE_SIZE)
            | (p[:, 1] < 0)
            | (p[:, 1] > WORKSPACE_SIZE)
            | (p[:, 2] < TABLE_HEIGHT - 0.02)
        )
        return [int(i) for i in np.flatnonzero(out)]

    # -- hand ---------------------------------------------------------------------------

    def _require_hand(self) -> GripperSpec:
        if self.gripper is None:
            raise ValueError("this world has no gripper; build it with gripper=<a GripperSpec>")
        return self.gripper

    def set_hand_pose(self, T_world_tcp: np.ndarray) -> None:
        """Teleport the hand (at rest, fingers open) so that its TCP frame is ``T_world_tcp``."""
        gripper = self._require_hand()
        m, d = self.model, self.data
        q = pose_to_qpos(np.asarray(T_world_tcp, dtype=float))
        d.mocap_pos[0], d.mocap_quat[0] = q[:3], q[3:]
        free = m.joint(f"{PREFIX}free")
        d.qpos[m.jnt_qposadr[free.id] : m.jnt_qposadr[free.id] + 7] = q
        for name, value in gripper.open_joint_positions().items():
            d.qpos[m.jnt_qposadr[m.joint(name).id]] = value
        hand_dofs = m.body_rootid[m.dof_bodyid] == self._hand_body
        d.qvel[hand_dofs] = 0.0
        d.act[:] = 0.0
        d.ctrl[:] = -gripper.close_ctrl
        mujoco.mj_forward(m, d)

    def hand_pose(self) -> np.ndarray:
        """Current ``T_world_tcp`` of the hand, 4×4."""
        self._require_hand()
        T = np.eye(4)
        T[:3, :3] = self.data.xmat[self._hand_body].reshape(3, 3)
        T[:3, 3] = self.data.xpos[self._hand_body]
        return T

    def push_until_slip(self, index: int, forces: np.ndarray, slip: float) -> int | None:
        """Push object ``index`` with ``forces[k]`` (world frame [N], at its centre of mass)
        during step ``k``, the hand's set-point unchanged, until the object's origin has moved
        more than ``slip`` [m] in the hand's TCP frame from where it was at the call.

        Returns the first ``k`` whose step starts with the object that far (MuJoCo computes
        positions at the start of a step, so step ``k`` sees the state after ``k`` steps: the
        force being applied when the slip shows is ``forces[k]``), or None if no step of the
        ``len(forces)`` does. The force is removed at the end.

        The start is where MuJoCo last computed the positions (the current state after
        `restore`, as for `hand_pose`). A few operations on 3-vectors per step, read from
        MuJoCo's own buffers: a force ramp costs little more than its MuJoCo steps, where one
        through `apply_force`, `step` and `hand_pose` spent more in Python
        (docs/reports/grasp-databases.md).
        """
        self._require_hand()
        if not 0 <= index < len(self.objects):
            raise ValueError(f"index must be in [0, {len(self.objects)}), got {index}")
        forces = np.asarray(forces, dtype=float)
        if forces.ndim != 2 or forces.shape[1] != 3:
            raise ValueError(f"forces must have shape (n, 3), got {forces.shape}")
        m, d = self.model, self.data
        body = self._obj_body[index]
        # views into MuJoCo's buffers: they follow every step
        wrench = d.xfrc_applied[body]
        wrench[3:] = 0.0
        p_object, p_hand = d.xpos[body], d.xpos[self._hand_body]
        R_hand = d.xmat[self._hand_body].reshape(3, 3)
        start = (p_object - p_hand) @ R_hand
        try:
            for k, force in enumerate(forces):
                wrench[:3] = force
                mujoco.mj_step(m, d)
                moved = (p_object - p_hand) @ R_hand - start
                if math.sqrt(moved @ moved) > slip:
                    return k
            return None
        finally:
            wrench[:] = 0.0

    def hand_boxes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The hand's box geoms in its TCP frame, as they are now: centres (B, 3), rotations
        (B, 3, 3) whose columns are the box axes, half-extents (B, 3) [m]."""
        self._require_hand()
        m, d = self.model, self.data
        T = np.linalg.inv(self.hand_pose())
        ids = self._hand_box_ids()
        centre = np.array([T[:3, :3] @ d.geom_xpos[g] + T[:3, 3] for g in ids])
        rotation = np.array([T[:3, :3] @ d.geom_xmat[g].reshape(3, 3) for g in ids])
        return centre, rotation, np.array([m.geom_size[g] for g in ids])

    def hand_box_names(self) -> list[str]:
        """The names of the boxes `hand_boxes` returns, in its order (``hand_palm``,
        ``hand_pad_left``, …)."""
        return [self.model.geom(g).name for g in self._hand_box_ids()]

    def _hand_box_ids(self) -> np.ndarray:
        self._require_hand()
        return np.flatnonzero(self._hand_geom & (self.model.geom_type == mujoco.mjtGeom.mjGEOM_BOX))

    def finger_opening(self) -> float:
        """Distance between the inner faces of the two pads along the closing axis [m]."""
        self._require_hand()
        m, d = self.model, self.data
        T = self.hand_pose()
        pads = [m.geom(f"{PREFIX}pad_{side}").id for side in ("left", "right")]
        z = [float((d.geom_xpos[g] - T[:3, 3]) @ T[:3, 2]) for g in pads]
        thickness = sum(float(m.geom_size[g][2]) for g in pads)  # two half-thicknesses
        return max(0.0, abs(z[0] - z[1]) - thickness)

    def _hand_contacts(self) -> tuple[np.ndarray, np.ndarray]:
        """The rows of the current contacts between the hand and the rest, (K,), and their
        geoms, (K, 2): the hand's first."""
        geom = self.data.contact.geom[: self.data.ncon]
        hand = self._hand_geom[geom]
        rows = np.flatnonzero(hand[:, 0] != hand[:, 1])
        return rows, np.where(hand[rows, :1], geom[rows], geom[rows, ::-1])

    def hand_in_collision(self) -> bool:
        """Whether the hand touches the table or any object."""
        return len(self._hand_contacts()[0]) > 0

    def hand_contact_force(self) -> float:
        """Total normal force [N] that the table and objects exert on the hand."""
        total, wrench = 0.0, np.zeros(6)
        for i in self._hand_contacts()[0]:
            mujoco.mj_contactForce(self.model, self.data, int(i), wrench)
            total += wrench[0]
        return total

    def hand_touches(self) -> list[int]:
        """What the hand touches, sorted: objects by index, ``-1`` for the table or a wall."""
        return sorted({int(o) for o in self._geom_object[self._hand_contacts()[1][:, 1]]})

    def objects_in_hand(self) -> list[int]:
        """Indices of objects that touch the hand, sorted."""
        return [i for i in self.hand_touches() if i >= 0]

    def move_hand(
        self,
        T_target: np.ndarray,
        duration: float,
        settle: float = 0.02,
        stop_force: float | None = None,
    ) -> float:
        """Move the hand's set-point from its current pose to ``T_target`` along a straight line
        (slerp for the rotation) with a smooth time law over ``duration`` seconds, then hold it
        for ``settle`` seconds.

        Returns how far [m] the hand then lags its set-point: near zero unless it is blocked;
        infinity if the motion stopped early because the contact force on the hand exceeded
        ``stop_force`` [N] (a guarded move, as a robot's collision detection does).
        """
        self._require_hand()
        d = self.data
        p0, q0 = d.mocap_pos[0].copy(), d.mocap_quat[0].copy()
        q1 = pose_to_qpos(np.asarray(T_target, dtype=float))
        rots = Rotation.from_quat([[q0[1], q0[2], q0[3], q0[0]], [q1[4], q1[5], q1[6], q1[3]]])
        n = max(1, round(duration / self.model.opt.timestep))
        s = np.linspace(0.0, 1.0, n + 1)[1:]
        s = 3 * s**2 - 2 * s**3
        xyzw = Slerp([0.0, 1.0], rots)(s).as_quat()
        for k in range(n):
            d.mocap_pos[0] = p0 + s[k] * (q1[:3] - p0)
            d.mocap_quat[0] = xyzw[k, [3, 0, 1, 2]]
            mujoco.mj_step(self.model, d)
            if stop_force is not None and k % 5 == 0 and self.hand_contact_force() > stop_force:
                return float("inf")
        self.step(settle)
        return float(np.linalg.norm(self.hand_pose()[:3, 3] - d.mocap_pos[0]))

    def actuate(self, close: bool, duration: float | None = None) -> None:
        """Close (or open) the fingers for ``duration`` s (default: the gripper's close time)."""
        gripper = self._require_hand()
        self.data.ctrl[:] = gripper.close_ctrl if close else -gripper.close_ctrl
        self.step(gripper.close_time if duration is None else duration)


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    return Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()


def pile_scene(
    objects: Sequence[ObjectSpec],
    seed: int = 0,
    gripper: GripperSpec | None = None,
    max_settle: float = 1.5,
) -> World:
    """Drop ``objects`` with random orientations into a box at the workspace centre, let them
    settle, remove the box, settle again, and drop objects that left the workspace."""
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (len(objects), 1, 1))
    c = WORKSPACE_SIZE / 2
    z = TABLE_HEIGHT + 0.02
    for i, obj in enumerate(objects):
        # rotate about the bounding-box centre; the object then stays in a ball of this
        # radius, and stacking the balls keeps the falling objects apart
        vertices = obj.hull_points()
        centre = vertices.min(axis=0) / 2 + vertices.max(axis=0) / 2
        radius = float(np.max(np.linalg.norm(vertices - centre, axis=1)))
        z += radius
        R = _random_rotation(rng)
        poses[i, :3, :3] = R
        jitter = max(0.0, PILE_BOX_HALF - radius - 0.002)  # the ball starts inside the walls
        poses[i, :3, 3] = np.r_[rng.uniform(c - jitter, c + jitter, size=2), z] - R @ centre
        z += radius + 0.005
    world = World(objects, poses, gripper=gripper, walls=True)
    world.settle(max_settle)
    world.rebuild(walls=False)
    world.settle(max_settle)
    _drop_outside(world)
    return world


def packed_scene(
    objects: Sequence[ObjectSpec],
    seed: int = 0,
    gripper: GripperSpec | None = None,
    max_settle: float = 1.0,
    attempts: int = 200,
) -> World:
    """Stand ``objects`` upright at random non-overlapping places with random yaw and settle.
    Objects that find no free place in ``attempts`` tries are left out."""
    rng = np.random.default_rng(seed)
    placed: list[tuple[ObjectSpec, np.ndarray]] = []
    circles: list[tuple[np.ndarray, float]] = []  # footprint circles taken so far
    for obj in objects:
        centre, r = obj.footprint()
        margin = min(r + 0.01, WORKSPACE_SIZE / 2)
        for _ in range(attempts):
            xy = rng.uniform(margin, WORKSPACE_SIZE - margin, size=2)
            if all(np.linalg.norm(xy - c) > r + rc + 0.005 for c, rc in circles):
                T = np.eye(4)
                T[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
                T[:3, 3] = (*(xy - T[:2, :2] @ centre), TABLE_HEIGHT + 0.001)
                placed.append((obj, T))
                circles.append((xy, r))
                break
    world = World(
        [o for o, _ in placed],
        np.array([T for _, T in placed]).reshape(-1, 4, 4),
        gripper=gripper,
    )
    world.settle(max_settle)
    _drop_outside(world)
    return world


VGN_DROP_HEIGHT = 0.2
"""Height above the table from which VGN drops each object of a pile [m]."""

VGN_PACKED_RANGE = (0.08, 0.22)
"""The x and y range in which VGN stands the objects of a packed scene [m]."""

VGN_PACKED_ATTEMPTS = 12
"""Placements VGN tries per packed scene, taken or not."""


def _bounding_centre(obj: ObjectSpec) -> np.ndarray:
    vertices = obj.hull_points()
    return vertices.min(axis=0) / 2 + vertices.max(axis=0) / 2


def vgn_pile_scene(
    objects: Sequence[ObjectSpec],
    seed: int = 0,
    gripper: GripperSpec | None = None,
    max_settle: float = 1.0,
) -> World:
    """A pile as VGN builds one (``generate_pile_scene`` of Breyer et al.'s simulator): inside
    a temporary box, each object in turn is dropped with a random orientation from
    `VGN_DROP_HEIGHT` above a random point of the middle third of the workspace and left up to
    ``max_settle`` s to rest; then the box is removed and objects that leave the workspace are
    dropped until the rest lies still."""
    rng = np.random.default_rng(seed)
    world = World((), gripper=gripper, walls=True)
    for obj in objects:
        R = _random_rotation(rng)
        T = np.eye(4)
        T[:3, :3] = R
        xy = rng.uniform(WORKSPACE_SIZE / 3, 2 * WORKSPACE_SIZE / 3, size=2)
        T[:3, 3] = np.r_[xy, TABLE_HEIGHT + VGN_DROP_HEIGHT] - R @ _bounding_centre(obj)
        poses = np.concatenate([world.object_poses(), T[None]])
        world = World([*world.objects, obj], poses, gripper=gripper, walls=True)
        world.settle(max_settle)
    world.rebuild(walls=False)
    _settle_and_drop_outside(world, 2 * max_settle)
    return world


def vgn_packed_scene(
    objects: Sequence[ObjectSpec],
    seed: int = 0,
    gripper: GripperSpec | None = None,
    max_settle: float = 1.0,
    attempts: int = VGN_PACKED_ATTEMPTS,
) -> World:
    """A packed scene as VGN builds one (``generate_packed_scene``): up to ``attempts`` times,
    the next object stands upright at a random (x, y) in `VGN_PACKED_RANGE` with a random yaw,
    resting on the table; if it touches another object it is taken away (its next attempt
    draws a new place), else the scene settles. Stops when every object stands or the
    attempts are spent, so a scene may hold fewer objects than given."""
    rng = np.random.default_rng(seed)
    world = World((), gripper=gripper)
    waiting = list(objects)
    for _ in range(attempts):
        if not waiting:
            break
        obj = waiting[0]
        T = np.eye(4)
        T[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
        T[:3, 3] = (*rng.uniform(*VGN_PACKED_RANGE, size=2), TABLE_HEIGHT + 0.002)
        T[:2, 3] -= T[:2, :2] @ _bounding_centre(obj)[:2]
        trial = World(
            [*world.objects, obj], np.concatenate([world.object_poses(), T[None]]), gripper
        )
        if trial.objects_touching(len(world.objects)):
            continue
        waiting.pop(0)
        world = trial
        _settle_and_drop_outside(world, max_settle)
    return world


def _settle_and_drop_outside(world: World, max_settle: float) -> None:
    """Settle, drop objects outside the workspace, and again until none leaves (VGN's
    ``remove_and_wait``)."""
    while True:
        world.settle(max_settle)
        outside = set(world.outside_workspace())
        if not outside:
            return
        world.rebuild([i for i in range(len(world.objects)) if i not in outside])


def _drop_outside(world: World) -> None:
    outside = set(world.outside_workspace())
    if outside:
        world.rebuild([i for i in range(len(world.objects)) if i not in outside])
