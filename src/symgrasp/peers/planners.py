"""Any planner's name and options resolved once, at the edge: what ``symgrasp detect --model``
and ``symgrasp bench declutter --model`` play.

A name is a shipped model or a checkpoint file (`symgrasp.detect.GraspDetector`), ``vgn``
(VGN's network from the data folder, `symgrasp.peers.vgn`), ``oracle`` (the scene's training
labels read from the simulator, `symgrasp.peers.oracle`), or ``package.module:NAME`` (a
user's planner, `symgrasp.peers.plugin`). Its options are a `symgrasp.config.PlannerOptions`
(names and numbers, as a benchmark records them): `load_planner` resolves the hand's name to
its `GripperSpec` here, and only the spec travels on.
"""

from __future__ import annotations

from pathlib import Path

from symgrasp.config import ORACLE_OPTIONS, PlannerOptions
from symgrasp.detect.detector import GraspDetector
from symgrasp.detect.planner import GraspPlanner
from symgrasp.detect.pretrained import resolve_model
from symgrasp.digest import file_sha256
from symgrasp.names import ORACLE, planner_kind
from symgrasp.peers.oracle import OraclePlanner
from symgrasp.peers.plugin import load_plugin
from symgrasp.peers.vgn import VGN, check_weights
from symgrasp.sim.grippers import get_gripper

DECODING = ("validity_threshold", "confidence_threshold", "validity_floor", "fallbacks")
"""The `PlannerOptions` of a trained model's decoding (`GraspDetector`'s arguments of the same
names)."""

TAKES = {
    "model": ("gripper", *DECODING, "approach_check", "workspace_origin"),
    "vgn": ("gripper", "workspace_origin"),
    ORACLE: ("gripper", *ORACLE_OPTIONS),
    "plugin": ("gripper",),
}
"""The `PlannerOptions` each kind of planner (`symgrasp.names.planner_kind`) takes; a trained
model's ``gripper`` is a guard (the checkpoint decides its hand)."""


def load_planner(
    name: str | Path, options: PlannerOptions = PlannerOptions(), device: str = "cpu"
) -> GraspPlanner:
    """The planner ``name`` names (module docstring), with ``options``, on ``device`` (the
    oracle runs no network). ``options.gripper``: the hand of a planner that takes any
    (default: vgn's franka, the oracle's `symgrasp.names.ORACLE_GRIPPER`; a user's function
    needs one); a checkpoint decides its own, and a hand other than it is refused. A shipped
    model's operating point is not read from its card here: a benchmark records its options
    whole (`symgrasp.detect.pretrained.shipped_operating_point` resolves them where they are
    given). Raises ValueError naming what is wrong (an option of another kind of planner
    among them), `symgrasp.objects.folder.MissingData` when VGN's weights are not in the data
    folder."""
    kind = planner_kind(str(name))
    given = options.given()
    foreign = [option for option in given if option not in TAKES[kind]]
    if foreign:
        raise ValueError(
            f"planner {name} takes no {', '.join(foreign)} (it takes {', '.join(TAKES[kind])})"
        )
    hand = given.pop("gripper", None)
    if hand is not None:
        hand = get_gripper(hand)  # the one resolution of the hand's name
    with_hand = {} if hand is None else {"gripper": hand}
    if kind == "vgn":
        return VGN(**with_hand, device=device, **given)
    if kind == ORACLE:
        return OraclePlanner(**with_hand, **given)
    if kind == "plugin":
        return load_plugin(str(name), hand)
    detector = GraspDetector.from_pretrained(name, device=device, operating_point=False, **given)
    if hand is not None and hand != detector.gripper:
        raise ValueError(
            f"model {name} was trained for the {detector.gripper.name!r} gripper, not "
            f"{hand.name!r}: the checkpoint decides the hand"
        )
    return detector


def planner_version(name: str | Path, options: PlannerOptions = PlannerOptions()) -> str:
    """The SHA-256 of what ``name`` plays, without building a network: the checkpoint file,
    VGN's weights file, the oracle's ``version`` (its source and database configuration, from
    ``options``, whatever the hand) or a user's planner's (loaded with ``options``, so that a
    function without a hand is refused here, before a benchmark writes anything)."""
    kind = planner_kind(str(name))
    if kind == ORACLE:
        given = options.given()
        return OraclePlanner(**{k: given[k] for k in ORACLE_OPTIONS if k in given}).version
    if kind == "vgn":
        return file_sha256(check_weights())
    if kind == "plugin":
        return load_planner(name, options).version
    return file_sha256(resolve_model(name))
