"""Units: one registry of the units trackdyn reads and writes, and their conversion to SI.

Every value of a parameter file is a table ``{value, unit, source}`` (`si_value`); the data
files' column names and the result variables' names end in a unit (`name_unit`,
`spelled_unit`); the netCDF files carry each variable's unit in UDUNITS spelling
(`udunits`). All of them are parsed, checked and converted by one `pint` registry
(`registry`), so that a unit is defined once and a name's unit is read whole.

Why pint: it is the unit library of scientific Python (maintained, typed, used by xarray's
unit support), it parses unit expressions (``kN s/m``, ``m/s^2``), checks their dimension
and converts them with SI prefixes, and it can be given a registry of its own. trackdyn's
registry does not load pint's default one (a thousand units, 0.2 s to build, and ``cycle``
there is a turn): it defines only what the files need, so that a unit outside it
(``furlong``, ``inch``) is refused rather than converted:

- the SI units m, kg, s, N, Pa, J, W, Hz with the prefixes u (micro), m, c, k, M, G, and
  ``rad``, whose dimension is its own (``[angle]``) so that a dimensionless ``-`` is not
  taken for an angle, with ``deg``;
- ``t`` (tonne) and ``h`` (hour, for ``km/h``);
- ``MGT``, megagross tonne, a million gross tonnes of traffic: a unit of **mass**, 1e9 kg
  (the same as ``Mt``), written ``Mt`` in netCDF files, where UDUNITS knows no MGT. Traffic
  is the mass of the vehicles that passed, so ``m/(100 MGT)`` (metres per 100 MGT) is a
  length per mass and reads back in any UDUNITS tool; a dimension of its own would have no
  spelling there;
- ``cycle``, a load cycle, a dimension of its own (``mm/cycle`` is not a length), written
  ``count`` in netCDF files (UDUNITS' ``cycle`` is a turn of 2 pi rad);
- ``-`` and ``1``: dimensionless.

Names spell a unit with ``_`` for a space, ``per`` for ``/``, a trailing digit as its
power, ``kmh`` for km/h and ``mgt`` for MGT (`NAME_SPELLINGS`), and every other unit by
its symbol: ``stiffness_kN_per_mm`` [kN/mm], ``body_bounce_acc_rms_m_per_s2`` [m/s^2],
``tamped_m_per_100_mgt`` [m/(100 MGT)].

Costs carry their currency the same way, as the name's last part (``life_cycle_cost_EUR``,
`money_name`), and as the ``units`` of their netCDF variables: a currency is not a unit of
the registry (no conversion between currencies is implied), so it is checked for its
spelling (`currency`) and refused where a name would read it as a unit (``t``, ``m``).

The registry is built once, on first use (importing pint takes 0.1-0.3 s), and each unit
text is parsed once: a conversion is one factor per unit, applied to a whole column.
"""

from __future__ import annotations

import functools
import re
import threading
import tokenize
from typing import Any

from trackdyn.errors import TrackdynInputError

GRAVITY = 9.81
"""Gravitational acceleration [m/s^2]."""

DEFINITIONS = """
micro- = 1e-6 = u- = µ-
milli- = 1e-3 = m-
centi- = 1e-2 = c-
kilo- = 1e3 = k-
mega- = 1e6 = M-
giga- = 1e9 = G-
metre = [length] = m = meter
kilogram = [mass] = kg
second = [time] = s
radian = [angle] = rad
cycle = [cycle]
newton = kilogram * metre / second ** 2 = N
pascal = newton / metre ** 2 = Pa
joule = newton * metre = J
watt = joule / second = W
hertz = 1 / second = Hz
degree = 0.017453292519943295 * radian = deg
hour = 3600 * second = h
tonne = 1e3 * kilogram = t
megagross_tonne = 1e9 * kilogram = MGT
"""
"""The registry's definitions, in pint's definition syntax (see the module docstring)."""

DIMENSIONLESS = ("-", "1")
"""Spellings of a dimensionless unit in files."""

UDUNITS_SYMBOLS = {"MGT": "Mt", "deg": "degree", "cycle": "count"}
"""UDUNITS spelling of the registry's symbols that UDUNITS spells otherwise or not at all."""

