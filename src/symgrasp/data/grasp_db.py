"""Per-object grasp databases: antipodal candidates, gravity-less closure, rejection scores.

The paper's pipeline (Appx. C "Additional Training Details"): sample antipodal grasps on an
object, randomise them, close the gripper on the free-floating object in a gravity-less
simulation and keep the *settled* relative pose of hand and object, so that both fingertip
pinches and deep power grasps appear. Each settled grasp then gets the gravity-rejection
score of ref. [pvgn]: how strong a disturbance it resists, measured by ramping a force on
the object along ``K`` fixed directions of the object frame until the object slips
(:func:`symgrasp.sim.execute.pull_out_force`). Definition and normalisation: docs/data.md.

A database is computed once per (object parameters, gripper, configuration) and cached as an
``.npz`` under a key that hashes the three.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from symgrasp.atomic import write_atomic
from symgrasp.config import DatabaseConfig
from symgrasp.data.directions import fibonacci_directions, interpolate, interpolation_support
from symgrasp.sim.execute import pull_out_forces
from symgrasp.sim.grippers import GripperSpec
from symgrasp.sim.objects import ObjectSpec, surface_samples
from symgrasp.sim.world import World

GRAVITY = 9.81
"""Standard gravity [m/s²], the unit of the normalised score."""

FLOAT_POSITION = (0.15, 0.15, 0.6)
"""Where the free-floating object waits during closure, far above the table [m]."""


@dataclass(frozen=True)
class GraspDatabase:
    """The settled grasps of one object and gripper (``N`` grasps, ``K`` directions).

    Attributes:
        T_object_tcp: (N, 4, 4) settled TCP pose in the object frame.
        width: (N,) finger opening after closure [m].
        contact_force: (N,) total normal force of the object on the hand after closure [N].
        held: (N,) whether the object touches the hand after closure.
        resisted_force: (N, K) force [N] resisted along each direction before slipping.
        score: (N, K) :func:`rejection_score` of ``resisted_force``, in [0, 1].
        directions: (K, 3) the disturbance directions in the object frame.
        candidates: closures tried to obtain these grasps.
    """

    T_object_tcp: np.ndarray
    width: np.ndarray
    contact_force: np.ndarray
    held: np.ndarray
    resisted_force: np.ndarray
    score: np.ndarray
    directions: np.ndarray
    candidates: int

    def __len__(self) -> int:
        return len(self.width)

    def score_along(self, query: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """The held grasps' scores (H,) along ``query`` (3,), a direction in the object frame
        (`symgrasp.data.directions.interpolate`). ``rows`` (indices into the held grasps)
        names those the caller will read: every score is known here, so all are returned
        (`OnDemandDatabase` measures only those)."""
        return interpolate(self.score[self.held], self.directions, query)

    def save(self, path: str | Path) -> None:
        """Write atomically (`symgrasp.atomic.write_atomic`)."""
        write_atomic(path, lambda file: np.savez_compressed(file, **dataclasses.asdict(self)))

    @classmethod
    def load(cls, path: str | Path) -> GraspDatabase:
        with np.load(path) as z:
            fields = {f.name: z[f.name] for f in dataclasses.fields(cls)}
        fields["candidates"] = int(fields["candidates"])
        return cls(**fields)


def rejection_score(resisted_force: np.ndarray, weight: float, clip: float) -> np.ndarray:
    """The normalised gravity-rejection score ``log(1 + min(F / (m g), C)) / log(1 + C)``.

    Units of the object's weight make it comparable across objects; the logarithm keeps a
    pinch that holds 3 weights (0.26 at C = 200) apart from one that holds none, and a grasp
    that holds 50 weights (0.74) apart from one that holds 200 (1.0).
    """
    ratio = np.minimum(np.asarray(resisted_force) / weight, clip)
    return np.log1p(ratio) / np.log1p(clip)


def antipodal_pairs(
    points: np.ndarray,
    normals: np.ndarray,
    friction: float,
    max_width: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Contact pairs of surface samples whose line lies in both friction cones (``atan μ``).

    Args:
        points, normals: (P, 3) surface samples and outward normals (`symgrasp.sim.objects.surface_samples`).
        friction: the object's friction coefficient μ.
        max_width: the gripper's largest opening [m].

    Returns the midpoints (M, 3) and the unit contact lines ``p₂ − p₁`` (M, 3), object frame;
    one partner per first contact that has any, drawn at random.
    """
    cone = np.cos(np.arctan(friction))
    line = points[None, :, :] - points[:, None, :]  # [i, j] = p_j − p_i
    dist = np.linalg.norm(line, axis=-1)
    u = line / np.maximum(dist, 1e-12)[..., None]
    # the finger at p_i pushes along +u (into the surface: against n_i); at p_j along −u
    ok = (
        (dist > 0.004)
        & (dist < max_width - 0.004)
        & (np.einsum("ijk,ik->ij", u, -normals) > cone)
        & (np.einsum("ijk,jk->ij", u, normals) > cone)
    )
    first = np.flatnonzero(ok.any(axis=1))
    second = np.array([rng.choice(np.flatnonzero(ok[i])) for i in first], dtype=int)
    mid = (points[first] + points[second]) / 2
    return mid.reshape(-1, 3), u[first, second].reshape(-1, 3)


