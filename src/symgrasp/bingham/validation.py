"""Argument checks of the Bingham functions: what is promoted and what is refused.

Shapes and dtypes cost nothing to check and are always checked. A check that reads values is
one fused reduction over the tensor (one host synchronisation on a GPU); counting the offending
rows and finding the first one happens only when it fails.

- Integer and bool tensors are promoted to ``torch.get_default_dtype()``, and ``A`` and ``v`` of
  different floating dtypes to ``torch.promote_types`` of the two, as torch's own operators do.
- ``A`` is used by its symmetric part (A + Aᵀ)/2: the density exp(vᵀAv) depends on nothing
  else, and the normaliser's eigendecomposition must read the same matrix as the quadratic
  form, or the density would not integrate to 1. With ``validate_args`` a non-symmetric ``A``
  is refused instead. A symmetric ``A`` is returned bit for bit.
- Anything but a tensor is refused (`TypeError`: `torch.as_tensor` it first), and so are
  complex tensors; so are batch shapes that do not broadcast, vectors that are not unit, and a
  non-finite ``A`` where NaN cannot simply propagate (the sampler would never accept a
  candidate) or when ``validate_args`` asks, and non-finite eigenvalues given to
  `log_normalizer` (`ValueError`).
- `unit_vector` is the support of a Bingham distribution as a ``torch.distributions``
  constraint, the same test `check_unit_vectors` applies.
"""

from __future__ import annotations

import math
import numbers

import torch
from torch.distributions import constraints

Tensor = torch.Tensor

_SYMMETRY_TOLERANCE = 1e-5
# Normalising a vector in a dtype leaves |‖v‖ − 1| of a few eps, and composing rotations a few
# eps more; √eps (3.5e-4 in float32, 3e-2 in float16) is orders of magnitude above that and
# orders below a forgotten normalisation. The floor admits float32 data cast to float64
# (|‖v‖ − 1| up to ~1e-6), where √eps = 1.5e-8 would refuse it. An admitted deviation δ
# changes vᵀAv by the relative 2δ.
_UNIT_TOLERANCE_FLOOR = 1e-5


def unit_tolerance(dtype: torch.dtype) -> float:
    """The largest |‖v‖ − 1| accepted as a unit vector stored in ``dtype``."""
    return max(math.sqrt(torch.finfo(dtype).eps), _UNIT_TOLERANCE_FLOOR)


class _UnitVector(constraints.Constraint):
    """Unit vectors along the last dimension, |‖v‖ − 1| ≤ `unit_tolerance` of their dtype: the
    sphere S^{d−1}, which ``torch.distributions.constraints`` does not define."""

    event_dim = 1

    def check(self, value: Tensor) -> Tensor:
        """``[...]`` True where ``value [..., d]`` is a finite unit vector."""
        value = as_floating(value, "value")
        norm = torch.linalg.vector_norm(value, dim=-1)
        return (norm - 1).abs() <= unit_tolerance(value.dtype)  # False for NaN


unit_vector = _UnitVector()


def check_tensor(t: Tensor, name: str) -> None:
    """Refuse anything but a tensor, naming the argument and the conversion."""
    if not isinstance(t, Tensor):
        raise TypeError(
            f"`{name}` must be a torch.Tensor, got {type(t).__name__} (torch.as_tensor({name}))"
        )


def as_floating(t: Tensor, name: str) -> Tensor:
    """``t`` if real floating point; integer and bool tensors in the default float dtype."""
    check_tensor(t, name)
    if t.is_complex():
        raise TypeError(f"`{name}` must be real, got {t.dtype}")
    return t if t.is_floating_point() else t.to(torch.get_default_dtype())


def _offenders(bad: Tensor) -> tuple[str, tuple[int, ...]]:
    """'k of N' and the batch index of the first offender, for a non-empty bool mask ``[...]``."""
    return f"{int(bad.sum())} of {bad.numel()}", tuple(bad.nonzero()[0].tolist())


