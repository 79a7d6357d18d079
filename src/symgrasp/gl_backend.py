"""Pick MuJoCo's OpenGL backend before mujoco is first imported.

MuJoCo reads ``MUJOCO_GL`` once, at import, and ``import mujoco`` itself fails when the
chosen backend's library is missing. So: keep an explicit ``MUJOCO_GL``; else use EGL or
OSMesa when their library exists (headless rendering); else, without a display, disable GL
so that mujoco still imports and depth images come from the ray caster.
"""

from __future__ import annotations

import ctypes.util
import os


def choose_gl_backend() -> str:
    """Set ``MUJOCO_GL`` if unset and return its value."""
    if "MUJOCO_GL" not in os.environ:
        if ctypes.util.find_library("EGL"):
            os.environ["MUJOCO_GL"] = "egl"
        elif ctypes.util.find_library("OSMesa"):
            os.environ["MUJOCO_GL"] = "osmesa"
        elif not os.environ.get("DISPLAY"):
            os.environ["MUJOCO_GL"] = "disable"
    return os.environ.get("MUJOCO_GL", "")
