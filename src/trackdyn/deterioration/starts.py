"""Start states of a deterioration run: tamped, as measured, as surveyed.

``"as measured"`` is the track as its files give it. ``"tamped"``: a freshly tamped
start, most of the D1 band taken out, the longer waves kept (`tamped_geometry`).
``"as surveyed"``: the measured track without the wavelengths under 3 m, mostly
measurement noise (`surveyed_geometry`).

Tamping lifts and levels the track over the short and middle wavelengths; the long waves
of the formation (EN 13848-1 bands D2, 25-70 m, and D3, 70-150 m) are mostly left. The
tamped profile of each rail is the measured one minus a fraction ``a`` of its D1-band
(3-25 m) longitudinal level, ``a`` chosen so that the root mean square over the segments
of the D1 standard deviation is `TAMPED_D1_SD` (``a = 0`` if the measured track is
already better; ``a = 1`` at most). Tamping also re-seats the sleepers: the ballast under
every sleeper is brought up to the rail, so no sleeper hangs at the start
(`trackdyn.deterioration.ballast.Ballast`, ``seated=True``).

References
----------
EN 13848-1:2019. Railway applications - Track - Track geometry quality - Part 1:
Characterisation of track geometry. CEN, Brussels.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import signal
from scipy.optimize import brentq

from trackdyn.deterioration.quality import D1Assessment
from trackdyn.track.quality import WAVEBANDS, longitudinal_level, to_uniform_grid
from trackdyn.track.track import RAILS, Geometry

TAMPED_D1_SD = 1.2e-3
"""D1 standard deviation after tamping, root mean square over the segments [m];
illustrative: the middle of the 1-1.5 mm the example is meant to start from."""

STARTS = ("tamped", "as measured", "as surveyed")
"""Start states of a deterioration run."""

SHORTEST = WAVEBANDS["D1"][0]
"""Shortest wavelength a survey is taken to resolve [m]."""


def tamped_geometry(geometry: Geometry, extent, segment_length: float,
                    target: float = TAMPED_D1_SD) -> Geometry:  # fmt: skip
    """The unloaded space curve right after tamping.

    Parameters
    ----------
    geometry : Geometry
        Measured unloaded space curve.
    extent : tuple of float
        Part of the track assessed (where geometry and supports overlap) [m].
    segment_length : float
        Segment length of the D1 standard deviation [m].
    target : float
        Root mean square over the segments of the D1 standard deviation after tamping,
        per rail [m].

    Returns
    -------
    Geometry
        Profiles with a fraction of the D1 band removed, per rail.
    """
    x = geometry.distance
    profiles = {}
    assess = D1Assessment(extent, segment_length)
    for rail in RAILS:
        z = geometry.profile(rail)
        d1 = longitudinal_level(x, z, "D1")

        def excess(a, z=z, d1=d1):
            sd = assess.rail(x, z - a * d1)[2]
            return float(np.sqrt(np.mean(sd**2))) - target * 1e3

        if excess(0.0) <= 0:
            a = 0.0
        elif excess(1.0) >= 0:
            a = 1.0
        else:
            a = brentq(excess, 0.0, 1.0, xtol=1e-6)
        profiles[rail] = z - a * d1
    return dataclasses.replace(geometry, left=profiles["left"], right=profiles["right"])


def surveyed_geometry(geometry: Geometry, shortest: float = SHORTEST) -> Geometry:
    """The geometry with wavelengths under ``shortest`` removed.

    Zero-phase 4th-order Butterworth low-pass (``scipy.signal.sosfiltfilt``), ends padded
    by holding the end value over one ``shortest``; non-uniform input is resampled at the
    median spacing and back. Coarser sampling than ``shortest / 2`` is returned as it is.

    Parameters
    ----------
    geometry : Geometry
        The surveyed geometry.
    shortest : float
        Shortest wavelength kept [m].
    """
    x = geometry.distance
    xu, _, dx, uniform = to_uniform_grid(x, x)
    if dx >= shortest / 2:
        return geometry
    sos = signal.butter(4, 1.0 / shortest, btype="lowpass", fs=1.0 / dx, output="sos")
    pad = min(xu.size - 1, int(np.ceil(shortest / dx)))
    smooth = {}
    for rail in RAILS:
        z = geometry.profile(rail)
        f = signal.sosfiltfilt(sos, z if uniform else np.interp(xu, x, z), padtype="constant",
                               padlen=pad)  # fmt: skip
        smooth[rail] = f if uniform else np.interp(x, xu, f)
    return dataclasses.replace(geometry, **smooth)
