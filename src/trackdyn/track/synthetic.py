"""Synthetic tracks: irregular geometry from a named spectrum and varying support stiffness.

Used for the built-in example section and for tests. The stiffness model is an engineering
estimate, not a calibrated one: each sleeper's curve is
``y(P) = P / k + g (1 - exp(-P / P0))``, a linear track stiffness ``k`` [N/m] behind a
seating range of gap ``g`` [m] that closes by about the seed's 32.5 kN seating load
(``P0 = 32.5 kN / 3``).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria,
§5.2 (the seating load of voided sleepers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trackdyn.errors import TrackdynInputError, shown
from trackdyn.track.spectra import generate_profile
from trackdyn.track.support import Curves, SupportCurve
from trackdyn.track.track import Geometry, Supports, Track

SEATING_LOAD = 32.5e3
"""Seating load quoted by the seed (Ebersöhn et al., 1993) [N]."""

CURVE_LOADS = np.array([0.0, 15.0, 32.5, 60.0, 100.0, 140.0, 180.0, 250.0]) * 1e3
"""Wheel loads at which synthetic curves are tabulated [N]."""


@dataclass(frozen=True)
class SoftSpot:
    """A stretch of weak support: stiffness times ``factor``, seating gap plus ``gap``.

    Parameters
    ----------
    centre : float
        Centre of the soft spot [m].
    length : float
        Length over which it is fully soft (cosine taper of the same length each side) [m].
    factor : float
        Stiffness multiplier at its centre [-].
    gap : float
        Additional seating gap at its centre [m].
    """

    centre: float
    length: float
    factor: float = 0.5
    gap: float = 1.0e-3

    def weight(self, x):
        d = np.abs(np.asarray(x) - self.centre) - self.length / 2
        return np.where(
            d <= 0, 1.0, np.where(d < self.length, 0.5 * (1 + np.cos(np.pi * d / self.length)), 0.0)
        )


@dataclass(frozen=True)
class VoidedSleepers:
    """Consecutive hanging sleepers on one or both rails.

    Parameters
    ----------
    position : float
        Position of the first voided sleeper (the nearest sleeper is taken) [m].
    count : int
        Number of consecutive voided sleepers.
    gap : float
        Seating gap (void) under each [m].
    rail : {"left", "right", "both"}
        Rail(s) affected.
    """

    position: float
    count: int = 2
    gap: float = 3.0e-3
    rail: str = "both"


@dataclass(frozen=True)
class Transition:
    """A transition onto a stiff structure (bridge, culvert, slab) with no seating gap.

    Parameters
    ----------
    start : float
        Start of the stiff structure [m].
    length : float
        Length of the stiff structure [m].
    factor : float
        Stiffness multiplier on the structure [-].
    """

    start: float
    length: float
    factor: float = 3.0

    def weight(self, x):
        x = np.asarray(x)
        return ((x >= self.start) & (x <= self.start + self.length)).astype(float)


def correlated_field(n: int, spacing: float, correlation_length: float, rng) -> np.ndarray:
    """Zero-mean, unit-variance Gaussian random field on ``n`` points ``spacing`` [m] apart.

    White noise smoothed with a Gaussian kernel; the autocorrelation is
    ``exp(-(d / correlation_length)^2)``.
    """
    if correlation_length <= 0:
        raise TrackdynInputError(
            f"correlation_length must be > 0, got {shown(correlation_length)} m"
        )
    sigma = correlation_length / np.sqrt(2) / spacing
    half = int(np.ceil(4 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    kernel /= np.sqrt(np.sum(kernel**2))
    noise = rng.standard_normal(n + 2 * half)
    return np.convolve(noise, kernel, mode="valid")


def synthetic_track(
    length: float = 1000.0,
    *,
    spectrum: str = "fra4",
    seed: int = 0,
    sample_spacing: float = 0.25,
    sleeper_spacing: float = 0.6,
    stiffness: float = 100e6,
    stiffness_cov: float = 0.2,
    correlation_length: float = 5.0,
    gap: float = 0.5e-3,
    rail_correlation: float = 0.7,
    features: tuple = (),
    where: str = "synthetic track",
) -> Track:
    """Make a synthetic track section.

    Parameters
    ----------
    length : float
        Section length [m].
    spectrum : str or None
        Irregularity spectrum name (see `trackdyn.track.spectra`); None gives level rails.
    seed : int
        Seed of the random generator; the same seed gives the same track.
    sample_spacing : float
        Geometry sampling interval [m].
    sleeper_spacing : float
        Sleeper spacing [m].
    stiffness : float
        Mean linear track stiffness per wheel above the seating range [N/m].
    stiffness_cov : float
        Coefficient of variation of the stiffness (lognormal field) [-]; 0 gives uniform.
    correlation_length : float
        Correlation length of the stiffness and gap fields [m].
    gap : float
        Mean seating gap [m]; its field has the same coefficient of variation.
    rail_correlation : float
        Correlation of the left and right rail fields [-].
    features : tuple
        `SoftSpot`, `VoidedSleepers` and `Transition` instances.
    where : str
        Name used in error messages.
    """
    if length <= 0 or sleeper_spacing <= 0 or sample_spacing <= 0 or stiffness <= 0:
        raise TrackdynInputError("length, spacings and stiffness must be > 0")
    rng = np.random.default_rng(seed)
    distance = np.arange(0.0, length + sample_spacing / 2, sample_spacing)
    if spectrum is None:
        left = right = np.zeros_like(distance)
    else:
        left = generate_profile(distance, spectrum, seed=rng.integers(2**32))
        right = generate_profile(distance, spectrum, seed=rng.integers(2**32))
    position = np.arange(sleeper_spacing / 2, length, sleeper_spacing)
    n = position.size
    common_k = correlated_field(n, sleeper_spacing, correlation_length, rng)
    common_g = correlated_field(n, sleeper_spacing, correlation_length, rng)
    c = np.clip(rail_correlation, 0.0, 1.0)
    s = stiffness_cov
    log_sd = np.sqrt(np.log1p(s**2))
    k = np.empty((2, n))
    g = np.empty((2, n))
    for r in range(2):
        fk = c * common_k + np.sqrt(1 - c**2) * correlated_field(
            n, sleeper_spacing, correlation_length, rng
        )
        fg = c * common_g + np.sqrt(1 - c**2) * correlated_field(
            n, sleeper_spacing, correlation_length, rng
        )
        k[r] = stiffness * np.exp(log_sd * fk - 0.5 * log_sd**2)
        g[r] = gap * np.exp(log_sd * fg - 0.5 * log_sd**2)
    for feature in features:
        if isinstance(feature, SoftSpot):
            w = feature.weight(position)
            k *= 1 + (feature.factor - 1) * w
            g += feature.gap * w
        elif isinstance(feature, Transition):
            w = feature.weight(position)
            k *= 1 + (feature.factor - 1) * w
            g *= 1 - w
        elif isinstance(feature, VoidedSleepers):
            i0 = int(np.argmin(np.abs(position - feature.position)))
            rails = {"left": [0], "right": [1], "both": [0, 1]}[feature.rail]
            for r in rails:
                g[r, i0 : i0 + feature.count] = feature.gap
        else:
            raise TrackdynInputError(f"unknown track feature {feature!r}")
    p0 = SEATING_LOAD / 3
    curves = [
        Curves.of(
            SupportCurve(
                CURVE_LOADS,
                CURVE_LOADS / k[r, i] + g[r, i] * (1 - np.exp(-CURVE_LOADS / p0)),
                f"{where}: {rail} rail, sleeper {i}",
            )
            for i in range(n)
        )
        for r, rail in enumerate(("left", "right"))
    ]
    return Track(
        Geometry(distance, left, right, where), Supports(position, curves[0], curves[1], where)
    )


EXAMPLE_FEATURES = (
    SoftSpot(centre=300.0, length=12.0, factor=0.45, gap=1.5e-3),
    VoidedSleepers(position=500.0, count=3, gap=3.0e-3, rail="left"),
    Transition(start=700.0, length=40.0, factor=3.0),
)
"""Named features of the built-in 1 km example section."""


def example_track() -> Track:
    """The built-in example: 1 km of heavy-haul track with a soft spot, voids and a bridge.

    FRA class 5 geometry; a soft spot at 300 m, three voided sleepers on the left rail at
    500 m and a 40 m stiff structure from 700 m, on a stiffness field of 100 kN/mm mean.
    """
    return synthetic_track(
        1000.0, spectrum="fra5", seed=2026, features=EXAMPLE_FEATURES, where="built-in example"
    )
