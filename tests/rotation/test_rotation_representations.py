"""The rotation representations behind symgrasp.rotation.get: losses, decoders, samplers."""

import math

import numpy as np
import pytest
import torch
from scipy import integrate, special
from scipy.spatial.transform import Rotation

from symgrasp import rotation
from symgrasp.bingham import sym_to_triu
from symgrasp.names import REPRESENTATIONS
from symgrasp.rotation import flip

CHANNELS = {"bingham2d": 9, "rotmat6d": 6, "rotmat6d_naive": 6, "quaternion": 4, "bingham3d": 10}
FLIP_INVARIANT = [name for name in CHANNELS if name != "rotmat6d_naive"]
DISTRIBUTIONS = ["bingham2d", "bingham3d"]
DTYPES = [torch.float32, torch.float64]


def _rotations(n: int, seed: int = 0, dtype: torch.dtype = torch.float64) -> torch.Tensor:
    return torch.as_tensor(Rotation.random(n, random_state=seed).as_matrix(), dtype=dtype)


def _pred(name: str, shape: tuple[int, ...], seed: int = 0, dtype=torch.float64) -> torch.Tensor:
    generator = torch.Generator().manual_seed(seed)
    return torch.randn(*shape, CHANNELS[name], generator=generator, dtype=dtype)


def _ideal(name: str, R: torch.Tensor, kappa: float = 100.0) -> torch.Tensor:
    """A confident prediction of R: the mode / regression target sits at R."""
    e_x, e_z = R[..., 0], R[..., 2]
    if name == "bingham2d":
        return torch.cat([sym_to_triu(kappa * _outer(e_z)), e_x], dim=-1)
    if name.startswith("rotmat6d"):
        return torch.cat([e_x, e_z], dim=-1)
    flat = Rotation.from_matrix(R.reshape(-1, 3, 3).numpy()).as_quat()  # scipy: (x, y, z, w)
    q = torch.as_tensor(flat, dtype=R.dtype).reshape(*R.shape[:-2], 4)
    return q if name == "quaternion" else sym_to_triu(kappa * _outer(q))


def _outer(v: torch.Tensor) -> torch.Tensor:
    return v[..., :, None] * v[..., None, :]


def _sym(a: torch.Tensor) -> torch.Tensor:
    """Independent reading of the triu layout: row by row."""
    rows = [[0, 1, 2], [1, 3, 4], [2, 4, 5]]
    return a[..., torch.tensor(rows)]


def _assert_proper(R: torch.Tensor, atol: float = 1e-6) -> None:
    R = R.reshape(-1, 3, 3)
    assert torch.isfinite(R).all()
    eye = torch.eye(3, dtype=R.dtype).expand_as(R)
    torch.testing.assert_close(R.mT @ R, eye, atol=atol, rtol=0)
    torch.testing.assert_close(
        torch.linalg.det(R), torch.ones(len(R), dtype=R.dtype), atol=atol, rtol=0
    )


def _angle_up_to_flip(R: torch.Tensor, R_ref: torch.Tensor) -> torch.Tensor:
    """Geodesic angle from R to the nearer of R_ref and its flip, in radians."""

    def angle(a, b):
        cos = ((a.mT @ b).diagonal(dim1=-2, dim2=-1).sum(-1) - 1) / 2
        return torch.acos(cos.clamp(-1, 1))

    return torch.minimum(angle(R, R_ref), angle(R, flip(R_ref)))


# --- the registry and bad input -----------------------------------------------------------------


def test_get_returns_every_named_representation():
    assert set(rotation.NAMES) == set(CHANNELS)
    for name, channels in CHANNELS.items():
        representation = rotation.get(name)
        assert representation.name == name
        assert representation.channels == channels


@pytest.mark.parametrize("name", CHANNELS)
def test_capabilities_match_what_the_representation_does(name):
    representation = rotation.get(name)
    pred = torch.randn(7, representation.channels, dtype=torch.float64)
    decoded = representation.decode(pred)
    assert (decoded.confidence is not None) == representation.has_confidence
    assert representation.default_confidence is None or representation.has_confidence
    bounded = representation.bounded_channels
    assert bounded is None or 0 <= bounded.start < bounded.stop <= representation.channels
    if representation.closing_axis_up_to_sign:  # the same output decodes either sign of e_z
        assert representation.has_distribution


def test_only_the_bingham_representations_have_confidences_and_bounds():
    with_confidence = {n for n in CHANNELS if rotation.get(n).has_confidence}
    bounded = {n for n in CHANNELS if rotation.get(n).bounded_channels is not None}
    assert with_confidence == bounded == {"bingham2d", "bingham3d"}
    assert rotation.get("bingham2d").default_confidence == rotation.PAPER_CONFIDENCE_THRESHOLD
    assert rotation.get("bingham3d").default_confidence is None


