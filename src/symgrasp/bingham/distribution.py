"""The Bingham distribution on S² and S³, a ``torch.distributions.Distribution``.

    B(A)(v) = exp(vᵀAv) / C(λ(A)),   v ∈ S^{d−1},  A ∈ Sym_d        (Ko et al. 2024, Sec. 3.1)

with C the normalising constant under the **surface measure** (`log_normalizer`). A and
A + cI are the same distribution, and B(A)(v) = B(A)(−v): the antipodal symmetry that lets one
parameter set stand for both 180°-flipped grasps of a parallel gripper.
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import ClassVar

import torch
from torch.autograd.function import once_differentiable
from torch.distributions import Distribution, constraints

from symgrasp.bingham.eigen import eigh3
from symgrasp.bingham.normalizer import _log_c_and_moments, log_normalizer, resolve_method
from symgrasp.bingham.sampling import sample_in_eigenbasis
from symgrasp.bingham.validation import (
    check_count,
    check_density_args,
    check_finite,
    check_matrix,
    check_unit_vectors,
    unit_vector,
)

Tensor = torch.Tensor

MAX_SAMPLE_VALUES = 2**28
"""The most values (samples × batch × d) one `Bingham.sample` call returns: 2 GiB in float64,
so that a mistyped size is refused before it allocates the machine's memory."""


def eigh(A: Tensor) -> tuple[Tensor, Tensor]:
    """Eigenvalues (ascending) and eigenvectors of symmetric ``[..., d, d]``, not differentiable.

    ``torch.linalg.eigh`` for d = 4. For d = 3, on a CPU the closed form `eigh3` (4× faster than
    LAPACK there, orthonormal to rounding even at repeated eigenvalues), elsewhere the library
    held to its conventions (`_library_eigh3`): on a GPU the closed form is a few hundred
    elementwise kernels whatever the batch, 3.4 ms for the 36 voxels of a detection against
    0.1 ms for the library (H100, ``benchmarks/results/detect-cuda.json``).
    """
    if A.shape[-1] != 3:
        return torch.linalg.eigh(A.detach())
    if A.device.type == "cpu":
        return eigh3(A)
    return _library_eigh3(A)


def _library_eigh3(A: Tensor) -> tuple[Tensor, Tensor]:
    """``torch.linalg.eigh`` of the upper triangle of ``A`` [..., 3, 3] in float64, returned in
    A's dtype, the first eigenvector flipped where the frame is left-handed: `eigh3`'s
    conventions."""
    lam, vectors = torch.linalg.eigh(A.detach().to(torch.float64), UPLO="U")
    columns = vectors.unbind(-1)
    handedness = torch.sign((torch.linalg.cross(columns[0], columns[1]) * columns[2]).sum(-1))
    vectors = torch.cat([vectors[..., :1] * handedness[..., None, None], vectors[..., 1:]], -1)
    return lam.to(A.dtype), vectors.to(A.dtype)


class _LogNormalizerOfMatrix(torch.autograd.Function):
    """log C(λ(A)) with the gradient V diag(E[vᵢ²]) Vᵀ = E[vvᵀ]: one eigendecomposition in the
    forward pass and none in the backward pass. The gradient needs no eigenvector derivative,
    so it is finite at repeated eigenvalues, where a backward through ``eigh`` is NaN."""

    @staticmethod
    def forward(ctx, A: Tensor, method: str) -> Tensor:  # type: ignore[override]
        lam, vectors = eigh(A)
        log_c, moments = _log_c_and_moments(lam, method)
        ctx.save_for_backward(vectors.to(torch.float64), moments)
        return log_c.to(A.dtype)

    @staticmethod
    @once_differentiable
    def backward(ctx, grad_output: Tensor) -> tuple[Tensor, None]:  # type: ignore[override]
        vectors, moments = ctx.saved_tensors
        second_moment_matrix = (vectors * moments.unsqueeze(-2)) @ vectors.transpose(-1, -2)
        return (grad_output[..., None, None] * second_moment_matrix).to(grad_output.dtype), None


