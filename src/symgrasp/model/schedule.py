"""Learning-rate schedules: the lr of every optimizer step of a run (`TrainConfig.schedule`).

``learning_rate(config, step, total)`` is the lr of optimizer step ``step`` (0-based, counted
over the whole run: epoch × batches per epoch + batch) of a run of ``total`` steps. It is a pure
function of the step, so a resumed run sets exactly the straight run's lr (no scheduler state
to save). With W = round(warmup · total) warm-up steps:

- **constant**: lr · s / W for s < W (from 0), then lr; without warm-up, lr at every step
  (Adam as before the schedules existed);
- **cosine** (SGDR without restarts, Loshchilov & Hutter 2017): the same warm-up, then
  min_lr + (lr − min_lr) · (1 + cos(π (s − W) / (total − 1 − W))) / 2: lr at s = W, min_lr at
  the last step;
- **onecycle** (Smith & Topin 2019): torch's ``OneCycleLR(max_lr=lr, total_steps=total,
  pct_start=warmup, anneal_strategy="cos", div_factor=25, three_phase=False)`` with its last lr
  set to min_lr (``final_div_factor = lr / 25 / min_lr``) and without its momentum cycling:
  a cosine half-wave from lr / 25 up to lr at step warmup · total − 1, then one down to min_lr
  at the last step.
"""

from __future__ import annotations

import math

from symgrasp.config import TrainConfig

ONECYCLE_DIV = 25.0
"""The onecycle schedule starts at lr / ONECYCLE_DIV (torch's default ``div_factor``)."""


def learning_rate(config: TrainConfig, step: int, total: int) -> float:
    """The lr of optimizer step ``step`` (0-based) of ``total`` under ``config``'s schedule."""
    if config.schedule == "onecycle":
        return _onecycle(config, step, total)
    warm = round(config.warmup * total)
    if step < warm:
        return config.lr * step / warm
    if config.schedule == "constant":
        return config.lr
    pct = min((step - warm) / max(total - 1 - warm, 1), 1.0)
    return _cosine(config.lr, config.min_lr, pct)


def _cosine(start: float, end: float, pct: float) -> float:
    """From ``start`` at ``pct`` 0 to ``end`` at 1 along a cosine half-wave (torch's form)."""
    return end + (start - end) / 2.0 * (math.cos(math.pi * pct) + 1)


def _onecycle(config: TrainConfig, step: int, total: int) -> float:
    peak = config.warmup * total - 1  # OneCycleLR's end of the rising phase, a float
    if 0 < peak and step <= peak:
        return _cosine(config.lr / ONECYCLE_DIV, config.lr, step / peak)
    # total − 1 − peak = total · (1 − warmup) > 0; a peak below 0 (warmup · total < 1) starts
    # the fall before step 0, as OneCycleLR does
    return _cosine(config.lr, config.min_lr, (step - peak) / (total - 1 - peak))