NAME_SPELLINGS = {"kmh": "km/h", "mgt": "MGT"}
"""Units spelled in names otherwise than by their symbol: name token -> unit."""

_UNPARSED: tuple[type[BaseException], ...] = (
    SyntaxError,
    tokenize.TokenError,
    AssertionError,  # pint's parser asserts on a dangling operator ("kN**")
    ArithmeticError,
    TypeError,
    ValueError,
)
"""What pint's parser raises for text that is not a unit expression (besides PintError)."""

_SYMBOL = re.compile(r"\b[^\W\d]\w*")
"""A unit's name or symbol in a unit expression (not the ``e`` of ``1e3``)."""

_BUILDING = threading.Lock()


def registry():
    """The unit registry (`DEFINITIONS`), built on first use, one for all threads (pint
    does not combine quantities of two registries).

    Returns
    -------
    pint.UnitRegistry
    """
    with _BUILDING:
        return _built()


@functools.cache
def _built():
    import pint

    units = pint.UnitRegistry(None, cache_folder=None)
    for line in DEFINITIONS.strip().splitlines():
        units.define(line)
    return units


@functools.cache
def quantity(unit: str) -> Any:
    """The size of a unit as a pint Quantity (``m/(100 MGT)`` is 0.01 m/MGT).

    Parameters
    ----------
    unit : str
        A unit expression of the registry, or ``-`` (dimensionless).

    Raises
    ------
    ValueError
        The text is empty or not a unit of the registry; the message says why.
    """
    import pint

    units = registry()
    text = "1" if unit.strip() in DIMENSIONLESS else unit
    if not text.strip():
        raise ValueError("no unit given")
    try:
        size = units.parse_expression(text)
    except pint.PintError as exc:
        raise ValueError(str(exc)) from None
    except _UNPARSED:
        raise ValueError("not a unit expression") from None
    return size if isinstance(size, units.Quantity) else units.Quantity(size)


@functools.cache
def si_factor(unit: str, si_unit: str) -> float:
    """The size of ``unit`` in ``si_unit``: multiply a value in ``unit`` by it.

    Parameters
    ----------
    unit : str
        A unit expression of the registry (``"kN/mm"``).
    si_unit : str
        The unit to convert to (``"N/m"``).

    Raises
    ------
    ValueError
        ``unit`` does not parse, or is not of the dimension of ``si_unit``; the message
        says which.
    """
    import pint

    size, target = quantity(unit), quantity(si_unit)
    try:
        return float((size / target).to("dimensionless").magnitude)
    except pint.DimensionalityError:
        raise ValueError(f"it is a unit of {size.dimensionality}") from None


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
    try:
        factor = si_factor(unit, si_unit)
    except ValueError as exc:
        raise TrackdynInputError(
            f"{where}: unit {unit!r} of {key} does not parse as {si_unit} ({exc})"
        ) from None
    value = entry["value"]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TrackdynInputError(f"{where}: value of {key} is not a number")
    return float(value) * factor


def _symbol(token: str) -> bool:
    """Whether ``token`` is a unit symbol of the registry (``kN``, not ``kilonewton``)."""
    import pint

    try:
        return bool(registry().get_symbol(token) == token)
    except pint.PintError:
        return False


@functools.cache
def spelled_unit(spelling: str) -> str | None:
    """The unit a name spells (``kN_per_mm`` -> ``kN/mm``), or None if it spells none.

    Parameters
    ----------
    spelling : str
        The end of a column or variable name after the quantity, as the module docstring
        says: ``_`` between the parts, one ``per``, a number only after ``per``
        (``m_per_100_mgt`` -> ``m/(100 MGT)``).
    """
    sides: tuple[list[str], list[str]] = ([], [])
    below, symbols = 0, [0, 0]
    for token in spelling.split("_"):
        if token == "per" and not below:
            below = 1
            continue
        if token.isdigit() and below:
            sides[below].append(token)
            continue
        base = token.rstrip("0123456789")
        power = token[len(base) :]
        if base in NAME_SPELLINGS:
            unit = NAME_SPELLINGS[base]
        elif base and _symbol(base):
            unit = base
        else:
            return None
        unit = f"({unit})" if "/" in unit and (below or power) else unit
        sides[below].append(f"{unit}^{power}" if power else unit)
        symbols[below] += 1
    if not symbols[below]:  # a unit on each side of "per"
        return None
    above = " ".join(sides[0]) or "1"
    if not below:
        return above
    return f"{above}/{sides[1][0] if len(sides[1]) == 1 else '(' + ' '.join(sides[1]) + ')'}"


