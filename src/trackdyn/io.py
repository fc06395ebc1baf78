"""CSV readers and writers for track data; units live in the column names.

Geometry: ``distance_m,left_mm,right_mm`` (any length unit: ``m``, ``mm``, ``km``).
Supports, long table of load-deflection curves: ``distance_m,rail,load_kN,deflection_mm``;
or linear supports: ``distance_m,rail,stiffness_kN_per_mm``. ``rail`` is ``left`` or
``right``; each sleeper position appears for both rails. A column's unit is any unit of
its kind in the unit registry, spelled as names spell units (`trackdyn.units`:
``_per_`` for ``/``).
"""

from __future__ import annotations

import functools
import os
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trackdyn.errors import TrackdynInputError, check_series
from trackdyn.limits import MAX_SAMPLE_SPACING
from trackdyn.provenance import note_read
from trackdyn.track.support import Curves
from trackdyn.track.survey import GeometryFormat, surveyed
from trackdyn.track.track import RAILS, Geometry, Supports
from trackdyn.units import spelled_factor

COLUMN_KINDS = {
    "length": ("m", "m, mm, km"),
    "force": ("N", "N, kN, MN"),
    "stiffness": ("N/m", "N_per_m, kN_per_mm, MN_per_m"),
}
"""Kinds of column: the SI unit its values are converted to, and units to name in messages."""


CHUNK_ROWS = 100_000
"""Rows of a CSV parsed at a time by the chunked readers (`geometry_pieces`, `support_pieces`)."""

_UNREADABLE = (pd.errors.ParserError, pd.errors.EmptyDataError)

HEAD_BYTES = 4096
"""Bytes of a CSV file looked at before pandas reads it (`_readable`)."""

UTF8_BOM = b"\xef\xbb\xbf"
UTF16_BOMS = (b"\xff\xfe", b"\xfe\xff")


def _text(path, data: bytes) -> str:
    """``data``, the bytes of the file ``path``, as text: UTF-8, a byte-order mark (as
    Windows editors write) dropped; UTF-16 or bytes that are not UTF-8 refused in one line.
    """
    if data.startswith(UTF16_BOMS) or b"\x00" in data:
        raise TrackdynInputError(f"{path}: saved as UTF-16 (or not text); save it as UTF-8")
    try:
        return data.removeprefix(UTF8_BOM).decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise TrackdynInputError(
            f"{path}: line {line}: byte 0x{data[exc.start]:02x} is not UTF-8 (saved as "
            "Latin-1 or Windows-1252?); save the file as UTF-8"
        ) from None


def _bytes(path, size: int = -1) -> bytes:
    """The first ``size`` bytes of the file ``path`` (all: -1); a file that is missing or
    cannot be read (permissions, a folder) is refused in one line. Every file trackdyn
    reads passes here, which notes it for the command's provenance
    (`trackdyn.provenance.note_read`)."""
    path = Path(path)
    if not path.exists():
        raise TrackdynInputError(f"{path}: no such file")
    try:
        with open(path, "rb") as fh:
            data = fh.read(size)
        note_read(path)
    except OSError as exc:
        raise TrackdynInputError(f"{path}: cannot read the file ({exc.strerror})") from None
    return data


def _readable(path: Path) -> None:
    """Refuse a CSV file that cannot be read, is not UTF-8 text, or separates its columns
    with ``;`` (a spreadsheet's CSV where the decimal point is a comma)."""
    head = _bytes(path, HEAD_BYTES)
    if head.startswith(UTF16_BOMS) or b"\x00" in head:
        _text(path, head)
    lines = (line.strip() for line in head.decode("utf-8", "replace").splitlines())
    header = next((line for line in lines if line and not line.startswith("#")), "")
    if ";" in header and "," not in header:
        raise TrackdynInputError(
            f"{path}: columns separated by ';' (a spreadsheet's CSV with decimal commas?); "
            "trackdyn reads ',' between columns and '.' as the decimal point"
        )


def _unreadable(path, exc: Exception) -> TrackdynInputError:
    """The refusal of a CSV file that pandas could not parse (``exc``)."""
    if isinstance(exc, UnicodeDecodeError):
        _text(path, _bytes(path))  # raises, naming the line
    return TrackdynInputError(f"{path}: not a readable CSV file ({exc})")


