"""`trackdyn track`: a long track analysed piece by piece, then its files and figures.

The memory taken does not grow with the track's length: the geometry and supports files
are read a piece at a time (`trackdyn.io`) and the track is cut into pieces of about
`PIECE_M`. Each piece holds `MARGIN_M` of track each side of its core, so the band-pass
filters of the quality bands settle (within about one longest wavelength, 70 m for D2)
before the core; of each piece only the core is kept, and the cores joined give what the
whole track read at once gives.

Sections are cut only at geometry samples that lie on a quality segment boundary (200 m
apart from the first sample of the track) and start at such a sample: the segments, and the
grid on which `trackdyn.track.quality.longitudinal_level` resamples an uneven profile, are
then those of the whole track. A geometry file with no sample on a segment boundary is read
as one piece.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from trackdyn.commands.netcdf import write_netcdf
from trackdyn.commands.staging import Record, output_folder
from trackdyn.commands.tables import frame_table
from trackdyn.errors import TrackdynInputError
from trackdyn.io import (
    CHUNK_ROWS,
    SupportRows,
    geometry_pieces,
    rail_curves,
    rail_rows,
    support_pieces,
    supports_of,
)
from trackdyn.limits import WHEEL_LOAD, check_within
from trackdyn.plots import example_marks, save
from trackdyn.plots.track import (
    plot_deflection_basin,
    plot_load_deflection,
    plot_track_overview,
)
from trackdyn.progress import note, status
from trackdyn.provenance import recorded
from trackdyn.track.analysis import (
    SEGMENT_M,
    curve_picks,
    most_voided,
    summary_table,
    track_dataset,
    voided_basin,
)
from trackdyn.track.rails import rail_section
from trackdyn.track.track import RAILS, Geometry, Track

PIECE_M = 10_000.0
"""Length of a piece's core [m], at least; a multiple of the segment length."""
MARGIN_M = 1000.0
"""Track read each side of a piece's core [m]: D2 segment SD within 2e-8 mm of the whole
track's on a synthetic profile (2e-6 mm with 700 m, 2e-4 mm with 400 m)."""
PAD_M = 50.0
"""Supports read beyond each end of a piece's geometry, so sleepers bracket it [m]."""
_TOL = 1e-9 * SEGMENT_M  # as segment_sd's tolerance [m]


@dataclass(frozen=True)
class Piece:
    """A piece of a long track (a read chunk) and the part of it that is its own.

    Parameters
    ----------
    track : Track
        The piece with its margins.
    keep : tuple of float
        Its core, ``[lo, hi)`` [m]; infinite at the ends of the track.
    """

    track: Track
    keep: tuple[float, float]


class _Rows:
    """Rows of a file read piece by piece, from the first not yet dropped, in file order."""

    def __init__(self, pieces: Iterator, distance: Callable, take: Callable, concat: Callable):
        self._pieces, self._distance, self._take, self._concat = pieces, distance, take, concat
        self.rows: Any = None
        self.done = False

    @property
    def distance(self) -> np.ndarray:
        return np.empty(0) if self.rows is None else self._distance(self.rows)

    def read(self) -> bool:
        """Read one more piece; False at the end of the file."""
        piece = next(self._pieces, None)
        self.done = piece is None
        if not self.done:
            self.rows = piece if self.rows is None else self._concat([self.rows, piece])
        return not self.done

    def reach(self, x: float) -> bool:
        """Read until a row lies beyond ``x`` [m]; False if the file ends first."""
        while not (self.distance.size and self.distance[-1] > x):
            if not self.read():
                return False
        return True

    def up_to(self, x: float):
        """The rows before the first one beyond ``x`` [m]."""
        return self._take(self.rows, slice(0, int(np.argmax(np.r_[self.distance > x, True]))))

    def drop_before(self, x: float) -> None:
        """Drop the rows before the first one at or beyond ``x`` [m]."""
        d = self.distance
        self.rows = self._take(self.rows, slice(int(np.argmax(np.r_[d >= x, True])), None))


def _geometry_rows(path, rows: int) -> _Rows:
    return _Rows(
        geometry_pieces(path, rows),
        lambda t: t[0],
        lambda t, s: tuple(a[s] for a in t),
        lambda parts: tuple(map(np.concatenate, zip(*parts, strict=True))),
    )


def _rail_rows(path, rail: str, rows: int) -> _Rows:
    pieces = (rail_rows(p, rail) for p in support_pieces(path, rows))
    return _Rows(pieces, lambda r: r.distance, SupportRows.take, SupportRows.concat)