def spelled_factor(spelling: str, si_unit: str) -> float:
    """The size in ``si_unit`` of the unit a name spells (`spelled_unit`; a column's unit).

    Parameters
    ----------
    spelling : str
        The end of the name after the quantity (``kN_per_mm``).
    si_unit : str
        The unit to convert to (``"N/m"``).

    Raises
    ------
    ValueError
        ``spelling`` spells no unit of the registry, or one of another dimension.
    """
    unit = spelled_unit(spelling)
    if unit is None:
        raise ValueError(f"{spelling!r} spells no unit of the registry")
    return si_factor(unit, si_unit)


@functools.cache
def name_unit(name: str) -> tuple[str, str | None]:
    """A name's quantity and the unit its end spells (`spelled_unit`), read whole.

    ``tamped_m_per_100_mgt`` is ``("tamped", "m/(100 MGT)")``, ``dyn_load_sd_kN`` is
    ``("dyn_load_sd", "kN")``; a name that ends in no unit, or in one that cannot be read
    whole (``per_mgt``: a ``per`` with nothing before it), is ``(name, None)``.

    Parameters
    ----------
    name : str
        A column or variable name (the quantity is at least its first part).
    """
    parts = name.split("_")
    for start in range(1, len(parts)):
        unit = spelled_unit("_".join(parts[start:]))
        if unit is not None:
            whole = parts[start - 1] != "per"
            return ("_".join(parts[:start]), unit) if whole else (name, None)
    return name, None


CURRENCY = re.compile(r"^[A-Za-z][A-Za-z0-9]{0,7}$")
"""A currency's spelling: an ISO 4217 code (``EUR``, ``ZAR``) or a short word of letters
and digits (``cu``, currency units, the default where none is named)."""


def currency(code: str) -> str:
    """``code`` checked as a currency (`CURRENCY`, and no unit of the registry).

    Parameters
    ----------
    code : str
        The currency.

    Raises
    ------
    ValueError
        It is not one word of up to 8 letters and digits, or a name ending in it would be
        read as a unit of the registry.
    """
    if not CURRENCY.match(code):
        raise ValueError(f"currency {code!r} is not one word of up to 8 letters and digits")
    if spelled_unit(code) is not None:
        raise ValueError(f"currency {code!r} reads as the unit {spelled_unit(code)}; "
                         "give its ISO 4217 code")  # fmt: skip
    return code


def money_name(quantity: str, code: str) -> str:
    """A cost's column and variable name: ``quantity`` with the currency as its unit part
    (``life_cycle_cost_EUR``)."""
    return f"{quantity}_{code}"


@functools.cache
def udunits(unit: str) -> str:
    """The UDUNITS spelling of a unit of the registry (``MGT`` -> ``Mt``, ``-`` -> ``1``).

    The unit is parsed first, so that a unit the registry does not define is never
    written; each symbol is then spelled as UDUNITS spells it (`UDUNITS_SYMBOLS`).

    Parameters
    ----------
    unit : str
        A unit expression of the registry.

    Raises
    ------
    ValueError
        The unit is not one of the registry.
    """
    try:
        quantity(unit)
    except ValueError as exc:
        raise ValueError(f"unit {unit!r}: {exc}") from None
    if unit.strip() in DIMENSIONLESS:
        return "1"
    units = registry()

    def spelled(match: re.Match) -> str:
        symbol = units.get_symbol(match[0])
        return UDUNITS_SYMBOLS.get(symbol, symbol)

    return _SYMBOL.sub(spelled, unit)