def _read_csv(path, **options) -> pd.DataFrame:
    path = Path(path)
    _readable(path)
    try:
        return pd.read_csv(path, comment="#", skipinitialspace=True, **options)
    except (*_UNREADABLE, UnicodeDecodeError) as exc:
        raise _unreadable(path, exc) from None


def read_table(
    path, required: tuple[str, ...], optional: tuple[str, ...] | None = None
) -> pd.DataFrame:
    """A small CSV table of text cells (a sections list, a zone table), with its
    ``required`` columns and at least one row; line ``i + 2`` of the file is row ``i``.
    Only an empty cell is missing (NaN): ``NA`` or ``null`` is text, as a name may be.

    Parameters
    ----------
    path : path
        The CSV file.
    required : tuple of str
        Columns it must have.
    optional : tuple of str, optional
        Columns it may have besides; any other is refused. None: any.
    """
    frame = _read_csv(path, dtype=str, keep_default_na=False, na_values=[""])
    frame.columns = [str(c).strip() for c in frame.columns]
    missing = [c for c in required if c not in frame.columns]
    if missing:
        raise TrackdynInputError(f"{path}: no column {missing[0]!r} ({','.join(required)})")
    known = required + (optional or ())
    other = [c for c in frame.columns if optional is not None and c not in known]
    if other:
        raise TrackdynInputError(
            f"{path}: unknown column {other[0]!r}; the columns are {', '.join(known)}"
        )
    if frame.empty:
        raise TrackdynInputError(f"{path}: no rows")
    return frame


def _read_chunks(path, rows: int, **options) -> Iterator[pd.DataFrame]:
    """The CSV ``rows`` data rows at a time; each frame's index counts data rows from 0."""
    with _read_csv(path, chunksize=rows, **options) as reader:
        while True:
            try:
                yield next(reader)
            except StopIteration:
                return
            except (*_UNREADABLE, UnicodeDecodeError) as exc:
                raise _unreadable(path, exc) from None


def column(
    frame: pd.DataFrame, quantity: str, kind: str, where, gaps: bool = False
) -> tuple[np.ndarray, str]:
    """Values of the column ``<quantity>_<unit>`` converted to SI, and the column name.

    Parameters
    ----------
    frame : DataFrame
        The table read from the file.
    quantity : str
        Column name before the unit, e.g. ``"distance"``.
    kind : {"length", "force", "stiffness"}
        Physical kind (`COLUMN_KINDS`): the column's unit must be one of that kind.
    where : str or Path
        File name for error messages.
    gaps : bool
        Empty and NaN cells are NaN (a gap to bridge), except in the first and last row.
    """
    si_unit, examples = COLUMN_KINDS[kind]
    matches = [c for c in frame.columns if str(c).startswith(quantity + "_")]
    if not matches:
        raise TrackdynInputError(f"{where}: no column {quantity}_<unit> (units such as {examples})")
    name = matches[0]
    unit = name[len(quantity) + 1 :]
    try:
        factor = spelled_factor(unit, si_unit)
    except ValueError:
        raise TrackdynInputError(
            f"{where}: unit {unit!r} of column {name!r} does not parse as a {kind} unit "
            f"(such as {examples})"
        ) from None
    values = pd.to_numeric(frame[name], errors="coerce").to_numpy(dtype=float)
    missing = frame[name].isna().to_numpy().copy()
    missing[[0, -1] if missing.size else []] = False
    bad = np.flatnonzero(~np.isfinite(values) & ~(gaps & missing))
    if bad.size:
        raise TrackdynInputError(
            f"{where}: column {name!r} is empty, NaN, infinite or not a number "
            f"at line {frame.index[bad[0]] + 2}"
        )
    return values * factor, name


def read_geometry(path, fmt: GeometryFormat | None = None) -> Geometry:
    """Read a geometry CSV (``distance_m,left_mm,right_mm``) into SI units.

    Parameters
    ----------
    path : path
        The CSV file; its first column ``distance_<unit>`` or ``chainage_<unit>``,
        increasing or decreasing.
    fmt : GeometryFormat, optional
        What its columns hold (`trackdyn.track.survey`); default a profile, positive
        downward, gaps up to `trackdyn.track.survey.MAX_GAP_M` bridged.
    """
    return _geometry(_read_csv(path), path, GeometryFormat() if fmt is None else fmt)


