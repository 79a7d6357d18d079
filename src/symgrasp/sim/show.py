"""Pictures of a simulated scene for people: a colour view and the depth image."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from symgrasp.perception.camera import CameraIntrinsic, default_extrinsic
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
        plt.imsave(paths["color"], GLRenderer(intrinsic).render_color(world, T))
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
