"""Settlement parameter files: one table per law, each parameter with unit and source.

```toml
[power]
description = "..."
K_s = { value = 0.5, unit = "mm", source = "...", min = 0.05, max = 5 }
```

``value`` in ``unit`` (converted to SI), ``source`` (where the value comes from, or
"illustrative"), and optionally ``min`` and ``max`` in the same unit: the range
`trackdyn calibrate` may fit the parameter in. The shipped file (`DEFAULT_FILE`) holds
illustrative values that are not calibrated.

A law's table may hold one sub-table per zone kind (`trackdyn.deterioration.zones`) with
the parameters that differ there, each again with value, unit and source::

    [power.structure]
    K_s = { value = 0.15, unit = "mm", source = "..." }

``open`` is the law's own table.
"""

from __future__ import annotations

import json
from importlib.resources import files

import numpy as np

from trackdyn.deterioration.settlement import LAWS, LawParameters
from trackdyn.errors import TrackdynInputError, unknown
from trackdyn.io import read_toml
from trackdyn.units import si_value

DEFAULT_FILE = files("trackdyn.deterioration").joinpath("settlement.toml")
"""The shipped parameter file (illustrative values, not calibrated)."""

BOUNDS = ("min", "max")
"""Optional keys of a parameter entry: the range a fit may move the parameter in."""


def _law_table(name: str, path) -> tuple[type[LawParameters], dict, str]:
    """The law's class, its ``[name]`` table from the parameter file (without the zone
    kinds' sub-tables), and the file's name."""
    cls, table, where = _full_table(name, path)
    kinds = zone_kinds(name, path)
    return cls, {k: v for k, v in table.items() if k not in kinds}, where


def _full_table(name: str, path) -> tuple[type[LawParameters], dict, str]:
    if name not in LAWS:
        raise unknown("settlement law", name, LAWS)
    where = str(path) if path is not None else "settlement.toml (shipped)"
    data = read_toml(path if path is not None else DEFAULT_FILE)
    if name not in data or not isinstance(data[name], dict):
        raise TrackdynInputError(f"{where}: no table [{name}] for the {name} law")
    return LAWS[name], data[name], where


def zone_kinds(name: str, path=None) -> list[str]:
    """The zone kinds with a sub-table ``[name.<kind>]`` in the parameter file, and open.

    Parameters
    ----------
    name : str
        Law name, a key of `LAWS`.
    path : path, optional
        Parameter file; default the shipped illustrative file.
    """
    _, table, _ = _full_table(name, path)
    expected = law_units(name)
    return ["open"] + [
        k
        for k, v in table.items()
        if k not in expected and isinstance(v, dict) and "value" not in v
    ]


def law_units(name: str) -> dict[str, str]:
    """The parameters of the law ``name`` and their SI units, shared ones first."""
    cls = LAWS[name]
    return {**cls.common, **cls.units}


def law_file_table(name: str, path=None) -> dict:
    """The ``[name]`` table of a parameter file as written: ``description`` and per
    parameter ``value``, ``unit``, ``source`` and optional ``min``/``max``, unconverted.

    Parameters
    ----------
    name : str
        Law name, a key of `LAWS`.
    path : path, optional
        Parameter file; default the shipped illustrative file.
    """
    return _law_table(name, path)[1]


def law_bounds(name: str, path=None) -> dict[str, tuple[float, float]]:
    """The ``min`` and ``max`` the parameter file gives for the law's parameters [SI units].

    Parameters without both are left out.

    Parameters
    ----------
    name : str
        Law name, a key of `LAWS`.
    path : path, optional
        Parameter file; default the shipped illustrative file.
    """
    _, table, where = _law_table(name, path)
    expected = law_units(name)
    bounds = {}
    for key, entry in table.items():
        if key not in expected or not isinstance(entry, dict):
            continue
        have = [b for b in BOUNDS if b in entry]
        if len(have) == 1:
            raise TrackdynInputError(f"{where}: [{name}] {key} gives {have[0]} but not both")
        if have:
            base = {k: v for k, v in entry.items() if k not in BOUNDS}
            lo, hi = (
                si_value({**base, "value": entry[b]}, f"{key} {b}", expected[key], where)
                for b in BOUNDS
            )
            if not lo < hi:
                raise TrackdynInputError(f"{where}: [{name}] {key} needs min < max")
            bounds[key] = (lo, hi)
    return bounds