def geometry_pieces(path, rows: int = CHUNK_ROWS) -> Iterator[tuple[np.ndarray, ...]]:
    """A geometry CSV read ``rows`` rows at a time, checked as `read_geometry` checks it.

    Yields
    ------
    distance, left, right : ndarray
        The piece's rows in SI units [m]; each piece is checked together with the last row
        of the one before, so the distance must increase across pieces too.
    """
    last = None
    for frame in _read_chunks(path, rows):
        piece = _geometry(frame if last is None else pd.concat([last, frame]), path)
        skip = 0 if last is None else 1
        yield piece.distance[skip:], piece.left[skip:], piece.right[skip:]
        last = frame.iloc[-1:]


def _geometry(frame: pd.DataFrame, path, fmt: GeometryFormat | None = None) -> Geometry:
    """Geometry of a table read from ``path``; messages count the rows of the whole file.
    With ``fmt`` (the whole file), read as `trackdyn.track.survey.surveyed` says; without
    (a piece of a long file), a profile in increasing distance and without gaps."""
    along = "chainage" if fmt is not None and "distance" not in _quantities(frame) else "distance"
    distance, name = column(frame, along, "length", path)
    reversed_ = fmt is not None and distance.size > 1 and distance[-1] < distance[0]
    if reversed_:
        frame, distance = frame.iloc[::-1], distance[::-1]
    try:
        check_series(distance, min_points=2, where=str(path))
    except TrackdynInputError as exc:  # rows in the file count the header line
        raise TrackdynInputError(_file_rows(str(exc), frame.index, 2, "line")) from None
    spacing = float(np.median(np.diff(distance)))
    if spacing > MAX_SAMPLE_SPACING:
        raise TrackdynInputError(
            f"{path}: the profile samples are {spacing:g} m apart by column {name!r}; the D1 "
            f"band (3-25 m) needs them at most {MAX_SAMPLE_SPACING:g} m apart (a wrong "
            "length unit?)"
        )
    left, _ = column(frame, "left", "length", path, gaps=fmt is not None)
    right, _ = column(frame, "right", "length", path, gaps=fmt is not None)
    try:
        if fmt is not None:
            lines = frame.index.to_numpy() + 2
            return surveyed(distance, left, right, lines, fmt, path, reversed_)
        return Geometry(distance, left, right, str(path))
    except TrackdynInputError as exc:
        raise TrackdynInputError(_file_rows(str(exc), frame.index, 0, "row")) from None


def _quantities(frame: pd.DataFrame) -> set[str]:
    """The quantities a table's columns name (``distance`` of ``distance_km``)."""
    return {str(c).partition("_")[0] for c in frame.columns}


def _file_rows(message: str, index, first: int, word: str) -> str:
    """Rewrite "row i" (index in ``frame``) as the file's data row or line (header line 1).

    Parameters
    ----------
    message : str
        Message naming "at row i", i counted from 0 in the table checked.
    index : pandas.Index
        The table's index: data rows of the file, counted from 0.
    first : int
        Number given to the file's first data row.
    word : str
        ``"line"`` or ``"row"``.
    """
    head, sep, tail = message.partition(" at row ")
    if not sep:
        return message
    num, _, rest = tail.partition(" ")
    return f"{head} at {word} {index[int(num)] + first}{(' ' + rest) if rest else ''}"


