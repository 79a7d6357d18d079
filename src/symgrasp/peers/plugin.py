"""A user's planner named ``package.module:NAME``, played like any other.

``NAME`` is either an object that meets `symgrasp.detect.planner.GraspPlanner` (it has its
own ``gripper``, ``name`` and ``version``), or a function ``observation → grasps`` (best
first), which `FunctionPlanner` makes a planner for a hand the caller names: its ``name`` is
``package.module:NAME`` and its ``version`` the SHA-256 of the module's source file, so a
benchmark's record changes when the code does. The module is imported as Python imports it
(the current folder first on ``sys.path`` for the command line, as ``python -m`` does); a
module that fails to import, whatever it raises, is a ValueError naming the planner.

Every plug-in, function or object, plans through `FunctionPlanner`, which checks what it
returns (`check_grasps`): a sequence of `Grasp`, each with a rigid pose and a finite score, or
a ValueError naming the planner; a planner's output is input to the benchmark, whose collision
check would drop a non-rigid pose and record "none found", and whose ranking would misread a
NaN score.
"""

from __future__ import annotations

import importlib
import inspect
import math
import numbers
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from symgrasp.detect.grasp import Grasp
from symgrasp.detect.planner import GraspPlanner, Observation
from symgrasp.digest import file_sha256
from symgrasp.names import PLUGIN_SEPARATOR, is_plugin_name
from symgrasp.perception.camera import is_rigid
from symgrasp.sim.grippers import GripperSpec


class FunctionPlanner:
    """A function ``observation → grasps`` (a user's, or a planner object's ``plan``) as a
    `GraspPlanner` for ``gripper`` whose grasps are checked (`check_grasps`)."""

    def __init__(
        self,
        function: Callable[[Observation], Sequence[Grasp]],
        gripper: GripperSpec,
        name: str,
        version: str,
    ) -> None:
        self.function, self.gripper, self.name, self.version = function, gripper, name, version

    def __repr__(self) -> str:
        return f"FunctionPlanner({self.name!r}, gripper={self.gripper.name!r})"

    def plan(self, observation: Observation) -> list[Grasp]:
        return check_grasps(self.function(observation), self.name)


def check_grasps(grasps: object, name: str) -> list[Grasp]:
    """``grasps``, what the planner ``name`` returned, as a list: a sequence of `Grasp` whose
    poses ``T_world_tcp`` are rigid 4×4 transforms and whose scores are finite numbers.
    ValueError naming the planner, the grasp and what is wrong otherwise."""
    if grasps is None or isinstance(grasps, (str, bytes, Grasp)) or not hasattr(grasps, "__iter__"):
        raise ValueError(
            f"planner {name} must return a sequence of symgrasp.detect.Grasp, best first ([] "
            f"for none), got {type(grasps).__name__}"
        )
    grasps = list(grasps)
    for i, grasp in enumerate(grasps):
        if not isinstance(grasp, Grasp):
            raise ValueError(
                f"planner {name} must return symgrasp.detect.Grasp objects, got "
                f"{type(grasp).__name__} (grasp {i})"
            )
        pose = np.asarray(grasp.pose, dtype=float)
        if pose.shape != (4, 4) or not is_rigid(pose):
            raise ValueError(
                f"planner {name}: grasp {i}'s pose must be T_world_tcp, a rigid 4×4 transform "
                f"(orthonormal rotation, det +1, last row 0 0 0 1), got shape {pose.shape}"
                + ("" if pose.shape != (4, 4) else f", det {np.linalg.det(pose[:3, :3]):.3g}")
            )
        score = grasp.score
        if not (isinstance(score, numbers.Real) and not isinstance(score, bool)) or not (
            math.isfinite(score)
        ):
            raise ValueError(
                f"planner {name}: grasp {i}'s score must be a finite number, got {score!r}"
            )
    return grasps


def find_plugin(name: str) -> object:
    """The object ``package.module:NAME`` names; ValueError naming what is missing."""
    module_name, _, attribute = name.partition(PLUGIN_SEPARATOR)
    if not is_plugin_name(name):
        raise ValueError(f"planner {name!r}: expected package.module:NAME")
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise ValueError(f"planner {name!r}: cannot import {module_name} ({error})") from None
    except Exception as error:  # the module's own code failed: where, in one line
        raise ValueError(
            f"planner {name!r}: importing {module_name} raised {type(error).__name__}: "
            f"{_first_line(error)} ({_where(error)})"
        ) from None
    if not hasattr(module, attribute):
        raise ValueError(f"planner {name!r}: module {module_name} has no {attribute!r}")
    return getattr(module, attribute)


def load_plugin(name: str, gripper: GripperSpec | None = None) -> GraspPlanner:
    """The planner ``package.module:NAME`` names (module docstring). A function needs
    ``gripper``; an object that is a planner already keeps its own, and ``gripper``, when
    given, must be that one. ValueError naming the planner otherwise."""
    found = find_plugin(name)
    if isinstance(found, GraspPlanner):
        if gripper is not None and found.gripper != gripper:
            raise ValueError(
                f"planner {name} plans for the {found.gripper.name!r} gripper, not {gripper.name!r}"
            )
        return FunctionPlanner(found.plan, found.gripper, found.name, found.version)
    if not callable(found):
        raise ValueError(
            f"planner {name!r} is a {type(found).__name__}: expected a function "
            "observation → grasps or an object with gripper, name, version and plan()"
        )
    if gripper is None:
        raise ValueError(
            f"planner {name} is a function: name the hand its grasps are for (gripper, --gripper)"
        )
    return FunctionPlanner(found, gripper, name, source_sha256(found))


def source_sha256(function: Callable) -> str:
    """The SHA-256 of the file that defines ``function`` ("" when it has none)."""
    try:
        path = inspect.getsourcefile(function)
    except TypeError:
        path = None
    return file_sha256(path) if path else ""


def _first_line(error: BaseException) -> str:
    return (str(error).strip().splitlines() or [""])[0]


def _where(error: BaseException) -> str:
    """``file:line`` where ``error`` was raised: for a syntax error the line it names, else the
    innermost frame of its traceback."""
    if isinstance(error, SyntaxError) and error.filename:
        return f"{Path(error.filename).name}:{error.lineno}"
    frame = traceback.extract_tb(error.__traceback__)[-1]
    return f"{Path(frame.filename).name}:{frame.lineno}"