def test_the_light_name_list_names_exactly_the_implementations():
    assert [rotation.get(n).name for n in REPRESENTATIONS] == list(REPRESENTATIONS)
    assert set(rotation._REPRESENTATIONS) == set(REPRESENTATIONS)


def test_get_unknown_name_lists_the_known_ones():
    with pytest.raises(ValueError, match="unknown rotation representation 'rotmat9d'") as info:
        rotation.get("rotmat9d")
    for name in CHANNELS:
        assert name in str(info.value)


@pytest.mark.parametrize("name", CHANNELS)
def test_wrong_channel_count_names_representation_and_channels(name):
    representation = rotation.get(name)
    bad = torch.zeros(4, CHANNELS[name] + 1)
    expected = rf"{name}: `pred` must be \[\.\.\., {CHANNELS[name]}\]"
    with pytest.raises(ValueError, match=expected):
        representation.loss(bad, _rotations(4))
    with pytest.raises(ValueError, match=expected):
        representation.decode(bad)


def test_bad_targets_and_masks_raise():
    representation = rotation.get("bingham2d")
    pred = torch.zeros(4, 9, dtype=torch.float64)
    R = _rotations(4)
    with pytest.raises(ValueError, match=r"`R_gt` must be \[\.\.\., 3, 3\] or \[\.\.\., K, 3, 3\]"):
        representation.loss(pred, R[:3])
    with pytest.raises(ValueError, match="`mask` needs K targets"):
        representation.loss(pred, R, torch.ones(4, dtype=torch.bool))
    with pytest.raises(ValueError, match="`mask` must be bool"):
        representation.loss(pred, R[:, None], torch.ones(4, 1))
    with pytest.raises(ValueError, match="K ≥ 1"):
        representation.loss(pred, R[:, None][:, :0])


# --- losses against closed forms ----------------------------------------------------------------


def test_bingham2d_loss_matches_closed_form():
    """A = κuuᵀ has C = 2π ∫₋₁¹ e^{κt²} dt = 2π √(π/κ) erfi(√κ) (Archimedes: dS = 2π dt)."""
    kappa, alpha = 5.0, 0.3
    R = _rotations(8, seed=3)
    u = torch.nn.functional.normalize(
        torch.randn(8, 3, generator=torch.Generator().manual_seed(4), dtype=R.dtype), dim=-1
    )
    x = 2.0 * (math.cos(alpha) * R[..., 0] + math.sin(alpha) * R[..., 1])
    pred = torch.cat([sym_to_triu(kappa * u[:, :, None] * u[:, None, :]), x], dim=-1)
    log_c = math.log(2 * math.pi * math.sqrt(math.pi / kappa) * special.erfi(math.sqrt(kappa)))
    expected = (1 - math.cos(alpha)) + log_c - kappa * (u * R[..., 2]).sum(-1) ** 2
    torch.testing.assert_close(rotation.get("bingham2d").loss(pred, R), expected)


def test_bingham3d_loss_is_mean_nll_of_both_twins_closed_form():
    """A = κppᵀ on S³: C = 4π ∫₋₁¹ e^{κt²} √(1−t²) dt; both twins q, q⊗i count half each."""
    kappa = 3.0
    rotations = Rotation.random(6, random_state=5)
    R = torch.as_tensor(rotations.as_matrix())
    p = torch.nn.functional.normalize(
        torch.randn(6, 4, generator=torch.Generator().manual_seed(6), dtype=R.dtype), dim=-1
    )
    pred = sym_to_triu(kappa * p[:, :, None] * p[:, None, :])
    integral, _ = integrate.quad(lambda t: np.exp(kappa * t * t) * np.sqrt(1 - t * t), -1, 1)
    log_c = math.log(4 * math.pi * integral)
    q = torch.as_tensor(rotations.as_quat())
    q_flip = torch.as_tensor((rotations * Rotation.from_rotvec([math.pi, 0, 0])).as_quat())
    expected = log_c - kappa * ((p * q).sum(-1) ** 2 + (p * q_flip).sum(-1) ** 2) / 2
    torch.testing.assert_close(rotation.get("bingham3d").loss(pred, R), expected)


