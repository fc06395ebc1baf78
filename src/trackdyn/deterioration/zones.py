"""Zones of a track: distance ranges that settle by their own law, parameters and rate field.

Open track on an embankment, the ballast on a bridge deck or box culvert (``structure``:
no subgrade under the ballast, so it settles less), the ``approach`` embankment next to a
structure (fill that is hard to compact next to the abutment, so it settles more), or a
kind of the user's own. A zone gives its law's parameters (in the API) or takes them
from the parameter file's table for its kind (``[power.structure]``, see
`trackdyn.deterioration.law_files`), and may have its own settlement-rate field. Sleepers
outside every zone are open track with the section's law and rate field.

Zone tables (CSV, one row per zone, paths relative to the table)::

    start_m,end_m,kind[,settlement_file][,rate_cov][,rate_correlation_length_m][,seed]
    0,140,open
    140,150,approach
    150,180,structure

Zones may leave gaps (open track) but not overlap; each lies on the track.

References
----------
Wang, H., Markine, V., Liu, X. (2017). Experimental analysis of railway track settlement in
transition zones. Proceedings of the Institution of Mechanical Engineers, Part F: Journal
of Rail and Rapid Transit, doi:10.1177/0954409717748789.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trackdyn.deterioration.ballast import check_rate_field
from trackdyn.errors import TrackdynInputError, shown, unknown
from trackdyn.io import read_table

KINDS = ("open", "structure", "approach")
"""Zone kinds with parameters in the shipped parameter file; a file may add its own."""

OPTIONAL = ("settlement_file", "rate_cov", "rate_correlation_length_m", "seed")
"""Optional columns of a zone table."""


@dataclass(frozen=True)
class RateField:
    """A lognormal settlement-rate field (`trackdyn.deterioration.ballast.rate_field`).

    Parameters
    ----------
    cov : float
        Coefficient of variation [-].
    correlation_length : float
        Correlation length [m].
    seed : int or tuple of int
        Seed.
    """

    cov: float
    correlation_length: float
    seed: int | tuple[int, ...]


@dataclass(frozen=True)
class Zone:
    """A distance range of the track with its own settlement law.

    Parameters
    ----------
    start, end : float
        Range along the track, start inclusive, end exclusive [m].
    kind : str
        ``open``, ``structure``, ``approach`` or the user's own.
    law : LawParameters
        Its settlement law and parameters.
    rate : RateField, optional
        Its own settlement-rate field; None: the section's.
    """

    start: float
    end: float
    kind: str
    law: object
    rate: RateField | None = None

    def holds(self, position) -> np.ndarray:
        """Which of the sleepers at ``position`` [m] lie in the zone."""
        x = np.asarray(position, dtype=float)
        return (x >= self.start) & (x < self.end)


def check_zones(zones, extent, where: str = "zones") -> None:
    """Refuse zones that overlap, are empty or lie outside the track.

    Parameters
    ----------
    zones : sequence of Zone
        The zones.
    extent : tuple of float
        First and last sleeper of the track [m].
    where : str
        Name of their source, for messages.
    """
    for i, z in enumerate(zones):
        if not (np.isfinite(z.start) and np.isfinite(z.end) and z.start < z.end):
            raise TrackdynInputError(
                f"{where}: zone {i + 1} needs start_m < end_m, got {shown(z.start)}, {shown(z.end)}"
            )
        if z.end <= extent[0] or z.start > extent[1]:
            raise TrackdynInputError(
                f"{where}: zone {i + 1} ({z.start:g}-{z.end:g} m) lies outside the track "
                f"({extent[0]:g}-{extent[1]:g} m)"
            )
    ordered = sorted(range(len(zones)), key=lambda i: zones[i].start)
    for a, b in zip(ordered, ordered[1:], strict=False):
        if zones[b].start < zones[a].end:
            raise TrackdynInputError(
                f"{where}: zones {a + 1} and {b + 1} overlap ({zones[b].start:g} m < "
                f"{zones[a].end:g} m)"
            )


def read_zones(path, load) -> list[Zone]:
    """Read a zone table (see the module docstring).

    Parameters
    ----------
    path : path
        The CSV file.
    load : callable
        ``load(kind, file)`` -> the law of a zone of ``kind`` from the parameter ``file``
        (None: the section's parameter file); raises `TrackdynInputError` for an unknown
        kind.
    """
    path = Path(path)
    frame = read_table(path, ("start_m", "end_m", "kind"), OPTIONAL)
    extra = [c for c in frame.columns if c not in ("start_m", "end_m", "kind", *OPTIONAL)]
    if extra:
        raise unknown("column", extra[0], ("start_m", "end_m", "kind", *OPTIONAL), f"{path}: ")
    zones = []
    for i, row in enumerate(frame.to_dict("records")):
        line = f"{path}: line {i + 2}"
        value = {k: (None if pd.isna(v) else str(v).strip()) for k, v in row.items()}
        start, end = (_number(value[k], k, line) for k in ("start_m", "end_m"))
        if not end > start:
            raise TrackdynInputError(f"{line}: end_m {end:g} m is not beyond start_m {start:g} m")
        kind = value["kind"] or ""
        if not kind:
            raise TrackdynInputError(f"{line}: kind is empty")
        file = value.get("settlement_file")
        if file is not None and not (path.parent / file).is_file():
            raise TrackdynInputError(f"{line}: settlement_file {file!r} not found")
        try:
            law = load(kind, None if file is None else path.parent / file)
        except TrackdynInputError as exc:
            raise TrackdynInputError(f"{line}: {exc}") from None
        given = [k for k in OPTIONAL[1:] if value.get(k) is not None]
        rate = None
        if given:
            if "rate_cov" not in given:
                raise TrackdynInputError(f"{line}: {given[0]} needs rate_cov")
            cov = _number(value["rate_cov"], "rate_cov", line)
            length = _number(value.get("rate_correlation_length_m") or "3",
                             "rate_correlation_length_m", line)  # fmt: skip
            seed = _number(value.get("seed") or "0", "seed", line)
            if seed < 0 or seed != int(seed):
                raise TrackdynInputError(f"{line}: seed must be a whole number >= 0")
            try:
                check_rate_field(cov, length)
            except TrackdynInputError as exc:
                raise TrackdynInputError(f"{line}: {exc}") from None
            rate = RateField(cov, length, int(seed))
        zones.append(Zone(start, end, kind, law, rate))
    return zones


def _number(text, name: str, line: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise TrackdynInputError(f"{line}: {name} {text!r} is not a number") from None
    if not np.isfinite(value):
        raise TrackdynInputError(f"{line}: {name} must be finite")
    return value
