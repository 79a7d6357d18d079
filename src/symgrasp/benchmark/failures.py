"""Why a declutter grasp failed: wrong yaw, wrong approach, collision, slip.

The simulator says *how* a trial ended (`symgrasp.sim.execute.Outcome`); a representation is
judged by *why*. The question the paper asks of a rotation is whether the closing axis about
an otherwise good approach was wrong: the averaged yaws of a regressor that was trained
towards both rotations of a symmetric grasp. So a failed grasp is replayed from the state
it started in, turned about its own approach axis ``e_x`` by each of `YAW_OFFSETS` (same TCP
position, same ``e_x``, closing axis ``e_z`` rotated in the plane ⊥ ``e_x``; offsets in
[0, π) cover every yaw of a symmetric hand). Then, in this order:

- ``wrong_yaw``: some turned grasp succeeds: the approach was right, the yaw was not;
- ``collision``: the hand hit something at pre-grasp or on the way in, whatever its yaw;
- ``wrong_approach``: the fingers closed on nothing, whatever the yaw: the grasp point or
  the approach direction misses the object, or the closing pushed it out of the pads (a
  closing line across an edge of a box, which rigid pads do not hold);
- ``slip`` / ``multiple``: an object was grasped and lost, or two were lifted.

Replays run on `World.snapshot` copies and the world is put back exactly as the failed
trial left it, so diagnosing does not change the round (tested).

A grasp is also attributed to the object it was aimed at (`aimed_object`), so modes can be
broken down by object family: does a representation fail on boxes and not on spheres? And a
collision names what the hand hit where it stopped (`struck`): the table, the target or a
neighbour, which points at different causes (the approach check's table rule, a grasp too
deep, the unseen side of the pile).
"""

from __future__ import annotations

import functools

import numpy as np

from symgrasp.sim import World
from symgrasp.sim.execute import Outcome, execute_grasp
from symgrasp.sim.objects import ObjectSpec
from symgrasp.sim.world import Snapshot

YAW_OFFSETS = np.deg2rad([30.0, 60.0, 90.0, 120.0, 150.0])
"""Turns about the approach axis tried to tell a wrong yaw from a wrong approach [rad]."""

MODES = ("success", "wrong_yaw", "wrong_approach", "collision", "slip", "multiple", "none_found")
"""Every attempt's mode, in report order (``none_found``: the detector proposed no grasp)."""

_BY_OUTCOME = {
    Outcome.SUCCESS: "success",
    Outcome.PREGRASP_COLLISION: "collision",
    Outcome.APPROACH_COLLISION: "collision",
    Outcome.NO_CONTACT: "wrong_approach",
    Outcome.SLIPPED: "slip",
    Outcome.MULTIPLE: "multiple",
}


STRUCK = ("table", "target", "neighbour")
"""What a collision can have hit, in report order (``table``: the table or a wall)."""


def struck(touched: tuple[int, ...], aimed: int | None) -> tuple[str, ...]:
    """What a collision hit, in `STRUCK` order, from what the hand touched where it stopped
    (`symgrasp.sim.execute.GraspResult.touched`: object indices, ``-1`` the table or a wall)
    and the index of the object the grasp was aimed at (`aimed_object`)."""
    hit = {"table" if i < 0 else "target" if i == aimed else "neighbour" for i in touched}
    return tuple(kind for kind in STRUCK if kind in hit)


def turned_about_approach(T_world_tcp: np.ndarray, angle: float) -> np.ndarray:
    """``T_world_tcp`` rotated by ``angle`` [rad] about its own ``e_x`` (4×4): same position,
    same approach, closing axis turned."""
    c, s = np.cos(angle), np.sin(angle)
    T_tcp_turned = np.eye(4)
    T_tcp_turned[1:3, 1:3] = [[c, -s], [s, c]]
    return T_world_tcp @ T_tcp_turned


def aimed_object(world: World, T_world_tcp: np.ndarray, samples: int = 256) -> int | None:
    """Index of the object whose surface is nearest the grasp's TCP (the point between the
    fingertips), from ``samples`` surface points per object; None when there is none."""
    if not world.objects:
        return None
    position = T_world_tcp[:3, 3]
    nearest = []
    for spec, T_world_object in zip(world.objects, world.object_poses(), strict=True):
        points = _surface(spec, samples) @ T_world_object[:3, :3].T + T_world_object[:3, 3]
        nearest.append(np.linalg.norm(points - position, axis=1).min())
    return int(np.argmin(nearest))


@functools.lru_cache(maxsize=256)
def _surface(spec: ObjectSpec, samples: int) -> np.ndarray:
    """``spec``'s seeded surface samples (samples, 3), once per object of a round: a round
    asks for the same objects at every attempt."""
    points = spec.sample_surface(samples)[0]
    points.flags.writeable = False
    return points


def failure_mode(world: World, before: Snapshot, grasp_pose: np.ndarray, outcome: Outcome) -> str:
    """The mode of a trial of ``grasp_pose`` that ended in ``outcome`` after starting from
    ``before`` (a snapshot of ``world``); ``world`` is left in the state it is in now."""
    if outcome is Outcome.SUCCESS:
        return "success"
    after = world.snapshot()
    try:
        for angle in YAW_OFFSETS:
            world.restore(before)
            turned = turned_about_approach(grasp_pose, float(angle))
            if execute_grasp(world, turned, remove=False).success:
                return "wrong_yaw"
    finally:
        world.restore(after)
    return _BY_OUTCOME[outcome]
