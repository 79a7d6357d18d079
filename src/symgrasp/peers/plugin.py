"""A user's planner named ``package.module:NAME``, played like any other.

``NAME`` is either an object that meets `symgrasp.detect.planner.GraspPlanner` (it has its
own ``gripper``, ``name`` and ``version``), or a function ``observation → grasps`` (best
first), which `FunctionPlanner` makes a planner for a hand the caller names: its ``name`` is
``package.module:NAME`` and its ``version`` the SHA-256 of the module's source file, so a
benchmark's record changes when the code does. The module is imported as Python imports it
(the current folder first on ``sys.path`` for the command line, as ``python -m`` does).
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable, Sequence

from symgrasp.detect.grasp import Grasp
from symgrasp.detect.planner import GraspPlanner, Observation
from symgrasp.digest import file_sha256
from symgrasp.names import PLUGIN_SEPARATOR, is_plugin_name
from symgrasp.sim.grippers import GripperSpec


class FunctionPlanner:
    """A function ``observation → grasps`` as a `GraspPlanner` for ``gripper``."""

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
        grasps = list(self.function(observation))
        wrong = [g for g in grasps if not isinstance(g, Grasp)]
        if wrong:
            raise TypeError(
                f"planner {self.name} must return symgrasp.detect.Grasp objects, got "
                f"{type(wrong[0]).__name__}"
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
        return found
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
