"""Each rail seat's settlement-rate factor estimated from the surveys (`trackdyn calibrate`).

The factor ``f = exp(u)`` multiplies every settlement increment of a rail seat
(`trackdyn.deterioration.ballast.rate_field`). Around a run with the field ``u0``, the
D1-band change the model predicts for survey ``k`` is linearised in ``u``: a rail seat
whose ballast settled ``b_k`` by then settles ``b_k (u - u0)`` more, and the rail, resting
on it, follows, interpolated linearly between sleepers as the loop's unloaded profile is,
and bridging short waves as a rail on springs does (`rail_transfer`, every sleeper
bearing; a sleeper that hangs, and the loads that follow the new dips, are left to the
next run). With ``M`` the D1 band-pass of that interpolation at the residual points, per
rail::

    y_k = measured_k - predicted_k(u0) + M (b_k u0) = M diag(b_k) u + e,   e ~ N(0, σ² I)

The prior: ``u ~ N(0, τ² C)``, ``C`` the correlation of the deterioration model's own
field (Gaussian, ``exp(-(d/ℓ)²)`` with ``ℓ`` the scenario's ``rate_correlation_length_m``,
the rails correlated by `trackdyn.deterioration.ballast.RAIL_CORRELATION`), projected so
that the mean of ``u`` over all rail seats is zero: a common factor is the law's scale
(K_s), not the field, and stays with the global fit (so K_s goes with this field: the
deterioration model's random field has mean factor 1 instead, ``exp(σ²/2)`` above a
field with mean ``ln factor`` 0). The strength ``λ = τ² / σ²`` is the one of largest
marginal likelihood of the surveys (type-II maximum likelihood, σ² profiled out; MacKay
1992), found on the eigenvalues of ``A C Aᵀ``, with ``τ`` at most the prior's bound
(`Prior`, ``fit.rate_cov_max``: D1-band surveys see the field and K_s only as their
product's pattern, so that without the bound the strength runs up the ridge: on surveys
made with a field of cov 0.3 it chose 0.95 for ``τ`` with K_s a quarter of the truth,
see `benchmarks/forecast.py`); the
estimate is the posterior mean, its standard error the posterior standard deviation (of
``u``, and ``f`` times it for the factor, delta method). Rail seats that no compared point
sees keep the prior: factor about 1, standard error about ``τ``.

References
----------
MacKay, D.J.C. (1992). Bayesian interpolation. Neural Computation 4(3), 415-447.

Rasmussen, C.E., Williams, C.K.I. (2006). Gaussian Processes for Machine Learning. MIT
Press, Cambridge, MA (eqs 2.25-2.30: posterior and marginal likelihood of a linear model
with a Gaussian prior).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solveh_banded
from scipy.optimize import brentq, minimize_scalar

from trackdyn.beam.elements import stiffness_band
from trackdyn.calibration.problem import compare
from trackdyn.deterioration.ballast import MAX_RATE_COV, RAIL_CORRELATION
from trackdyn.errors import TrackdynInputError
from trackdyn.track.quality import longitudinal_level
from trackdyn.track.track import RAILS

JITTER = 1e-9
"""Added to the eigenvalues' floor of the prior correlation [-] (a Gaussian correlation
matrix is numerically singular)."""

DEFAULT_RATE_COV_MAX = 0.5
"""Default largest coefficient of variation of the estimated settlement-rate factor [-]
(``fit.rate_cov_max``): illustrative, an engineering bound, not a published value (the
deterioration model's default field has 0.3). With it, a forecast from a calibration of
surveys the model made with a field of cov 0.3 held the true first tamping within its
10-90 % interval for 11 of 12 segment-truths (`benchmarks/forecast.py`, 6 truths); with
the bound at the model's largest, 3, for 2 of 4."""

LOG_STRENGTH_RANGE = (-12.0, 8.0)
"""Search range of ``ln λ`` of the marginal likelihood, ``λ`` in [1/mm²]: from a field of
a thousandth of the noise to one of fifty times it."""


@dataclass(frozen=True)
class FieldEstimate:
    """The estimated settlement-rate field.

    Parameters
    ----------
    position : ndarray
        Sleeper positions [m].
    factor, standard_error : ndarray
        (2 rails, sleepers) settlement-rate factor and its standard error [-].
    log_factor : ndarray
        (2 rails, sleepers) ``ln factor`` [-].
    observed : ndarray
        (sleepers) rail seats within the compared stretch [bool].
    prior_sd : float
        ``τ``, the standard deviation of ``ln factor`` the data chose [-].
    noise_mm : float
        ``σ``, the residual noise the data chose [mm].
    posterior_root : ndarray
        (2 rails x sleepers, k) ``S`` with ``S Sᵀ`` the posterior covariance of ``ln
        factor`` [-] (`draws`).
    """

    position: np.ndarray
    factor: np.ndarray
    standard_error: np.ndarray
    log_factor: np.ndarray
    observed: np.ndarray
    prior_sd: float
    noise_mm: float
    posterior_root: np.ndarray

    def draws(self, count: int, seed: int) -> np.ndarray:
        """``count`` fields drawn from the posterior, (count, 2 rails, sleepers) factor [-]:
        ``exp(û + S ξ)``, ``ξ`` standard normal. Each has the correlation along the
        track the prior gives where the surveys say little, and follows the estimate
        where they say much (a conditional simulation of the field).

        Parameters
        ----------
        count : int
            Fields to draw [-].
        seed : int
            Seed of the draws.
        """
        xi = np.random.default_rng(seed).standard_normal((self.posterior_root.shape[1], count))
        u = self.log_factor.reshape(-1, 1) + self.posterior_root @ xi
        return np.exp(u.T.reshape(count, *self.log_factor.shape))

    @property
    def cov(self) -> float:
        """Coefficient of variation of a lognormal factor with ``prior_sd`` [-]."""
        return float(np.sqrt(np.expm1(self.prior_sd**2)))


def rail_transfer(position, stiffness, EI: float) -> np.ndarray:
    """Rail deflection at each sleeper per unit ballast level under each, every sleeper
    bearing, (sleepers, sleepers) [-]: ``(K + D)⁻¹ D`` with ``K`` the rail's beam stiffness
    (`trackdyn.beam.elements.stiffness_band`, deflection and rotation per sleeper) and
    ``D`` the support springs on the deflections. A short wave of settlement is bridged.

    Parameters
    ----------
    position : ndarray
        Sleeper positions [m].
    stiffness : ndarray
        Support stiffness per sleeper [N/m].
    EI : float
        Rail bending stiffness [N m^2].
    """
    n = position.size
    band = stiffness_band(position, EI)
    band[-1, 0::2] += stiffness
    rhs = np.zeros((2 * n, n))
    rhs[2 * np.arange(n), np.arange(n)] = stiffness
    return solveh_banded(band, rhs)[0::2]


def band_matrix(x, position, transfer=None) -> np.ndarray:
    """D1 band-pass at ``x`` of the rail's deflection per unit settlement of each sleeper
    (``transfer``, `rail_transfer`; default: the rail follows), linearly interpolated
    between sleepers, (points, sleepers) [-].

    Parameters
    ----------
    x : ndarray
        Distances of the compared points [m].
    position : ndarray
        Sleeper positions [m].
    transfer : ndarray, optional
        (sleepers, sleepers) rail deflection per unit settlement [-].
    """
    transfer = np.eye(position.size) if transfer is None else transfer
    columns = [longitudinal_level(x, np.interp(x, position, column), "D1")
               for column in transfer.T]  # fmt: skip
    return np.array(columns).T


def prior_correlation(position, length: float) -> np.ndarray:
    """Correlation of ``ln factor`` over both rails' sleepers, (2n, 2n), mean projected out.

    Parameters
    ----------
    position : ndarray
        Sleeper positions [m].
    length : float
        Correlation length [m].
    """
    d = position[:, None] - position[None, :]
    along = np.exp(-((d / length) ** 2))
    rails = np.array([[1.0, RAIL_CORRELATION], [RAIL_CORRELATION, 1.0]])
    c = np.kron(rails, along)
    c -= c.mean(axis=0, keepdims=True)
    c -= c.mean(axis=1, keepdims=True)
    return c


@dataclass(frozen=True)
class Linearised:
    """The surveys' change linearised in ``ln factor`` about a run (module docstring).

    Parameters
    ----------
    a : ndarray
        (residual points, 2 rails x sleepers) D1-band change per unit of ``ln factor`` [mm].
    y : ndarray
        (residual points) measured minus predicted change plus ``a u0`` [mm].
    """

    a: np.ndarray
    y: np.ndarray


def linearise(problem, ds, log_factor, band) -> Linearised:
    """`Linearised` about the run ``ds`` with the field ``log_factor``.

    Parameters
    ----------
    problem : Calibration
        The calibration.
    ds : xarray.Dataset
        A run of the fitted tonnage with the field ``log_factor``.
    log_factor : ndarray
        (2, sleepers) ``ln factor`` of that run [-].
    band : sequence of ndarray
        `band_matrix` of the problem per rail.
    """
    n = problem.position.size
    comparison = compare(problem, ds)
    blocks, y = [], []
    for k in np.flatnonzero(problem.fitted):
        at = int(np.argmin(np.abs(ds.mgt.values - problem.mgt[k])))
        settled = ds.settlement.values[at]  # (rail, sleeper) [m]
        for r in range(len(RAILS)):
            rows = band[r][problem.use] * 1e3  # mm of D1 change per m of settlement
            a = np.zeros((rows.shape[0], 2 * n))
            a[:, r * n : (r + 1) * n] = rows * settled[r]
            miss = (comparison.measured[k, r] - comparison.predicted[k, r])[problem.use] * 1e3
            blocks.append(a)
            y.append(miss + a[:, r * n : (r + 1) * n] @ log_factor[r])
    return Linearised(np.vstack(blocks), np.concatenate(y))


class Prior:
    """The prior correlation ``C`` of ``ln factor`` (`prior_correlation`) and a square
    root ``R`` with ``C = R Rᵀ``.

    Parameters
    ----------
    position : ndarray
        Sleeper positions [m].
    length : float
        Correlation length [m].
    max_cov : float
        Largest coefficient of variation of the factor the strength may give [-]: ``τ`` is
        at most ``max_sd = √ln(1 + max_cov²)``.
    """

    def __init__(self, position, length: float, max_cov: float = DEFAULT_RATE_COV_MAX):
        if not 0 < max_cov <= MAX_RATE_COV:
            raise TrackdynInputError(f"fit.rate_cov_max must be in (0, {MAX_RATE_COV:g}], got "
                                     f"{max_cov:g}")  # fmt: skip
        self.max_sd = float(np.sqrt(np.log1p(max_cov**2)))
        self.c = prior_correlation(position, length)
        eig, vec = np.linalg.eigh(self.c)
        keep = eig > JITTER * eig.max()
        self.root = vec[:, keep] * np.sqrt(eig[keep])


@dataclass(frozen=True)
class Evidence:
    """The marginal likelihood of the linearised surveys at its best strength.

    Parameters
    ----------
    lam : float
        ``λ = τ²/σ²`` of largest marginal likelihood [1/mm²].
    sigma2 : float
        ``σ²`` with it [mm²].
    misfit : ndarray
        ``y - A û`` with ``û`` the posterior mean [mm].
    penalty : ndarray
        ``√λ Gᵀ w``, ``G = A R``, ``w = (I + λ K)⁻¹ y`` [mm]: with ``misfit`` (which is
        ``w``) the squares sum to ``yᵀ (I + λ K)⁻¹ y = min_u |y - A u|² + uᵀ C⁻¹ u / λ``.
    log_det : float
        ``ln det(I + λ K)``, ``K = A C Aᵀ`` [-].
    """

    lam: float
    sigma2: float
    misfit: np.ndarray
    penalty: np.ndarray
    log_det: float

    def residual(self) -> np.ndarray:
        """A vector whose squared norm is ``exp(-2 ln L / m)`` up to a constant factor,
        ``L`` the marginal likelihood with ``λ`` and ``σ²`` at their best [mm]."""
        m = self.misfit.size
        return np.concatenate([self.misfit, self.penalty]) * np.exp(self.log_det / (2 * m))


def evidence(lin: Linearised, prior: Prior) -> Evidence:
    """`Evidence` of the linearised surveys: ``λ`` and ``σ²`` of largest marginal
    likelihood (``σ²`` profiled out, ``λ`` by bounded scalar search on ``ln λ``), with
    ``τ`` at most the prior's ``max_sd``."""
    g = lin.a @ prior.root
    eig, v = np.linalg.eigh(g @ g.T)
    eig = np.maximum(eig, 0.0)
    yv, m = v.T @ lin.y, lin.y.size

    def minus_log_evidence(log_lam):
        s = 1.0 + np.exp(log_lam) * eig
        return m * np.log(np.sum(yv**2 / s) / m) + np.sum(np.log(s))

    best = minimize_scalar(minus_log_evidence, bounds=LOG_STRENGTH_RANGE, method="bounded")
    log_lam = float(best.x)

    def excess(log_lam):  # ln τ² - ln τ_max², τ² = λ σ²(λ) rising with λ
        s = 1.0 + np.exp(log_lam) * eig
        return log_lam + np.log(np.sum(yv**2 / s) / m) - 2 * np.log(prior.max_sd)

    if excess(log_lam) > 0:
        log_lam = brentq(excess, LOG_STRENGTH_RANGE[0], log_lam)
    lam = float(np.exp(log_lam))
    s = 1.0 + lam * eig
    w = v @ (yv / s)
    return Evidence(lam, float(np.sum(yv**2 / s) / m), w, np.sqrt(lam) * (g.T @ w),
                    float(np.sum(np.log(s))))  # fmt: skip


def _solve(lin: Linearised, prior: Prior, lam: float):
    """``G = A R``, the Cholesky factor of ``I + λ G Gᵀ`` and ``w = (I + λ G Gᵀ)⁻¹ y``."""
    g = lin.a @ prior.root
    chol = np.linalg.cholesky(np.eye(lin.y.size) + lam * (g @ g.T))
    w = np.linalg.solve(chol.T, np.linalg.solve(chol, lin.y))
    return g, chol, w


def estimate(lin: Linearised, prior: Prior, position, observed, lam: float,
             sigma2: float) -> FieldEstimate:  # fmt: skip
    """The posterior mean and standard deviation of ``ln factor`` (module docstring).

    Parameters
    ----------
    lin : Linearised
        The linearised surveys.
    prior : Prior
        The prior correlation.
    position : ndarray
        Sleeper positions [m].
    observed : ndarray
        Sleepers within the compared stretch [bool].
    lam, sigma2 : float
        ``λ`` [1/mm²] and ``σ²`` [mm²] (`strength`).
    """
    g, chol, w = _solve(lin, prior, lam)
    h = prior.root @ g.T  # C Aᵀ
    u = lam * (h @ w)
    z = np.linalg.solve(chol, h.T)
    var = sigma2 * lam * (np.diag(prior.c) - lam * np.sum(z**2, axis=0))
    n = position.size
    u, se = u.reshape(2, n), np.sqrt(np.maximum(var, 0.0)).reshape(2, n)
    factor = np.exp(u)
    return FieldEstimate(position, factor, factor * se, u, observed,
                         float(np.sqrt(sigma2 * lam)), float(np.sqrt(sigma2)),
                         posterior_root(g, prior, lam, sigma2))  # fmt: skip


def posterior_root(g, prior: Prior, lam: float, sigma2: float) -> np.ndarray:
    """``S`` with ``S Sᵀ`` the posterior covariance of ``ln factor``, (2n, k) [-].

    In the prior's coordinates ``u = R w``, ``w ~ N(0, λσ² I)``, the posterior covariance
    of ``w`` is ``λσ² (I + λ GᵀG)⁻¹`` (Rasmussen & Williams 2006, eq. 2.8); with ``GᵀG =
    V E Vᵀ``, ``S = √(λσ²) R V (I + λE)^(-1/2)``.

    Parameters
    ----------
    g : ndarray
        ``G = A R`` (residual points, k) [mm].
    prior : Prior
        The prior correlation and its root ``R``.
    lam, sigma2 : float
        ``λ`` [1/mm²] and ``σ²`` [mm²].
    """
    e, v = np.linalg.eigh(g.T @ g)
    return np.sqrt(lam * sigma2) * (prior.root @ (v / np.sqrt(1.0 + lam * np.maximum(e, 0.0))))


def joint_information(j, g, lam: float, sigma2: float) -> np.ndarray:
    """Fisher information of global parameters fitted with the field, the field's
    uncertainty included, (parameters, parameters).

    With ``J`` the residuals' Jacobian in the parameters and ``G = A R`` the one in the
    field's coordinates ``w`` (``u = R w``, ``w ~ N(0, λσ² I)``), the Hessian of
    ``(|r|² + |w|²/λ) / σ²`` has the parameters' block ``JᵀJ/σ²`` coupled to the field's
    ``(GᵀG + I/λ)/σ²``; the parameters' information is its Schur complement,
    ``Jᵀ (I + λ G Gᵀ)⁻¹ J / σ²`` (Woodbury): less than ``JᵀJ/σ²`` in every direction the
    field can mimic. Its inverse is the covariance of the parameters with the field
    integrated out, at the strength ``λ``.

    Parameters
    ----------
    j : ndarray
        (residuals, parameters) Jacobian in the parameters [mm per unit].
    g : ndarray
        (residuals, field coordinates) Jacobian in ``w`` [mm].
    lam : float
        ``λ = τ²/σ²`` [1/mm²].
    sigma2 : float
        ``σ²`` [mm²].
    """
    spread = np.eye(j.shape[0]) + lam * (g @ g.T)
    return j.T @ np.linalg.solve(spread, j) / sigma2
