"""Pictures of detected grasps: gripper outlines over the point cloud, as a PNG or an HTML page.

A grasp is drawn as the U-shaped outline of an open parallel gripper (:func:`gripper_outline`):
two fingers along the approach axis ``e_x`` at ``±width/2`` along the closing axis ``e_z``, the
palm bar joining them and a stem behind the palm, so both axes of ``T_world_tcp`` can be read
off the picture. Grasps are coloured by their gravity-rejection score on a fixed ``[0, 1]``
scale, so pictures of different scenes compare.

- :func:`save_grasps_png`: a 3-D view and a top view, for reports (matplotlib, Agg).
- :func:`save_grasps_html`: one self-contained page with a small canvas viewer (drag to orbit,
  wheel to zoom) that can also show samples of each grasp's closing-axis distribution.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize, to_hex
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from symgrasp.atomic import write_atomic
from symgrasp.sim.grippers import GripperSpec
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

STEM_LENGTH = 0.04
"""Length of the outline's stem behind the palm, along ``−e_x`` [m]."""

SAMPLE_HALF_LENGTH = 0.015
"""Half-length of the segment drawn for one closing-axis sample in the HTML page [m]."""

PNG_MAX_POINTS = 20_000
HTML_MAX_POINTS = 30_000
SUBSAMPLE_SEED = 0

HEIGHT_NORM = Normalize(-0.05, 0.2)
"""Grey shades of the cloud in the PNG: white at z = −0.05 m, black from 0.2 m up."""

SCORE_NORM = Normalize(0.0, 1.0)
SCORE_CMAP = colormaps["viridis"]
SCORE_LABEL = "gravity-rejection score"


def gripper_outline(
    T_world_tcp: np.ndarray, gripper: GripperSpec, width: float | None = None
) -> np.ndarray:
    """Line segments of an open gripper's U-shaped outline in world coordinates [m].

    Args:
        T_world_tcp: (4, 4) or (G, 4, 4) grasp poses.
        gripper: dimensions of the hand.
        width: opening between the fingers [m]; ``gripper.max_width`` by default.

    Returns:
        (S, 2, 3) or (G, S, 2, 3) segment end points, S = 4: the fingers at ``+e_z`` and
        ``−e_z`` (each from its tip to the palm), the palm bar, the stem.
    """
    T = np.asarray(T_world_tcp, dtype=float)
    if T.shape[-2:] != (4, 4) or T.ndim not in (2, 3):
        raise ValueError(f"T_world_tcp must have shape (4, 4) or (G, 4, 4), got {T.shape}")
    half = (gripper.max_width if width is None else width) / 2
    tip = gripper.tip_beyond_tcp
    palm = tip - gripper.finger_depth
    segments_tcp = np.array(
        [
            [[tip, 0.0, half], [palm, 0.0, half]],
            [[tip, 0.0, -half], [palm, 0.0, -half]],
            [[palm, 0.0, -half], [palm, 0.0, half]],
            [[palm, 0.0, 0.0], [palm - STEM_LENGTH, 0.0, 0.0]],
        ]
    )
    R, t = T[..., :3, :3], T[..., :3, 3]
    return np.einsum("...ij,skj->...ski", R, segments_tcp) + t[..., None, None, :]


