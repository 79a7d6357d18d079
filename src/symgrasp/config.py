"""The configurations of symgrasp's jobs: plain dataclasses, one per job, each field documented.

A configuration holds names and numbers only, so that it can be saved beside what it made
(a dataset's manifest, a checkpoint, a benchmark's results) and compared with the next run's.
This module imports nothing of symgrasp but `symgrasp.names`: the command line builds its
options from these fields and their documentation (`symgrasp.fields.field_docs`) and answers
``--help`` without loading torch or MuJoCo. The packages use the configurations where the work
is done (`symgrasp.data`, `symgrasp.model`, `symgrasp.benchmark`), and resolve the names they
hold there, once (a gripper by `symgrasp.sim.grippers.get_gripper`, an object set by
`symgrasp.objects.sets.resolve`).
"""

from __future__ import annotations

import json
import math
import numbers
import re
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from symgrasp.names import (
    BACKENDS,
    DECOMPOSITIONS,
    MESH_UNITS,
    NOISES,
    PROTOCOLS,
    REPRESENTATIONS,
    SCENES,
    SCHEDULES,
    VALIDITY_LOSSES,
    VIEWS,
)

SEED_MAX = 2**32 - 1
"""Seeds are integers in [0, SEED_MAX] (what numpy and torch both accept)."""

MAX_OBJECTS = 20
"""Most objects a benchmark round drops into the 30 cm workspace (VGN drops 5)."""

MAX_VIEWS = 36
"""Most depth images a benchmark attempt renders (VGN renders 6)."""

ONE_VIEW = ("fixed", "side")
"""The views of `VIEWS` that are one camera: their ``views`` is 1."""


def check_global_batch(batch_size: int, world: int) -> None:
    """Raise ValueError unless ``world`` ranks can split the global batch evenly."""
    if batch_size % world:
        raise ValueError(
            f"batch_size {batch_size} must be a multiple of the {world} training processes: "
            "it is the global batch, split evenly between them"
        )


def check_range(name: str, value: Any, lo: float, hi: float, integer: bool = True) -> None:
    """Raise ValueError naming ``name`` unless ``value`` is a finite number (an integer where
    ``integer``) in [lo, hi]: arguments are checked before any work starts, with bounds where
    memory or time would otherwise explode."""
    kind = numbers.Integral if integer else numbers.Real
    if not (isinstance(value, kind) and not isinstance(value, bool) and lo <= value <= hi):
        what = "an integer" if integer else "a number"  # NaN fails the comparison too
        raise ValueError(f"{name} must be {what} in [{_number(lo)}, {_number(hi)}], got {value!r}")


DEVICE = re.compile(r"auto|cpu|cuda(:\d+)?")
"""The devices symgrasp runs on: "auto" (CUDA when available, else the CPU), "cpu", "cuda" or
"cuda:N"."""


def check_device(name: Any) -> None:
    """Raise ValueError unless ``name`` is one of `DEVICE`'s (whether this machine has CUDA is
    `symgrasp.device.resolve_device`'s to say, with torch)."""
    if not (isinstance(name, str) and DEVICE.fullmatch(name)):
        raise ValueError(f"device must be 'auto', 'cpu' or 'cuda[:N]', got {name!r}")


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _number(x: float) -> str:
    return str(x) if isinstance(x, int) else f"{x:g}"


def _check_interval(name: str, value: tuple[float, float], lo: float, hi: float) -> None:
    if len(value) != 2:
        raise ValueError(f"{name} must be two numbers (low, high), got {value!r}")
    check_range(f"{name}[0]", value[0], lo, hi, integer=False)
    check_range(f"{name}[1]", value[1], value[0], hi, integer=False)


def _check_mesh_unit(value: str) -> None:
    if value not in MESH_UNITS:
        raise ValueError(f"mesh_unit must be one of {MESH_UNITS}, got {value!r}")


DEFAULT_VALIDITY = 0.08
"""The detector's validity threshold, chosen by declutter rounds on training objects
(docs/detect.md): the validity head is calibrated to the rare valid voxels (≈ 0.1 % of the
grid), so its probabilities are low on unfamiliar piles, and 0.5 left most rounds without a
grasp."""

