"""CSV readers and writers for track data; units live in the column names.

Geometry: ``distance_m,left_mm,right_mm`` (any length unit: ``m``, ``mm``, ``km``).
Supports, long table of load-deflection curves: ``distance_m,rail,load_kN,deflection_mm``;
or linear supports: ``distance_m,rail,stiffness_kN_per_mm``. ``rail`` is ``left`` or
``right``; each sleeper position appears for both rails.
"""

from __future__ import annotations

import functools
import os
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from trackdyn.errors import TrackdynInputError, check_series
from trackdyn.track.support import Curves
from trackdyn.track.track import RAILS, Geometry, Supports

UNITS = {
    "length": {"m": 1.0, "mm": 1e-3, "km": 1e3},
    "force": {"N": 1.0, "kN": 1e3, "MN": 1e6},
    "stiffness": {"N_per_m": 1.0, "kN_per_mm": 1e6, "MN_per_m": 1e6},
}


def _read_csv(path, **options) -> pd.DataFrame:
    path = Path(path)
    if not path.is_file():
        raise TrackdynInputError(f"{path}: no such file")
    try:
        return pd.read_csv(path, comment="#", skipinitialspace=True, **options)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise TrackdynInputError(f"{path}: not a readable CSV file ({exc})") from None


def column(frame: pd.DataFrame, quantity: str, kind: str, where) -> tuple[np.ndarray, str]:
    """Values of the column ``<quantity>_<unit>`` converted to SI, and the column name.

    Parameters
    ----------
    frame : DataFrame
        The table read from the file.
    quantity : str
        Column name before the unit, e.g. ``"distance"``.
    kind : {"length", "force", "stiffness"}
        Physical kind, which fixes the accepted units.
    where : str or Path
        File name for error messages.
    """
    matches = [c for c in frame.columns if str(c).startswith(quantity + "_")]
    if not matches:
        raise TrackdynInputError(
            f"{where}: no column {quantity}_<unit> (units: {', '.join(UNITS[kind])})"
        )
    name = matches[0]
    unit = name[len(quantity) + 1 :]
    if unit not in UNITS[kind]:
        raise TrackdynInputError(
            f"{where}: unit {unit!r} of column {name!r} does not parse as a {kind} unit "
            f"({', '.join(UNITS[kind])})"
        )
    values = pd.to_numeric(frame[name], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise TrackdynInputError(
            f"{where}: column {name!r} is empty, NaN, infinite or not a number at line {bad[0] + 2}"
        )
    return values * UNITS[kind][unit], name


def read_geometry(path) -> Geometry:
    """Read a geometry CSV (``distance_m,left_mm,right_mm``) into SI units."""
    frame = _read_csv(path)
    distance, _ = column(frame, "distance", "length", path)
    try:
        check_series(distance, min_points=2, where=str(path))
    except TrackdynInputError as exc:  # rows in the file count the header line
        raise TrackdynInputError(_file_rows(str(exc))) from None
    left, _ = column(frame, "left", "length", path)
    right, _ = column(frame, "right", "length", path)
    return Geometry(distance, left, right, str(path))


def _file_rows(message: str) -> str:
    """Rewrite "row i" (0-based data index) as the file's line number (header is line 1)."""
    head, sep, tail = message.partition(" at row ")
    if not sep:
        return message
    num, _, rest = tail.partition(" ")
    return f"{head} at line {int(num) + 2}{(' ' + rest) if rest else ''}"


def read_supports(path) -> Supports:
    """Read a supports CSV: load-deflection curves or linear stiffness per sleeper and rail."""
    frame = _read_csv(path, dtype={"rail": "category"})  # a few names, not a string a row
    if "rail" not in frame.columns:
        raise TrackdynInputError(f"{path}: no column 'rail' (left or right)")
    distance, _ = column(frame, "distance", "length", path)
    names = frame["rail"].cat.categories.astype(str).str.strip().str.lower()
    rails = np.r_[pd.Index(RAILS).get_indexer(names), -1][frame["rail"].cat.codes]  # -1: none
    bad = np.flatnonzero(rails < 0)
    if bad.size:
        raise TrackdynInputError(
            f"{path}: line {bad[0] + 2}: rail {frame['rail'].iloc[bad[0]]!r} is not left or right"
        )
    linear = any(str(c).startswith("stiffness_") for c in frame.columns)
    if linear:
        values, _ = column(frame, "stiffness", "stiffness", path)
    else:
        load, _ = column(frame, "load", "force", path)
        defl, _ = column(frame, "deflection", "length", path)
    per_rail = {}
    for index, rail in enumerate(RAILS):
        rows = np.flatnonzero(rails == index)
        if rows.size == 0:
            raise TrackdynInputError(f"{path}: no rows for the {rail} rail")
        d = distance[rows]
        start = np.r_[0, np.flatnonzero(np.diff(d) != 0) + 1, rows.size]
        positions = d[start[:-1]]
        bad = np.flatnonzero(np.diff(positions) <= 0)
        if bad.size:
            raise TrackdynInputError(
                f"{path}: line {rows[start[bad[0] + 1]] + 2}: sleeper positions of the {rail} "
                "rail are not increasing (each sleeper's rows must be together, in order)"
            )
        lines = rows[start[:-1]] + 2, rows[start[1:] - 1] + 2
        where = functools.partial(_curve_where, f"{path}: {rail} rail", positions, *lines)
        if linear:
            curves = _linear_curves(values[rows], start, where)
        else:
            curves = _measured_curves(load[rows], defl[rows], start, rows, where)
        per_rail[rail] = positions, curves
    pos_l, pos_r = per_rail["left"][0], per_rail["right"][0]
    if pos_l.shape != pos_r.shape or not np.allclose(pos_l, pos_r):
        raise TrackdynInputError(f"{path}: left and right rails list different sleeper positions")
    return Supports(pos_l, per_rail["left"][1], per_rail["right"][1], str(path))


def _curve_where(source: str, position, first, last, i: int) -> str:
    """Where curve ``i`` of a supports file is: its sleeper position [m] and file lines."""
    return f"{source} at {position[i]:g} m (lines {first[i]}-{last[i]})"


def _linear_curves(stiffness, start, where) -> Curves:
    """Curves of linear supports [N/m] given on one row per sleeper (rows ``start[i]:``)."""
    many = np.flatnonzero(np.diff(start) != 1)
    if many.size:
        raise TrackdynInputError(f"{where(many[0])}: one stiffness per sleeper expected")
    return Curves.linear(stiffness, where)


def _measured_curves(load, deflection, start, rows, where) -> Curves:
    """Measured curves [N], [m], refusing a sleeper whose rows start again (file ``rows``)."""
    again = load == np.repeat(load[start[:-1]], np.diff(start))
    again[start[:-1]] = False
    if again.any():
        k = int(np.argmax(again))
        i = int(np.searchsorted(start, k, side="right")) - 1
        raise TrackdynInputError(
            f"{where(i)}: this sleeper's curve starts again at line {rows[k] + 2} (rows repeated?)"
        )
    return Curves(load, deflection, start, where)


def write_geometry(geometry: Geometry, path) -> None:
    """Write a geometry CSV with ``distance_m,left_mm,right_mm``."""
    frame = pd.DataFrame(
        {
            "distance_m": geometry.distance,
            "left_mm": geometry.left * 1e3,
            "right_mm": geometry.right * 1e3,
        }
    )
    atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g"))


def write_supports(supports: Supports, path) -> None:
    """Write a supports CSV as a long table ``distance_m,rail,load_kN,deflection_mm``."""
    rows = []
    for rail in RAILS:
        curves = getattr(supports, rail)
        rows.append(
            pd.DataFrame(
                {
                    "distance_m": np.repeat(supports.position, np.diff(curves.start)),
                    "rail": rail,
                    "load_kN": curves.load / 1e3,
                    "deflection_mm": curves.deflection * 1e3,
                }
            )
        )
    frame = pd.concat(rows, ignore_index=True)
    atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g"))


def read_toml(path) -> dict:
    """Read a TOML file; a missing or malformed file is a one-line error."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except OSError:
        raise TrackdynInputError(f"{path}: cannot read the file") from None
    except tomllib.TOMLDecodeError as exc:
        raise TrackdynInputError(f"{path}: not valid TOML ({exc})") from None


def atomic_write(path, write) -> None:
    """Call ``write(tmp_path)`` then move the file into place, so no half file is left."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.part")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_netcdf(ds, path) -> None:
    """Write a Dataset to netCDF-4, uncompressed.

    Simulated float64 time series are mostly noise in their last digits: zlib saved about
    20 % of a 1 km run's file (24.5 against 31 MB) and took 0.9 s against 0.07 s to write.
    """
    ds.to_netcdf(path, format="NETCDF4")
