"""The names a user can pass, defined without importing what they name.

The command line offers them as choices before any heavy module loads (``symgrasp --help``
answers without torch or MuJoCo); each package resolves a name once, at the edge
(`symgrasp.rotation.get`, `symgrasp.sim.get_gripper`, `symgrasp.sim.object_set`, …), and
implements exactly these (tests check it).
"""

from pathlib import Path

REPRESENTATIONS = ("bingham2d", "rotmat6d", "rotmat6d_naive", "quaternion", "bingham3d")
"""Rotation representations (`symgrasp.rotation`)."""

GRIPPERS = ("franka", "robotiq-2f85")
"""Built-in grippers (`symgrasp.sim.grippers`)."""

GRIPPER_SPEC_SUFFIX = ".toml"
"""A gripper is also given by a spec file whose name ends so (`symgrasp.sim.grippers`)."""

PROCEDURAL_OBJECT_SETS = (
    "household-train",
    "household-test",
    "large-box",
    "blocks",
    "thin-boxes-train",
)
"""Object sets built in code (`symgrasp.sim.objects`); they need no files."""

MESH_OBJECT_SETS = ("vgn-pile-train", "vgn-pile-test", "vgn-packed-train", "vgn-packed-test")
"""VGN's household mesh sets, read from the data folder (`symgrasp.objects.folder`)."""

OBJECT_SETS = (*PROCEDURAL_OBJECT_SETS, *MESH_OBJECT_SETS)

TEST_OBJECT_SETS = ("household-test", "large-box", "vgn-pile-test", "vgn-packed-test")
"""The sets that only report: no choice (checkpoint, threshold, operating point) is made on them;
``large-box`` is the paper's precision test (``thin-boxes-train`` stands in for it in choices)."""
"""Named object sets; ``--objects`` also takes a folder of meshes."""

MESH_UNITS = ("auto", "m", "cm", "mm")
"""Length units of bare mesh files (`symgrasp.objects.mesh`); "auto" guesses metres or
millimetres from each mesh's size."""

DECOMPOSITIONS = ("vhacd-32", "vhacd", "coacd", "coacd-fast")
"""Convex decomposition presets of bare meshes, the default first
(`symgrasp.objects.decomposition.PRESETS`)."""

SCENES = ("pile", "packed")
"""Scene kinds (`symgrasp.sim.world`)."""

PROTOCOLS = ("symgrasp", "paper")
"""What the declutter benchmark executes of a planner's ranked grasps: ``symgrasp``, the first
whose approach misses the observed scene (`symgrasp.benchmark.declutter.first_free`);
``paper``, the first, unchecked, as the paper's and VGN's simulated protocol."""

NOISES = ("none", "dex")
"""Depth noise of the declutter benchmark's images (`symgrasp.benchmark.sensing`) and of the
training data's (`symgrasp.data.scenes`): none, or the field's ``dex`` model (GIGA's, after
Dex-Net: `symgrasp.perception.noise`)."""

VIEWS = ("fixed", "side", "circle", "random")
"""Where the declutter benchmark's cameras look from (`symgrasp.benchmark.sensing`): symgrasp's
fixed camera, GIGA's side view, VGN's circle of views, or random views from the training
distribution."""

CUT_OBJECTS = ("flag", "remove", "ignore")
"""What a detector does with the grasps whose hand meets depth points the workspace cube left
out, on an object it cuts (`symgrasp.detect.limits`): flag them (`Grasp.cut`), remove them, or
not look."""

SCHEDULES = ("constant", "cosine", "onecycle")
"""Learning-rate schedules of training (`symgrasp.model.schedule`)."""

VALIDITY_LOSSES = ("bce", "focal")
"""Losses of the validity head (`symgrasp.model.loss`)."""

PRETRAINED = (
    "bingham2d-robotiq-2f85",
    "bingham2d-franka",
    "rotmat6d-robotiq-2f85",
    "rotmat6d-franka",
    "quaternion-robotiq-2f85",
    "quaternion-franka",
    "bingham3d-robotiq-2f85",
    "bingham3d-franka",
)
"""Models shipped with the package (`symgrasp.detect.pretrained`): the paper's detector for
each built-in hand, then seed 0 of each baseline cell of Table 1 (`docs/models.md`)."""

