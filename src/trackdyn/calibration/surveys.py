"""Geometry surveys of one section: read, checked for gaps, aligned in distance.

A recording car's distance reference drifts from run to run by metres, so before two
surveys can be compared each is aligned to the first: both rails' D1-band longitudinal
level (`trackdyn.track.quality.longitudinal_level`) on a common uniform grid, the shift
that maximises their normalised cross-correlation over whole samples, refined to a
fraction of a sample by a parabola through the peak and its neighbours. The correlation
at the peak says whether the surveys show the same track; below ``min_correlation`` the
survey is refused.

Settlement does not only deepen the dips: the wheel loads lag the geometry, so the D1
profile of a later survey also looks shifted by some decimetres (0.2 m in 5 MGT on a
synthetic section, 7-DOF model at 60 km/h). The calibration therefore aligns each survey
again, within `REFINE` of the first shift, to the profile the model predicts for its
tonnage.

The change between surveys is taken in the D1 band too, ``D1(z_k - z_1)`` on the first
survey's distance grid: surveys need no common vertical reference (the band-pass drops
offsets and long waves), and the change of the predicted profile goes through the same
filter on the same grid, so the ends of the band-pass affect both alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_geometry
from trackdyn.track.quality import WAVEBANDS, longitudinal_level
from trackdyn.track.track import RAILS, Geometry

REFINE = 1.0
"""Half-width of the search of the alignment to a predicted profile [m]."""

MIN_OVERLAP = 0.5
"""Shortest overlap of a shifted survey with the first, as a fraction of the shorter, and
of all surveys together as a fraction of the first [-]."""


def read_survey(path) -> Geometry:
    """Read a survey (geometry CSV, ``distance_m,left_mm,right_mm``): `read_geometry`,
    which bridges gaps up to its ``max_gap_m`` and refuses longer ones naming the lines.

    Parameters
    ----------
    path : path
        The CSV file.
    """
    return read_geometry(path)


def d1_levels(geometry: Geometry, spacing: float) -> tuple[float, np.ndarray]:
    """D1-band level of both rails resampled every ``spacing`` from the first distance.

    Parameters
    ----------
    geometry : Geometry
        The survey.
    spacing : float
        Grid spacing [m].

    Returns
    -------
    start : float
        Distance of the first grid point [m].
    levels : ndarray
        (2 rails, points) D1-band level [m].
    """
    x = geometry.distance
    grid = x[0] + spacing * np.arange(int(np.floor((x[-1] - x[0]) / spacing + 1e-9)) + 1)
    levels = [
        longitudinal_level(grid, np.interp(grid, x, geometry.profile(r)), "D1") for r in RAILS
    ]
    return float(x[0]), np.array(levels)


@dataclass(frozen=True)
class Alignment:
    """How a survey lines up with the first one.

    Parameters
    ----------
    shift : float
        Distance to add to the survey's distances to match the first survey's [m].
    correlation : float
        Normalised cross-correlation of the D1-band levels at that shift [-].
    """

    shift: float
    correlation: float


def align(reference: Geometry, survey: Geometry, max_shift: float, around: float = 0.0):
    """The shift within ``around ± max_shift`` that best lines ``survey`` up with
    ``reference`` (an `Alignment`).

    Parameters
    ----------
    reference : Geometry
        The first survey (or the profile predicted for the survey's tonnage).
    survey : Geometry
        A later survey of the same section.
    max_shift : float
        Largest offset from ``around`` searched [m].
    around : float
        Centre of the search [m].
    """
    spacing = float(np.median(np.diff(reference.distance)))
    a0, a = d1_levels(reference, spacing)
    b0, b = d1_levels(survey, spacing)
    least = MIN_OVERLAP * min(a.shape[1], b.shape[1])
    # pairing a[i] with b[i + lag] means shift = a0 - b0 - lag * spacing
    first = int(np.ceil((a0 - b0 - around - max_shift) / spacing))
    last = int(np.floor((a0 - b0 - around + max_shift) / spacing))
    lags, corr = np.arange(first, last + 1), []
    for lag in lags.tolist():
        i0, i1 = max(0, -lag), min(a.shape[1], b.shape[1] - lag)
        if i1 - i0 < least:
            corr.append(-np.inf)
            continue
        p, q = a[:, i0:i1], b[:, i0 + lag : i1 + lag]
        corr.append(np.sum(p * q) / np.sqrt(np.sum(p * p) * np.sum(q * q)))
    corr = np.nan_to_num(np.array(corr), nan=-np.inf, neginf=-np.inf)  # not -1.8e308
    k = int(np.argmax(corr))
    if not np.isfinite(corr[k]):
        raise TrackdynInputError(
            f"{survey.where}: covers {survey.distance[0]:g}-{survey.distance[-1]:g} m and "
            f"overlaps {reference.where} ({reference.distance[0]:g}-"
            f"{reference.distance[-1]:g} m) by less than half the shorter at every shift "
            f"within {around:+g} ± {max_shift:g} m"
        )
    frac = 0.0
    if 0 < k < corr.size - 1 and np.all(np.isfinite(corr[k - 1 : k + 2])):
        lo, mid, hi = corr[k - 1 : k + 2]
        curve = lo - 2 * mid + hi
        frac = 0.5 * (lo - hi) / curve if curve < 0 else 0.0
    return Alignment(a0 - b0 - (lags[k] + frac) * spacing, float(corr[k]))


def common_grid(reference: Geometry, surveys, shifts, extent, margin=0.0) -> np.ndarray:
    """Indices of the first survey's distances covered by every aligned survey with
    ``margin`` to spare, and inside ``extent``; refused when that is less than
    `MIN_OVERLAP` of the first survey's supported length (surveys of different lengths).

    Parameters
    ----------
    reference : Geometry
        The first survey.
    surveys : sequence of Geometry
        All surveys (the first included, with shift 0).
    shifts : sequence of float
        Their shifts [m].
    extent : tuple of float
        Part of the track with supports [m].
    margin : float
        Distance the shifts may still move by [m].
    """
    pairs = list(zip(surveys, shifts, strict=True))
    starts = [s.distance[0] + d + margin for s, d in pairs]
    ends = [s.distance[-1] + d - margin for s, d in pairs]
    lo, hi = max([extent[0], *starts]), min([extent[1], *ends])
    a, b = max(extent[0], reference.distance[0]), min(extent[1], reference.distance[-1])
    if hi - lo < MIN_OVERLAP * (b - a):
        short = pairs[int(np.argmax(starts) if lo - a > b - hi else np.argmin(ends))][0]
        raise TrackdynInputError(
            f"{short.where}: the surveys share only {lo:.1f}-{hi:.1f} m of the first survey's "
            f"{a:.1f}-{b:.1f} m; surveys of the same stretch are needed (at least half in common)"
        )
    return np.flatnonzero((reference.distance >= lo) & (reference.distance <= hi))


def profiles_at(survey: Geometry, shift: float, x) -> np.ndarray:
    """Both rails' profile of an aligned survey at the distances ``x`` [m], (2, points).

    Parameters
    ----------
    survey : Geometry
        The survey.
    shift : float
        Its shift [m].
    x : ndarray
        Distances on the first survey's reference [m].
    """
    return np.array([np.interp(x, survey.distance + shift, survey.profile(r)) for r in RAILS])


def d1_change(x, change) -> np.ndarray:
    """D1-band part of a change of both rails' profiles, (2, points) [m].

    Parameters
    ----------
    x : ndarray
        Distances [m].
    change : ndarray
        (2, points) profile change [m].
    """
    return np.array([longitudinal_level(x, c, "D1") for c in change])


NOISE_FACTOR = 2.0
"""A fitted survey's D1-band change must exceed this many times the measurement noise
expected in the band [-]; noise alone gives about 1 (1.0 for 0.3 mm white noise on the
example's 200 m)."""


def change_and_noise(x, change, valid) -> tuple[float, float]:
    """RMS of the D1-band part of a profile change at the ``valid`` points and the RMS that
    its measurement noise alone would give in the band [m].

    The noise is taken from the sample-to-sample scatter of the change (settlement under a
    rail beam is smooth over a sample spacing, white noise of SD σ gives differences of SD
    σ√2) and scaled to the D1 band's share of the frequencies up to the Nyquist frequency.

    Parameters
    ----------
    x : ndarray
        Uniformly spaced distances [m].
    change : ndarray
        (2 rails, points) profile change [m].
    valid : ndarray
        Points compared (away from the band-pass ends) [bool].
    """
    spacing = float(np.median(np.diff(x)))
    shortest, longest = WAVEBANDS["D1"]
    share = (1 / shortest - 1 / longest) * 2 * spacing
    noise = float(np.std(np.diff(change, axis=1)) / np.sqrt(2) * np.sqrt(min(share, 1.0)))
    return float(np.sqrt(np.mean(d1_change(x, change)[:, valid] ** 2))), noise
