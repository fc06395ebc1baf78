"""The rate-field estimate's linear algebra, and the rate-field file, without model runs.

The estimate is checked on a linear problem made for it: a known field drawn from the
prior (`trackdyn.deterioration.ballast.rate_field`'s own Gaussian correlation), seen
through a band-pass of its settlement pattern plus white noise; a linear Gaussian model,
so the posterior mean and standard deviation are exact and can be checked against a
direct solve (Rasmussen, C.E., Williams, C.K.I. (2006), Gaussian Processes for Machine
Learning, MIT Press, eqs 2.25-2.26) and against the field the data were made with.
"""

import numpy as np
import pytest

from trackdyn.calibration.field import (
    Linearised,
    Prior,
    band_matrix,
    estimate,
    evidence,
    joint_information,
    prior_correlation,
    rail_transfer,
)
from trackdyn.calibration.surveys import d1_change
from trackdyn.deterioration.ballast import RAIL_CORRELATION, rate_field, read_rate_field
from trackdyn.errors import TrackdynInputError

SPACING = 0.6  # sleeper spacing [m]
LENGTH = 3.0  # correlation length of the field [m], the deterioration default
N = 150  # sleepers: 90 m


def _problem(sigma_u=0.3, noise=0.05, seed=1):
    """A linear problem: two rails, the D1 band of a 1 mm settlement pattern times the
    log-factor, sampled every 1.5 m (the calibration's residual spacing)."""
    rng = np.random.default_rng(seed)
    position = SPACING * np.arange(N)
    x = np.arange(0.0, position[-1], 0.25)
    band = band_matrix(x, position)[::6] * 1e3  # mm per m
    settled = 1e-3 * (1.0 + 0.5 * rng.random((2, N)))  # 1-1.5 mm [m]
    a = np.zeros((2 * band.shape[0], 2 * N))
    for r in range(2):
        a[r * band.shape[0] : (r + 1) * band.shape[0], r * N : (r + 1) * N] = band * settled[r]
    c = prior_correlation(position, LENGTH)
    eig, vec = np.linalg.eigh(c)
    root = vec * np.sqrt(np.maximum(eig, 0.0))
    u = sigma_u * root @ rng.standard_normal(2 * N)
    y = a @ u + noise * rng.standard_normal(a.shape[0])
    return position, Linearised(a, y), u, c


def test_band_matrix_is_the_band_pass_of_the_interpolated_settlement():
    rng = np.random.default_rng(0)
    position = SPACING * np.arange(N)
    x = np.arange(0.0, position[-1], 0.25)
    settlement = rng.random(N) * 1e-3
    direct = d1_change(x, np.array([np.interp(x, position, settlement)] * 2))[0]
    np.testing.assert_allclose(band_matrix(x, position) @ settlement, direct, atol=1e-12)


def test_prior_has_the_fields_correlation_with_its_mean_projected_out():
    position = SPACING * np.arange(N)
    c = prior_correlation(position, LENGTH)
    np.testing.assert_allclose(c.sum(axis=0), 0.0, atol=1e-9)  # mean of u is 0
    # centring C = K with the mean removed: P K P, P = I - 11ᵀ/2N (closed form)
    d = position[:, None] - position[None, :]
    k = np.kron([[1, RAIL_CORRELATION], [RAIL_CORRELATION, 1]], np.exp(-((d / LENGTH) ** 2)))
    p = np.eye(2 * N) - 1.0 / (2 * N)
    np.testing.assert_allclose(c, p @ k @ p, atol=1e-12)