def track_pieces(
    geometry, supports, length: float = PIECE_M, margin: float = MARGIN_M, rows=CHUNK_ROWS
) -> Iterator[Piece]:
    """The track of a geometry and a supports file, piece by piece.

    Parameters
    ----------
    geometry, supports : path
        Geometry and supports CSV files (as `trackdyn.data.load_track` reads).
    length : float
        Least length of a piece's core [m].
    margin : float
        Track each side of a core [m].
    rows : int
        Rows of a file read at a time.

    Yields
    ------
    Piece
        Consecutive pieces; their cores cover the track once.
    """
    geo = _geometry_rows(geometry, rows)
    rails = [_rail_rows(supports, rail, rows) for rail in RAILS]
    x0 = _first_sample(geo, rails[0])
    lo = -np.inf
    while True:
        cut = None if x0 is None else _next_cut(geo, x0, max(lo, x0) + length, margin)
        end = np.inf if cut is None else cut + margin
        if not all([r.reach(end + PAD_M) for r in rails]):  # every file read that far
            cut, end = None, np.inf
        if cut is None:  # the last piece: the rest of both files
            for r in rails:
                r.reach(np.inf)
            last = max((r.distance[-1] for r in rails if r.distance.size), default=np.inf)
            while geo.read():  # every row is checked; those past the supports are of no use
                geo.rows = geo.up_to(max(last, geo.distance[0]))
        part = geo.rows if cut is None else geo.up_to(end)
        found = [r.rows if cut is None else r.up_to(end + PAD_M) for r in rails]
        distance, left, right = part
        track = Track(Geometry(distance, left, right, str(geometry)), supports_of(found, supports))
        yield Piece(track, (lo, np.inf if cut is None else cut))
        if cut is None or x0 is None:  # x0 is None only with cut None
            return
        d = geo.distance
        start = d[_anchors(d, x0) & (d <= cut - margin)]
        geo.drop_before(start[-1] if start.size else d[0])
        for r in rails:
            r.drop_before(geo.distance[0] - PAD_M)
        lo = cut


def _first_sample(geo: _Rows, left: _Rows) -> float | None:
    """First geometry sample [m] that the supports cover (None if there is none)."""
    if not (geo.reach(-np.inf) and left.reach(-np.inf)):
        return None
    start = max(geo.distance[0], left.distance[0])
    if not (geo.reach(start) or geo.distance[-1] >= start):
        return None
    d = geo.distance
    return float(d[np.searchsorted(d, start)])


def _anchors(d: np.ndarray, x0: float) -> np.ndarray:
    """Which samples ``d`` [m] lie on a quality segment boundary."""
    r = (d - x0) / SEGMENT_M
    return np.abs(r - np.round(r)) * SEGMENT_M <= _TOL


def _next_cut(geo: _Rows, x0: float, target: float, margin: float) -> float | None:
    """First segment boundary at a sample from ``target`` on with ``margin`` read after it."""
    while True:
        d = geo.distance
        cuts = d[_anchors(d, x0) & (d >= target - _TOL)]
        if cuts.size and d[-1] > cuts[0] + margin:
            return float(cuts[0])
        if not geo.read():
            return None


def _read_curve(path, rail: str, position: float):
    """The curve at ``position`` [m] of ``rail`` in a supports file (`SupportCurve`)."""
    found = []
    for piece in support_pieces(path):
        rows = rail_rows(piece, rail)
        found.append(rows.take(rows.distance == position))
        if (rows.distance > position).any():
            break
    return rail_curves(SupportRows.concat(found), rail, path)[1][0]


def analyse_pieces(geometry, supports, static_load, delta, rail_section, **options):
    """The analysis of `trackdyn.track.analysis` on a long track, piece by piece.

    Parameters
    ----------
    geometry, supports : path
        Geometry and supports CSV files.
    static_load : float
        Static wheel load Ps [N].
    delta : float
        Dynamic wheel load increment δ [-].
    rail_section : RailSection
        Rail of the voided-sleeper deflection basin.
    **options
        Passed to `Track.linearise`, and ``length``, ``margin``, ``rows`` to
        `track_pieces`.

    Returns
    -------
    ds : xarray.Dataset
        As `track_dataset` gives for the whole track.
    picks : list of CurvePick
        The curves of the load-deflection figure, as `curve_picks` picks them over the
        whole track (a curve not kept from its piece is read again from the file).
    basin : tuple
        `voided_basin` over the most voided sleeper of the track.
    """
    cutting = {k: options.pop(k) for k in ("length", "margin", "rows") if k in options}
    parts, kept, best, basin, offset = [], ({}, {}), None, None, 0
    for piece in track_pieces(geometry, supports, **cutting):
        lin = piece.track.linearise(static_load, delta, **options)
        ds = track_dataset(lin, piece.keep)
        first = int(np.searchsorted(lin.track.supports.position, piece.keep[0] - _TOL))
        core = slice(first, first + ds.sizes["sleeper"])
        r, i = most_voided(lin, core)
        key = (-lin.seating_gap()[r, i], r, offset + i - first)
        if best is None or key < best:
            best, basin = key, voided_basin(lin, rail_section, sleepers=core)
        for values, pick in ((lin.k2, np.argmin), (lin.k2, np.argmax), (lin.ys, np.argmax)):
            r, i = np.unravel_index(pick(values[:, core]), values[:, core].shape)
            kept[r][offset + i] = getattr(lin.track.supports, RAILS[r])[first + i]
        parts.append(ds)
        offset += ds.sizes["sleeper"]
    ds = _join(parts)
    position = ds.sleeper_distance.values

    def curve(r, i):
        return kept[r][i] if i in kept[r] else _read_curve(supports, RAILS[r], position[i])

    return ds, curve_picks(ds.k2.values, ds.ys.values, position, curve), basin