TABLE_CLEARANCE = 0.001
"""Gap [m] the open hand keeps from the table: the labels' collision check (`DataConfig`'s
``clearance``: boxes grown by it, held it above the table) and the declutter benchmark's
choice of a grasp to execute (`symgrasp.benchmark.declutter.first_free`), so that a detector
executes only what its labels could have taught. Before 2026-11-27 the benchmark let the
hand's boxes, shrunk by 2 mm, sink 2 mm below the table (``table_clearance`` −0.002): a pad of a
tilted grasp up to ≈ 5 mm deep, which the physics stops as an approach collision
(docs/benchmark.md, "The table in the approach check")."""

SURFACE_CLEARANCE = 0.001
"""Gap [m] the open hand keeps from the *observed* surface for the declutter benchmark to
execute a grasp (`symgrasp.benchmark.declutter.first_free`): the labels' clearance
(`DataConfig`'s ``clearance``, kept from the true meshes), chosen on training rounds of three
detectors (docs/benchmark.md, "The observed surface in the approach check"). Until 2026-11-27 18:00 UTC
the benchmark let the observed points lie 2 mm inside the hand's boxes (−0.002)."""

TEST_SEED_LIMIT = 10_000
"""Declutter round seeds below this are reserved for test benchmarks (the docs' tables use
0…99 and 1000…1099): model selection (`symgrasp.benchmark.selection`) never plays them."""

VALIDATION_SEED = 1_000_000
"""Round seed 0 of the declutter validation that selects checkpoints, far from every test
seed."""

JUDGE_SEED = 2_000_000
"""Round seed 0 of the judging rounds on training objects (choosing among finished runs, a
recipe, a model's validity threshold): off the test seeds and off the checkpoint selection's."""

VALIDATION_OBJECTS = "vgn-pile-train"
"""The object set of the declutter validation: training objects."""

VALIDATION_ROUNDS = 200
"""Rounds of a declutter validation: ≈ 450 executed grasps, an SR interval of about ±4 points.
Checkpoints of one run differ by a few points (the 8 epochs of a 7 200-scene run: test SR
67.7–83.6, 100 rounds each), which the ±9 points of 50 rounds cannot rank; 200 rounds take
≈ 2–3 min per checkpoint on one core."""


@dataclass(frozen=True)
class DatabaseConfig:
    """How a per-object grasp database is built (`symgrasp.data.grasp_db`)."""

    grasps: int = 300
    """Settled, held grasps to collect per object and gripper."""
    max_candidates: int | None = None
    """Most closures to try before giving up on reaching ``grasps``; default max(2000,
    4 · grasps), room for hard objects where most closures hold nothing."""
    surface_points: int = 1500
    """Surface samples the antipodal pairs are drawn from."""
    approach_cone: float = math.radians(30.0)
    """Half-angle [rad] of the cone about the inward normal of the nearest side face in which
    the approach e_x is drawn."""
    tilt: float = 0.2
    """Largest random tilt [rad] of the closing axis away from the contact line."""
    offset: tuple[float, float] = (-0.01, 0.03)
    """Range [m] of the TCP offset along the approach from the contacts' midpoint: positive
    pushes the palm towards the object (power grasps), negative pinches with the tips."""
    directions: int = 32
    """Number K of disturbance directions of the gravity-rejection score."""
    score_clip: float = 200.0
    """Resisted force C, in units of the object's weight, at which the score saturates."""
    ramp_time: float = 0.3
    """Seconds for a force ramp to reach score_clip · m · g."""
    slip: float = 0.005
    """Object displacement relative to the hand [m] that ends a ramp."""

    def __post_init__(self) -> None:
        check_range("grasps", self.grasps, 1, 100_000)
        if self.max_candidates is None:
            object.__setattr__(self, "max_candidates", max(2000, 4 * self.grasps))
        check_range("max_candidates", self.max_candidates, self.grasps, 10**7)
        check_range("surface_points", self.surface_points, 10, 10**6)
        check_range("approach_cone", self.approach_cone, 0, math.pi / 2, integer=False)
        check_range("tilt", self.tilt, 0, math.pi / 2, integer=False)
        _check_interval("offset", self.offset, -0.1, 0.1)
        check_range("directions", self.directions, 4, 1024)
        check_range("score_clip", self.score_clip, 1e-3, 1e6, integer=False)
        check_range("ramp_time", self.ramp_time, 1e-3, 60, integer=False)
        check_range("slip", self.slip, 1e-4, 0.1, integer=False)