def test_quaternion_loss_is_one_minus_cos_half_angle_and_zero_at_the_flip():
    rotations = Rotation.random(5, random_state=7)
    R = torch.as_tensor(rotations.as_matrix())
    representation = rotation.get("quaternion")
    for theta in (0.1, 1.0, 2.5):
        turned = rotations * Rotation.from_rotvec([0, 0, theta])  # about the closing axis
        pred = -3.0 * torch.as_tensor(turned.as_quat())  # any scale and sign
        expected = torch.full((5,), 1 - math.cos(theta / 2), dtype=R.dtype)
        torch.testing.assert_close(representation.loss(pred, R), expected)
    flipped = torch.as_tensor((rotations * Rotation.from_rotvec([math.pi, 0, 0])).as_quat())
    torch.testing.assert_close(representation.loss(flipped, R), torch.zeros(5, dtype=R.dtype))


def test_rotmat6d_losses_match_closed_form():
    alpha, gamma = 0.4, 2.0  # gamma > π/2: the flipped twin is nearer
    R = _rotations(5, seed=8)
    x = 2.0 * (math.cos(alpha) * R[..., 0] + math.sin(alpha) * R[..., 1])
    z = 0.5 * (math.cos(gamma) * R[..., 2] + math.sin(gamma) * R[..., 1])
    pred = torch.cat([x, z], dim=-1)
    with_flip = torch.full((5,), (1 - math.cos(alpha)) + (1 - abs(math.cos(gamma))), dtype=R.dtype)
    naive = torch.full((5,), (1 - math.cos(alpha)) + (1 - math.cos(gamma)), dtype=R.dtype)
    torch.testing.assert_close(rotation.get("rotmat6d").loss(pred, R), with_flip)
    torch.testing.assert_close(rotation.get("rotmat6d_naive").loss(pred, R), naive)


# --- the flip ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", FLIP_INVARIANT)
def test_loss_is_invariant_to_flipping_the_ground_truth(name):
    representation = rotation.get(name)
    pred = _pred(name, (64,))
    R = _rotations(64 * 3, seed=9).reshape(64, 3, 3, 3)
    torch.testing.assert_close(
        representation.loss(pred, flip(R[:, 0])), representation.loss(pred, R[:, 0])
    )
    some = torch.rand(64, 3, generator=torch.Generator().manual_seed(10)) < 0.5
    mixed = torch.where(some[..., None, None], flip(R), R)
    torch.testing.assert_close(representation.loss(pred, mixed), representation.loss(pred, R))


def test_bingham2d_loss_is_exactly_flip_invariant():
    representation = rotation.get("bingham2d")
    for dtype in DTYPES:
        pred, R = _pred("bingham2d", (256,), dtype=dtype), _rotations(256, dtype=dtype)
        assert torch.equal(representation.loss(pred, flip(R)), representation.loss(pred, R))


def test_naive_6d_loss_is_not_flip_invariant():
    representation = rotation.get("rotmat6d_naive")
    pred, R = _pred("rotmat6d_naive", (64,)), _rotations(64)
    difference = representation.loss(pred, flip(R)) - representation.loss(pred, R)
    assert difference.abs().min() > 0


# --- decoding -----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", CHANNELS)
@pytest.mark.parametrize("dtype", DTYPES)
def test_ideal_prediction_decodes_to_the_rotation_or_its_flip(name, dtype):
    R = _rotations(50, seed=11, dtype=dtype).reshape(5, 10, 3, 3)
    decoded = rotation.get(name).decode(_ideal(name, R))
    assert decoded.rotation.shape == (5, 10, 3, 3)
    _assert_proper(decoded.rotation)
    error = _angle_up_to_flip(decoded.rotation.double(), R.double())
    assert error.max() < (1e-3 if dtype == torch.float32 else 1e-6)
    if name in DISTRIBUTIONS:
        # eigenvalues (0, …, 0, κ): Σᵢ (λ_max − λᵢ) = (d − 1) κ
        expected = torch.full((5, 10), 100.0 * (2 if name == "bingham2d" else 3), dtype=dtype)
        torch.testing.assert_close(decoded.confidence, expected)
    else:
        assert decoded.confidence is None


def test_bingham2d_decode_keeps_the_approach_and_takes_the_mode():
    pred = _pred("bingham2d", (100,), seed=12)
    decoded = rotation.get("bingham2d").decode(pred)
    x = pred[:, 6:]
    torch.testing.assert_close(decoded.rotation[..., 0], x / x.norm(dim=-1, keepdim=True))
    # e_z is the top eigenvector of A made orthogonal to e_x: e_z ∥ v − (v·e_x)e_x.
    eigenvalues, eigenvectors = np.linalg.eigh(_sym(pred[:, :6]).numpy())
    v = torch.as_tensor(eigenvectors[..., -1])
    e_x = decoded.rotation[..., 0]
    v_perp = torch.nn.functional.normalize(v - (v * e_x).sum(-1, keepdim=True) * e_x, dim=-1)
    torch.testing.assert_close(
        (decoded.rotation[..., 2] * v_perp).sum(-1).abs(), torch.ones(100, dtype=pred.dtype)
    )
    gaps = eigenvalues[..., -1:] - eigenvalues
    torch.testing.assert_close(decoded.confidence, torch.as_tensor(gaps.sum(-1)))