@dataclass(frozen=True)
class SupportRows:
    """Rows of a supports CSV in SI units, checked row by row.

    Parameters
    ----------
    distance : ndarray
        Sleeper position of each row [m].
    rail : ndarray
        Index of the row's rail in `RAILS`.
    values : tuple of ndarray
        Stiffness [N/m] (linear supports), or load [N] and deflection [m].
    line : ndarray
        Line of each row in the file (the header is line 1).
    """

    distance: np.ndarray
    rail: np.ndarray
    values: tuple[np.ndarray, ...]
    line: np.ndarray

    def take(self, rows) -> SupportRows:
        """The rows selected by ``rows`` (an index array, mask or slice)."""
        return SupportRows(
            self.distance[rows],
            self.rail[rows],
            tuple(v[rows] for v in self.values),
            self.line[rows],
        )

    @staticmethod
    def concat(parts) -> SupportRows:
        """Rows of ``parts`` (a non-empty sequence of `SupportRows`) one after another."""
        return SupportRows(
            np.concatenate([p.distance for p in parts]),
            np.concatenate([p.rail for p in parts]),
            tuple(np.concatenate(v) for v in zip(*(p.values for p in parts), strict=True)),
            np.concatenate([p.line for p in parts]),
        )


def read_supports(path) -> Supports:
    """Read a supports CSV: load-deflection curves or linear stiffness per sleeper and rail."""
    rows = _support_rows(_read_csv(path, dtype={"rail": "category"}), path)
    return supports_of([rail_rows(rows, rail) for rail in RAILS], path)


def read_measured_stiffness(path) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Read a measured track stiffness, ``distance_m,rail,stiffness_kN_per_mm`` at any
    positions (`trackdyn.track.measured`): per rail, distances [m] (strictly increasing),
    stiffnesses [N/m] and the file's line of each row."""
    rows = _support_rows(_read_csv(path, dtype={"rail": "category"}), path)
    if len(rows.values) != 1:
        raise TrackdynInputError(
            f"{path}: supports_kind = 'measured' reads a column stiffness_kN_per_mm, not "
            "load-deflection curves"
        )
    measured = {}
    for rail in RAILS:
        r = rail_rows(rows, rail)
        if r.distance.size == 0:
            raise TrackdynInputError(f"{path}: no rows for the {rail} rail")
        bad = np.flatnonzero(np.diff(r.distance) <= 0)
        if bad.size:
            raise TrackdynInputError(
                f"{path}: line {r.line[bad[0] + 1]}: the {rail} rail's distances are not increasing"
            )
        measured[rail] = (r.distance, r.values[0], r.line)
    return measured


def support_pieces(path, rows: int = CHUNK_ROWS) -> Iterator[SupportRows]:
    """A supports CSV read ``rows`` rows at a time, each row checked as `read_supports` does."""
    for frame in _read_chunks(path, rows, dtype={"rail": "category"}):
        yield _support_rows(frame, path)


def rail_rows(rows: SupportRows, rail: str) -> SupportRows:
    """The rows of one rail (``"left"`` or ``"right"``)."""
    return rows.take(rows.rail == RAILS.index(rail))


def _support_rows(frame: pd.DataFrame, path) -> SupportRows:
    """Check and convert the rows of a supports table (rail names, numbers, units)."""
    if "rail" not in frame.columns:
        raise TrackdynInputError(f"{path}: no column 'rail' (left or right)")
    distance, _ = column(frame, "distance", "length", path)
    names = frame["rail"].cat.categories.astype(str).str.strip().str.lower()
    rails = np.r_[pd.Index(RAILS).get_indexer(names), -1][frame["rail"].cat.codes]  # -1: none
    line = frame.index.to_numpy() + 2
    bad = np.flatnonzero(rails < 0)
    if bad.size:
        raise TrackdynInputError(
            f"{path}: line {line[bad[0]]}: rail {frame['rail'].iloc[bad[0]]!r} is not left or right"
        )
    values: tuple[np.ndarray, ...]
    if any(str(c).startswith("stiffness_") for c in frame.columns):
        values = (column(frame, "stiffness", "stiffness", path)[0],)
    else:
        values = tuple(
            column(frame, q, kind, path)[0]
            for q, kind in (("load", "force"), ("deflection", "length"))
        )
    return SupportRows(distance, rails.astype(np.int8), values, line)


def supports_of(per_rail, path) -> Supports:
    """Supports from the rows of the left and the right rail (`SupportRows` each)."""
    (pos_l, left), (pos_r, right) = (
        rail_curves(rows, rail, path) for rows, rail in zip(per_rail, RAILS, strict=True)
    )
    if pos_l.shape != pos_r.shape or not np.allclose(pos_l, pos_r):
        raise TrackdynInputError(f"{path}: left and right rails list different sleeper positions")
    return Supports(pos_l, left, right, str(path))