TRAINING_DATABASE = DatabaseConfig(grasps=150, directions=16)
"""The grasp databases of the shipped models' training data (VGN's training meshes: 150 held
grasps, 16 directions, the rest the defaults; docs/data.md,
experiments/campaigns/robust_training.toml): what the oracle planner reads unless told
otherwise (`symgrasp.peers.oracle`)."""


@dataclass(frozen=True)
class SceneConfig:
    """What a dataset is made of: everything that changes its content (`symgrasp.data`)."""

    object_set: str = "household-train"
    """Object set the pool is drawn from: a name, a folder of URDF files or bare meshes, or
    mesh sets and folders joined by commas (`symgrasp.objects.sets.resolve`)."""
    mesh_unit: str = "auto"
    """Length unit of bare mesh files: m, cm, mm, or auto (millimetres when a mesh is longer
    than 2 units, else metres)."""
    decomposition: str = DECOMPOSITIONS[0]
    """How bare meshes are cut into convex parts, each collided as one convex geom: vhacd-32
    (V-HACD, at most 32 parts), vhacd (V-HACD's defaults, at most 64), coacd (CoACD's
    defaults, the only decomposition before these presets) or coacd-fast (CoACD, a shorter
    search); each preset's parts are cached apart (docs/objects.md). URDF objects and the
    procedural sets are not cut."""
    gripper: str = "robotiq-2f85"
    """The gripper whose grasps are labelled: a built-in's name or a .toml spec file (the
    dataset stores the whole spec)."""
    pool_size: int = 16
    """Objects in the pool the scenes draw from (one grasp database each)."""
    pool_seed: int = 0
    """Seed of the pool's object parameters."""
    kinds: tuple[str, ...] = SCENES
    """Scene kinds, drawn uniformly."""
    mean_objects: float = 4.0
    """N = Poisson(mean_objects) + 1 objects per scene (VGN)."""
    max_objects: int = 10
    """N is capped here."""
    k_max: int = 8
    """Rotation targets kept per voxel."""
    camera_distance: tuple[float, float] = (0.45, 0.7)
    """Range [m] of the camera's distance to the workspace centre."""
    camera_polar: tuple[float, float] = (0.1, math.pi / 3)
    """Range [rad] of the camera's angle from the vertical."""
    surface_spacing: float = 0.003
    """Spacing [m] of the surface samples of the swept-hand collision check."""
    clearance: float = TABLE_CLEARANCE
    """Gap [m] the open hand must keep from objects and table (negative: allowed
    penetration)."""
    label_spread: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    """How far [m] a surviving grasp's TCP may move and still hold: back and forward along
    the approach e_x, then either way along e_y and along the closing axis e_z. Every voxel
    whose centre such a move reaches, and where the open hand passes the collision check too,
    is labelled with the grasp's rotation, score and width (0 0 0 0: only the voxel holding
    the TCP)."""
    database: DatabaseConfig = field(default_factory=DatabaseConfig)
    """How the per-object grasp databases are built."""
    noise: str = "none"
    """Depth noise of each scene's image before it is fused: none, or dex (the declutter
    benchmark's --noise dex, one function for both: the image times Gamma(k = 1000,
    θ = 0.001), and with probability 0.5 plus a 5 mm Gaussian field drawn on a 4× coarser grid,
    upsampled), drawn from the dataset's seed and the scene's id alone (docs/data.md, "Depth
    noise"). The labels do not change."""
    table_scale: bool = False
    """Divide each noisy image by the depth scale read off the table before it is fused
    (`symgrasp.perception.table_scaled`: the robot's sensing of the benchmark's --table-scale),
    so that the TSDF shows the surfaces where the labels are: the noise's scale factor moves
    the whole image along the rays, and the simulator's labels do not move with it. Needs a
    noise (docs/data.md, "Depth noise")."""

    def __post_init__(self) -> None:
        _check_mesh_unit(self.mesh_unit)
        _check_choice("decomposition", self.decomposition, DECOMPOSITIONS)
        check_noise(self.noise)
        if self.table_scale and self.noise == "none":
            raise ValueError(
                "table_scale needs a depth noise (noise='dex', --noise dex): a noiseless image "
                "is at the table's scale already"
            )
        unknown = set(self.kinds) - set(SCENES)
        if not self.kinds or unknown:
            raise ValueError(f"kinds must be a non-empty subset of {SCENES}, got {self.kinds}")
        check_range("pool_size", self.pool_size, 1, 100_000)
        check_range("pool_seed", self.pool_seed, 0, SEED_MAX)
        check_range("mean_objects", self.mean_objects, 0, 30, integer=False)
        check_range("max_objects", self.max_objects, 1, 30)
        check_range("k_max", self.k_max, 1, 64)
        _check_interval("camera_distance", self.camera_distance, 0.1, 5.0)
        _check_interval("camera_polar", self.camera_polar, 0.0, math.pi / 2)
        check_range("surface_spacing", self.surface_spacing, 5e-4, 0.05, integer=False)
        check_range("clearance", self.clearance, -0.01, 0.05, integer=False)
        if len(self.label_spread) != 4:
            raise ValueError(
                f"label_spread must be four distances (back, forward, e_y, e_z), got "
                f"{self.label_spread!r}"
            )
        for name, value in zip(("back", "forward", "e_y", "e_z"), self.label_spread, strict=True):
            check_range(f"label_spread ({name})", value, 0, 0.05, integer=False)