@pytest.mark.parametrize("name", CHANNELS)
@pytest.mark.parametrize("dtype", DTYPES)
def test_decode_gives_proper_rotations_even_for_degenerate_predictions(name, dtype):
    representation = rotation.get(name)
    random = _pred(name, (3, 100), seed=13, dtype=dtype)
    zeros = torch.zeros(7, CHANNELS[name], dtype=dtype)
    _assert_proper(representation.decode(random).rotation)
    _assert_proper(representation.decode(zeros).rotation)
    torch.testing.assert_close(
        representation.decode(zeros).rotation, torch.eye(3, dtype=dtype).expand(7, 3, 3)
    )
    if name == "bingham2d":  # x along the Bingham mode
        parallel = torch.cat(
            [
                sym_to_triu(torch.diag(torch.tensor([0.0, 0.0, 5.0], dtype=dtype))),
                torch.tensor([0.0, 0.0, 2.0], dtype=dtype),
            ]
        )
        _assert_proper(representation.decode(parallel).rotation)
    if name.startswith("rotmat6d"):
        x = random[..., :3]
        for z in (x, -2 * x, x + 1e-7 * random[..., 3:]):
            _assert_proper(representation.decode(torch.cat([x, z], dim=-1)).rotation)


# --- gradients ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", CHANNELS)
@pytest.mark.parametrize("dtype", DTYPES)
def test_gradients_are_finite_at_zero_initialisation(name, dtype):
    representation = rotation.get(name)
    R = _rotations(32, seed=14, dtype=dtype)
    some = torch.rand(8, 4, generator=torch.Generator().manual_seed(0)) < 0.5
    for targets, mask in ((R, None), (R.reshape(8, 4, 3, 3), some)):
        batch = targets.shape[:-3] if mask is not None else targets.shape[:-2]
        pred = torch.zeros(*batch, CHANNELS[name], dtype=dtype, requires_grad=True)
        loss = representation.loss(pred, targets, mask)
        loss.sum().backward()
        assert loss.dtype == dtype
        assert torch.isfinite(loss).all()
        assert torch.isfinite(pred.grad).all()


# --- K targets and masks ------------------------------------------------------------------------


@pytest.mark.parametrize("name", CHANNELS)
def test_k_targets_combine_as_mean_for_distributions_and_min_for_regressions(name):
    representation = rotation.get(name)
    pred = _pred(name, (16,), seed=15)
    R = _rotations(16 * 5, seed=16).reshape(16, 5, 3, 3)
    each = torch.stack([representation.loss(pred, R[:, k]) for k in range(5)], dim=-1)
    expected = each.mean(-1) if name in DISTRIBUTIONS else each.amin(-1)
    torch.testing.assert_close(representation.loss(pred, R), expected)


@pytest.mark.parametrize("name", CHANNELS)
def test_masked_out_targets_change_neither_loss_nor_gradient(name):
    representation = rotation.get(name)
    R = _rotations(16 * 3, seed=17).reshape(16, 3, 3, 3)
    padded = torch.cat([R, torch.full((16, 2, 3, 3), torch.nan, dtype=R.dtype)], dim=1)
    padded = padded[:, torch.tensor([3, 0, 1, 4, 2])]  # valid targets in slots 1, 2, 4
    mask = torch.tensor([False, True, True, False, True]).expand(16, 5)
    pred = _pred(name, (16,), seed=18).requires_grad_(True)
    (reference,) = torch.autograd.grad(representation.loss(pred, R).sum(), pred)
    loss = representation.loss(pred, padded, mask)
    (gradient,) = torch.autograd.grad(loss.sum(), pred)
    torch.testing.assert_close(loss, representation.loss(pred, R))
    torch.testing.assert_close(gradient, reference)


