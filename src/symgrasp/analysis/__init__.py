"""The paper's three analysis figures (Ko et al. 2024, Sec. 4.1, Sec. 4.2 and Appx. A).

- `percentile_figure`: the band angles θᵢ^(99%) of 2D Bingham distributions, approximated by
  Eq. 12 and measured by Monte Carlo (Appx. A, Figs. 7 and 8);
- `continuity_figure`: the score field and the closing axes e_z of several detectors in one
  horizontal voxel layer over a long box (Sec. "Analysis of Rotation Continuity",
  Fig. 3);
- `distribution_figure`: closing axes sampled from a Bingham detector over the box and a flat
  cylinder (Sec. "Analysis of Rotation Distribution", Fig. 4).

Each writes a PNG and a JSON with the numbers and the command that made them, atomically
(`files`), into a folder of pictures that it holds for the call (`symgrasp.folders.PICTURES`:
docs/figures is one; a folder of other files, or one another process writes, is refused). One module per figure; `scenes` holds the analysis scenes and the voxel-layer
helpers that the continuity and distribution figures share.
"""

from symgrasp.analysis.continuity import (
    closing_axes,
    continuity_figure,
    continuity_statistics,
    plot_continuity,
    reduce_or_none,
)
from symgrasp.analysis.distribution import (
    SampledAxes,
    distribution_figure,
    object_statistics,
    plot_distribution,
    sample_axes,
)
from symgrasp.analysis.files import (
    save_figure,
    write_json,
    write_text,
)
from symgrasp.analysis.percentiles import (
    DOT_SAMPLES,
    PAPER_EXAMPLE,
    PERCENTILE,
    SHAPES,
    PercentileRow,
    Shape,
    percentile_figure,
    percentile_markdown,
    percentile_row,
    percentile_rows,
    plot_percentile_bands,
)
from symgrasp.analysis.scenes import (
    ARROW_LENGTH,
    FLAT_CYLINDER,
    LONG_BOX,
    SLICE_HEIGHT,
    VIEW_MARGIN,
    DepthView,
    FieldSlice,
    Placed,
    busiest_layer,
    check_validity,
    choose_layer,
    cut_layer,
    draw_field,
    parse_model_specs,
    predict,
    render_depth,
    slice_layer,
    view_limits,
    voxel_centres_xy,
)

__all__ = [
    "ARROW_LENGTH",
    "DOT_SAMPLES",
    "FLAT_CYLINDER",
    "LONG_BOX",
    "PAPER_EXAMPLE",
    "PERCENTILE",
    "SHAPES",
    "SLICE_HEIGHT",
    "VIEW_MARGIN",
    "DepthView",
    "FieldSlice",
    "PercentileRow",
    "Placed",
    "SampledAxes",
    "Shape",
    "busiest_layer",
    "check_validity",
    "choose_layer",
    "closing_axes",
    "continuity_figure",
    "continuity_statistics",
    "cut_layer",
    "distribution_figure",
    "draw_field",
    "object_statistics",
    "parse_model_specs",
    "percentile_figure",
    "percentile_markdown",
    "percentile_row",
    "percentile_rows",
    "plot_continuity",
    "plot_distribution",
    "plot_percentile_bands",
    "predict",
    "reduce_or_none",
    "render_depth",
    "sample_axes",
    "save_figure",
    "slice_layer",
    "view_limits",
    "voxel_centres_xy",
    "write_json",
    "write_text",
]