@dataclass(frozen=True)
class NetworkConfig:
    """What fixes the network's shape (`symgrasp.model.network.GraspNet`)."""

    representation: str = "bingham2d"
    """Rotation representation of the rotation head."""
    widths: tuple[int, int, int, int] = (8, 16, 32, 64)
    """Network channels at 40³, 20³, 10³ and 5³."""
    features: int = 16
    """Channels of the feature volume the heads read."""

    def __post_init__(self) -> None:
        if self.representation not in REPRESENTATIONS:
            raise ValueError(
                f"unknown rotation representation {self.representation!r}; "
                f"known: {', '.join(REPRESENTATIONS)}"
            )
        if len(self.widths) != 4:
            raise ValueError(f"widths must be 4 channel counts, got {self.widths}")
        for width in self.widths:
            check_range("widths", width, 1, 1024)
        check_range("features", self.features, 1, 1024)
        object.__setattr__(self, "widths", tuple(self.widths))


@dataclass(frozen=True)
class LossWeights:
    """Weights of the three terms in the total loss (`symgrasp.model.loss`)."""

    validity: float = 1.0
    """Weight of the validity loss."""
    score: float = 1.0
    """Weight of the score loss."""
    rotation: float = 1.0
    """Weight of the rotation loss."""

    def __post_init__(self) -> None:
        for name in ("validity", "score", "rotation"):
            check_range(f"weight of the {name} loss", getattr(self, name), 0, 1e6, integer=False)
        if self.validity == self.score == self.rotation == 0:
            raise ValueError(
                "the weights of the validity, score and rotation losses are all 0: the total "
                "loss would be 0 and training would change nothing; give one a positive weight"
            )


def _check_choice(name: str, value: Any, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}, got {value!r}")


@dataclass(frozen=True)
class ValidityLoss:
    """The loss of the validity head (`symgrasp.model.loss`): binary cross-entropy, or the
    focal loss of Lin et al. 2017, which scales each voxel's cross-entropy by (1 − p_t)^γ."""

    kind: str = "bce"
    """Loss of the validity head: "bce" (binary cross-entropy) or "focal" (Lin et al. 2017);
    both are summed over the voxels and divided by the number of valid voxels."""
    focal_gamma: float = 2.0
    """Focusing exponent γ of the focal validity loss (0: cross-entropy)."""
    focal_alpha: float | None = None
    """Weight α of the valid voxels in the focal validity loss, 1 − α of the others (default:
    no weighting)."""
    ignore_band: int = 0
    """Invalid voxels within this many voxels (Chebyshev distance) of a valid voxel of their
    scene are left out of the validity loss: a grasp that holds there may just not have been
    sampled (0: every voxel counts)."""

    def __post_init__(self) -> None:
        _check_choice("validity_loss", self.kind, VALIDITY_LOSSES)
        check_range("focal_gamma", self.focal_gamma, 0, 10, integer=False)
        if self.focal_alpha is not None:
            check_range("focal_alpha", self.focal_alpha, 0, 1, integer=False)
        check_range("ignore_band", self.ignore_band, 0, 8)
        if self.kind == "bce" and (self.focal_gamma != 2.0 or self.focal_alpha is not None):
            raise ValueError(
                "focal_gamma and focal_alpha are options of the focal loss (validity_loss "
                f"'focal'); the validity loss is 'bce', got focal_gamma {self.focal_gamma!r}, "
                f"focal_alpha {self.focal_alpha!r}"
            )


