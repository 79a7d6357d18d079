"""Symmetric matrices from their upper triangles: the 6 (S²) or 10 (S³) network outputs.

The element order is the upper triangle read row by row. For d = 3:

    a = (a₀ … a₅)  ↦  A = [[a₀, a₁, a₂],
                           [a₁, a₃, a₄],
                           [a₂, a₄, a₅]]

and for d = 4, a = (A₁₁, A₁₂, A₁₃, A₁₄, A₂₂, A₂₃, A₂₄, A₃₃, A₃₄, A₄₄). This is ``triu`` of
Eq. 7 in Ko et al. (2024).
"""

from __future__ import annotations

import torch

_DIM_OF_TRIU = {6: 3, 10: 4}


def _triu_index(d: int, device: torch.device) -> torch.Tensor:
    """[d, d] index into the triu vector for every matrix entry."""
    rows, cols = torch.triu_indices(d, d, device=device)
    index = torch.empty(d, d, dtype=torch.long, device=device)
    position = torch.arange(rows.numel(), device=device)
    index[rows, cols] = position
    index[cols, rows] = position
    return index


def triu_to_sym(a: torch.Tensor) -> torch.Tensor:
    """Symmetric matrix from its upper triangle, row by row.

    Args:
        a: ``[..., 6]`` or ``[..., 10]``.

    Returns:
        ``[..., 3, 3]`` or ``[..., 4, 4]``; differentiable in ``a``.
    """
    if a.ndim == 0 or a.shape[-1] not in _DIM_OF_TRIU:
        raise ValueError(
            f"triu_to_sym: `a` must have trailing size 6 or 10, got shape {tuple(a.shape)}"
        )
    d = _DIM_OF_TRIU[a.shape[-1]]
    index = _triu_index(d, a.device)
    return a[..., index.flatten()].unflatten(-1, (d, d))


def sym_to_triu(A: torch.Tensor) -> torch.Tensor:
    """Upper triangle of ``[..., d, d]`` (d = 3 or 4), row by row: the inverse of `triu_to_sym`."""
    if A.ndim < 2 or A.shape[-1] != A.shape[-2] or A.shape[-1] not in (3, 4):
        raise ValueError(
            f"sym_to_triu: `A` must be [..., 3, 3] or [..., 4, 4], got shape {tuple(A.shape)}"
        )
    d = A.shape[-1]
    rows, cols = torch.triu_indices(d, d, device=A.device)
    return A[..., rows, cols]
