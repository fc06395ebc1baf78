"""Plausible ranges of physical input: values outside them are refused as typing errors.

The ranges are wide (they admit every track and vehicle the models are meant for) and
exist to catch a wrong unit or a corrupt value before it becomes an infinite standard
deviation or a wheel flying off the rail.
"""

from __future__ import annotations

import numpy as np

from trackdyn.errors import TrackdynInputError

MAX_SPEED_KMH = 400.0
"""Highest vehicle speed [km/h]: above the fastest freight and passenger service."""

MAX_PROFILE = 1.0
"""Largest magnitude of a vertical rail profile value [m]: measured geometry is a few mm
to cm about its mean, a few dm over long grades."""

SUPPORT_STIFFNESS = (1e6, 1e10)
"""Range of a support's (linear or linearised) stiffness per rail seat [N/m]: 1 kN/mm, a
nearly hanging sleeper, to 10 GN/m, ten times slab track."""


def check_within(values, lo: float, hi: float, what: str, unit: str, scale: float = 1.0):
    """Refuse the first value outside ``[lo, hi]``, naming it and its index.

    Parameters
    ----------
    values : array_like
        Values in SI units.
    lo, hi : float
        Plausible range [SI units].
    what : str
        Name of the values, with their source, for the message.
    unit : str
        Unit shown in the message (values and range are divided by ``scale``).
    scale : float
        Size of that unit in SI units.
    """
    v = np.asarray(values, dtype=float)
    bad = np.flatnonzero(~((v >= lo) & (v <= hi)))
    if bad.size:
        i = bad[0]
        at = f" at row {i}" if v.ndim else ""
        raise TrackdynInputError(
            f"{what}{at} is {float(v.flat[i]) / scale:g} {unit}, outside the plausible "
            f"{lo / scale:g} to {hi / scale:g} {unit}"
        )
