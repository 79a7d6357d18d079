"""Choosing the torch device, the same way for training and detection."""

from __future__ import annotations

import torch

from symgrasp.config import check_device


def resolve_device(name: str) -> torch.device:
    """``"auto"`` → CUDA when available, else CPU; anything else as given (one of
    `symgrasp.config.DEVICE`'s, the devices symgrasp is tested on)."""
    check_device(name)
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    device = torch.device(name)
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device {name!r} asked for, but CUDA is not available")
    return device