PEERS = ("vgn",)
"""Other people's detectors that symgrasp runs from their published weights in the data folder
(`symgrasp.peers`): VGN's network (Breyer et al., CoRL 2020)."""

ORACLE = "oracle"
"""The planner that reads the simulator's state and returns the scene's training labels
(`symgrasp.peers.oracle`): the upper bound of the declutter benchmark, no detector."""

ORACLE_GRIPPER = "robotiq-2f85"
"""The oracle's hand when none is named: the paper's."""

BACKENDS = ("process", "ray")
"""Where the tasks of data generation and benchmarks run (`symgrasp.parallel`): a pool of
local processes, or a Ray cluster (the optional extra ``cluster``)."""


def demo_model(gripper: str) -> str:
    """The shipped model the demo plays for ``gripper`` when no model is given: the paper's
    ``bingham2d`` trained for that built-in hand; a ValueError for a spec file (no model is
    shipped for it)."""
    if gripper.lower().endswith(GRIPPER_SPEC_SUFFIX):
        raise ValueError(
            f"gripper {gripper} is a spec file: no model is shipped for it; pass a model "
            "trained for it (--model)"
        )
    return f"bingham2d-{gripper}"


PLUGIN_SEPARATOR = ":"
"""Between a user's planner's module and its name: ``package.module:NAME``."""


def is_plugin_name(name: str) -> bool:
    """Whether ``name`` has the form ``package.module:NAME`` (and is no file)."""
    module, sep, attribute = str(name).partition(PLUGIN_SEPARATOR)
    return bool(sep and module and attribute.isidentifier()) and not Path(name).exists()


def planner_kind(name: str) -> str:
    """What plays for the planner name ``name`` (`symgrasp.peers.planners` loads it):
    ``"model"`` (a shipped model or a checkpoint file), a peer's name (`PEERS`), `ORACLE` or
    ``"plugin"`` (a user's ``package.module:NAME``)."""
    if str(name) in (*PEERS, ORACLE):
        return str(name)
    return "plugin" if is_plugin_name(str(name)) else "model"


MEASURE_ALIASES = {"declutter": "declutter_sr_cr", "val_loss": "val_total"}
"""Measure names ``symgrasp select --by`` also takes (`symgrasp.benchmark.selection`)."""

DECLUTTER_MEASURES = ("declutter_sr_cr", "declutter_sr", "declutter_cr")
"""Of the declutter validation: success ratio plus clear ratio (what ``declutter`` selects by),
the success ratio and the clear ratio. SR alone rewards a detector that hardly tries: the
checkpoint that executes one grasp in 200 rounds and lifts it has SR 100 %
(docs/reports/model-selection.md, "Why SR + CR and not SR alone")."""


def measure_direction(measure: str) -> int:
    """+1 when a higher ``measure`` is better (AP, shares, SR, CR), −1 when lower is (losses,
    angles, score error, ``top_empty``); ValueError naming ``--by`` for a column that is no
    measure of quality (bookkeeping, confidences)."""
    name = MEASURE_ALIASES.get(measure, measure)
    higher = ("_valid", "_correct", "_valid_near", "_correct_near")
    if name in DECLUTTER_MEASURES or name == "validity_ap":
        return 1
    if name.startswith("top") and name.endswith(higher):
        return 1
    if name.startswith(("val_", "train_")) or name.endswith("_deg"):
        return -1
    if name in ("score_mae", "top_empty"):
        return -1
    raise ValueError(
        f"--by: {measure!r} is not a measure to select by (no better direction); use declutter "
        "(SR + CR), declutter_sr, declutter_cr, val_loss, a loss (val_*), validity_ap, "
        "score_mae, an angle (*_deg) or a top-k share (top1_valid, top5_correct, …)"
    )
