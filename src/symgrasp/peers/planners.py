"""Any planner's name resolved once, at the edge: what ``symgrasp detect --model`` and ``symgrasp
bench declutter --model`` play.

A name is a shipped model or a checkpoint file (`symgrasp.detect.GraspDetector`), ``vgn``
(VGN's network from the data folder, `symgrasp.peers.vgn`), ``oracle`` (the scene's training
labels read from the simulator, `symgrasp.peers.oracle`), or ``package.module:NAME`` (a
user's planner, `symgrasp.peers.plugin`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from symgrasp.detect.detector import GraspDetector
from symgrasp.detect.planner import GraspPlanner
from symgrasp.detect.pretrained import resolve_model
from symgrasp.digest import file_sha256
from symgrasp.names import ORACLE_GRIPPER, planner_kind
from symgrasp.peers.oracle import OraclePlanner
from symgrasp.peers.plugin import load_plugin
from symgrasp.peers.vgn import VGN, check_weights
from symgrasp.sim.grippers import GripperSpec, get_gripper


def load_planner(
    name: str | Path,
    gripper: GripperSpec | str | None = None,
    device: str = "cpu",
    **options: Any,
) -> GraspPlanner:
    """The planner ``name`` names (module docstring), on ``device``. ``gripper`` (a spec or a
    built-in's name): the hand for a planner that takes any (``vgn``, ``oracle``, a user's
    function); a checkpoint decides its own, and a hand other than it is refused.
    ``options``: keyword arguments of `GraspDetector` (all of them: a shipped model's
    operating point is not read from its card here), `symgrasp.peers.vgn.VGN` or
    `symgrasp.peers.oracle.OraclePlanner` (which runs no network: ``device`` is not its).
    Raises ValueError naming what is wrong, `symgrasp.objects.folder.MissingData` when VGN's weights are not in the data
    folder."""
    hand = gripper if gripper is None or isinstance(gripper, GripperSpec) else get_gripper(gripper)
    kind = planner_kind(str(name))
    if kind == "vgn":
        return VGN(hand or "franka", device=device, **options)
    if kind == "oracle":
        return OraclePlanner(hand or ORACLE_GRIPPER, **options)
    if kind == "plugin":
        if options:
            raise ValueError(
                f"planner {name} takes no detector options, got {', '.join(sorted(options))}"
            )
        return load_plugin(str(name), hand)
    # a benchmark records its planner's options whole: a model card's operating point is
    # resolved where the options are given (`symgrasp.detect.pretrained.shipped_operating_point`)
    detector = GraspDetector.from_pretrained(name, device=device, operating_point=False, **options)
    if hand is not None and hand != detector.gripper:
        raise ValueError(
            f"model {name} was trained for the {detector.gripper.name!r} gripper, not "
            f"{hand.name!r}: the checkpoint decides the hand"
        )
    return detector


def planner_version(
    name: str | Path, gripper: GripperSpec | str | None = None, **options: Any
) -> str:
    """The SHA-256 of what ``name`` plays, without building a network: the checkpoint file,
    VGN's weights file, the oracle's ``version`` (its source and database configuration) or
    a user's planner's (its source file's hash). ``options``: the planner's keyword arguments
    (`load_planner`), which only the oracle's version depends on."""
    kind = planner_kind(str(name))
    if kind == "oracle":
        return load_planner(name, gripper, **options).version
    if kind == "vgn":
        return file_sha256(check_weights())
    if kind == "plugin":
        return load_planner(name, gripper).version
    return file_sha256(resolve_model(name))