def nll(A: Tensor, v: Tensor, method: str = "auto", validate_args: bool = False) -> Tensor:
    """Bingham negative log-likelihood −vᵀAv + log C(λ(A))  (Ko et al. 2024, Eq. 13).

    The gradient is d nll/dA = E[vvᵀ] − vvᵀ (exponential-family identity), computed from one
    eigendecomposition; it stays finite at degenerate spectra (A = 0, λ₁ = λ₂), where a backward
    through ``eigh`` eigenvectors is NaN. A is used by its symmetric part (A + Aᵀ)/2, the only
    part vᵀAv sees, so the density integrates to 1 for any A. Not twice differentiable.

    Args:
        A: ``[..., d, d]``, d = 3 or 4; symmetrised (refused unless symmetric with
            ``validate_args``).
        v: ``[..., d]`` unit vectors; batch dimensions broadcast with A's. Refused unless
            |‖v‖ − 1| is within `validation.unit_tolerance` of v's dtype.
        method: normaliser method, see `log_normalizer`.
        validate_args: also check that A is symmetric and finite (shapes, dtypes and the unit
            norm of v are always checked; see `symgrasp.bingham.validation`).

    Returns:
        ``[...]`` the per-element loss, in the promoted dtype of A and v.
    """
    A, v = check_density_args(A, v, validate_args)
    quadratic = torch.einsum("...i,...ij,...j->...", v, A, v)
    return _LogNormalizerOfMatrix.apply(A, resolve_method(method, A.shape[-1])) - quadratic