def test_posterior_equals_the_direct_gaussian_solve():
    position, lin, _, c = _problem()
    prior = Prior(position, LENGTH)
    ev = evidence(lin, prior)
    field = estimate(lin, prior, position, np.ones(N, bool), ev.lam, ev.sigma2)
    # direct: mean = τ² C Aᵀ (σ² I + τ² A C Aᵀ)⁻¹ y, cov = τ² C - τ⁴ C Aᵀ (...)⁻¹ A C
    tau2, s2, a = ev.lam * ev.sigma2, ev.sigma2, lin.a
    cov_y = s2 * np.eye(lin.y.size) + tau2 * a @ c @ a.T
    mean = tau2 * c @ a.T @ np.linalg.solve(cov_y, lin.y)
    cov = tau2 * c - tau2**2 * c @ a.T @ np.linalg.solve(cov_y, a @ c)
    np.testing.assert_allclose(field.log_factor.ravel(), mean, atol=1e-6)
    np.testing.assert_allclose(field.standard_error.ravel() / field.factor.ravel(),
                               np.sqrt(np.maximum(np.diag(cov), 0)), atol=1e-6)  # fmt: skip
    # the profiled misfit and penalty sum to yᵀ (I + λK)⁻¹ y (the identity in Evidence)
    k = a @ c @ a.T
    quad = lin.y @ np.linalg.solve(np.eye(lin.y.size) + ev.lam * k, lin.y)
    assert np.sum(ev.misfit**2) + np.sum(ev.penalty**2) == pytest.approx(quad, rel=1e-8)


def test_posterior_draws_have_the_direct_gaussian_covariance():
    position, lin, _, c = _problem()
    prior = Prior(position, LENGTH)
    ev = evidence(lin, prior)
    field = estimate(lin, prior, position, np.ones(N, bool), ev.lam, ev.sigma2)
    # the root against the direct posterior covariance (closed form, as the test above)
    tau2, a = ev.lam * ev.sigma2, lin.a
    cov_y = ev.sigma2 * np.eye(lin.y.size) + tau2 * a @ c @ a.T
    cov = tau2 * c - tau2**2 * c @ a.T @ np.linalg.solve(cov_y, a @ c)
    root = field.posterior_root
    np.testing.assert_allclose(root @ root.T, cov, atol=1e-6 * np.abs(cov).max())
    # 4000 draws: their ln factor's mean and SD per rail seat within sampling error of the
    # estimate and its standard error (SE of a mean sd/√4000, of an SD about sd/√8000)
    u = np.log(field.draws(4000, seed=1))
    sd = field.standard_error / field.factor
    assert np.all(np.abs(u.mean(axis=0) - field.log_factor) < 5 * sd / np.sqrt(4000))
    np.testing.assert_allclose(u.std(axis=0), sd, rtol=5 / np.sqrt(8000))
    # the same seed, the same draws (a forecast is reproducible)
    np.testing.assert_array_equal(field.draws(3, seed=7), field.draws(3, seed=7))


def test_estimate_finds_the_field_and_its_strength():
    position, lin, u, _ = _problem()
    prior = Prior(position, LENGTH)
    ev = evidence(lin, prior)
    field = estimate(lin, prior, position, np.ones(N, bool), ev.lam, ev.sigma2)
    # strength and noise of the marginal likelihood near those the data were made with
    # (0.3 and 0.05 mm); acceptance ±30 %: from 120 points they spread by about ±20 %
    # (0.27-0.32 and 0.045-0.064 mm over seeds 1-6, measured)
    assert field.prior_sd == pytest.approx(0.3, rel=0.3)
    assert field.noise_mm == pytest.approx(0.05, rel=0.3)
    inner = slice(10, N - 10)  # the band-pass ends see less
    est, true = field.log_factor[:, inner].ravel(), u.reshape(2, N)[:, inner].ravel()
    assert np.corrcoef(est, true)[0, 1] > 0.8
    # about 95 % of the true values within 2 standard errors (Gaussian posterior)
    se = (field.standard_error / field.factor)[:, inner].ravel()
    assert 0.8 < np.mean(np.abs(est - true) < 2 * se) <= 1.0  # 0.85-0.97 over seeds 1-6


def test_no_field_in_the_data_gives_a_weak_prior():
    position, lin, _, _ = _problem(sigma_u=0.0)
    prior = Prior(position, LENGTH)
    ev = evidence(lin, prior)
    field = estimate(lin, prior, position, np.ones(N, bool), ev.lam, ev.sigma2)
    assert field.cov < 0.05 and np.max(np.abs(field.factor - 1)) < 0.05