def save_grasps_png(
    path: str | Path,
    points: np.ndarray,
    poses: np.ndarray,
    scores: np.ndarray,
    gripper: GripperSpec,
    title: str = "",
    highlight: int | None = None,
) -> Path:
    """Draw grasps over a point cloud, in a 3-D view and a top view, as a PNG.

    Args:
        path: where the picture goes (written atomically).
        points: (N, 3) point cloud in the world frame [m], shaded by height; at most 20 000
            are drawn.
        poses: (G, 4, 4) grasps ``T_world_tcp``; G may be 0.
        scores: (G,) gravity-rejection scores, coloured on the scale ``[0, 1]``.
        gripper: the hand whose outline is drawn, fully open.
        title: heading; the number of grasps is appended.
        highlight: index of a grasp to draw thicker (e.g. the one executed).

    Returns:
        ``path``.
    """
    points, poses, scores = _checked(points, poses, scores)
    if highlight is not None and not 0 <= highlight < len(poses):
        raise ValueError(f"highlight must index one of the {len(poses)} grasps, got {highlight}")
    cloud = _subsample(points, PNG_MAX_POINTS)
    cloud = cloud[np.argsort(cloud[:, 2])]  # the top view shows the highest point of a column
    order = np.argsort(scores)  # the best grasps are drawn last, on top
    outlines = gripper_outline(poses[order], gripper)
    segments = outlines.reshape(-1, 2, 3)
    per_grasp = outlines.shape[1]
    colors = np.repeat(SCORE_CMAP(SCORE_NORM(scores[order])), per_grasp, axis=0)
    thick = order == highlight  # all False when highlight is None
    widths = np.repeat(np.where(thick, 3.5, 1.2), per_grasp)

    figure = Figure(figsize=(13, 6), layout="constrained")
    figure.suptitle(_heading(title, scores))
    view = figure.add_subplot(1, 2, 1, projection="3d")
    top = figure.add_subplot(1, 2, 2)
    view.computed_zorder = False  # outlines stay on top of the cloud, in call order
    shade = {"c": cloud[:, 2], "cmap": "Greys", "norm": HEIGHT_NORM, "s": 0.5, "linewidths": 0}
    view.scatter(*cloud.T, depthshade=False, **shade)
    view.plot(*_table_border().T, color="0.75", linewidth=0.8)
    top.scatter(*cloud[:, :2].T, **shade)
    if len(poses):  # an empty collection breaks the 3-D view
        view.add_collection3d(Line3DCollection(segments, colors=colors, linewidths=widths))
        top.add_collection(LineCollection(segments[..., :2], colors=colors, linewidths=widths))

    limits = (0.0, WORKSPACE_SIZE)
    view.set(xlim=limits, ylim=limits, zlim=limits, xlabel="x [m]", ylabel="y [m]")
    view.set_zlabel("z [m]")
    view.set_box_aspect((1, 1, 1), zoom=0.95)
    view.view_init(elev=30, azim=-60)
    top.set(xlim=limits, ylim=limits, xlabel="x [m]", ylabel="y [m]", aspect="equal")
    top.set_title("top view")
    figure.colorbar(ScalarMappable(SCORE_NORM, SCORE_CMAP), ax=top, label=SCORE_LABEL)
    return write_atomic(path, lambda file: figure.savefig(file, format="png", dpi=100))


def save_grasps_html(
    path: str | Path,
    points: np.ndarray,
    poses: np.ndarray,
    scores: np.ndarray,
    gripper: GripperSpec,
    closing_samples: dict[int, np.ndarray] | None = None,
    title: str = "",
) -> Path:
    """Write a self-contained HTML page with an interactive 3-D view of grasps over a cloud.

    The data sit in the page as one JSON blob (``<script id="grasp-data">``); a small inline
    script draws it on a canvas: drag to orbit, wheel to zoom. No external resources.

    Args:
        path: where the page goes (written atomically).
        points: (N, 3) point cloud in the world frame [m]; at most 30 000 are kept, rounded
            to 0.1 mm.
        poses: (G, 4, 4) grasps ``T_world_tcp``; G may be 0.
        scores: (G,) gravity-rejection scores, coloured on the scale ``[0, 1]``.
        gripper: the hand whose outline is drawn, fully open.
        closing_samples: for some grasp indices ``i``, (S, 3) unit closing axes ``e_z``
            sampled from grasp ``i``'s distribution; each is drawn as a thin segment
            ``±1.5 cm · e_z`` through that grasp's TCP.
        title: heading of the page; the number of grasps is appended.

    Returns:
        ``path``.
    """
    points, poses, scores = _checked(points, poses, scores)
    outlines = gripper_outline(poses, gripper)
    data = {
        "workspace": WORKSPACE_SIZE,
        "points": np.round(_subsample(points, HTML_MAX_POINTS), 4).tolist(),
        "grasps": [
            {
                "index": i,
                "score": round(float(scores[i]), 4),
                "color": to_hex(SCORE_CMAP(SCORE_NORM(scores[i]))),
                "segments": np.round(outlines[i], 4).tolist(),
            }
            for i in range(len(poses))
        ],
        "samples": _sample_segments(poses, closing_samples or {}),
    }
    blob = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    heading = html.escape(_heading(title, scores))
    page = _PAGE.format(title=heading, data=blob, script=_VIEWER_JS)
    return write_atomic(path, lambda file: file.write(page.encode("utf-8")))