@dataclass
class TrainConfig:
    """Everything a training run depends on (stored in every checkpoint as its `record`)."""

    data: str
    """Dataset folder (`symgrasp.data.dataset.GraspDataset`)."""
    out: str
    """Run folder for checkpoints, metrics.csv and learning_curve.png."""
    network: NetworkConfig = field(default_factory=NetworkConfig)
    """The network's shape: its rotation representation, channels and features."""
    gripper: str = "robotiq-2f85"
    """The gripper the dataset must have been produced for: a built-in's name or a .toml spec
    file (the checkpoint stores the whole spec)."""
    epochs: int = 10
    """Epochs to train."""
    batch_size: int = 4
    """Scenes per batch (per optimizer step)."""
    micro_batch: int = 0
    """Scenes per forward and backward pass (0: the whole batch). Each batch is trained in
    chunks of this many scenes whose gradients add up to the whole batch's: GroupNorm normalises
    every scene alone and each chunk's loss is weighted by its share of the batch's labelled
    voxels. Only speed and memory change, up to float rounding; small chunks stay in the CPU's
    cache (docs/reports/training-speed.md: a batch of 16 in chunks of 2 steps ≈ 1.8× faster on 2
    cores)."""
    lr: float = 1e-3
    """Adam learning rate (the peak of a schedule)."""
    seed: int = 0
    """Seed of the initial weights, the batches and the augmentation."""
    device: str = "auto"
    """"auto" (CUDA if available, else CPU), "cpu", "cuda" or "cuda:N"."""
    autocast: bool = True
    """Run the network's forward passes under bfloat16 autocast on CUDA (the losses stay in
    float32); off, CUDA trains in float32 like the CPU (TF32 convolutions off too), e.g. to add
    runs to a comparison trained on the CPU without putting the precision in it. No effect on
    the CPU."""
    workers: int = 0
    """Data loading processes (0: in the training process)."""
    augment: bool = True
    """Let the dataset augment the training split."""
    resume: bool = False
    """Continue the run in ``out`` from its last.pt; with none there, start it (so a script
    that runs across sessions can always pass it)."""
    loss_weights: LossWeights = field(default_factory=LossWeights)
    """Weights of the loss terms."""
    schedule: str = "constant"
    """Learning-rate schedule over all optimizer steps of the run: "constant", "cosine" (decay
    to min_lr) or "onecycle" (up from lr/25 over the warmup fraction, then down to min_lr);
    see docs/model.md."""
    warmup: float = 0.0
    """Fraction of all optimizer steps spent warming up: linearly from 0 to lr for constant and
    cosine, the rising phase of onecycle (which needs it above 0)."""
    min_lr: float = 0.0
    """Learning rate at the last step of a cosine or onecycle schedule."""
    ema: float = 0.0
    """Decay of the exponential moving average of the weights, updated after every optimizer
    step, in [0, 1) (0: off); when on, validation, best.pt and the checkpoints' model are the
    average."""
    weight_decay: float = 0.0
    """Decoupled weight decay (AdamW) of every weight (0: plain Adam)."""
    validity: ValidityLoss = field(default_factory=ValidityLoss)
    """The loss of the validity head."""
    train_scenes: int = 0
    """Train on the first N scenes of the train split by scene id (0: all); the validation split
    is unchanged."""
    val_scenes: int = 0
    """Validate on the first N scenes of the val split by scene id (0: all): runs on nested
    training sets of one dataset then share one validation set of a chosen cost."""
    keep_every: int = 0
    """Also keep epoch_NNN.pt (what last.pt holds then) every N epochs (0: never)."""

    def __post_init__(self) -> None:
        if not self.data or not self.out:
            raise ValueError(f"data and out must be folder paths, got {self.data!r}, {self.out!r}")
        check_range("epochs", self.epochs, 1, 100_000)
        check_range("batch_size", self.batch_size, 1, 4096)
        check_range("micro_batch", self.micro_batch, 0, 4096)
        check_range("lr", self.lr, 1e-12, 10.0, integer=False)
        check_range("seed", self.seed, 0, SEED_MAX)
        check_device(self.device)
        check_range("workers", self.workers, 0, 64)
        _check_choice("schedule", self.schedule, SCHEDULES)
        check_range("warmup", self.warmup, 0, 1, integer=False)
        if self.schedule == "onecycle" and not 0 < self.warmup < 1:
            raise ValueError(
                f"the onecycle schedule needs warmup in (0, 1), the fraction of its rising phase "
                f"(Smith & Topin use 0.3), got {self.warmup!r}"
            )
        check_range("min_lr", self.min_lr, 0, self.lr, integer=False)
        if self.schedule == "constant" and self.min_lr != 0:
            raise ValueError(
                f"min_lr is where a cosine or onecycle schedule ends; the schedule is "
                f"'constant', got min_lr {self.min_lr!r}"
            )
        if not (_is_number(self.ema) and 0 <= self.ema < 1):  # 1 would never leave the start
            raise ValueError(f"ema must be a number in [0, 1) (0: off), got {self.ema!r}")
        check_range("weight_decay", self.weight_decay, 0, 1, integer=False)
        check_range("train_scenes", self.train_scenes, 0, 10**8)
        check_range("val_scenes", self.val_scenes, 0, 10**8)
        check_range("keep_every", self.keep_every, 0, 100_000)

    def record(self) -> dict[str, Any]:
        """The configuration as checkpoints store it: plain data, flat as it was before
        ``network`` and ``validity`` were nested (their fields beside the others, the validity
        loss's kind as ``validity_loss``), ``loss_weights`` a dict."""
        record: dict[str, Any] = {}
        for key, value in asdict(self).items():
            if key in _STORED_FLAT:
                record.update({_STORED_AS.get(k, k): v for k, v in value.items()})
            else:
                record[key] = value
        return record

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> TrainConfig:
        """The configuration a checkpoint stores (`record`'s form); the fields the checkpoint
        predates take their defaults, which it was trained with."""
        flat = dict(record)
        for name, nested in _STORED_FLAT.items():
            stored = {f.name: _STORED_AS.get(f.name, f.name) for f in fields(nested)}
            flat[name] = nested(**{k: flat.pop(key) for k, key in stored.items() if key in flat})
        flat["loss_weights"] = LossWeights(**flat.get("loss_weights", {}))
        return cls(**flat)


