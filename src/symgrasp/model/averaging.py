"""An exponential moving average of a network's weights (`TrainConfig.ema`).

Averaging the iterates of SGD (Polyak & Juditsky 1992) and its exponential, recent-weighted form
used with modern networks (Izmailov et al. 2018 average SGD's weights along the trajectory)
often generalise better than the last iterate. After every optimizer step,

    θ̄ ← decay · θ̄ + (1 − decay) · θ,      θ̄₀ = θ₀ (the initial weights),

so after n steps θ̄ₙ = decayⁿ θ₀ + (1 − decay) Σₖ₌₁ⁿ decayⁿ⁻ᵏ θₖ: a window of about
1 / (1 − decay) steps. Buffers (e.g. a BatchNorm's running statistics) are copied, not
averaged: they are statistics of the current weights.
"""

from __future__ import annotations

import copy

import torch


class WeightAverage:
    """The exponential moving average of ``net``'s parameters, as a copy of ``net``
    (``module``, which validation and the checkpoints use); ``decay`` in [0, 1)."""

    def __init__(self, net: torch.nn.Module, decay: float) -> None:
        if not 0 <= decay < 1:
            raise ValueError(f"decay must be in [0, 1), got {decay!r}")
        self.decay = decay
        self.module = copy.deepcopy(net).requires_grad_(False)

    @torch.no_grad()
    def update(self, net: torch.nn.Module) -> None:
        """One step of the average towards ``net``'s current weights (call after each
        optimizer step)."""
        for average, weight in zip(self.module.parameters(), net.parameters(), strict=True):
            average.lerp_(weight, 1.0 - self.decay)
        for average, buffer in zip(self.module.buffers(), net.buffers(), strict=True):
            average.copy_(buffer)