def rail_curves(rows: SupportRows, rail: str, path) -> tuple[np.ndarray, Curves]:
    """Sleeper positions [m] and curves of one rail's rows, in file order."""
    if rows.distance.size == 0:
        raise TrackdynInputError(f"{path}: no rows for the {rail} rail")
    d = rows.distance
    start = np.r_[0, np.flatnonzero(np.diff(d) != 0) + 1, d.size]
    positions = d[start[:-1]]
    bad = np.flatnonzero(np.diff(positions) <= 0)
    if bad.size:
        raise TrackdynInputError(
            f"{path}: line {rows.line[start[bad[0] + 1]]}: sleeper positions of the {rail} "
            "rail are not increasing (each sleeper's rows must be together, in order)"
        )
    lines = rows.line[start[:-1]], rows.line[start[1:] - 1]
    where = functools.partial(_curve_where, f"{path}: {rail} rail", positions, *lines)
    if len(rows.values) == 1:
        return positions, _linear_curves(rows.values[0], start, where)
    load, deflection = rows.values
    return positions, _measured_curves(load, deflection, start, rows.line, where)


def _curve_where(source: str, position, first, last, i: int) -> str:
    """Where curve ``i`` of a supports file is: its sleeper position [m] and file lines."""
    return f"{source} at {position[i]:g} m (lines {first[i]}-{last[i]})"


def _linear_curves(stiffness, start, where) -> Curves:
    """Curves of linear supports [N/m] given on one row per sleeper (rows ``start[i]:``)."""
    many = np.flatnonzero(np.diff(start) != 1)
    if many.size:
        raise TrackdynInputError(f"{where(many[0])}: one stiffness per sleeper expected")
    return Curves.linear(stiffness, where)


def _measured_curves(load, deflection, start, lines, where) -> Curves:
    """Measured curves [N], [m], refusing a sleeper whose rows start again (file ``lines``)."""
    again = load == np.repeat(load[start[:-1]], np.diff(start))
    again[start[:-1]] = False
    if again.any():
        k = int(np.argmax(again))
        i = int(np.searchsorted(start, k, side="right")) - 1
        raise TrackdynInputError(
            f"{where(i)}: this sleeper's curve starts again at line {lines[k]} (rows repeated?)"
        )
    return Curves(load, deflection, start, where)


DISTANCE_FORMAT = "{:.10g}"
"""Distances written to CSV files [m]: ten significant digits, 0.1 mm at 1000 km (with six,
samples 0.25 m apart beyond 100 km were written as the same distance)."""


def _distances(x) -> list[str]:
    return [DISTANCE_FORMAT.format(v) for v in np.asarray(x, dtype=float).tolist()]


def write_geometry(geometry: Geometry, path) -> None:
    """Write a geometry CSV with ``distance_m,left_mm,right_mm`` (distances to
    `DISTANCE_FORMAT`, the rest to six significant digits)."""
    frame = pd.DataFrame(
        {
            "distance_m": _distances(geometry.distance),
            "left_mm": geometry.left * 1e3,
            "right_mm": geometry.right * 1e3,
        }
    )
    atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g"))


def write_supports(supports: Supports, path) -> None:
    """Write a supports CSV as a long table ``distance_m,rail,load_kN,deflection_mm``
    (distances to `DISTANCE_FORMAT`, the rest to six significant digits)."""
    rows = []
    for rail in RAILS:
        curves = getattr(supports, rail)
        rows.append(
            pd.DataFrame(
                {
                    "distance_m": _distances(np.repeat(supports.position, np.diff(curves.start))),
                    "rail": rail,
                    "load_kN": curves.load / 1e3,
                    "deflection_mm": curves.deflection * 1e3,
                }
            )
        )
    frame = pd.concat(rows, ignore_index=True)
    atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g"))


def read_toml(path) -> dict:
    """Read a TOML file (UTF-8, with or without a byte-order mark); a missing, unreadable,
    malformed or otherwise encoded file is a one-line error."""
    path = Path(path)
    text = _text(path, _bytes(path))
    try:
        return tomllib.loads(text)
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