def law_table_toml(name: str, entries: dict, description: str | None = None) -> str:
    """A law's table of a parameter file as TOML text, read back by `load_law`.

    Parameters
    ----------
    name : str
        Law name, the table's header ``[<name>]``.
    entries : dict
        Per parameter: its ``value``, ``unit``, optionally ``min`` and ``max``, and its
        ``source``, in the file's units.
    description : str, optional
        The table's ``description``.
    """
    lines = [f"[{name}]"]
    if description is not None:
        lines.append(f"description = {json.dumps(description)}")
    lines += [f"{key} = {_entry_toml(entry)}" for key, entry in entries.items()]
    return "\n".join(lines) + "\n"


def _entry_toml(entry: dict) -> str:
    keys = ["value", "unit", *[b for b in BOUNDS if b in entry], "source"]
    parts = []
    for key in keys:
        v = entry[key]
        parts.append(f"{key} = {json.dumps(v) if isinstance(v, str) else format(v, '.6g')}")
    return "{ " + ", ".join(parts) + " }"


def _check_plausible(key: str, value: float, bounds, units, source: str, within: str) -> None:
    """Refuse ``key`` = ``value`` [SI] of ``source`` outside its ``bounds`` (min and max of
    ``within``)."""
    lo, hi = bounds.get(key, (-np.inf, np.inf))
    if not lo <= value <= hi:
        raise TrackdynInputError(
            f"{source} {key} = {value:g} {units[key]} is outside the plausible {lo:g} to "
            f"{hi:g} {units[key]} (min and max of {within})"
        )


def load_law(name: str, path=None, kind: str = "open", **overrides) -> LawParameters:
    """A settlement law with parameters from a TOML file.

    Parameters
    ----------
    name : str
        Law name, a key of `LAWS`.
    path : path, optional
        Parameter file with a table ``[<name>]`` whose entries are tables with ``value``,
        ``unit`` and ``source`` (optionally ``min`` and ``max``, see `law_bounds`); default
        the shipped illustrative file.
    kind : str
        Zone kind (`trackdyn.deterioration.zones`): ``open`` (the law's table), or a kind
        whose sub-table ``[<name>.<kind>]`` replaces some of the parameters (refused
        outside the law's ``min`` and ``max``).
    **overrides : float
        Parameter values replacing the file's [SI units] (for every kind); refused
        outside the file's ``min`` and ``max`` where it gives them (a unit typed wrong).
    """
    cls, table, where = _law_table(name, path)
    own: dict = {}  # the kind's own entries
    if kind != "open":
        kinds = zone_kinds(name, path)
        if kind not in kinds:
            raise unknown(f"zone kind (a table [{name}.<kind>])", kind, kinds, f"{where}: ")
        own = _full_table(name, path)[1][kind]
        table = {**table, **own}
    label = f"[{name}]" if kind == "open" else f"[{name}.{kind}]"
    expected = law_units(name)
    values = {}
    for key, entry in table.items():
        if key == "description":
            continue
        if key not in expected:
            raise TrackdynInputError(f"{where}: {label} unknown parameter {key!r}")
        if isinstance(entry, dict):
            entry = {k: v for k, v in entry.items() if k not in BOUNDS}
        values[key] = si_value(entry, key, expected[key], f"{where}: {label}")
    extra = sorted(set(overrides) - set(expected))
    if extra:
        raise unknown(f"settlement parameter of the {name} law", extra[0], expected)
    bounds = law_bounds(name, path)
    for key in (k for k in own if k in values):  # within the law's min and max, as overrides
        _check_plausible(key, values[key], bounds, expected, f"{where}: {label}",
                         f"[{name}] there")  # fmt: skip
    values.update({k: float(v) for k, v in overrides.items()})
    for key, value in overrides.items():
        _check_plausible(key, value, bounds, expected, f"[settlement] overrides of {label}",
                         f"{where}; overrides are in SI units")  # fmt: skip
    missing = [k for k in expected if k not in values]
    if missing:
        raise TrackdynInputError(f"{where}: {label} missing parameter {missing[0]}")
    try:
        return cls(**values)
    except TrackdynInputError as exc:
        named = [k for k in overrides if f"parameter {k} " in f"{exc} "]
        source = f"[settlement] overrides of {label}" if named else f"{where}: {label}"
        raise TrackdynInputError(f"{source} {exc}") from None
