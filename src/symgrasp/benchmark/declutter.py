"""One round of simulated decluttering: the protocol of VGN and the paper (Sec. 4.3).

A round drops ``N`` objects of a set as a pile on the table. Before every attempt the cameras'
depth images (by default one, from a fixed camera, noiseless: `symgrasp.benchmark.sensing`)
are handed to the planner (any
`symgrasp.detect.planner.GraspPlanner`: a `GraspDetector`, VGN's network, a user's
function), and one of its ranked grasps (a detector's: by gravity-rejection score) is executed
(`symgrasp.sim.execute.execute_grasp`); a successful grasp removes its object. Which one is the
``protocol``'s (`symgrasp.names.PROTOCOLS`): ``"paper"``, the first, as the paper's and VGN's
simulated protocol; ``"symgrasp"``, symgrasp's addition, the first whose open hand, from the
pre-grasp along the approach to the grasp, misses the *observed* surface by
``surface_clearance`` and keeps ``table_clearance`` above the table (`first_free`, what a robot
can check; the surface is the zero crossings of the images, noise and all, fused into the
workspace TSDF, the same for every planner). The round ends when the table is clear, no grasp is found, or
``max_failures`` attempts in a row fail.

A round is a pure function of its seed: the same seed gives the same round.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from symgrasp.benchmark.failures import aimed_object, failure_mode, struck
from symgrasp.benchmark.sensing import Sensor
from symgrasp.config import SURFACE_CLEARANCE, TABLE_CLEARANCE
from symgrasp.detect import Grasp
from symgrasp.detect.detector import fuse
from symgrasp.detect.planner import GraspPlanner
from symgrasp.names import PROTOCOLS
from symgrasp.objects.sets import ObjectSource
from symgrasp.sim.collision import hand_collides
from symgrasp.sim.execute import execute_grasp
from symgrasp.sim.grippers import GripperSpec
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import World

NONE_FOUND = "none_found"
"""The outcome of an attempt for which the planner proposed no executable grasp."""


@dataclass(frozen=True)
class Attempt:
    """One grasp attempt of a round.

    Attributes:
        outcome: an `symgrasp.sim.execute.Outcome` value, or `NONE_FOUND`.
        grasp: the executed grasp (None when none was found).
        candidates: grasps the planner proposed.
        rejected: of those, skipped because their approach hit the observed scene (0 under
            the ``"paper"`` protocol, which checks nothing).
        planning_s: seconds from rendering the depth images to the chosen grasp (rendering,
            noise, the planner, the collision checks).
        objects_before: objects on the table before the attempt.
        mode: why it failed or ``"success"`` (`symgrasp.benchmark.failures.MODES`); None
            when the round was played without diagnosis.
        target: the family of the object the grasp was for: the lifted one on success,
            else the one nearest the TCP (`symgrasp.benchmark.failures.aimed_object`); None
            when none was found.
        struck: for a collision, what the hand hit where it stopped
            (`symgrasp.benchmark.failures.struck`); empty otherwise.
    """

    outcome: str
    grasp: Grasp | None
    candidates: int
    rejected: int
    planning_s: float
    objects_before: int
    mode: str | None = None
    target: str | None = None
    struck: tuple[str, ...] = ()

    @property
    def success(self) -> bool:
        return self.outcome == "success"


@dataclass
class Round:
    """The record of one round: ``objects`` presented (those left on the table after the
    pile settled), the depth ``renderer`` (``"gl"`` or ``"raycast"``), its attempts, and the
    families of the objects ``presented`` and of those ``left`` on the table when it ended."""

    seed: int
    objects: int
    renderer: str
    attempts: list[Attempt] = field(default_factory=list)
    presented: list[str] = field(default_factory=list)
    left: list[str] = field(default_factory=list)

    @property
    def successes(self) -> int:
        return sum(a.success for a in self.attempts)

    @property
    def executed(self) -> int:
        """Attempts that executed a grasp (a round's last attempt may have found none)."""
        return sum(a.outcome != NONE_FOUND for a in self.attempts)

    @property
    def success_ratio(self) -> float:
        """Successes / executed attempts (NaN when nothing was executed)."""
        return self.successes / self.executed if self.executed else float("nan")

    @property
    def clear_ratio(self) -> float:
        """Successes / objects presented."""
        return self.successes / self.objects if self.objects else float("nan")


Observer = Callable[[World, np.ndarray, list[Grasp], Attempt], None]
"""Called after each attempt with the world (as the attempt left it), the points (P, 3) of
the depth images taken before the attempt (`symgrasp.detect.planner.Observation.points`), the
candidate grasps and the attempt."""


def run_round(
    planner: GraspPlanner,
    objects: ObjectSource,
    num_objects: int = 5,
    seed: int = 0,
    scene: str = "pile",
    max_failures: int = 2,
    max_attempts: int | None = None,
    sensor: Sensor | None = None,
    observer: Observer | None = None,
    diagnose: bool = True,
    table_clearance: float = TABLE_CLEARANCE,
    surface_clearance: float = SURFACE_CLEARANCE,
    protocol: str = "symgrasp",
) -> Round:
    """Play one declutter round with ``planner`` (its gripper) on ``num_objects`` objects of
    the set ``objects`` (resolved once by `symgrasp.objects.sets.resolve`, for all the rounds
    it plays) in a ``scene`` ("pile" or "packed"); the scene and its objects are drawn from
    ``seed``.

    ``max_attempts`` defaults to twice the number of objects; ``sensor`` (default: one
    noiseless image from the fixed camera) says what the cameras see before each attempt,
    drawn from ``seed`` and the attempt's index (`symgrasp.benchmark.sensing`);
    ``table_clearance`` and ``surface_clearance`` are `first_free`'s, which the ``"symgrasp"``
    ``protocol`` applies and ``"paper"`` does not (the module docstring). With
    ``diagnose``, each failed grasp is replayed at other yaws to name its failure mode
    (`symgrasp.benchmark.failures`); the round itself is the same either way.
    """
    if num_objects < 1 or max_failures < 1:
        raise ValueError(
            f"num_objects and max_failures must be ≥ 1, got {num_objects}, {max_failures}"
        )
    if protocol not in PROTOCOLS:
        raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
    sensor = sensor or Sensor()
    renderer = make_renderer(sensor.intrinsic)
    world = objects.scene(scene, objects.draw(num_objects, seed, scene), seed, planner.gripper)
    record = Round(seed, len(world.objects), renderer.name,
                   presented=[spec.family for spec in world.objects])  # fmt: skip
    max_attempts = 2 * num_objects if max_attempts is None else max_attempts
    failures = 0
    while world.objects and failures < max_failures and len(record.attempts) < max_attempts:
        start = time.perf_counter()
        observation = sensor.observe(renderer, world, seed, len(record.attempts))
        candidates = list(planner.plan(observation))
        if protocol == "paper":
            chosen, rejected = (candidates[0] if candidates else None), 0
        else:
            seen = fuse(observation.depth, observation.intrinsic, observation.T_world_camera)
            points = seen.point_cloud().cpu().numpy()
            chosen, rejected = first_free(
                candidates, planner.gripper, points, table_clearance, surface_clearance
            )
        planning = time.perf_counter() - start
        before = len(world.objects)
        mode: str | None = NONE_FOUND if diagnose else None
        target, hit = None, ()
        if chosen is None:
            outcome = NONE_FOUND
        else:
            families = [spec.family for spec in world.objects]
            aimed = aimed_object(world, chosen.pose)
            state = world.snapshot() if diagnose else None
            result = execute_grasp(world, chosen.pose)
            outcome = result.outcome.value
            target = families[aimed if result.object_index is None else result.object_index]
            hit = struck(result.touched, aimed)
            if state is not None:
                mode = failure_mode(world, state, chosen.pose, result.outcome)
        attempt = Attempt(
            outcome, chosen, len(candidates), rejected, planning, before, mode, target, hit
        )
        record.attempts.append(attempt)
        if observer is not None:
            observer(world, observation.points(), candidates, attempt)
        if chosen is None:
            break
        failures = 0 if attempt.success else failures + 1
    record.left = [spec.family for spec in world.objects]
    return record


def save_attempt_png(
    path: str | Path,
    points: np.ndarray,
    candidates: list[Grasp],
    attempt: Attempt,
    gripper: GripperSpec,
    title: str,
    drawn: int = 10,
) -> Path:
    """Draw an attempt (an `Observer`'s arguments) to ``path``: the observed ``points``, the
    best ``drawn`` candidates coloured by score and the executed one thick."""
    from symgrasp.detect.show import save_grasps_png

    shown = candidates[:drawn]
    return save_grasps_png(
        path,
        points,
        np.array([g.pose for g in shown]).reshape(-1, 4, 4),
        np.array([g.score for g in shown]),
        gripper,
        title=title,
        highlight=next((i for i, g in enumerate(shown) if g is attempt.grasp), None),
    )


def picture_observer(folder: str | Path, gripper: GripperSpec, caption: str = "") -> Observer:
    """An `Observer` that draws attempt ``n`` of a round to ``folder/attempt_NN.png``
    (`save_attempt_png`), titled ``caption`` + the attempt's number and mode."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    count = [0]

    def observe(
        world: World, points: np.ndarray, candidates: list[Grasp], attempt: Attempt
    ) -> None:
        count[0] += 1
        title = f"{caption}attempt {count[0]}: {attempt.mode or attempt.outcome}"
        path = folder / f"attempt_{count[0]:02d}.png"
        save_attempt_png(path, points, candidates, attempt, gripper, title)

    return observe


def first_free(
    candidates: list[Grasp],
    gripper: GripperSpec,
    points: np.ndarray,
    table_clearance: float = TABLE_CLEARANCE,
    surface_clearance: float = SURFACE_CLEARANCE,
    batch: int = 8,
) -> tuple[Grasp | None, int]:
    """The first candidate whose open hand, swept from the pre-grasp, keeps ``surface_clearance``
    [m] from ``points`` and ``table_clearance`` above the table (both by default the labels'
    1 mm: `symgrasp.config.SURFACE_CLEARANCE` and `TABLE_CLEARANCE`; a negative value lets
    points that deep inside the hand's boxes pass); and how many before it were rejected.
    Checked in small batches: the first one usually passes."""
    for start in range(0, len(candidates), batch):
        chunk = candidates[start : start + batch]
        hits = hand_collides(
            np.array([g.pose for g in chunk]), gripper, points, tolerance=-surface_clearance,
            table_tolerance=-table_clearance,
        )  # fmt: skip
        free = np.flatnonzero(~hits)
        if len(free):
            return chunk[free[0]], start + int(free[0])
    return None, len(candidates)
