"""Pictures for people: a simulated scene (a colour view and the depth image), and a hand from
its spec, open and closed."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from scipy.spatial import ConvexHull

from symgrasp.perception.camera import CameraIntrinsic, default_extrinsic
from symgrasp.sim.grippers import PREFIX, GripperSpec
from symgrasp.sim.render import GLRenderer, gl_available, make_renderer
from symgrasp.sim.world import World
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE


def _plot_meshes(world: World, path: Path) -> None:
    """Matplotlib fallback for the colour view: the object meshes in 3D."""
    fig = plt.figure(figsize=(6.4, 4.8))
    ax = fig.add_subplot(projection="3d")
    for obj, T in zip(world.objects, world.object_poses(), strict=True):
        mesh = obj.mesh()
        vertices = mesh.vertices @ T[:3, :3].T + T[:3, 3]
        ax.add_collection3d(
            Poly3DCollection(vertices[mesh.faces], facecolor=obj.rgba[:3], edgecolor="none")
        )
    ax.set(xlim=(0, WORKSPACE_SIZE), ylim=(0, WORKSPACE_SIZE), zlim=(TABLE_HEIGHT, WORKSPACE_SIZE))
    ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title="scene (matplotlib fallback)")
    ax.set_box_aspect((1, 1, (WORKSPACE_SIZE - TABLE_HEIGHT) / WORKSPACE_SIZE))
    fig.savefig(path, dpi=100)
    plt.close(fig)


def save_scene_pictures(
    world: World, out: str | Path, stem: str, intrinsic: CameraIntrinsic | None = None
) -> tuple[dict[str, Path], str]:
    """Write ``{stem}_color.png`` and ``{stem}_depth.png`` of ``world`` seen from the default
    camera into ``out``; returns the paths by kind and the name of the depth renderer."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    intrinsic = intrinsic or CameraIntrinsic()
    T = default_extrinsic()
    paths = {"color": out / f"{stem}_color.png", "depth": out / f"{stem}_depth.png"}
    if gl_available():
        plt.imsave(paths["color"], GLRenderer(intrinsic, pictures=True).render_color(world, T))
    else:
        _plot_meshes(world, paths["color"])
    renderer = make_renderer(intrinsic)
    depth = renderer.render(world, T)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    image = ax.imshow(np.where(depth > 0, depth, np.nan), cmap="viridis")
    fig.colorbar(image, ax=ax, label="depth [m]")
    ax.set_title(f"depth ({renderer.name}), {intrinsic.width}×{intrinsic.height}")
    ax.axis("off")
    fig.savefig(paths["depth"], dpi=100, bbox_inches="tight")
    plt.close(fig)
    return paths, renderer.name


_PART_COLOURS = {"palm": "0.65", "link": "tab:blue", "pad": "tab:orange", "finger": "tab:orange"}
"""Fill colour of a hand box by the first word of its name after the prefix."""

_VIEWS = {"side": (2, 0), "front": (2, 1)}
"""TCP-frame axes drawn across and up in each view: the side view looks along e_y (approach
e_x pointing down), the front view along e_x (from the wrist)."""


def _box_outline(
    centre: np.ndarray, rotation: np.ndarray, half: np.ndarray, axes: tuple
) -> np.ndarray:
    """The outline [mm] of a box (TCP frame [m]) projected on the TCP frame's ``axes``."""
    signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    corners = (centre + (signs * half) @ rotation.T)[:, list(axes)] * 1000
    return corners[ConvexHull(corners).vertices]


def _dimension(
    ax: plt.Axes, a: tuple, b: tuple, text: str, at: float = 0.5, **text_options: object
) -> None:
    """A double arrow from ``a`` to ``b`` [mm] labelled ``text`` at fraction ``at`` of it."""
    ax.annotate("", a, b, arrowprops={"arrowstyle": "<->", "lw": 0.8, "shrinkA": 0, "shrinkB": 0})
    where = (1 - at) * np.asarray(a) + at * np.asarray(b)
    ax.text(*where, text, fontsize=8, **{"ha": "center", "va": "center", **text_options})


def _hand_state(gripper: GripperSpec, close: bool) -> tuple[list[str], tuple, float]:
    """Box names, boxes (as `World.hand_boxes`) and pad opening [m] of the simulated hand,
    open or after closing for its ``close_time`` on nothing."""
    world = World([], gripper=gripper)
    if close:
        world.actuate(close=True)
    return world.hand_box_names(), world.hand_boxes(), world.finger_opening()