def check_matrix(A: Tensor, name: str, symmetric: bool) -> Tensor:
    """``A [..., d, d]``, d = 3 or 4, as floating point and symmetrised, (A + Aᵀ)/2; refused
    unless symmetric to a relative 1e-5 if ``symmetric``."""
    check_tensor(A, name)
    if A.ndim < 2 or A.shape[-1] != A.shape[-2] or A.shape[-1] not in (3, 4):
        raise ValueError(f"`{name}` must be [..., 3, 3] or [..., 4, 4], got shape {tuple(A.shape)}")
    A = as_floating(A, name)
    if symmetric:
        scale = A.abs().amax(dim=(-2, -1)).clamp(min=1.0)
        asymmetry = (A - A.transpose(-1, -2)).abs().amax(dim=(-2, -1)) / scale
        if (asymmetry > _SYMMETRY_TOLERANCE).any():
            raise ValueError(
                f"`{name}` must be symmetric, got relative asymmetry {asymmetry.max().item():.3g} "
                f"(shape {tuple(A.shape)})"
            )
    return (
        A + (A.transpose(-1, -2) - A) / 2
    )  # (A + Aᵀ)/2, exactly A when symmetric, even near overflow


def check_count(value: int, name: str, lo: int = 0) -> int:
    """``value`` as an int if it is an integer ≥ ``lo``, else a ValueError (a TypeError for a
    non-integer) naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"`{name}` must be an integer, got {type(value).__name__}")
    if value < lo:
        raise ValueError(f"`{name}` must be an integer ≥ {lo}, got {value}")
    return int(value)


def check_finite(t: Tensor, name: str, event_dim: int = 2) -> None:
    """Refuse NaN or inf anywhere in ``t``: matrices ``[..., d, d]`` (``event_dim`` 2) or
    vectors ``[..., d]`` (``event_dim`` 1)."""
    if torch.isfinite(t).all():
        return
    bad = ~torch.isfinite(t).flatten(-event_dim).all(-1)
    if bad.ndim:
        count, first = _offenders(bad)
        kind = "matrices" if event_dim == 2 else "vectors"
        detail = f"{count} {kind} hold NaN or inf, the first at batch index {first}"
    else:
        detail = f"got {t.tolist()}"
    raise ValueError(f"`{name}` must be finite: {detail} (shape {tuple(t.shape)})")


def check_unit_vectors(v: Tensor, d: int, name: str) -> Tensor:
    """``v [..., d]`` as floating point, refused unless every vector is finite and unit."""
    check_tensor(v, name)
    if v.ndim == 0 or v.shape[-1] != d:
        raise ValueError(f"`{name}` must be [..., {d}], got shape {tuple(v.shape)}")
    v = as_floating(v, name)
    within = unit_vector.check(v)
    if within.all():
        return v
    count, first = _offenders(~within)
    detail = f"{count} are not, the first at batch index {first} with" if within.ndim else "got"
    raise ValueError(
        f"`{name}` must hold finite unit vectors (|‖v‖ − 1| ≤ {unit_tolerance(v.dtype):.2g} in "
        f"{v.dtype}): {detail} ‖v‖ = {torch.linalg.vector_norm(v[first]).item():.6g} "
        f"(shape {tuple(v.shape)})"
    )


def check_density_args(A: Tensor, v: Tensor, validate_args: bool) -> tuple[Tensor, Tensor]:
    """``A [..., d, d]`` and unit ``v [..., d]`` in one dtype, their batch shapes broadcastable.

    Symmetry and finiteness of A are checked only if ``validate_args``: a NaN in A gives a NaN
    density, which is not silent, and a training loop can report it with its own advice.
    """
    A = check_matrix(A, "A", symmetric=validate_args)
    if validate_args:
        check_finite(A, "A")
    d = A.shape[-1]
    v = check_unit_vectors(v, d, "v")
    try:
        torch.broadcast_shapes(A.shape[:-2], v.shape[:-1])
    except RuntimeError:
        raise ValueError(
            f"`A` [..., {d}, {d}] and `v` [..., {d}] must broadcast in their batch dimensions; "
            f"got `A` {tuple(A.shape)}, `v` {tuple(v.shape)}"
        ) from None
    dtype = torch.promote_types(A.dtype, v.dtype)
    return A.to(dtype), v.to(dtype)