def _checked(
    points: np.ndarray, poses: np.ndarray, scores: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The arguments as float arrays, after checking they are finite and their shapes agree."""
    points, poses, scores = (np.asarray(a, dtype=float) for a in (points, poses, scores))
    for name, array in (("points", points), ("poses", poses), ("scores", scores)):
        if not np.isfinite(array).all():
            raise ValueError(f"{name} must be finite")
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {points.shape}")
    if poses.ndim != 3 or poses.shape[1:] != (4, 4):
        raise ValueError(f"poses must have shape (G, 4, 4), got {poses.shape}")
    if scores.shape != (len(poses),):
        raise ValueError(f"scores must have shape ({len(poses)},), got {scores.shape}")
    return points, poses, scores


def _subsample(points: np.ndarray, limit: int) -> np.ndarray:
    """(≤ limit, 3) points drawn without replacement by a fixed seed, in their order."""
    if len(points) <= limit:
        return points
    keep = np.random.default_rng(SUBSAMPLE_SEED).choice(len(points), limit, replace=False)
    return points[np.sort(keep)]


def _heading(title: str, scores: np.ndarray) -> str:
    """``title`` followed by the number of grasps and the best score."""
    count = f"{len(scores)} grasps, best score {scores.max():.2f}" if len(scores) else "no grasps"
    return f"{title} — {count}" if title else count


def _table_border() -> np.ndarray:
    """(5, 3) closed loop around the table top inside the workspace."""
    s, h = WORKSPACE_SIZE, TABLE_HEIGHT
    return np.array([[0, 0, h], [s, 0, h], [s, s, h], [0, s, h], [0, 0, h]])


def _sample_segments(
    poses: np.ndarray, closing_samples: dict[int, np.ndarray]
) -> list[list[list[float]]]:
    """Segments ``tcp ± SAMPLE_HALF_LENGTH · e_z`` of every closing-axis sample, as lists."""
    segments = []
    for i, samples in closing_samples.items():
        if not 0 <= i < len(poses):
            raise ValueError(f"closing_samples has key {i}, not one of the {len(poses)} grasps")
        e_z = np.asarray(samples, dtype=float)
        if e_z.ndim != 2 or e_z.shape[1] != 3:
            raise ValueError(f"closing_samples[{i}] must have shape (S, 3), got {e_z.shape}")
        tcp = poses[i, :3, 3]
        ends = np.stack([tcp - SAMPLE_HALF_LENGTH * e_z, tcp + SAMPLE_HALF_LENGTH * e_z], axis=1)
        segments += np.round(ends, 4).tolist()
    return segments


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
  body {{ font-family: sans-serif; margin: 12px; }}
  #view {{ border: 1px solid #ccc; cursor: grab; }}
  #legend {{ display: inline-block; vertical-align: top; margin-left: 12px; font-size: 13px; }}
  .swatch {{ display: inline-block; width: 14px; height: 10px; margin-right: 6px; }}
</style>
</head>
<body>
<h2>{title}</h2>
<canvas id="view" width="900" height="700"></canvas>
<div id="legend"></div>
<script type="application/json" id="grasp-data">{data}</script>
<script>
{script}
</script>
</body>
</html>
"""

_VIEWER_JS = """\
"use strict";
// Orbit camera around the workspace centre: yaw about world z, then pitch (elevation).
const data = JSON.parse(document.getElementById("grasp-data").textContent);
const canvas = document.getElementById("view");
const ctx = canvas.getContext("2d");
const half = data.workspace / 2;
const DISTANCE = 1.0;  // camera distance from the centre [m]
let yaw = -0.9, pitch = 0.5, zoom = 1.0;

// World point -> [screen x, screen y, depth]; perspective from DISTANCE.
function project(p) {
  const x = p[0] - half, y = p[1] - half, z = p[2] - half;
  const cy = Math.cos(yaw), sy = Math.sin(yaw), cp = Math.cos(pitch), sp = Math.sin(pitch);
  const right = cy * x - sy * y, ahead = sy * x + cy * y;
  const up = sp * ahead + cp * z, depth = cp * ahead - sp * z;
  const scale = zoom * DISTANCE * canvas.height / 0.5 / (DISTANCE + depth);
  return [canvas.width / 2 + scale * right, canvas.height / 2 - scale * up, depth];
}

function drawSegments(segments, color, width) {
  ctx.strokeStyle = color;
  ctx.lineWidth = width;
  ctx.beginPath();
  for (const [a, b] of segments) {
    const pa = project(a), pb = project(b);
    ctx.moveTo(pa[0], pa[1]);
    ctx.lineTo(pb[0], pb[1]);
  }
  ctx.stroke();
}

function cubeEdges(s) {
  const edges = [];
  for (let axis = 0; axis < 3; axis++)
    for (const u of [0, s]) for (const v of [0, s]) {
      const a = [u, v], b = [u, v];
      a.splice(axis, 0, 0);
      b.splice(axis, 0, s);
      edges.push([a, b]);
    }
  return edges;
}

function draw() {
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  drawSegments(cubeEdges(data.workspace), "#ddd", 1);
  const axes = [[[0, 0, 0], [0.05, 0, 0]], [[0, 0, 0], [0, 0.05, 0]], [[0, 0, 0], [0, 0, 0.05]]];
  ["#d62728", "#2ca02c", "#1f77b4"].forEach((c, k) => drawSegments([axes[k]], c, 2));
  // Points far to near, nearer ones darker.
  const projected = data.points.map(project).sort((a, b) => b[2] - a[2]);
  for (const [sx, sy, depth] of projected) {
    const grey = Math.round(150 + 250 * Math.max(-0.2, Math.min(0.2, depth)));
    ctx.fillStyle = `rgb(${grey},${grey},${grey})`;
    ctx.fillRect(sx - 1, sy - 1, 2, 2);
  }
  const byScore = [...data.grasps].sort((a, b) => a.score - b.score);
  for (const g of byScore) drawSegments(g.segments, g.color, 2);
  ctx.globalAlpha = 0.6;
  drawSegments(data.samples, "#ff7f0e", 1);
  ctx.globalAlpha = 1.0;
}

function showLegend() {
  const best = [...data.grasps].sort((a, b) => b.score - a.score).slice(0, 10);
  const rows = best.map(g =>
    `<div><span class="swatch" style="background:${g.color}"></span>` +
    `grasp ${g.index}: ${g.score.toFixed(3)}</div>`);
  document.getElementById("legend").innerHTML =
    `<b>gravity-rejection score</b> (0 purple … 1 yellow)<br>` +
    `${data.points.length} points, ${data.grasps.length} grasps` +
    (data.samples.length ? `, ${data.samples.length} closing-axis samples (orange)` : "") +
    `<br>top grasps:` + (rows.join("") || " none") +
    `<p>drag: orbit, wheel: zoom<br>axes: x red, y green, z blue</p>`;
}

let dragging = null;
canvas.addEventListener("mousedown", e => { dragging = [e.clientX, e.clientY]; });
window.addEventListener("mouseup", () => { dragging = null; });
window.addEventListener("mousemove", e => {
  if (!dragging) return;
  yaw += 0.01 * (e.clientX - dragging[0]);
  pitch = Math.max(-1.57, Math.min(1.57, pitch + 0.01 * (e.clientY - dragging[1])));
  dragging = [e.clientX, e.clientY];
  requestAnimationFrame(draw);
});
canvas.addEventListener("wheel", e => {
  e.preventDefault();
  zoom *= Math.exp(-0.001 * e.deltaY);
  requestAnimationFrame(draw);
}, { passive: false });

showLegend();
draw();
"""