def save_gripper_png(gripper: GripperSpec, path: str | Path) -> Path:
    """Draw ``gripper``'s simulated hand open and closed, seen from the side and from the front
    (the boxes of its model, which the swept-hand collision check uses), with its dimensions
    annotated [mm] and its spec listed; returns the path."""
    path = Path(path)
    g = gripper
    states = {"open": _hand_state(g, close=False), "closed": _hand_state(g, close=True)}
    fig = plt.figure(figsize=(12, 9), layout="constrained")
    grid = fig.add_gridspec(2, 3, width_ratios=(1.1, 0.8, 0.5))
    top: dict[str, plt.Axes] = {}
    for row, (state, (names, boxes, opening)) in enumerate(states.items()):
        for col, (view, axes) in enumerate(_VIEWS.items()):
            ax = fig.add_subplot(grid[row, col], sharex=top.get(view), sharey=top.get(view))
            for name, *box in zip(names, *boxes, strict=True):
                part = name.removeprefix(PREFIX).split("_")[0]
                outline = _box_outline(*box, axes)
                ax.fill(*outline.T, color=_PART_COLOURS.get(part, "0.4"), alpha=0.85, lw=0.8,
                        edgecolor="k")  # fmt: skip
            ax.plot(0, 0, "k+", ms=10)
            ax.text(-2, 2, "TCP ", fontsize=8, ha="right", va="bottom")
            ax.set_aspect("equal")
            ax.set_xlabel("e_z, closing axis [mm]")
            ax.set_ylabel("e_x, approach (down) [mm]" if view == "side" else "e_y [mm]")
            when = "" if state == "open" else f" after close_time {g.close_time:g} s"
            ax.set_title(f"{state}, {view} view: opening {opening * 1000:.1f} mm{when}", fontsize=9)
            if state == "open":
                _annotate(ax, g, view)
                ax.margins(0.08)
                top[view] = ax
                if view == "side":
                    ax.invert_yaxis()
    text = fig.add_subplot(grid[:, 2])
    text.axis("off")
    text.text(0, 1, _spec_lines(g), family="monospace", fontsize=9, va="top")
    fig.suptitle(f"gripper {g.name!r} ({g.kind}): the boxes of its simulated hand", fontsize=11)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, format="png")  # the path given, whatever its suffix
    plt.close(fig)
    return path


def _annotate(ax: plt.Axes, g: GripperSpec, view: str) -> None:
    """Dimension arrows [mm] of the open hand in ``view``."""
    mm = 1000
    half, thick, tip = g.max_width / 2 * mm, g.pad_thickness * mm, g.tip_beyond_tcp * mm
    face = tip - g.finger_depth * mm  # the palm's face, at the fingers' root
    back = face - g.palm_size[0] * mm
    pz = g.palm_size[2] / 2 * mm
    if view == "front":
        y, py = g.pad_width / 2 * mm, g.palm_size[1] / 2 * mm
        _dimension(ax, (half + thick + 3, -y), (half + thick + 3, y), f" pad_width\n {2 * y:g}",
                   ha="left")  # fmt: skip
        _dimension(ax, (-pz - 4, -py), (-pz - 4, py), f"palm_size[1] \n{2 * py:g} ", ha="right")
        return
    _dimension(ax, (-half, tip + 5), (half, tip + 5), f"max_width {2 * half:g}", va="top")
    side = half + thick + 4
    _dimension(ax, (side, face), (side, tip), f" finger_depth\n {tip - face:.1f}", ha="left")
    _dimension(ax, (-side, 0), (-side, tip), f"tip_beyond_tcp {tip:.1f} ", ha="right")
    ax.plot([-side, 0], [0, 0], "k:", lw=0.6)
    _dimension(ax, (-pz, back - 5), (pz, back - 5), f"palm_size[2] {2 * pz:g}", at=0.75,
               va="bottom")  # fmt: skip
    _dimension(ax, (pz + 4, back), (pz + 4, face), f" palm_size[0]\n {face - back:g}", ha="left")
    flange = -g.tcp_offset * mm
    ax.plot([-10, 10], [flange, flange], "k-", lw=2.5)
    ax.text(-12, flange, "flange", fontsize=8, ha="right", va="center")
    _dimension(ax, (0, flange), (0, 0), f" tcp_offset\n {-flange:g}", ha="left")


def _spec_lines(g: GripperSpec) -> str:
    """The spec as its file's lines, lengths also in mm."""
    lines = []
    for key, value in g.to_dict().items():
        if key == "fingers":
            lines += ["", "[fingers]"]
            lines += [_spec_line(k, v) for k, v in value.items()]
        else:
            lines.append(_spec_line(key, value))
    lines += ["", "derived:", _spec_line("finger_depth", g.finger_depth),
              _spec_line("tip_beyond_tcp", g.tip_beyond_tcp)]  # fmt: skip
    return "\n".join(lines)


def _spec_line(key: str, value: object) -> str:
    if isinstance(value, str):
        return f'{key} = "{value}"'
    if isinstance(value, list):
        return f"{key} = [{', '.join(f'{v:g}' for v in value)}]"
    return f"{key} = {value:g}"
