"""Vertical track irregularity spectra, synthetic profiles and PSD estimation.

``Omega`` is in rad/m; the PSDs are treated as one-sided in ``Omega`` (variance = integral
over 0 < Omega < inf), in m^2/(rad/m), all of the form
``S = k A_v Oc^2 / ((Omega^2 + Or^2)(Omega^2 + Oc^2))``:

- German spectra (ORE B176, as used in the vehicle dynamics literature): ``k = 1``,
  ``Oc = 0.8246``, ``Or = 0.0206`` rad/m, ``A_v = 4.032e-7`` m rad (low disturbance,
  ``german_low``) or ``1.080e-6`` m rad (high disturbance, ``german_high``).
- US Federal Railroad Administration track classes (as tabulated in the railway vehicle
  dynamics literature, e.g. Garg & Dukkipati 1984): ``k = 0.25``, ``Oc = 0.8245`` rad/m,
  ``Or = 0``, ``A_v`` = 1.2107, 1.0181, 0.6816, 0.5376, 0.2095, 0.0339 cm^2 rad/m for
  ``fra1``..``fra6``; stated validity 1.524-304.8 m wavelength.

References
----------
Garg, V.K. & Dukkipati, R.V. (1984). Dynamics of Railway Vehicle Systems. Academic Press,
Toronto (FRA track class spectra).

ORE Question B176 (1989). Bogies with steered or steering wheelsets, Report No. 1:
Specifications and preliminary studies. Office for Research and Experiments of the
International Union of Railways, Utrecht (German low/high disturbance spectra).

Welch, P.D. (1967). The use of fast Fourier transform for the estimation of power spectra.
IEEE Transactions on Audio and Electroacoustics 15(2), 70-73.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from trackdyn.errors import TrackdynInputError, check_series, unknown
from trackdyn.track.quality import to_uniform_grid


@dataclass(frozen=True)
class TrackSpectrum:
    """A spectrum ``k A_v Oc^2 / ((W^2 + Or^2)(W^2 + Oc^2))``; call it with ``W`` [rad/m].

    Parameters
    ----------
    name : str
        Key in :data:`SPECTRA`.
    A_v : float
        Roughness coefficient [m^2 rad/m] (equivalently m rad).
    omega_c : float
        Cut-off spatial frequency ``Oc`` [rad/m].
    omega_r : float
        Low-frequency corner ``Or``, 0 for the FRA spectra [rad/m].
    k : float
        Scale factor, 0.25 for the FRA spectra [-].
    source : str
        Where the figures come from.
    """

    name: str
    A_v: float
    omega_c: float
    omega_r: float
    k: float
    source: str

    def __call__(self, omega) -> np.ndarray:
        w2, oc2 = np.asarray(omega, dtype=float) ** 2, self.omega_c**2
        return self.k * self.A_v * oc2 / ((w2 + self.omega_r**2) * (w2 + oc2))


_GERMAN, _FRA = "ORE B176 (German spectrum)", "FRA class, Garg & Dukkipati (1984)"
SPECTRA: dict[str, TrackSpectrum] = {
    "german_low": TrackSpectrum("german_low", 4.032e-7, 0.8246, 0.0206, 1.0, _GERMAN),
    "german_high": TrackSpectrum("german_high", 1.080e-6, 0.8246, 0.0206, 1.0, _GERMAN),
    **{
        f"fra{i}": TrackSpectrum(f"fra{i}", a * 1e-4, 0.8245, 0.0, 0.25, _FRA)
        for i, a in enumerate((1.2107, 1.0181, 0.6816, 0.5376, 0.2095, 0.0339), start=1)
    },
}
"""Known spectra by name."""


def get_spectrum(spectrum: str | TrackSpectrum) -> TrackSpectrum:
    """Look up a spectrum by name (case-insensitive) or pass a :class:`TrackSpectrum` through."""
    found = spectrum if isinstance(spectrum, TrackSpectrum) else SPECTRA.get(str(spectrum).lower())
    if found is None:
        raise unknown("spectrum", spectrum, SPECTRA)
    return found


def psd(name: str | TrackSpectrum, omega) -> np.ndarray:
    """One-sided vertical irregularity PSD.

    Parameters
    ----------
    name : str or TrackSpectrum
        Spectrum name, one of :data:`SPECTRA` (e.g. ``"fra4"``, ``"german_high"``).
    omega : array_like
        Spatial frequency, finite and > 0 [rad/m].

    Returns
    -------
    ndarray
        PSD [m^2/(rad/m)].
    """
    w = np.asarray(omega, dtype=float)
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise TrackdynInputError("omega must be finite and > 0 [rad/m]")
    return get_spectrum(name)(w)


def _integer(name: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lo <= value <= hi:
        raise TrackdynInputError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def _harmonic_sum(x: np.ndarray, w: np.ndarray, amp: np.ndarray, phase: np.ndarray):
    """``sum_i amp_i cos(w_i x + phase_i)``, with work arrays of ~16 MB."""
    block = max(1, min(x.size, 1_000_000 // w.size))
    _, _, dx, uniform = to_uniform_grid(x, x)
    if not uniform:
        chunks = (x[i : i + block] for i in range(0, x.size, block))
        return np.concatenate([np.cos(np.outer(xc, w) + phase) @ amp for xc in chunks])
    # Uniform grid: all blocks share exp(i w t); one column of `coef` per block start.
    template = np.exp(1j * np.outer(dx * np.arange(block), w))
    starts = x[0] + dx * block * np.arange(-(-x.size // block))
    parts = []
    for j in range(0, starts.size, block):
        coef = amp[:, None] * np.exp(1j * (np.outer(w, starts[j : j + block]) + phase[:, None]))
        parts.append((template @ coef).real.T.ravel())
    return np.concatenate(parts)[: x.size]


WAVELENGTH_RANGE = (1.524, 304.8)
"""Shortest and longest wavelength of a synthetic profile [m]: the FRA spectra's stated
validity (5 to 1000 ft)."""


def generate_profile(
    distance,
    spectrum: str | TrackSpectrum,
    *,
    seed=None,
    wavelength_range: tuple[float, float] = WAVELENGTH_RANGE,
    n_harmonics: int = 2000,
) -> np.ndarray:
    """Synthetic vertical profile as a sum of harmonics with random phases.

    The band ``2 pi / wavelength_range`` is split into ``n_harmonics`` equal bins; each bin
    holds one cosine at a uniformly random frequency within the bin (which avoids the
    periodicity of an exactly even comb), amplitude ``sqrt(2 S(W_i) dW)`` and a uniformly
    random phase. The expected variance equals the integral of ``S`` over the band.

    Parameters
    ----------
    distance : array_like
        Positions along the track, finite and strictly increasing [m].
    spectrum : str or TrackSpectrum
        Spectrum name, one of :data:`SPECTRA`.
    seed : int or numpy.random.Generator, optional
        Seed for :func:`numpy.random.default_rng`; same seed gives the same profile.
    wavelength_range : tuple of float
        Shortest and longest wavelength generated [m].
    n_harmonics : int
        Number of harmonics [-].

    Returns
    -------
    ndarray
        Vertical profile, positive downward, zero mean in expectation [m].
    """
    spec = get_spectrum(spectrum)
    x = check_series(distance)
    lo, hi = (float(v) for v in wavelength_range)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
        raise TrackdynInputError(f"wavelength_range must be 0 < min < max, got {wavelength_range}")
    n_harmonics = _integer("n_harmonics", n_harmonics, 1, 10**6)
    rng = np.random.default_rng(seed)
    w_lo = 2 * np.pi / hi
    dw = (2 * np.pi / lo - w_lo) / n_harmonics
    w = w_lo + dw * (np.arange(n_harmonics) + rng.random(n_harmonics))
    amp = np.sqrt(2.0 * spec(w) * dw)
    phase = rng.uniform(0.0, 2 * np.pi, n_harmonics)
    return _harmonic_sum(x, w, amp, phase)


def estimate_psd(distance, profile, nperseg: int | None = None):
    """Welch estimate of the one-sided PSD of a profile, comparable with :func:`psd`.

    Hann window, 50 % overlap, linear detrend. Non-uniform input is first resampled
    linearly at the median spacing, which attenuates the shortest wavelengths a little.

    Parameters
    ----------
    distance : array_like
        Positions, finite and strictly increasing [m].
    profile : array_like
        Vertical profile [m].
    nperseg : int, optional
        Samples per Welch segment; default ``min(1024, n)`` [-].

    Returns
    -------
    omega : ndarray
        Spatial frequency, zero excluded [rad/m].
    S : ndarray
        One-sided PSD [m^2/(rad/m)].
    """
    x, z = check_series(distance, profile, min_points=8)
    _, zu, dx, _ = to_uniform_grid(x, z)
    nperseg = _integer("nperseg", min(1024, zu.size) if nperseg is None else nperseg, 8, zu.size)
    f, pxx = signal.welch(zu, fs=1.0 / dx, nperseg=nperseg, detrend="linear")
    # cycles/m -> rad/m: Omega = 2 pi f, S(Omega) = P(f) / (2 pi).
    return 2 * np.pi * f[1:], pxx[1:] / (2 * np.pi)