def test_rate_field_file_is_read_per_rail_seat(tmp_path):
    position = 10.0 + SPACING * np.arange(20)
    rows = ["distance_m,rail,factor,standard_error"]
    rows += [f"{x + 0.01:g},{rail},{1 + 0.01 * i + (0.5 if rail == 'right' else 0)},0.1"
             for i, x in enumerate(position) for rail in ("right", "left")]  # fmt: skip
    rows += ["0,left,9,0.1", "0,right,9,0.1"]  # beyond the track: not used
    (tmp_path / "f.csv").write_text("\n".join(rows) + "\n")
    factor = read_rate_field(tmp_path / "f.csv", position)
    np.testing.assert_allclose(factor[0], 1 + 0.01 * np.arange(20))
    np.testing.assert_allclose(factor[1], 1.5 + 0.01 * np.arange(20))
    np.testing.assert_array_equal(rate_field(20, SPACING, 0.3, 3.0, 0, given=factor), factor)


@pytest.mark.parametrize(
    "rows, message",
    [
        (["{x},left,1", "{x},right,1"], "the field must cover the track"),
        (["{x},left,-1", "{x},right,1"], "line 2: needs distance_m a number"),
        (["{x},middle,1"], "line 2: needs distance_m a number, rail left or right"),
    ],
)
def test_rate_field_file_refused(tmp_path, rows, message):
    position = SPACING * np.arange(5)
    body = "\n".join(r.format(x=x) for x in position[:3] for r in rows)
    (tmp_path / "f.csv").write_text("distance_m,rail,factor\n" + body + "\n")
    with pytest.raises(TrackdynInputError, match=message):
        read_rate_field(tmp_path / "f.csv", position)


def test_given_field_of_the_wrong_size_is_refused():
    with pytest.raises(TrackdynInputError, match="given rate field has shape"):
        rate_field(5, SPACING, 0.3, 3.0, 0, given=np.ones((2, 4)))


def test_rail_transfer_follows_long_waves_and_bridges_short_ones():
    """Against the beam on an elastic foundation: a settlement wave of length ``L`` moves
    the rail by ``k / (k + EI (2π/L)⁴)`` of it, ``k`` the support stiffness per metre
    (Hetényi, M. (1946), Beams on Elastic Foundation, University of Michigan Press)."""
    position = SPACING * np.arange(400)
    kd, ei = 60e6, 6.4e6  # N/m per sleeper; 60E1 rail, EI about 6.4 MN m² [N m^2]
    transfer = rail_transfer(position, np.full(position.size, kd), ei)
    np.testing.assert_allclose(transfer.sum(axis=1)[5:-5], 1.0, atol=1e-9)  # uniform: follows
    inner = slice(100, 300)
    for wavelength in (3.0, 6.0, 24.0):
        wave = np.sin(2 * np.pi * position / wavelength)
        k = kd / SPACING
        expected = k / (k + ei * (2 * np.pi / wavelength) ** 4)
        amplitude = np.max(np.abs((transfer @ wave)[inner])) / np.max(np.abs(wave[inner]))
        assert amplitude == pytest.approx(expected, rel=0.03), wavelength  # discrete supports


def test_joint_information_is_the_schur_complement_of_the_joint_hessian():
    """Against the direct inverse of the Hessian of ``(|r|² + |w|²/λ) / σ²`` over the
    parameters and the field together: the parameters' block of its inverse (linear
    algebra, no approximation)."""
    rng = np.random.default_rng(3)
    j, g = rng.standard_normal((60, 2)), rng.standard_normal((60, 25))
    lam, sigma2 = 0.7, 0.04
    full = np.block([[j.T @ j, j.T @ g], [g.T @ j, g.T @ g + np.eye(25) / lam]]) / sigma2
    direct = np.linalg.inv(full)[:2, :2]
    np.testing.assert_allclose(np.linalg.inv(joint_information(j, g, lam, sigma2)), direct,
                               rtol=1e-10)  # fmt: skip
    # a field coordinate that mimics a parameter exactly: the surveys see only their sum, so
    # the parameter is known no better than that coordinate's prior variance λσ²
    g[:, 0] = j[:, 0]
    mimicked = np.linalg.inv(joint_information(j, g, lam, sigma2))
    assert mimicked[0, 0] >= lam * sigma2 > 10 * np.linalg.inv(j.T @ j / sigma2)[0, 0]
