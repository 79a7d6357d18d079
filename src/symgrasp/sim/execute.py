"""Grasp execution: the protocol that labels and evaluates every grasp.

:func:`execute_grasp` places the open hand 10 cm back along ``e_x`` (pre-grasp), approaches
the grasp pose along a straight line, closes, lifts 30 cm along world +z and holds. It
only uses the :class:`~symgrasp.sim.world.World` interface, never MuJoCo directly.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from symgrasp.sim.protocol import LIFT_HEIGHT, PREGRASP_DISTANCE
from symgrasp.sim.world import PARK_POSITION, World

BLOCKED_ERROR = 0.004
"""The hand counts as blocked when it lags its commanded pose by this much [m] ..."""

BLOCKED_FORCE = 20.0
"""... or when the open hand is pressed by more than this [N] on its way in (what a wrist
force sensor would flag: fingers landing on top of an object); the approach stops there."""


class Outcome(enum.Enum):
    """How a grasp trial ended."""

    SUCCESS = "success"
    PREGRASP_COLLISION = "pregrasp_collision"  # the open hand at pre-grasp touches something
    APPROACH_COLLISION = "approach_collision"  # blocked or pressed on the way in
    NO_CONTACT = "no_contact"  # the fingers closed on nothing
    SLIPPED = "slipped"  # something was grasped but nothing is held after lift and hold
    MULTIPLE = "multiple"  # more than one object was lifted


@dataclass(frozen=True)
class GraspResult:
    """Outcome of a trial, the index (before removal) of the lifted object, if any, and for
    a collision what the hand touched where it stopped (`World.hand_touches`: objects by
    index, ``-1`` the table or a wall)."""

    outcome: Outcome
    object_index: int | None = None
    touched: tuple[int, ...] = ()

    @property
    def success(self) -> bool:
        return self.outcome is Outcome.SUCCESS


def top_grasp(position: np.ndarray, yaw: float = 0.0) -> np.ndarray:
    """``T_world_tcp`` of a vertical grasp: ``e_x`` = world −z, closing axis ``e_z`` at angle
    ``yaw`` [rad] from world +x in the table plane, TCP at ``position`` (3,) [m]."""
    e_x = np.array([0.0, 0.0, -1.0])
    e_z = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    T = np.eye(4)
    T[:3, :3] = np.c_[e_x, np.cross(e_z, e_x), e_z]
    T[:3, 3] = position
    return T


def _check_pose(grasp_pose: np.ndarray) -> np.ndarray:
    T = np.asarray(grasp_pose, dtype=float)
    if T.shape != (4, 4) or not np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-5):
        raise ValueError("grasp_pose must be a 4×4 homogeneous transform with a rotation block")
    return T


def execute_grasp(
    world: World, grasp_pose: np.ndarray, hold_time: float = 0.25, remove: bool = True
) -> GraspResult:
    """Run one grasp trial of the world's hand at ``grasp_pose`` (``T_world_tcp``).

    Success: exactly one object is lifted above half the lift height and still touches the
    hand after ``hold_time`` seconds. That object is then removed from the world (unless
    ``remove`` is False); the hand is parked again.
    """
    T = _check_pose(grasp_pose)
    if world.gripper is None:
        raise ValueError("execute_grasp needs a world with a hand; build it with gripper=...")
    result = _trial(world, T, hold_time)
    park = np.eye(4)
    park[:3, 3] = PARK_POSITION
    if result.success and remove:
        world.remove_object(result.object_index)
    world.set_hand_pose(park)
    return result


def _trial(world: World, T: np.ndarray, hold_time: float) -> GraspResult:
    pregrasp = T.copy()
    pregrasp[:3, 3] -= PREGRASP_DISTANCE * T[:3, 0]
    world.set_hand_pose(pregrasp)
    if touched := world.hand_touches():
        return GraspResult(Outcome.PREGRASP_COLLISION, touched=tuple(touched))

    lag = world.move_hand(T, duration=0.25, stop_force=BLOCKED_FORCE)
    if lag > BLOCKED_ERROR:
        return GraspResult(Outcome.APPROACH_COLLISION, touched=tuple(world.hand_touches()))

    start_z = world.object_positions()[:, 2].copy()
    world.actuate(close=True)
    if not world.objects_in_hand():
        return GraspResult(Outcome.NO_CONTACT)

    lifted = T.copy()
    lifted[2, 3] += LIFT_HEIGHT
    world.move_hand(lifted, duration=0.5)
    world.step(hold_time)

    raised = np.flatnonzero(world.object_positions()[:, 2] - start_z > LIFT_HEIGHT / 2)
    held = [i for i in world.objects_in_hand() if i in raised]
    if len(raised) > 1:
        return GraspResult(Outcome.MULTIPLE)
    if len(held) == 1:
        return GraspResult(Outcome.SUCCESS, held[0])
    return GraspResult(Outcome.SLIPPED)


def ramp(max_force: float, step: float) -> np.ndarray:
    """The force of a ramp at each step [N]: ``step`` more at every step, summed step by step,
    up to the first value that reaches ``max_force`` (which ends the ramp), shape (n,)."""
    if not max_force > 0 or not step > 0:
        raise ValueError(f"max_force and the ramp's step must be positive, got {max_force}, {step}")
    forces, force = [], 0.0
    while force < max_force:
        force += step
        forces.append(force)
    return np.array(forces)


def pull_out_forces(
    world: World,
    object_index: int,
    directions: np.ndarray,
    max_force: float = 300.0,
    rate: float = 600.0,
    slip: float = 0.01,
) -> np.ndarray:
    """Forces [N] at which a held object is pulled ``slip`` metres out of the hand, one per
    direction (K, 3) (world frame; any length but zero), each ramp from the world's current
    state, to which the world returns.

    A force along the direction on the object's centre of mass ramps up at ``rate`` N/s while
    the hand holds still (`World.push_until_slip`); the result is the force being applied when
    the object is seen ``slip`` out of place, ``max_force`` if it never is. Returns (K,).
    """
    dirs = np.asarray(directions, dtype=float)
    if dirs.ndim != 2 or dirs.shape[1] != 3 or np.any(np.linalg.norm(dirs, axis=1) == 0):
        raise ValueError(f"directions must be non-zero 3-vectors, shape (K, 3), got {dirs.shape}")
    magnitude = ramp(max_force, rate * world.timestep)
    start = world.snapshot()
    resisted = np.full(len(dirs), float(max_force))
    for k, u in enumerate(dirs):
        world.restore(start)
        slipped = world.push_until_slip(
            object_index, magnitude[:, None] * (u / np.linalg.norm(u)), slip
        )
        if slipped is not None:
            resisted[k] = min(magnitude[slipped], max_force)
    world.restore(start)
    return resisted


def pull_out_force(
    world: World,
    object_index: int,
    direction: np.ndarray,
    max_force: float = 300.0,
    rate: float = 600.0,
    slip: float = 0.01,
) -> float:
    """`pull_out_forces` along one ``direction`` (3,)."""
    u = np.asarray(direction, dtype=float)
    if u.shape != (3,) or np.linalg.norm(u) == 0:
        raise ValueError("direction must be a non-zero 3-vector")
    return float(pull_out_forces(world, object_index, u[None], max_force, rate, slip)[0])


def stepwise_pull_out_forces(
    world: World,
    object_index: int,
    directions: np.ndarray,
    max_force: float = 300.0,
    rate: float = 600.0,
    slip: float = 0.01,
) -> np.ndarray:
    """`pull_out_forces` as it was before `World.push_until_slip`, the same arguments and, bit
    for bit, the same result: each ramp stepped one `World.step` at a time through `World`'s
    interface (`apply_force`, `step`, `hand_pose`, `object_positions`), the hand's pose and the
    object's position read back after every step. Slow (more Python than MuJoCo per step): the
    reference that tests/sim/test_sim_execute.py and tests/data/test_data_grasp_db.py check
    the fast ramps against and that benchmarks/grasp_db.py times them against."""

    def in_hand() -> np.ndarray:
        """The object's position in the hand's frame."""
        return (
            np.linalg.inv(world.hand_pose()) @ np.r_[world.object_positions()[object_index], 1.0]
        )[:3]

    start_state = world.snapshot()
    resisted = []
    for direction in np.asarray(directions, dtype=float):
        world.restore(start_state)
        u = direction / np.linalg.norm(direction)
        start = in_hand()
        force = 0.0
        while force < max_force:
            force += rate * world.timestep
            world.apply_force(object_index, force * u)
            world.step(world.timestep)
            if np.linalg.norm(in_hand() - start) > slip:
                break
        world.apply_force(object_index, np.zeros(3))
        resisted.append(min(force, max_force))
    world.restore(start_state)
    return np.array(resisted)