def side_normals(
    midpoints: np.ndarray, lines: np.ndarray, points: np.ndarray, normals: np.ndarray
) -> np.ndarray:
    """For each grasp, the outward normal (M, 3) of the nearest "side" of the object,
    projected onto the plane normal to the closing line and normalised.

    A side is a surface sample whose normal is within 60° of that plane (so not a face the
    fingers press on); the nearest one to the contacts' midpoint is where fingers that close
    along the line enter the object with the least depth. Grasps without such a sample get
    NaN rows.
    """
    along = normals @ lines.T  # [p, m] normal component along grasp m's closing line
    side = np.abs(along) < np.cos(np.deg2rad(30.0))
    dist = np.linalg.norm(points[:, None, :] - midpoints[None, :, :], axis=-1)
    nearest = np.argmin(np.where(side, dist, np.inf), axis=0)
    n = normals[nearest] - along[nearest, np.arange(len(lines))][:, None] * lines
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    ok = side[nearest, np.arange(len(lines))][:, None] & (norm > 1e-6)
    return np.where(ok, n / np.maximum(norm, 1e-12), np.nan)


def randomised_frames(
    midpoints: np.ndarray,
    lines: np.ndarray,
    outward: np.ndarray,
    cfg: DatabaseConfig,
    rng: np.random.Generator,
) -> np.ndarray:
    """``T_object_tcp`` candidates (M, 4, 4) around antipodal pairs.

    The closing axis starts on the contact line; the approach ``e_x`` points against
    ``outward`` (:func:`side_normals`; the hand comes in through the nearest side), turned
    about the closing axis by a uniform angle within ``±cfg.approach_cone`` (uniform over the
    circle where ``outward`` is NaN); the frame tilts by up to ``cfg.tilt`` about ``e_y``; the
    TCP moves by ``cfg.offset`` along the approach; half of the frames are flipped (the same
    grasp). Approaching along the inward normal makes the approach a function of where the
    TCP sits on the object, as in VGN's sampler, so grasps that share a voxel share an
    approach (up to the cone) rather than spreading over the whole circle.
    """
    n = len(midpoints)
    e_z = lines
    free = np.isnan(outward[:, 0])
    helper = np.where(np.abs(e_z[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    a = np.cross(e_z, helper)
    a = np.where(free[:, None], a, -np.nan_to_num(outward))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(e_z, a)
    theta = np.where(
        free, rng.uniform(-np.pi, np.pi, n), rng.uniform(-cfg.approach_cone, cfg.approach_cone, n)
    )[:, None]
    e_x = np.cos(theta) * a + np.sin(theta) * b
    R = np.stack([e_x, np.cross(e_z, e_x), e_z], axis=-1)
    tilt = Rotation.from_rotvec(
        np.c_[0 * theta, rng.uniform(-cfg.tilt, cfg.tilt, (n, 1)), 0 * theta]
    )
    R = R @ tilt.as_matrix()
    flip = rng.random(n) < 0.5
    R[flip] = R[flip] @ np.diag([1.0, -1.0, -1.0])
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = R
    T[:, :3, 3] = midpoints + rng.uniform(*cfg.offset, (n, 1)) * R[:, :, 0]
    return T


def build_database(
    obj: ObjectSpec, gripper: GripperSpec, cfg: DatabaseConfig = DatabaseConfig(), seed: int = 0
) -> GraspDatabase:
    """Sample, close and score grasps on ``obj`` until ``cfg.grasps`` are held (or
    ``cfg.max_candidates`` closures were tried); closures that hold nothing are kept with
    ``held`` False and zero scores. Deterministic for a given seed. The closures and scores
    of `OnDemandDatabase`, every score measured."""
    return OnDemandDatabase(obj, gripper, cfg, seed).complete()


class OnDemandDatabase:
    """The database `build_database` makes, whose scores are measured when first read.

    The closures are made at once (same seed: the same candidates and settled grasps) and the
    settled state of each held grasp is kept; the score of grasp ``g`` along direction ``k`` is
    measured from that state the first time it is read (`measure`). A force ramp starts from
    its grasp's settled state alone (`symgrasp.sim.execute.pull_out_forces`), so a score does
    not depend on which others were measured before and equals `build_database`'s bit for bit.

    Why: a scene reads a grasp's score only along the directions nearest its gravity
    (`score_along`: three of K) and only for the grasps its collision check keeps (≈ 7 %),
    while the ramps are 70–89 % of a whole database's time (docs/data.md). A database read by
    a few scenes, as the oracle's (`symgrasp.peers.oracle`: every object a round draws is new),
    costs its closures and a small part of its ramps.

    Attributes: those of `GraspDatabase`; ``resisted_force`` and ``score`` are NaN where a
    held grasp was not measured yet. The object's world stays in memory (one MuJoCo model).
    """

    def __init__(
        self,
        obj: ObjectSpec,
        gripper: GripperSpec,
        cfg: DatabaseConfig = DatabaseConfig(),
        seed: int = 0,
    ) -> None:
        rng = np.random.default_rng(seed)
        T_world_object = np.eye(4)
        T_world_object[:3, 3] = FLOAT_POSITION
        world = World([obj], T_world_object[None], gripper=gripper)
        world.set_gravity(np.zeros(3))
        start = world.snapshot()
        poses, widths, forces, held, settled = [], [], [], [], []
        tried = placed = 0
        # ``placed`` also counts candidates whose open hand starts in collision, so an object
        # that admits no collision-free placement cannot loop forever
        while (
            sum(held) < cfg.grasps
            and tried < cfg.max_candidates
            and placed < 10 * cfg.max_candidates
        ):
            points, normals = surface_samples(obj, cfg.surface_points, rng)
            mid, line = antipodal_pairs(points, normals, obj.friction, gripper.max_width, rng)
            if not len(mid):
                break
            outward = side_normals(mid, line, points, normals)
            for T_object_tcp in randomised_frames(mid, line, outward, cfg, rng):
                if sum(held) >= cfg.grasps or tried >= cfg.max_candidates:
                    break
                placed += 1
                world.restore(start)
                world.set_hand_pose(T_world_object @ T_object_tcp)
                if world.hand_in_collision():
                    continue  # the open hand would start inside the object
                tried += 1
                world.actuate(close=True)
                T_wo = world.object_poses()[0]
                poses.append(np.linalg.inv(T_wo) @ world.hand_pose())
                widths.append(world.finger_opening())
                forces.append(world.hand_contact_force())
                held.append(bool(world.objects_in_hand()))
                settled.append((world.snapshot(), T_wo[:3, :3]) if held[-1] else None)
        n = len(poses)
        self.T_object_tcp = np.asarray(poses).reshape(n, 4, 4)
        self.width = np.asarray(widths, dtype=float)
        self.contact_force = np.asarray(forces, dtype=float)
        self.held = np.asarray(held, dtype=bool)
        self.directions = fibonacci_directions(cfg.directions)
        self.candidates = tried
        self.resisted_force = np.where(self.held[:, None], np.nan, np.zeros((n, cfg.directions)))
        self._cfg = cfg
        self._weight = obj.mass * GRAVITY
        self._world = world
        self._settled = settled  # (snapshot, R_world_object) of each held grasp, else None
        self._rescore()

    def __len__(self) -> int:
        return len(self.width)

    def _rescore(self) -> None:
        # over the whole (N, K) array, as build_database always scored: NumPy's vectorised
        # log1p may round an element differently in another position or array size
        self.score = rejection_score(self.resisted_force, self._weight, self._cfg.score_clip)

    def measure(self, grasps: np.ndarray, directions: np.ndarray) -> None:
        """Measure the scores of ``grasps`` (indices into all N) along ``directions`` (indices
        into K) that are not measured yet; grasps that hold nothing score zero already."""
        directions = np.asarray(directions, dtype=int).reshape(-1)
        max_force = self._cfg.score_clip * self._weight
        changed = False
        for g in np.asarray(grasps, dtype=int).reshape(-1):
            missing = directions[np.isnan(self.resisted_force[g, directions])]
            if not len(missing):
                continue
            state, R_world_object = self._settled[g]
            self._world.restore(state)
            # object frame → world, one product per direction as ever (the same bits)
            pulls = np.array([R_world_object @ u for u in self.directions[missing]])
            self.resisted_force[g, missing] = pull_out_forces(
                self._world, 0, pulls, max_force, max_force / self._cfg.ramp_time, self._cfg.slip
            )
            changed = True
        if changed:
            self._rescore()

    def score_along(self, query: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """`GraspDatabase.score_along`, measuring first what it reads of ``rows`` (indices
        into the held grasps; all if None); the other held grasps' entries may be NaN."""
        held = np.flatnonzero(self.held)
        self.measure(
            held if rows is None else held[rows], interpolation_support(self.directions, query)
        )
        return interpolate(self.score[self.held], self.directions, query)

    def complete(self) -> GraspDatabase:
        """The whole database, every score measured."""
        self.measure(np.flatnonzero(self.held), np.arange(len(self.directions)))
        return GraspDatabase(
            T_object_tcp=self.T_object_tcp,
            width=self.width,
            contact_force=self.contact_force,
            held=self.held,
            resisted_force=self.resisted_force,
            score=self.score,
            directions=self.directions,
            candidates=self.candidates,
        )


def database_key(obj: ObjectSpec, gripper: GripperSpec, cfg: DatabaseConfig, seed: int) -> str:
    """Cache key: a hash of the object's parameters (a convex part's vertices included), the
    gripper's whole spec (an edited spec file is a new gripper), the configuration, seed."""
    text = json.dumps(
        [dataclasses.asdict(obj), gripper.to_dict(), dataclasses.asdict(cfg), seed],
        sort_keys=True,
        default=lambda array: array.round(7).tolist(),
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def database_path(
    cache_dir: str | Path, obj: ObjectSpec, gripper: GripperSpec, cfg: DatabaseConfig, seed: int
) -> Path:
    """Where the database of ``obj`` and ``gripper`` is cached in ``cache_dir``."""
    return (
        Path(cache_dir) / f"{obj.name}_{gripper.name}_{database_key(obj, gripper, cfg, seed)}.npz"
    )


def read_cached(path: str | Path) -> GraspDatabase | None:
    """The database cached at ``path``; None (with a warning if the file is corrupted) when
    it must be built."""
    path = Path(path)
    if path.exists():
        try:
            return GraspDatabase.load(path)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
            warnings.warn(f"recomputing the corrupted grasp database {path} ({err})", stacklevel=2)
    return None


def cached_database(
    obj: ObjectSpec,
    gripper: GripperSpec,
    cache_dir: str | Path,
    cfg: DatabaseConfig = DatabaseConfig(),
    seed: int = 0,
) -> GraspDatabase:
    """The database of ``obj`` and ``gripper`` from ``cache_dir``, built on the first call."""
    path = database_path(cache_dir, obj, gripper, cfg, seed)
    db = read_cached(path)
    if db is None:
        db = build_database(obj, gripper, cfg, seed)
        db.save(path)
    return db
