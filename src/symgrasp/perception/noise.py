"""Depth noise of a real sensor, the field's ``dex`` model: GIGA's (Jiang et al., RSS 2021: "Gamma"
(k = 1000, θ = 0.001) and "Gaussian process" (σ = 0.005) noise, after Dex-Net 2.0, Mahler et
al., RSS 2017), as its code applies it to each rendered image (``UT-Austin-RPL/GIGA``,
``src/vgn/utils/misc.py`` ``apply_dex_noise``):

1. the whole image times one factor ``g ~ Gamma(k, θ = 1/k)`` (mean 1, SD 1/√k: 3.2 % for
   k = 1000, ≈ 19 mm at 0.6 m): a scale error of the whole depth, as a miscalibrated baseline
   makes;
2. with probability ``p`` (0.5), plus a smooth field: white Gaussian noise of SD ``σ`` (5 mm)
   on a grid ``grid_step`` (4) times coarser than the image, upsampled bilinearly (GIGA's
   stand-in for a Gaussian process). Interpolation averages neighbouring grid values, so a
   pixel's SD is below ``σ``: its variance is ``σ² ∏ₐ ((1 − tₐ)² + tₐ²)`` for its fractional
   offsets ``tₐ`` from the grid's nodes along each axis; at ``grid_step`` 4 the offsets are 1/8,
   3/8, 5/8, 7/8 and the root mean square over the image's pixels is ``σ × 0.65625`` (3.3 mm).

What differs from GIGA's code: a pixel without return (0) stays 0 (a sensor reports no depth
there; GIGA's code adds the noise to every pixel); the image's border pixels take
the nearest grid values (GIGA's resize pads with zeros there, damping the field on the border's
two pixels); the draws come from a seeded generator of their own, not NumPy's global stream.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.ndimage import zoom

from symgrasp.names import NOISES


def noisy_depth(depth: np.ndarray, noise: str, seed: int | Sequence[int]) -> np.ndarray:
    """``depth`` (H, W) [m] as the sensor ``noise`` (`symgrasp.names.NOISES`) gives it:
    ``depth`` itself for ``"none"`` (no draw, no copy), `add_depth_noise` at its defaults
    drawn from ``seed`` for ``"dex"``. The one reading of the names, shared by the benchmark's
    cameras (`symgrasp.benchmark.sensing`) and the training data (`symgrasp.data.scenes`)."""
    if noise == "none":
        return depth
    if noise == "dex":
        return add_depth_noise(depth, seed)
    raise ValueError(f"noise must be one of {NOISES}, got {noise!r}")


def add_depth_noise(
    depth: np.ndarray,
    seed: int | Sequence[int] = 0,
    gamma_shape: float = 1000.0,
    sigma: float = 0.005,
    grid_step: int = 4,
    field_probability: float = 0.5,
) -> np.ndarray:
    """A noisy copy (float32) of ``depth`` (H, W) [m] (module docstring); pixels without return
    (0) stay 0.

    ``seed``: an integer or a sequence of them (`numpy.random.default_rng`), the draws taken in
    the order scale factor, whether the field is added, the field; ``gamma_shape``: k of the
    Gamma(k, 1/k) scale factor; ``sigma`` [m]: SD of the field's grid values; ``grid_step``:
    pixels per grid cell (the grid is ``H // grid_step`` × ``W // grid_step``, at least 1 × 1);
    ``field_probability``: the chance that the field is added.
    """
    depth = np.asarray(depth, dtype=np.float32)
    if depth.ndim != 2:
        raise ValueError(f"depth must be a (H, W) image, got shape {depth.shape}")
    if not gamma_shape > 0:
        raise ValueError(f"gamma_shape must be > 0, got {gamma_shape}")
    if not sigma >= 0:
        raise ValueError(f"sigma must be ≥ 0 [m], got {sigma}")
    if not (isinstance(grid_step, int | np.integer) and grid_step >= 1):
        raise ValueError(f"grid_step must be an integer ≥ 1, got {grid_step!r}")
    if not 0 <= field_probability <= 1:
        raise ValueError(f"field_probability must be in [0, 1], got {field_probability}")
    rng = np.random.default_rng(seed)
    noisy = depth * rng.gamma(gamma_shape, 1.0 / gamma_shape)
    if rng.random() < field_probability:
        noisy = noisy + smooth_field(depth.shape, sigma, grid_step, rng)
    return np.where(depth > 0, noisy, 0.0).astype(np.float32)


def smooth_field(
    shape: tuple[int, int], sigma: float, grid_step: int, rng: np.random.Generator
) -> np.ndarray:
    """White Gaussian noise of SD ``sigma`` on a grid ``grid_step`` times coarser than ``shape``
    (H, W), upsampled bilinearly to ``shape``, grid cells and pixels aligned by their edges
    (each grid value sits at the centre of its ``grid_step`` × ``grid_step`` block)."""
    h, w = shape
    coarse = rng.normal(0.0, sigma, size=(max(1, h // grid_step), max(1, w // grid_step)))
    factors = (h / coarse.shape[0], w / coarse.shape[1])
    return zoom(coarse, factors, order=1, mode="nearest", grid_mode=True)