_STORED_FLAT = {"network": NetworkConfig, "validity": ValidityLoss}
"""The configurations nested in `TrainConfig` that checkpoints store flat, as before they were
nested."""

_STORED_AS = {"kind": "validity_loss"}
"""Their fields that checkpoints store under another name."""


def check_noise(noise: str) -> None:
    """Raise ValueError naming the argument unless ``noise`` is one of `NOISES`."""
    if noise not in NOISES:
        raise ValueError(f"noise must be one of {NOISES}, got {noise!r}")


def check_sensing(noise: str, view: str, views: int) -> None:
    """Raise ValueError naming the argument unless ``noise`` is one of `NOISES`, ``view`` one of
    `VIEWS` and ``views`` a number of images it takes (1 for the `ONE_VIEW` cameras)."""
    check_noise(noise)
    if view not in VIEWS:
        raise ValueError(f"view must be one of {VIEWS}, got {view!r}")
    check_range("views", views, 1, MAX_VIEWS)
    if view in ONE_VIEW and views != 1:
        raise ValueError(f"views must be 1 with view {view!r} (one camera), got {views}")


@dataclass(frozen=True, kw_only=True)
class PlannerOptions:
    """What a planner is played with besides its name (`BenchmarkConfig.model`): names and
    numbers, each field None (or off) where the planner's own default applies. Resolved once,
    where the planner loads (`symgrasp.peers.planners.load_planner`: the hand's name to its
    spec); each kind of planner takes only its own (`symgrasp.peers.planners.TAKES`).

    A benchmark records them as the (name, value) pairs of the fields `given`, in field order
    (`BenchmarkConfig.record`): the form ``config.json`` has always had."""

    gripper: str | None = None
    """The hand, a built-in's name or a .toml spec file, of a planner that takes any (vgn,
    the oracle, a user's function; default: vgn's franka, the oracle's robotiq-2f85). A trained
    model decides its own: naming another is refused."""
    validity_threshold: float | None = None
    """A trained model's validity threshold (default: the detector's, `DEFAULT_VALIDITY`)."""
    confidence_threshold: float | None = None
    """A trained model's Bingham confidence threshold; 0 turns it off (default: its
    representation's)."""
    validity_floor: float | None = None
    """A trained model's forced decoding: voxels whose validity lies between this and the
    threshold are ranked after all those above it (default: none)."""
    fallbacks: int | None = None
    """Other rotations a trained model offers for each voxel past a refused approach (default:
    none)."""
    approach_check: bool = False
    """A trained model checks its own grasps' approach against what it sees."""
    grasps: int | None = None
    """Held grasps per object in the oracle's databases (default: `TRAINING_DATABASE`'s)."""
    directions: int | None = None
    """Disturbance directions of the oracle's scores (default: `TRAINING_DATABASE`'s)."""
    offset: tuple[float, float] | None = None
    """Range [m] of the TCP's offset along the approach in the oracle's databases (default:
    `TRAINING_DATABASE`'s)."""
    workspace_origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """World position [m] of the workspace cube's corner, for a trained model and vgn (the
    benchmark's workspace starts at the world's origin)."""

    def __post_init__(self) -> None:
        if self.gripper is not None and not (isinstance(self.gripper, str) and self.gripper):
            raise ValueError(
                f"gripper must be a built-in's name or a .toml spec file, got {self.gripper!r}"
            )
        for name in ("validity_threshold", "validity_floor"):
            if getattr(self, name) is not None:
                check_range(name, getattr(self, name), 0, 1, integer=False)
        if self.confidence_threshold is not None:
            check_range("confidence_threshold", self.confidence_threshold, 0, 1e6, integer=False)
        if self.fallbacks is not None:
            check_range("fallbacks", self.fallbacks, 0, 1000)
        if not isinstance(self.approach_check, bool):
            raise ValueError(f"approach_check must be True or False, got {self.approach_check!r}")
        if self.offset is not None:
            object.__setattr__(self, "offset", tuple(self.offset))
        origin = tuple(self.workspace_origin)
        if len(origin) != 3 or not all(_is_number(x) and math.isfinite(x) for x in origin):
            raise ValueError(
                f"workspace_origin must be 3 finite numbers [m], got {self.workspace_origin!r}"
            )
        object.__setattr__(self, "workspace_origin", origin)
        database = {name: getattr(self, name) for name in ORACLE_OPTIONS}
        DatabaseConfig(**{k: v for k, v in database.items() if v is not None})  # its checks

    def given(self) -> dict[str, Any]:
        """The fields off their defaults, by name, in field order."""
        return {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if getattr(self, f.name) != f.default
        }


