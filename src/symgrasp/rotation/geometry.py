"""Small rotation utilities: quaternions ↔ matrices, the gripper flip, Gram–Schmidt keeping e_x.

Quaternions are **scalar-last**, q = (x, y, z, w) = (sin(θ/2) u, cos(θ/2)) for a rotation by θ
about the unit axis u: the order of ``scipy.spatial.transform.Rotation``, roma and VGN. q and −q
are the same rotation.

A grasp rotation is R = [e_x e_y e_z] (``docs/conventions.md``): e_x the approach direction, e_z
the closing axis, e_y = e_z × e_x. The gripper's flip, 180° about e_x, is R → R·diag(1, −1, −1).
"""

from __future__ import annotations

import torch

Tensor = torch.Tensor

# |z_⊥| below this many machine epsilons of |z| is rounding noise, not a direction.
_PARALLEL_TOLERANCE_EPS = 16


def _check_trailing(t: Tensor, shape: tuple[int, ...], name: str) -> None:
    if t.ndim < len(shape) or tuple(t.shape[-len(shape) :]) != shape:
        dims = ", ".join(str(s) for s in shape)
        raise ValueError(f"`{name}` must be [..., {dims}], got shape {tuple(t.shape)}")


def flip(R: Tensor) -> Tensor:
    """The same grasp turned 180° about its approach axis: R·diag(1, −1, −1), ``[..., 3, 3]``."""
    _check_trailing(R, (3, 3), "R")
    return R * R.new_tensor([1.0, -1.0, -1.0])


def flip_quaternion(q: Tensor) -> Tensor:
    """The quaternion of the flipped grasp, q ⊗ (1, 0, 0, 0) = (w, z, −y, −x), ``[..., 4]``.

    It is orthogonal to q on S³ (⟨q, q ⊗ i⟩ = Re(i) = 0): not −q, a different rotation.
    """
    _check_trailing(q, (4,), "q")
    x, y, z, w = q.unbind(-1)
    return torch.stack([w, z, -y, -x], dim=-1)


def quaternion_to_matrix(q: Tensor) -> Tensor:
    """Rotation matrix ``[..., 3, 3]`` of unit quaternions ``q [..., 4]`` (x, y, z, w)."""
    _check_trailing(q, (4,), "q")
    x, y, z, w = q.unbind(-1)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return torch.stack([torch.stack(row, dim=-1) for row in rows], dim=-2)


def matrix_to_quaternion(R: Tensor) -> Tensor:
    """Unit quaternion ``[..., 4]`` (x, y, z, w) of rotation matrices ``R [..., 3, 3]``.

    Shepperd's method (1978): of the four expressions 4qᵢ·q built from R, use the one whose
    pivot qᵢ is largest in magnitude, so no division by a small number occurs (the naive
    w = ½√(1 + tr R) fails near 180°). The sign makes that largest component positive.
    """
    _check_trailing(R, (3, 3), "R")
    r = R.unbind(-1)
    r00, r10, r20 = r[0].unbind(-1)
    r01, r11, r21 = r[1].unbind(-1)
    r02, r12, r22 = r[2].unbind(-1)
    candidates = torch.stack(  # row i is 4qᵢ·(x, y, z, w) for pivot i ∈ (x, y, z, w)
        [
            torch.stack([1 + r00 - r11 - r22, r01 + r10, r02 + r20, r21 - r12], dim=-1),
            torch.stack([r01 + r10, 1 - r00 + r11 - r22, r12 + r21, r02 - r20], dim=-1),
            torch.stack([r02 + r20, r12 + r21, 1 - r00 - r11 + r22, r10 - r01], dim=-1),
            torch.stack([r21 - r12, r02 - r20, r10 - r01, 1 + r00 + r11 + r22], dim=-1),
        ],
        dim=-2,
    )
    pivot = candidates.diagonal(dim1=-2, dim2=-1).argmax(-1)  # 4qᵢ², largest
    index = pivot[..., None, None].expand(*pivot.shape, 1, 4)
    best = candidates.gather(-2, index).squeeze(-2)
    return best / best.norm(dim=-1, keepdim=True)


def unit(v: Tensor, eps: float = 1e-8) -> Tensor:
    """v / max(|v|, eps) over the last axis (``torch.nn.functional.normalize``).

    The direction inside losses: exact for |v| ≥ eps, and differentiable with a finite gradient
    everywhere, also at v = 0 (where it is I/eps).
    """
    return torch.nn.functional.normalize(v, dim=-1, eps=eps)


def normalize(v: Tensor, fallback: Tensor) -> Tensor:
    """v/|v|, or ``fallback`` (a unit vector broadcastable to v) where |v| = 0."""
    norm = v.norm(dim=-1, keepdim=True)
    tiny = torch.finfo(v.dtype).tiny
    return torch.where(norm > tiny, v / norm.clamp(min=tiny), fallback.to(v))


def gram_schmidt(x: Tensor, z: Tensor) -> Tensor:
    """Proper rotation [e_x e_y e_z] from an approach x and a closing axis z, keeping e_x.

    e_x = x/|x| is kept exactly; e_z = normalize(z − (e_x·z) e_x); e_y = e_z × e_x
    (Zhou et al. 2019's Gram–Schmidt with the columns in the order of Ko et al. 2024, Sec. 3.3,
    which keep the approach axis because it is the easier one to learn). The projection is
    applied twice so e_z stays orthogonal to rounding level when z is nearly parallel to x.

    Deterministic fallbacks keep degenerate inputs proper rotations: e_x = (1, 0, 0) where x = 0;
    where z = 0 or z ∥ x (|z_⊥| ≤ 16 ε |z|), e_z is built from the coordinate axis least aligned
    with e_x instead of z, preferring z, then y on ties, so that x = z = 0 gives the identity.

    Args:
        x: ``[..., 3]`` approach direction, any length.
        z: ``[..., 3]`` closing axis, any length; broadcasts with x.

    Returns:
        ``[..., 3, 3]`` with det = 1.
    """
    _check_trailing(x, (3,), "x")
    _check_trailing(z, (3,), "z")
    x, z = torch.broadcast_tensors(x, z)
    e_x = normalize(x, x.new_tensor([1.0, 0.0, 0.0]))
    z_perp = _reject(z, e_x)
    z_perp = _reject(z_perp, e_x)
    eps, tiny = torch.finfo(z.dtype).eps, torch.finfo(z.dtype).tiny
    z_norm = z.norm(dim=-1, keepdim=True)
    perp_norm = z_perp.norm(dim=-1, keepdim=True)
    degenerate = perp_norm <= (_PARALLEL_TOLERANCE_EPS * eps * z_norm).clamp(min=tiny)
    least_aligned = 2 - e_x.abs().flip(-1).argmin(-1)  # ties go to z, then y
    axis = torch.nn.functional.one_hot(least_aligned, 3).to(e_x)
    fallback = _reject(axis, e_x)
    fallback = fallback / fallback.norm(dim=-1, keepdim=True)  # |axis·e_x| ≤ 1/√3: well posed
    e_z = torch.where(degenerate, fallback, z_perp / perp_norm.clamp(min=tiny))
    e_y = torch.linalg.cross(e_z, e_x)
    return torch.stack([e_x, e_y, e_z], dim=-1)


def _reject(v: Tensor, direction: Tensor) -> Tensor:
    """v minus its component along the unit vector ``direction``."""
    return v - (v * direction).sum(-1, keepdim=True) * direction
