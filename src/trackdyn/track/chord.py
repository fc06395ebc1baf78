"""Chord (versine) measurements of the longitudinal level, and the profile they come from.

Older track recording cars and hand trolleys measure the vertical profile as a versine: the
offset of the rail at the measuring point from a chord resting on the rail ``back`` metres
behind it and ``front`` metres ahead. With the profile ``z`` positive downward (the
package's convention), the versine is positive where the rail dips below the chord::

    v(x) = z(x) - (front z(x - back) + back z(x + front)) / (back + front)

A harmonic ``z = e^(i k x)`` (``k = 2 pi / wavelength``) comes out multiplied by the chord's
transfer function (derived from the line above; see `Chord.gain`)::

    H(k) = 1 - (front e^(-i k back) + back e^(i k front)) / (back + front)

For a symmetric chord of length ``L`` (``back = front = L / 2``) this is the real
``H = 1 - cos(k L / 2)``: zero gain at wavelengths ``L / 2, L / 4, ...`` (for a 10 m chord
5 m and 2.5 m; for a 20 m chord 10 m and 5 m) and towards long waves, a gain of 2 at
``L, L / 3, ...``. An asymmetric chord has zeros only at wavelengths that divide both
``back`` and ``front``, so it passes the whole D1 band when they share no long common
divisor, at the price of a phase shift the inverse undoes.

The profile is recovered by the inverse of ``H``, limited where the gain is small::

    Z(k) = V(k) conj(H(k)) / max(|H(k)|^2, floor^2)

over the wavelengths asked for, zero elsewhere: the exact inverse ``V / H`` where
``|H| >= floor``; below it the gain is too small for the measurement noise (which the
inverse would amplify by ``1 / |H|``), the inverse is held at ``1 / floor`` times the
versine there, and those wavelengths are reported as the lost band (`Chord.lost_band`),
where the recovered profile holds less than the true one.

References
----------
EN 13848-2:2020. Railway applications - Track - Track geometry quality - Part 2: Measuring
systems - Track recording vehicles. CEN, Brussels (chord-based measuring principles and
their transfer functions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trackdyn.errors import TrackdynInputError, check_series, require_positive

GAIN_FLOOR = 0.2
"""Chord gain below which wavelengths count as lost and the inverse is damped [-]: with
0.2 mm of measurement noise on the versine, a gain of 0.2 lets at most 1 mm of noise into
the recovered profile (illustrative: set by the noise of the measurement, which a railway
knows for its own car)."""

RECOVERED_BAND = (3.0, 70.0)
"""Wavelengths recovered from a versine unless given [m]: the EN 13848-1 D1 and D2 bands."""


@dataclass(frozen=True)
class Chord:
    """A measuring chord resting on the rail ``back_m`` behind and ``front_m`` ahead of the
    measuring point.

    Parameters
    ----------
    back_m, front_m : float
        Distances from the measuring point to the chord's ends [m], > 0.
    """

    back_m: float
    front_m: float

    def __post_init__(self):
        require_positive("chord_back_m", self.back_m)
        require_positive("chord_front_m", self.front_m)

    @classmethod
    def symmetric(cls, length_m: float) -> Chord:
        """A mid-chord measurement over a chord of ``length_m`` [m]."""
        half = float(require_positive("chord_m", length_m)) / 2.0
        return cls(half, half)

    def gain(self, wavelength) -> np.ndarray:
        """The transfer function ``H`` from profile to versine at ``wavelength`` [m]
        (complex; ``|H|`` is the gain)."""
        k = 2.0 * np.pi / np.asarray(wavelength, dtype=float)
        a, b = self.back_m, self.front_m
        return 1.0 - (b * np.exp(-1j * k * a) + a * np.exp(1j * k * b)) / (a + b)

    def versine(self, distance, profile) -> np.ndarray:
        """The versine this chord measures on ``profile`` at ``distance`` [m] (positive
        down, as the profile), NaN where an end of the chord lies beyond the profile.

        Parameters
        ----------
        distance : array_like
            Positions, strictly increasing [m].
        profile : array_like
            Vertical profile, positive downward [m].
        """
        x, z = check_series(distance, profile)
        a, b = self.back_m, self.front_m
        behind = np.interp(x - a, x, z)
        ahead = np.interp(x + b, x, z)
        v = z - (b * behind + a * ahead) / (a + b)
        v[(x - a < x[0]) | (x + b > x[-1])] = np.nan
        return v

    def lost_band(self, band=RECOVERED_BAND, floor: float = GAIN_FLOOR) -> list[tuple]:
        """Wavelength ranges within ``band`` where the gain is below ``floor``, as
        (shortest, longest) [m], found on a fine grid of wavelengths (0.1 % apart)."""
        lo, hi = band
        wavelength = np.geomspace(lo, hi, int(np.log(hi / lo) / np.log1p(1e-3)) + 2)
        weak = np.abs(self.gain(wavelength)) < floor
        edges = np.flatnonzero(np.diff(np.concatenate([[0], weak.astype(int), [0]])))
        return [(float(wavelength[s]), float(wavelength[e - 1])) for s, e in edges.reshape(-1, 2)]


def profile_from_versine(distance, versine, chord: Chord, band=RECOVERED_BAND,
                         floor: float = GAIN_FLOOR, where: str = "") -> np.ndarray:  # fmt: skip
    """The vertical profile whose versine over ``chord`` is ``versine``, over the
    wavelengths of ``band`` (the regularised inverse of the chord's transfer function, see
    the module's text).

    The versine is mirrored at both ends before the transform (no jump where the record
    ends wraps round); near either end the result is less reliable: a sum of sines of 4.5
    mm recovered from a 10 m chord's versine came out up to 2.1 mm off within 50 m of an
    end, 0.36 mm 50-100 m and 0.053 mm 100-200 m from it, 0.014 mm beyond.

    Parameters
    ----------
    distance : array_like
        Positions, uniformly spaced (a recording car's samples) [m].
    versine : array_like
        Measured versine, positive downward, finite [m].
    chord : Chord
        The measuring chord.
    band : tuple of float
        Shortest and longest wavelength recovered [m]; beyond them the recovery tapers to
        zero over a ratio of `BAND_TAPER`.
    floor : float
        Gain below which the inverse is held (`GAIN_FLOOR`) [-].
    where : str
        Source named in error messages (a file).

    Returns
    -------
    ndarray
        The recovered profile at ``distance``, positive downward, zero mean [m].
    """
    at = f"{where}: " if where else ""
    x, v = check_series(distance, versine, where=where)
    step = np.diff(x)
    dx = float(np.median(step))
    if np.max(np.abs(step - dx)) > 1e-6 * dx:
        raise TrackdynInputError(f"{at}a versine needs uniformly spaced samples; the spacing "
                                 f"varies from {step.min():g} to {step.max():g} m")  # fmt: skip
    lo, hi = (float(b) for b in band)
    if not 2.0 * dx * BAND_TAPER < lo < hi:
        raise TrackdynInputError(f"{at}the recovered band must be {2 * BAND_TAPER:g} sample "
                                 f"spacings ({2 * BAND_TAPER * dx:g} m) < shortest < longest, "
                                 f"got {band}")  # fmt: skip
    mirrored = np.concatenate([v, v[::-1]]) - np.mean(v)
    wavenumber = 2.0 * np.pi * np.fft.rfftfreq(mirrored.size, dx)
    spectrum = np.fft.rfft(mirrored)
    out = np.zeros_like(spectrum)
    weight = band_weight(2.0 * np.pi / np.maximum(wavenumber, 1e-300), lo, hi)
    inside = weight > 0
    h = chord.gain(2.0 * np.pi / wavenumber[inside])
    out[inside] = weight[inside] * spectrum[inside] * np.conj(h) / np.maximum(np.abs(h) ** 2,
                                                                              floor**2)  # fmt: skip
    return np.fft.irfft(out, mirrored.size)[: v.size]


BAND_TAPER = 1.5
"""Ratio of wavelengths over which the recovered band's edges taper to zero [-]: a sharp
edge rings along the record: a sum of sines of 4.5 mm (6.25, 12.5 and 20 m) recovered from
a 10 m chord's versine came out up to 0.058 mm off 200-400 m from an end and 0.021 mm
400-1000 m from it; with the taper 0.014 and 0.004 mm."""


def band_weight(wavelength, lo: float, hi: float) -> np.ndarray:
    """1 between ``lo`` and ``hi`` [m], falling as ``cos^2`` in log wavelength to 0 at
    ``lo / BAND_TAPER`` and ``hi * BAND_TAPER``."""
    lam = np.asarray(wavelength, dtype=float)
    below = np.clip(np.log(lo / lam) / np.log(BAND_TAPER), 0.0, 1.0)
    above = np.clip(np.log(lam / hi) / np.log(BAND_TAPER), 0.0, 1.0)
    return np.cos(0.5 * np.pi * np.maximum(below, above)) ** 2 * (np.maximum(below, above) < 1)