@pytest.mark.parametrize("name", CHANNELS)
def test_all_masked_elements_have_zero_loss_and_gradient(name):
    representation = rotation.get(name)
    R = _rotations(12, seed=19).reshape(4, 3, 3, 3)
    R[0] = torch.nan  # padding
    mask = torch.tensor([[False] * 3, [True, False, True], [False] * 3, [True] * 3])
    pred = _pred(name, (4,), seed=20).requires_grad_(True)
    loss = representation.loss(pred, R, mask)
    loss.sum().backward()
    assert loss[0] == 0 and loss[2] == 0
    assert torch.isfinite(loss).all() and (loss[[1, 3]] != 0).all()
    assert (pred.grad[[0, 2]] == 0).all() and torch.isfinite(pred.grad).all()


# --- sampling -----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", DISTRIBUTIONS)
def test_samples_are_proper_rotations_near_a_confident_mode(name):
    representation = rotation.get(name)
    R = _rotations(6, seed=21).reshape(2, 3, 3, 3)
    pred = _ideal(name, R, kappa=2000.0)
    samples = representation.sample(pred, 50, torch.Generator().manual_seed(0))
    assert samples.shape == (2, 3, 50, 3, 3)
    _assert_proper(samples)
    error = _angle_up_to_flip(samples, R[..., None, :, :])
    assert error.max() < math.radians(10)  # spread ~ 1/√κ ≈ 1.3°
    again = representation.sample(pred, 50, torch.Generator().manual_seed(0))
    assert torch.equal(samples, again)


def test_bingham2d_samples_keep_the_approach_and_spread_when_uncertain():
    representation = rotation.get("bingham2d")
    x = torch.tensor([0.0, 0.0, -3.0], dtype=torch.float64)  # top-down approach
    pred = torch.cat([torch.zeros(6, dtype=torch.float64), x])  # A = 0: uniform e_z
    samples = representation.sample(pred, 2000, torch.Generator().manual_seed(1))
    torch.testing.assert_close(samples[..., 0], (x / 3).expand(2000, 3))
    yaw = torch.atan2(samples[:, 1, 2], samples[:, 0, 2])  # e_z is uniform in the xy-plane
    assert yaw.cos().mean().abs() < 0.1 and yaw.sin().mean().abs() < 0.1


@pytest.mark.parametrize("name", DISTRIBUTIONS)
def test_the_distribution_reads_a_from_its_channels_and_decodes_alike(name):
    representation = rotation.get(name)
    R = _rotations(4, seed=23)
    pred = _ideal(name, R, kappa=50.0)
    distribution = representation.distribution(pred)
    line = R[..., 2] if name == "bingham2d" else _ideal("quaternion", R)
    torch.testing.assert_close(distribution.A, 50.0 * _outer(line))
    assert torch.equal(distribution.confidence, representation.decode(pred).confidence)


def test_a_bingham_on_s3_fitted_to_both_flips_has_no_mode_about_the_approach():
    """The closed form behind `bingham3d`'s yaw failures: R and R turned by π about e_x are
    the orthogonal quaternions q and q ⊗ i, so the maximum-likelihood fit to both gives A two
    equal top eigenvalues (a whole circle of modes); on S² both flips are one line ±e_z, whose
    fit has a single sharp mode."""
    from symgrasp.bingham import fit
    from symgrasp.rotation.geometry import flip_quaternion

    generator = torch.Generator().manual_seed(24)
    R = _rotations(1, seed=25)[0].double()
    q = _ideal("quaternion", R)
    twins = torch.stack([q, flip_quaternion(q)]).repeat(500, 1)
    noisy = twins + 0.05 * torch.randn(twins.shape, generator=generator, dtype=twins.dtype)
    s3 = fit(noisy / noisy.norm(dim=-1, keepdim=True)).eigenvalues
    lines = torch.stack([R[:, 2], -R[:, 2]]).repeat(500, 1)
    noisy = lines + 0.05 * torch.randn(lines.shape, generator=generator, dtype=lines.dtype)
    s2 = fit(noisy / noisy.norm(dim=-1, keepdim=True)).eigenvalues
    assert (s3[-1] - s3[-2]) < 0.05 * (s3[-2] - s3[-3])
    assert (s2[-1] - s2[-2]) > 100


@pytest.mark.parametrize("name", sorted(set(CHANNELS) - set(DISTRIBUTIONS)))
def test_point_estimates_have_no_distribution(name):
    with pytest.raises(NotImplementedError, match=name):
        rotation.get(name).distribution(torch.zeros(2, CHANNELS[name]))


@pytest.mark.parametrize("name", sorted(set(CHANNELS) - set(DISTRIBUTIONS)))
def test_point_estimates_do_not_sample(name):
    with pytest.raises(NotImplementedError, match=name):
        rotation.get(name).sample(torch.zeros(2, CHANNELS[name]), 3)