ORACLE_OPTIONS = ("grasps", "directions", "offset")
"""The `PlannerOptions` of the oracle (`DatabaseConfig`'s fields of its databases)."""


@dataclass(frozen=True, kw_only=True)
class BenchmarkConfig:
    """What a declutter benchmark runs (`symgrasp.benchmark.runner`): seeds ``seed … seed +
    rounds − 1``. Keyword-only, so a field added later cannot shift a caller's arguments."""

    model: str = "bingham2d-robotiq-2f85"
    """The planner played: a shipped model name, a checkpoint path, vgn (VGN's network, its
    weights in the data folder: docs/peers.md), or your own as package.module:NAME
    (docs/benchmark.md, "Any planner")."""
    objects: str = "household-test"
    """Object set the rounds draw from: a name, a folder of URDF files or bare meshes, or mesh
    sets and folders joined by commas (`symgrasp.objects.sets.resolve`)."""
    mesh_unit: str = "auto"
    """Length unit of bare mesh files: m, cm, mm, or auto (millimetres when a mesh is longer
    than 2 units, else metres)."""
    decomposition: str = DECOMPOSITIONS[0]
    """How bare meshes are cut into convex parts, each collided as one convex geom: vhacd-32
    (V-HACD, at most 32 parts), vhacd (V-HACD's defaults, at most 64), coacd (CoACD's
    defaults, the only decomposition before these presets) or coacd-fast (CoACD, a shorter
    search); each preset's parts are cached apart (docs/objects.md). URDF objects and the
    procedural sets are not cut."""
    scene: str = "pile"
    """How each round's objects are laid out: "pile" or "packed"."""
    num_objects: int = 5
    """Objects per round."""
    rounds: int = 100
    """Rounds to play."""
    seed: int = 0
    """Seed of round 0; round r uses seed + r."""
    options: PlannerOptions = field(default_factory=PlannerOptions)
    """The planner's options (`PlannerOptions`: the hand of a planner that takes any, a
    detector's decoding, the oracle's databases), resolved where the planner loads
    (`symgrasp.peers.planners.load_planner`)."""
    diagnose: bool = True
    """Replay each failed grasp turned about its approach axis to name its failure mode."""
    pictures: bool = False
    """Draw every attempt into pictures/seed_NNNN/ of the output folder."""
    noise: str = "none"
    """Depth noise of every image: none, or dex (GIGA's, after Dex-Net: the image times
    Gamma(k = 1000, θ = 0.001), and with probability 0.5 plus a 5 mm Gaussian field drawn on a
    4× coarser grid, upsampled), drawn from the round's seed, the attempt and the view, the same
    for every planner (docs/sensing.md)."""
    view: str = "fixed"
    """Where the cameras look from: fixed (symgrasp's camera, 45° below horizontal), side (GIGA's,
    30° below horizontal from one side), circle (VGN's: --views cameras around the workspace, 60°
    below horizontal), random (--views cameras drawn each attempt from the training data's
    distribution)."""
    views: int = 1
    """Depth images per attempt, fused: 1 for fixed and side; VGN renders 6 (circle)."""
    table_scale: bool = False
    """The robot reads each image's depth scale off its table (known: 5 cm above the workspace
    floor) and divides the image by it before the planner and the collision check see it
    (`symgrasp.perception.table_depth_scale`): undoes the dex noise's scale factor, for every
    planner alike (docs/sensing.md)."""
    table_clearance: float = TABLE_CLEARANCE
    """Gap [m] the open hand must keep from the table for a grasp to be executed
    (`symgrasp.benchmark.declutter.first_free`); −0.002 plays the rule of the benchmarks before
    2026-11-27 (`TABLE_CLEARANCE`)."""
    surface_clearance: float = SURFACE_CLEARANCE
    """Gap [m] the open hand must keep from the observed surface for a grasp to be executed
    (`symgrasp.benchmark.declutter.first_free`); negative: points that deep inside the hand are
    passed; −0.002 plays the rule of the benchmarks until 2026-11-27 18:00 UTC (`SURFACE_CLEARANCE`)."""
    protocol: str = "symgrasp"
    """Which of the planner's ranked grasps is executed: symgrasp (the first whose open hand, swept
    from the pre-grasp, keeps the two clearances above from the observed scene: symgrasp's
    addition) or paper (the first, unchecked: the paper's and VGN's simulated protocol)."""

    def __post_init__(self) -> None:
        if self.scene not in SCENES:
            raise ValueError(f"scene must be one of {SCENES}, got {self.scene!r}")
        _check_mesh_unit(self.mesh_unit)
        _check_choice("decomposition", self.decomposition, DECOMPOSITIONS)
        check_range("num_objects", self.num_objects, 1, MAX_OBJECTS)
        check_range("rounds", self.rounds, 1, 100_000)
        check_range("seed", self.seed, 0, SEED_MAX - self.rounds)
        check_sensing(self.noise, self.view, self.views)
        check_range("table_clearance", self.table_clearance, -0.01, 0.05, integer=False)
        check_range("surface_clearance", self.surface_clearance, -0.01, 0.05, integer=False)
        if self.protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS}, got {self.protocol!r}")

    def record(self) -> dict[str, Any]:
        """The configuration as a benchmark folder records it (``config.json``): plain JSON
        data, ``options`` the (name, value) pairs of the options given
        (`PlannerOptions.given`), tuples as lists."""
        record = {f.name: getattr(self, f.name) for f in fields(self)}
        return json.loads(json.dumps({**record, "options": list(self.options.given().items())}))


MAX_WORKERS = 4096
"""Most tasks a job runs at once."""


@dataclass(frozen=True)
class ParallelConfig:
    """Where the pure tasks of a job run (`symgrasp.parallel`). Not part of what a job makes:
    the same seed gives the same bytes on every backend and any number of workers."""

    backend: str = "process"
    """"process" (local processes) or "ray" (a Ray cluster; pip install 'symgrasp[cluster]')."""
    workers: int | None = None
    """Tasks run at once: local processes (default 1: in this process), or with ray the tasks in
    flight (default: every CPU of the cluster)."""
    ray_address: str | None = None
    """The Ray cluster to run on: host:port of its head, or "auto" for the one this machine
    belongs to (default: $RAY_ADDRESS, else a local Ray instance with one CPU per worker)."""

    def __post_init__(self) -> None:
        if self.backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS}, got {self.backend!r}")
        if self.workers is not None:
            check_range("workers", self.workers, 1, MAX_WORKERS)
        if self.ray_address is not None and self.backend != "ray":
            raise ValueError(
                f"ray_address {self.ray_address!r} needs backend 'ray' (--backend ray)"
            )