class Bingham(Distribution):
    """Bingham distribution with parameter matrix A, a ``torch.distributions.Distribution``.

    Its support is the unit sphere (`validation.unit_vector`); A is its one parameter
    (``arg_constraints``: symmetric). It composes with torch's tools (``Independent``,
    ``MixtureSameFamily``, ``expand``); it has no reparametrised sample (``has_rsample`` is
    False: the ACG rejection sampler is not differentiable) and no useful `mean`.

    Args:
        A: ``[*batch_shape, d, d]``, d = 3 (S²) or 4 (S³), used by its symmetric part
            (A + Aᵀ)/2; integer and bool tensors are promoted to the default float dtype.
        validate_args: torch's convention: None follows
            ``Distribution.set_default_validate_args`` (on by default, off under ``python -O``).
            When on, a non-symmetric (relative 1e-5) or non-finite A is refused here. When off,
            a NaN in A gives NaN results, except in `sample`, which always refuses it. Shapes and
            the unit norm of values passed to `log_prob` are always checked.
        method: normaliser method used by `log_prob` and `entropy`, see `log_normalizer`.
    """

    arg_constraints: ClassVar[dict[str, constraints.Constraint]] = {"A": constraints.symmetric}
    support = unit_vector
    has_rsample = False

    def __init__(self, A: Tensor, validate_args: bool | None = None, method: str = "auto") -> None:
        validate = Distribution._validate_args if validate_args is None else validate_args
        A = check_matrix(A, "A", symmetric=validate)
        if validate:
            check_finite(A, "A")
        resolve_method(method, A.shape[-1])
        self.A = A
        self.method = method
        # A is checked above with messages naming it; torch's check of `arg_constraints` would
        # only read the symmetrised A again.
        super().__init__(A.shape[:-2], A.shape[-1:], validate_args=False)
        self._validate_args = validate

    def expand(self, batch_shape: torch.Size | tuple[int, ...], _instance=None) -> Bingham:
        """The same distribution repeated over ``batch_shape`` (A expanded, not copied)."""
        new = self._get_checked_instance(Bingham, _instance)
        batch_shape = torch.Size(batch_shape)
        new.A = self.A.expand(batch_shape + self.A.shape[-2:])
        new.method = self.method
        super(Bingham, new).__init__(batch_shape, self.event_shape, validate_args=False)
        new._validate_args = self._validate_args
        return new

    @property
    def dim(self) -> int:
        """d, the ambient dimension (3 for S², 4 for S³)."""
        return self.A.shape[-1]

    @cached_property
    def _eigh(self) -> tuple[Tensor, Tensor]:
        return eigh(self.A)

    @property
    def eigenvalues(self) -> Tensor:
        """``[..., d]`` in ascending order (not shifted); not differentiable (use `log_prob`)."""
        return self._eigh[0]

    @property
    def eigenvectors(self) -> Tensor:
        """``[..., d, d]``; column i belongs to ``eigenvalues[..., i]``; a rotation on S²."""
        return self._eigh[1]

    @property
    def mode(self) -> Tensor:
        """``[..., d]``: the eigenvector of the largest eigenvalue (Eq. 6).

        −mode is a mode too; the sign returned makes the largest-magnitude component positive.
        """
        mode = self.eigenvectors[..., -1]
        pivot = mode.gather(-1, mode.abs().argmax(-1, keepdim=True))
        return mode * torch.where(pivot < 0, -1.0, 1.0).to(mode.dtype)

    @property
    def confidence(self) -> Tensor:
        """``[...]``: Σᵢ (λ_max − λᵢ), i.e. (λ₃−λ₂)+(λ₃−λ₁) on S² (Ko et al. 2024, Sec. 3.3)."""
        lam = self.eigenvalues
        return (lam[..., -1:] - lam).sum(-1)

    @property
    def mean(self) -> Tensor:
        """Undefined here: B(A)(v) = B(A)(−v), so E[v] = 0 whatever A, which says nothing about
        it. Raises NotImplementedError, as torch's distributions do for a moment they lack."""
        raise NotImplementedError(
            "Bingham: `mean` is 0 for every A (the density is antipodally symmetric); use `mode`, "
            "or the second moments `second_moments(eigenvalues)` along `eigenvectors`"
        )

    def log_prob(self, v: Tensor) -> Tensor:
        """``[...]`` log density of unit vectors ``v [..., d]`` (surface measure); v's batch
        dimensions broadcast with `batch_shape`. ``v`` is refused unless unit (`support`) and
        shaped so, whatever ``validate_args``."""
        return -nll(self.A, v, self.method)

    def entropy(self) -> Tensor:
        """``[...]`` differential entropy in nats (surface measure), −E[log p(v)] =
        log C − Σᵢ λᵢ E[vᵢ²]: one evaluation of the normaliser and its gradient, exact to the
        normaliser's accuracy; not differentiable (its gradient needs the Hessian of log C)."""
        lam = self.eigenvalues.detach().to(torch.float64)
        log_c, moments = _log_c_and_moments(lam, resolve_method(self.method, self.dim))
        return (log_c - (lam * moments).sum(-1)).to(self.A.dtype)

    def sample(
        self,
        sample_shape: tuple[int, ...] | torch.Size = (),
        generator: torch.Generator | None = None,
    ) -> Tensor:
        """Exact samples, ``[*sample_shape, *batch_shape, d]`` (ACG rejection, `sampling`)."""
        samples, _ = self._sample_with_count(sample_shape, generator)
        return samples

    def acceptance_rate(
        self, num_samples: int = 1000, generator: torch.Generator | None = None
    ) -> Tensor:
        """``[...]`` fraction of ACG candidates the sampler accepts, measured on ``num_samples``
        (≥ 1) fresh draws."""
        check_count(num_samples, "num_samples", lo=1)
        _, drawn = self._sample_with_count((num_samples,), generator)
        return num_samples / drawn.to(torch.float64)

    def _sample_with_count(
        self, sample_shape: tuple[int, ...] | torch.Size, generator: torch.Generator | None
    ) -> tuple[Tensor, Tensor]:
        if not isinstance(sample_shape, tuple | torch.Size):
            raise TypeError(
                f"`sample_shape` must be a tuple of integers, e.g. (n,), got {sample_shape!r}"
            )
        for size in sample_shape:
            check_count(size, "sample_shape")
        n = math.prod(sample_shape)
        values = n * math.prod(self.batch_shape) * self.dim
        if values > MAX_SAMPLE_VALUES:
            raise ValueError(
                f"`sample_shape` {tuple(sample_shape)} asks for {values:.3g} values for the batch "
                f"{tuple(self.batch_shape)}; at most {MAX_SAMPLE_VALUES:.3g} per call (draw in parts)"
            )
        check_finite(self.A, "A")  # no candidate is ever accepted for a non-finite A
        lam, vectors = (t.detach().to(torch.float64) for t in self._eigh)
        concentrations = (lam[..., -1:] - lam).reshape(-1, self.dim)
        x, drawn = sample_in_eigenbasis(concentrations, n, generator)  # [B, n, d]
        v = torch.einsum("bij,bnj->nbi", vectors.reshape(-1, self.dim, self.dim), x)
        v = v.reshape(*sample_shape, *self.batch_shape, self.dim).to(self.A.dtype)
        return v, drawn.reshape(self.batch_shape)

    def percentile_angle(self, p: float, axis: int) -> Tensor:
        """Approximate θᵢ^(p) (Ko et al. 2024, Appx. A, Eq. 12).

        The angle θ for which the band {v : |⟨v, dᵢ⟩| ≤ sin(θ/2)} around the great circle
        orthogonal to eigenvector dᵢ holds probability p: θᵢ^(p) ≈ 2 erf⁻¹(p)/√(λ_max − λᵢ).
        Accurate when the concentrations are large.

        Args:
            p: probability in (0, 1).
            axis: eigenvector index i in ascending eigenvalue order, 0 ≤ i < d − 1.
        """
        self._check_percentile_args(p, axis)
        lam = self.eigenvalues
        return 2 * torch.special.erfinv(lam.new_tensor(p)) / (lam[..., -1] - lam[..., axis]).sqrt()

    def percentile_angle_mc(
        self,
        p: float,
        axis: int,
        num_samples: int = 100_000,
        generator: torch.Generator | None = None,
    ) -> Tensor:
        """Monte-Carlo θᵢ^(p): 2 arcsin of the p-quantile of |⟨v, dᵢ⟩| over ``num_samples`` (≥ 1)
        exact samples."""
        self._check_percentile_args(p, axis)
        check_count(num_samples, "num_samples", lo=1)
        v = self.sample((num_samples,), generator)
        cosine = torch.einsum("n...i,...i->n...", v, self.eigenvectors[..., axis]).abs()
        return 2 * torch.asin(torch.quantile(cosine.to(torch.float64), p, dim=0).clamp(max=1)).to(
            v.dtype
        )

    def _check_percentile_args(self, p: float, axis: int) -> None:
        if not 0 < p < 1:
            raise ValueError(f"percentile_angle: `p` must be in (0, 1), got {p}")
        if not 0 <= axis < self.dim - 1:
            raise ValueError(f"percentile_angle: `axis` must be in [0, {self.dim - 2}], got {axis}")

    def __repr__(self) -> str:
        return f"Bingham(batch_shape={tuple(self.batch_shape)}, dim={self.dim})"


