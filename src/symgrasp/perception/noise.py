"""Depth noise of a real structured-light/stereo sensor, as used by GIGA (after Dex-Net):
one multiplicative gamma factor per image and additive spatially correlated Gaussian noise
(white noise on a coarse grid, upsampled bicubically)."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import zoom


def add_depth_noise(
    depth: np.ndarray,
    seed: int = 0,
    gamma_shape: float = 1000.0,
    sigma: float = 0.005,
    correlation_px: int = 8,
) -> np.ndarray:
    """A noisy copy of ``depth`` (H, W) [m]; pixels without return (0) stay 0.

    ``gamma_shape``: shape k of the Gamma(k, 1/k) scale factor (mean 1, std 1/√k);
    ``sigma`` [m]: std of the correlated noise; ``correlation_px``: its correlation length.
    """
    depth = np.asarray(depth, dtype=np.float32)
    if depth.ndim != 2:
        raise ValueError(f"depth must be a (H, W) image, got shape {depth.shape}")
    if gamma_shape <= 0 or sigma < 0 or correlation_px < 1:
        raise ValueError("gamma_shape must be > 0, sigma ≥ 0 and correlation_px ≥ 1")
    rng = np.random.default_rng(seed)
    h, w = depth.shape
    coarse = rng.normal(0.0, sigma, size=(-(-h // correlation_px) + 1, -(-w // correlation_px) + 1))
    smooth = zoom(coarse, correlation_px, order=3)[:h, :w]
    noisy = depth * rng.gamma(gamma_shape, 1.0 / gamma_shape) + smooth
    return np.where(depth > 0, noisy, 0.0).astype(np.float32)
