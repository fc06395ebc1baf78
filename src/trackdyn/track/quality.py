"""Track geometry quality: longitudinal level in the EN 13848 wavebands, segment SD.

EN 13848-1 defines the longitudinal level in wavebands D1 (3-25 m), D2 (25-70 m) and
D3 (70-150 m); quality is assessed from its standard deviation over fixed-length segments
(commonly 200 m). The filter here is a zero-phase Butterworth band-pass (forward and
backward, so the magnitude is ``|H|^2`` and there is no phase shift); it is not the
standard's reference filter, so values for wavelengths near the band edges can differ from
those of a recording car.

References
----------
EN 13848-1:2019. Railway applications - Track - Track geometry quality - Part 1:
Characterisation of track geometry. CEN, Brussels.

EN 13848-5:2017. Railway applications - Track - Track geometry quality - Part 5: Geometric
quality levels - Plain line, switches and crossings. CEN, Brussels.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pandas as pd
from scipy import signal

from trackdyn.errors import TrackdynInputError, check_series, shown, unknown

WAVEBANDS: dict[str, tuple[float, float]] = {
    "D1": (3.0, 25.0),
    "D2": (25.0, 70.0),
    "D3": (70.0, 150.0),
}
"""EN 13848-1 wavebands, (shortest, longest) wavelength [m]."""


def to_uniform_grid(x: np.ndarray, z: np.ndarray, rtol: float = 1e-6):
    """Return ``(xu, zu, dx, uniform)``: ``z`` linearly resampled at the median spacing.

    If every ``x`` lies within ``rtol * dx`` of a uniform grid, the input is returned
    unchanged with ``uniform=True``.
    """
    dx = float(np.median(np.diff(x))) if x.size > 1 else 1.0
    if np.all(np.abs(x - x[0] - dx * np.arange(x.size)) <= rtol * dx):
        return x, z, dx, True
    xu = x[0] + dx * np.arange(int(np.floor((x[-1] - x[0]) / dx + 1e-9)) + 1)
    return xu, np.interp(xu, x, z), dx, False


def _band(band) -> tuple[str, float, float]:
    if isinstance(band, str):
        key = band.upper()
        if key not in WAVEBANDS:
            raise unknown("band", band, WAVEBANDS)
        return key, *WAVEBANDS[key]
    try:
        lo, hi = (float(v) for v in band)
    except (TypeError, ValueError):
        raise TrackdynInputError(f"band must be a name or (min, max) in m, got {band!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
        raise TrackdynInputError(f"band must satisfy 0 < min < max [m], got {band!r}")
    return f"{lo:g}-{hi:g} m", lo, hi


def longitudinal_level(
    distance, profile, band="D1", *, order: int = 4, where: str = ""
) -> np.ndarray:
    """Longitudinal level: the vertical profile band-passed to one EN 13848 waveband.

    Zero-phase Butterworth band-pass (forward and backward, as ``scipy.signal.sosfiltfilt``)
    between spatial frequencies ``1/max`` and ``1/min`` cycles/m. Non-uniform input is
    resampled linearly at the median spacing, filtered and interpolated back. Both ends are
    padded by holding the end value over one longest wavelength (of the padding types in
    ``sosfiltfilt`` this gave the smallest end transients on synthetic profiles); within
    about one longest wavelength of either end the result is still less reliable.

    Parameters
    ----------
    distance : array_like
        Positions, finite and strictly increasing; the length must be at least twice the
        longest wavelength of the band [m].
    profile : array_like
        Vertical profile, positive downward [m].
    band : str or tuple of float
        ``"D1"``, ``"D2"``, ``"D3"`` or (shortest, longest) wavelength [m].
    order : int
        Butterworth prototype order; the band-pass has twice as many poles [-].
    where : str
        Source of the profile (a file) named in error messages.

    Returns
    -------
    ndarray
        Longitudinal level at ``distance`` [m].
    """
    return LevelFilter(distance, band, order=order, where=where)(profile)


class LevelFilter:
    """`longitudinal_level` on one grid of distances, set up once (checked, the filter
    designed, the grid's spacing found) for the profiles of many states of a track: the
    deterioration loop assesses every step's geometry on the same grid.

    Parameters
    ----------
    distance, band, order, where
        As `longitudinal_level`.
    """

    def __init__(self, distance, band="D1", *, order: int = 4, where: str = ""):
        x = check_series(distance, min_points=3, where=where)
        at = f"{where}: " if where else ""
        label, lam_min, lam_max = _band(band)
        if isinstance(order, bool) or int(order) != order or not 1 <= order <= 10:
            raise TrackdynInputError(f"order must be an integer in 1..10, got {order!r}")
        length = x[-1] - x[0]
        if length < 2.0 * lam_max:
            raise TrackdynInputError(
                f"{at}profile length {length:g} m is too short for band {label}: "
                f"need at least {2.0 * lam_max:g} m (2 x longest wavelength)"
            )
        xu, _, dx, uniform = to_uniform_grid(x, x)
        if dx >= lam_min / 2.0:
            raise TrackdynInputError(
                f"{at}distance spacing {dx:g} m is too coarse for band {label}: "
                f"need < {lam_min / 2:g} m"
            )
        self.x, self.xu, self.uniform, self.where = x, xu, uniform, where
        self.sos, self.zi = _bandpass(int(order), lam_min, lam_max, dx)
        self.padlen = min(xu.size - 1, int(np.ceil(lam_max / dx)))

    def __call__(self, profile) -> np.ndarray:
        """Longitudinal level of ``profile`` (at the distances) [m]."""
        z = np.asarray(profile, dtype=float)
        if z.shape != self.x.shape or not np.isfinite(z).all():
            check_series(self.x, z, where=self.where)  # refuses it, naming the row
        zu = z if self.uniform else np.interp(self.xu, self.x, z)
        out = _forward_backward(self.sos, self.zi, zu, self.padlen)
        return out if self.uniform else np.interp(self.x, self.xu, out)


def segment_sd(distance, level, segment_length: float = 200.0) -> pd.DataFrame:
    """Standard deviation of the longitudinal level over fixed-length segments.

    Segments start at ``distance[0]`` and are half-open, ``[start, start + L)``, except that
    the last one also holds its end point. A remainder longer than ``L / 2`` is a segment of
    its own (ending at ``distance[-1]``); a shorter one belongs to the last whole segment
    (which then ends at ``distance[-1]``, up to ``1.5 L`` long), so every position is in a
    segment, unless the series is ``L / 2`` long or shorter (no segment). The SD
    is over the samples in the segment (``ddof=0``, not distance-weighted); a segment with
    fewer than 2 samples gets NaN.

    Parameters
    ----------
    distance : array_like
        Positions, finite and strictly increasing [m].
    level : array_like
        Longitudinal level, e.g. from :func:`longitudinal_level` [m].
    segment_length : float
        Segment length ``L`` [m].

    Returns
    -------
    pandas.DataFrame
        Columns ``segment_start_m`` [m], ``segment_end_m`` [m] and ``sd_mm`` [mm].
    """
    x, v = check_series(distance, level, name="level")
    starts, ends, sd = segment_sd_values(x, v, segment_length)
    return pd.DataFrame({"segment_start_m": starts, "segment_end_m": ends, "sd_mm": sd})


def segment_sd_values(x: np.ndarray, v: np.ndarray, segment_length: float):
    """`segment_sd` as arrays (segment starts and ends [m], SD [mm]), of series already
    checked: for callers that assess many profiles (the deterioration loop), without a
    DataFrame each time."""
    segments = Segments(x, segment_length)
    return segments.starts, segments.ends, segments.sd(v)


class Segments:
    """The segments of `segment_sd` on one grid of distances, found once.

    Parameters
    ----------
    x : ndarray
        Positions, checked: finite and strictly increasing [m].
    segment_length : float
        Segment length [m].

    Attributes
    ----------
    starts, ends : ndarray
        Segment bounds [m].
    """

    def __init__(self, x: np.ndarray, segment_length: float):
        seg = float(segment_length)
        if not (np.isfinite(seg) and seg > 0):
            raise TrackdynInputError(
                f"segment_length must be finite and > 0, got {shown(segment_length)}"
            )
        span = x[-1] - x[0]
        tol = 1e-9 * seg
        n_full = int(np.floor(span / seg + 1e-9))
        starts = x[0] + seg * np.arange(n_full)
        ends = starts + seg
        if span - n_full * seg > seg / 2.0:
            starts = np.append(starts, x[0] + n_full * seg)
            ends = np.append(ends, x[-1])
        elif n_full > 0:  # a remainder of at most half a segment: part of the last one
            ends[-1] = x[-1]
        self.starts, self.ends, self._rows = starts, ends, []
        for k, (start, end) in enumerate(zip(starts, ends, strict=True)):
            lo = np.searchsorted(x, start - tol, side="left")
            last = k == starts.size - 1
            hi = np.searchsorted(x, end + tol if last else end - tol,
                                 side="right" if last else "left")  # fmt: skip
            self._rows.append((int(lo), int(hi)))

    def sd(self, v: np.ndarray) -> np.ndarray:
        """Standard deviation of ``v`` (at the positions) over each segment [mm] (NaN with
        fewer than 2 samples)."""
        sd = np.full(self.starts.size, np.nan)
        for k, (lo, hi) in enumerate(self._rows):
            if hi - lo >= 2:
                sd[k] = np.std(v[lo:hi]) * 1e3
        return sd


@lru_cache(maxsize=64)
def _bandpass(order: int, lam_min: float, lam_max: float, dx: float):
    """Second-order sections of the Butterworth band-pass of `longitudinal_level` and their
    steady-state response to a unit step (``scipy.signal.sosfilt_zi``), designed once per
    band and spacing (the deterioration loop filters every step's profiles); shared, so not
    to be changed by a caller."""
    sos = signal.butter(order, [1.0 / lam_max, 1.0 / lam_min], btype="bandpass", fs=1.0 / dx,
                        output="sos")  # fmt: skip
    return sos, signal.sosfilt_zi(sos)


def _forward_backward(sos, zi, z, padlen: int) -> np.ndarray:
    """``z`` filtered forward and then backward (zero phase), each end padded with
    ``padlen`` copies of its end value and each pass started in the steady state of its
    first input value, as ``scipy.signal.sosfiltfilt(sos, z, padtype="constant",
    padlen=padlen)`` does, with the steady state ``zi`` given rather than found again."""
    ext = np.concatenate([np.full(padlen, z[0]), z, np.full(padlen, z[-1])])
    forward = signal.sosfilt(sos, ext, zi=zi * ext[0])[0]
    backward = signal.sosfilt(sos, forward[::-1], zi=zi * forward[-1])[0][::-1]
    return backward[padlen : backward.size - padlen]