def _join(parts: list[xr.Dataset]) -> xr.Dataset:
    """The pieces' datasets (from `track_dataset`) joined along the track."""
    first, along = parts[0], ("distance", "sleeper", "segment")
    variables = {}
    for name, var in first.variables.items():
        dim = next((d for d in var.dims if d in along), None)
        pieces = [p.variables[name] for p in parts]
        variables[name] = var if dim is None else xr.Variable.concat(pieces, dim)
    coords = {name: variables.pop(name) for name in first.coords}
    return xr.Dataset(variables, coords=coords, attrs=first.attrs)


def write_track_outputs(ds: xr.Dataset, picks, basin, folder, marks=()) -> None:
    """Write ``track.nc`` and the three track figures into ``folder``.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.track.analysis.track_dataset` (or of the pieces of a long
        track, joined).
    picks : list of CurvePick
        Curves of the load-deflection figure (`trackdyn.track.analysis.curve_picks`).
    basin : tuple
        Result of `trackdyn.track.analysis.voided_basin`.
    folder : Path
        Output folder.
    marks : sequence of trackdyn.plots.Mark
        Stretches of track to mark on the overview (the example's features).
    """
    from trackdyn.deterioration.loop import LoopOptions

    ps, delta = ds.attrs["static_wheel_load_N"], ds.attrs["delta"]
    write_netcdf(ds, folder / "track.nc")
    threshold = LoopOptions.model_fields["threshold_sd_mm"].default
    fig = plot_track_overview(ds, marks=marks, threshold_sd_mm=threshold)
    save(fig, folder / "track_overview.png")
    fig = plot_load_deflection(picks, static_load=ps, delta=delta)
    save(fig, folder / "load_deflection.png")
    save(plot_deflection_basin(basin, load=ps), folder / "deflection_basin.png")


@recorded
def track(
    geometry, supports, wheel_load_kN: float, delta: float, rail: str, extrapolate: bool,
    out, overwrite: bool, console,
) -> None:  # fmt: skip
    """Analyse a track and write track.nc and three figures into ``out``.

    Parameters
    ----------
    geometry, supports : path, optional
        Geometry and supports CSV files; neither: the built-in 1 km example section.
    wheel_load_kN : float
        Static wheel load Ps [kN].
    delta : float
        Dynamic wheel load increment δ [-].
    rail : str
        Rail section name (`trackdyn.track.rails.rail_section`).
    extrapolate : bool
        Allow Ps ± ΔP beyond the measured curves.
    out : str or Path
        Output folder.
    overwrite : bool
        Replace another command's outputs in ``out``.
    console : rich.console.Console
        Where the summary table is shown (stdout); progress goes to stderr.
    """
    from trackdyn.data import EXAMPLE_GEOMETRY, EXAMPLE_SUPPORTS, example_path

    check_within(wheel_load_kN * 1e3, *WHEEL_LOAD, "--wheel-load-kN", "kN", 1e3)
    if (geometry is None) != (supports is None):
        raise TrackdynInputError("give both --geometry and --supports, or neither for the example")
    given = geometry is not None
    if not given:
        geometry, supports = example_path(EXAMPLE_GEOMETRY), example_path(EXAMPLE_SUPPORTS)
    section = rail_section(rail)
    record = Record(
        f"trackdyn track: linearised track at Ps = {wheel_load_kN:g} kN, delta = {delta:g}",
        {"geometry": geometry, "supports": supports},
        {"wheel_load_kN": wheel_load_kN, "delta": delta, "rail": rail, "extrapolate": extrapolate},
    )
    with output_folder(out, "track", overwrite, record) as stage:
        with status("reading and linearising the track, piece by piece"):
            ds, picks, basin = analyse_pieces(
                geometry, supports, wheel_load_kN * 1e3, delta, section, extrapolate=extrapolate
            )
        table = summary_table(ds)
        record.headline = {"rails": table.to_dict(orient="records")}
        write_track_outputs(ds, picks, basin, stage, [] if given else example_marks())
    source = geometry if given else f"built-in example, {EXAMPLE_GEOMETRY}"
    console.print(frame_table(table, f"Track summary ({source})"))
    note(f"wrote track.nc, summary.json and 3 figures to {out}")
    note("\n".join(record.lines()), 2)
