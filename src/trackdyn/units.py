"""Units: the one table of unit names and their SI factors, and the parameter-file values.

Every value of a parameter file is a table ``{value, unit, source}``; the data files' column
names end in one of these units (`trackdyn.io`).
"""

from __future__ import annotations

import math

from trackdyn.errors import TrackdynInputError

GRAVITY = 9.81
"""Gravitational acceleration [m/s^2]."""

UNITS: dict[str, tuple[str, float]] = {
    "kg": ("kg", 1.0),
    "t": ("kg", 1e3),
    "kg m^2": ("kg m^2", 1.0),
    "t m^2": ("kg m^2", 1e3),
    "N": ("N", 1.0),
    "kN": ("N", 1e3),
    "MN": ("N", 1e6),
    "N/m": ("N/m", 1.0),
    "kN/m": ("N/m", 1e3),
    "kN/mm": ("N/m", 1e6),
    "MN/m": ("N/m", 1e6),
    "N s/m": ("N s/m", 1.0),
    "kN s/m": ("N s/m", 1e3),
    "MN s/m": ("N s/m", 1e6),
    "m": ("m", 1.0),
    "mm": ("m", 1e-3),
    "km": ("m", 1e3),
    "m/cycle": ("m/cycle", 1.0),
    "mm/cycle": ("m/cycle", 1e-3),
    "1/cycle": ("1/cycle", 1.0),
    "rad": ("rad", 1.0),
    "deg": ("rad", math.pi / 180),
    "-": ("-", 1.0),
}
"""Accepted units: name -> (SI unit it converts to, factor)."""


def si_value(entry, key: str, si_unit: str, where: str) -> float:
    """The value of a ``{value, unit, source}`` table in SI units.

    Parameters
    ----------
    entry : dict
        The parameter's table from the file.
    key : str
        Parameter name, for messages.
    si_unit : str
        The SI unit the parameter must convert to.
    where : str
        File (and table) name, for messages.
    """
    if not isinstance(entry, dict) or set(entry) != {"value", "unit", "source"}:
        raise TrackdynInputError(f"{where}: parameter {key} needs value, unit and source")
    unit = str(entry["unit"])
    if unit not in UNITS or UNITS[unit][0] != si_unit:
        raise TrackdynInputError(f"{where}: unit {unit!r} of {key} does not parse as {si_unit}")
    value = entry["value"]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TrackdynInputError(f"{where}: value of {key} is not a number")
    return float(value) * UNITS[unit][1]
