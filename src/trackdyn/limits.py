"""Plausible ranges of physical input: values outside them are refused as typing errors.

The ranges are wide (they admit every track and vehicle the models are meant for) and
exist to catch a wrong unit or a corrupt value before it becomes an infinite standard
deviation or a wheel flying off the rail.
"""

from __future__ import annotations

import math
import os

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

MAX_SAMPLE_SPACING = 1.5
"""Largest median spacing of a geometry's profile samples [m]: half the shortest D1
wavelength (3 m); recording cars sample every 0.25-0.5 m, so wider is a wrong unit."""

MAX_SLEEPER_GAP = 3.0
"""Largest distance between neighbouring sleepers [m]: five times a 0.6 m spacing, four
sleepers missing in a row; wider gaps are spans the discretely supported rail of the
models does not describe."""

WHEEL_LOAD = (1e3, 5e5)
"""Range of a static wheel load [N]: 1 kN, a light trolley, to 500 kN, 2.5 times the
196 kN wheel of a 40 t heavy-haul axle (a load typed in N or t is refused)."""

MAX_STEPS = 1e8
"""Most time steps of one run: about 20 minutes of the compiled scheme; a step count above
it comes from a time step or a path length typed in the wrong unit."""

MAX_TOTAL_MGT = 1e4
"""Longest horizon of a deterioration loop [MGT]: 40 years of 250 MGT, the heaviest
heavy-haul traffic; beyond, a tonnage typed in tonnes or a horizon in the wrong unit."""

MEMORY_FRACTION = 0.5
"""Fraction of the machine's physical memory one computation may plan to hold
(`require_memory`): the rest is for the system, the other workers and what the estimates
leave out."""


def memory_budget() -> float:
    """Memory one computation may hold [bytes]: `MEMORY_FRACTION` of the machine's physical
    memory (read with ``os.sysconf``; unbounded where the system does not say)."""
    try:
        return MEMORY_FRACTION * os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return math.inf


def require_memory(needed: float, what: str) -> None:
    """Refuse, before allocating it, a computation estimated to need more than
    `memory_budget`.

    Parameters
    ----------
    needed : float
        Estimated memory [bytes].
    what : str
        What needs it and why, for the message (``"a run of 1.2e+07 stored steps"``).
    """
    budget = memory_budget()
    if needed > budget:
        raise TrackdynInputError(
            f"{what} needs about {needed / 1e9:.3g} GB of memory, more than the "
            f"{budget / 1e9:.3g} GB allowed ({MEMORY_FRACTION:.0%} of this machine's memory)"
        )


VEHICLE = {
    # Masses [kg] and inertias [kg m^2]: the shipped presets' smallest value / 10 to their
    # largest x 10 (a mass typed in tonnes is refused), rounded out to a power of ten.
    "m1": (1e3, 1e6),  # presets 10.4 t empty to 94.4 t loaded
    "I1": (1e3, 1e6),  # presets 1.5e4 to 1e5
    "Ip": (1e4, 1e8),  # presets 1.6e5 to 1.3e6
    "m2": (100.0, 1e5),  # presets 1260
    "I2": (100.0, 1e5),  # presets 1210
    "mw1": (100.0, 1e5),  # presets 1778
    "Iw1": (100.0, 1e5),  # presets 1180
    "Isf": (10.0, 1e4),  # presets 280
    # Stiffnesses [N/m]: the presets' value / 10 (rounded out) up to a rigid part; a value
    # typed in MN/m or kN/mm is refused. kp reaches 1e12, the near-rigid primary of 1e4
    # times the presets' 20 MN/m that checks the reduced models.
    "k1": (1e5, 1e9),  # presets 4 MN/m
    "kp": (1e5, 1e12),  # presets 20 MN/m
    "k_ss": (1e4, 1e9),  # presets 0.786 MN/m
    # Damping [N s/m]: 0 (undamped) to 100 MN s/m, 800 times the presets' largest (120 kN s/m).
    "rho_p": (0.0, 1e8),
    "rho1": (0.0, 1e8),
    "rho2": (0.0, 1e8),
    # The friction law's slope near zero velocity [N s/m]: a numerical regularisation, from
    # 1 (wedges that never slip) to 1000 times the presets' 1 MN s/m.
    "C_slope": (1.0, 1e9),
    # Lengths [m]: the presets' value / 10 to x 10, rounded out to one digit (a length in
    # mm or cm is refused).
    "b": (0.09, 10.0),  # presets 0.98
    "b_cc": (0.4, 50.0),  # presets 4.3
    "l": (0.05, 6.0),  # presets 0.5675
    "a": (0.09, 10.0),  # presets 0.9145
    "x_ss": (0.0, 0.5),  # presets 10 to 45 mm; 0: no preload
    # Physical bounds: friction coefficients of metal on metal lie below 1 (presets 0.25);
    # a wedge face between 1 and 89 deg from the vertical (presets 36.3 deg) [rad].
    "mu": (0.0, 1.0),
    "alpha_w": (math.radians(1.0), math.radians(89.0)),
}
"""Plausible range of each vehicle parameter [SI units] (`trackdyn.vehicle.parameters`)."""


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