def fit(v: Tensor, steps: int = 100) -> Bingham:
    """Maximum-likelihood Bingham fit to unit vectors ``v [N, d]``.

    The eigenvectors of A are those of the scatter matrix S = mean vvᵀ; the eigenvalues solve
    E[vᵢ²] = Sᵢᵢ, the minimum of the convex −Σ λᵢ Sᵢᵢ + log C(λ), found by L-BFGS over
    log-concentrations (λ_d = 0).
    """
    if not isinstance(v, Tensor) or v.ndim != 2 or v.shape[-1] not in (3, 4) or not len(v):
        shape = tuple(v.shape) if isinstance(v, Tensor) else type(v).__name__
        raise ValueError(f"fit: `v` must be [N, 3] or [N, 4] with N ≥ 1, got {shape}")
    v = check_unit_vectors(v, v.shape[-1], "v")
    scatter = torch.einsum("ni,nj->ij", v, v).to(torch.float64) / v.shape[0]
    moments, vectors = torch.linalg.eigh(scatter)
    target = moments[:-1].clamp(min=1e-12)
    # Start from the concentrated-limit answer κᵢ ≈ 1/(2 E[vᵢ²]).
    log_kappa = torch.log(1 / (2 * target)).clone().requires_grad_(True)
    optimiser = torch.optim.LBFGS([log_kappa], max_iter=steps, line_search_fn="strong_wolfe")

    def objective() -> Tensor:
        optimiser.zero_grad()
        lam = torch.cat([-log_kappa.exp(), log_kappa.new_zeros(1)])
        loss = log_normalizer(lam) - (lam[:-1] * target).sum()
        loss.backward()
        return loss

    optimiser.step(objective)
    lam = torch.cat([-log_kappa.detach().exp(), log_kappa.new_zeros(1)])
    A = vectors @ torch.diag(lam) @ vectors.T
    return Bingham(A.to(v.dtype))
