"""Recording-car geometry: what a geometry file holds, and the profile made of it.

A track recording car does not give the vertical space curve the model runs on: it gives
the longitudinal level already filtered to the EN 13848-1 D1 band (3-25 m) or to D1 and D2
(3-70 m), or, on older cars and hand trolleys, chord versines (`trackdyn.track.chord`);
its chainage is in km, decreasing when it ran that way, with gaps where it lost its
reference. `GeometryFormat` says which (the ``[track]`` keys of every command), and
`surveyed` turns the columns read into the `Geometry`, with `Geometry.notes` saying what
was done and what the profile lacks:

- ``profile`` (the default): the columns are the profile, positive downward;
- ``d1``, ``d1d2``: the filtered level is taken as the profile; the wavelengths beyond the
  band (25 or 70 m), which move the wagon body, are missing;
- ``versine``: the profile is recovered by the regularised inverse of the chord's
  transfer function over `trackdyn.track.chord.RECOVERED_BAND`, the chord's lost band
  stated.

Rows in decreasing chainage are put in increasing order (the run goes towards increasing
chainage; the rails keep their names); gaps (empty cells, or a step longer than
`GAP_STEP` sample spacings) up to ``max_gap_m`` are bridged by linear interpolation,
longer ones refused naming the lines. A profile whose D1 standard deviation lies outside
`D1_SD_MM` is refused: below it the numbers are metres under a ``_mm`` header, above it
no track the model means.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, PositiveFloat, model_validator

from trackdyn.errors import TrackdynInputError
from trackdyn.strict import Strict
from trackdyn.track.chord import RECOVERED_BAND, Chord, profile_from_versine
from trackdyn.track.quality import WAVEBANDS, longitudinal_level
from trackdyn.track.track import RAILS, Geometry

MAX_GAP_M = 2.0
"""Longest gap bridged by default [m], from the last sample before it to the first after
it: under the shortest D1 wavelength (3 m), so that no whole D1 wave is made up
(illustrative: a railway sets its own rule)."""

GAP_STEP = 1.5
"""A step between neighbouring samples longer than this many median spacings is a gap of
missing rows [-] (a recording car samples evenly; an uneven file's steps stay below it)."""

D1_SD_MM = (0.05, 30.0)
"""Plausible D1 standard deviation of a rail's profile [mm]: EN 13848-5's alert limits lie
near 1-4 mm, new track about 0.3 mm; below 0.05 mm the numbers are metres under a ``_mm``
header, above 30 mm no track the model means (millimetres under a ``_m`` header)."""

FLAT_SD_MM = 1e-6
"""D1 standard deviation below which a profile is flat (a test track), taken as it is [mm]."""

NOTE_PREFIX = "geometry_note_"
"""Start of the names under which outputs hold `Geometry.notes` (``geometry_note_kind``)."""

FILTERED = {"d1": WAVEBANDS["D1"], "d1d2": (WAVEBANDS["D1"][0], WAVEBANDS["D2"][1])}
"""Wavelengths [m] a filtered longitudinal level holds, by kind."""


class GeometryFormat(Strict):
    """What a geometry file holds (the ``[track]`` keys shared by every command).

    Parameters
    ----------
    geometry_kind : {"profile", "d1", "d1d2", "versine"}
        The profile, the D1 or D1+D2 longitudinal level, or chord versines.
    chord_m : float, optional
        Length of a symmetric (mid-chord) versine's chord [m]; with ``versine``.
    chord_back_m, chord_front_m : float, optional
        Or an asymmetric chord's ends behind and ahead of the measuring point, in the
        direction the car ran [m].
    max_gap_m : float
        Longest gap bridged by linear interpolation (`MAX_GAP_M`) [m].
    profile_sign : {"down", "up"}
        Which way the file's values are positive; ``"up"`` is turned to the package's
        positive-downward convention.
    """

    geometry_kind: Literal["profile", "d1", "d1d2", "versine"] = "profile"
    chord_m: PositiveFloat | None = None
    chord_back_m: PositiveFloat | None = None
    chord_front_m: PositiveFloat | None = None
    max_gap_m: float = Field(MAX_GAP_M, ge=0.0, le=100.0)
    profile_sign: Literal["down", "up"] = "down"

    @model_validator(mode="after")
    def _chord(self):
        ends = [e is not None for e in (self.chord_back_m, self.chord_front_m)]
        symmetric = self.chord_m is not None
        if self.geometry_kind != "versine":
            if symmetric or any(ends):
                raise ValueError(f"a chord is for geometry_kind = 'versine', not "
                                 f"{self.geometry_kind!r}")  # fmt: skip
        elif symmetric == all(ends) or (any(ends) and not all(ends)):
            raise ValueError("geometry_kind = 'versine' needs chord_m, or chord_back_m and "
                             "chord_front_m")  # fmt: skip
        return self

    def chord(self) -> Chord:
        """The versine's chord, in the direction the car ran."""
        if self.chord_m is not None:
            return Chord.symmetric(self.chord_m)
        assert self.chord_back_m is not None and self.chord_front_m is not None
        return Chord(self.chord_back_m, self.chord_front_m)


def surveyed(distance, left, right, lines, fmt: GeometryFormat, where, reversed_: bool):
    """The geometry of a file's columns as ``fmt`` says they are meant.

    Parameters
    ----------
    distance : ndarray
        Positions, strictly increasing [m].
    left, right : ndarray
        The rails' columns [m]; NaN where a value is missing (not in the first or last row).
    lines : ndarray
        The file's line of each row (for messages).
    fmt : GeometryFormat
        What the columns hold.
    where : str or Path
        The file, named in messages and notes.
    reversed_ : bool
        The rows were in decreasing chainage (reversed before this call).

    Returns
    -------
    Geometry
        Positive downward, with `Geometry.notes` on what was done.
    """
    notes = {}
    if reversed_:
        notes["direction"] = ("rows in decreasing chainage (the recording car's direction) "
                              "put in increasing order: the run goes towards increasing "
                              "chainage, the rails keep the file's names")  # fmt: skip
    distance, rails, bridged = bridge_gaps(distance, (left, right), lines, fmt.max_gap_m, where)
    if bridged:
        notes["gaps"] = bridged
    if fmt.profile_sign == "up":
        rails = tuple(-z for z in rails)
        notes["sign"] = "profile given positive upward, turned to positive downward"
    if fmt.geometry_kind == "versine":
        chord = fmt.chord()
        if reversed_:
            chord = Chord(chord.front_m, chord.back_m)
        rails = tuple(profile_from_versine(distance, v, chord, where=str(where)) for v in rails)
        notes["kind"] = versine_note(fmt.chord())
    elif fmt.geometry_kind in FILTERED:
        notes["kind"] = filtered_note(fmt.geometry_kind)
    left, right = rails
    geometry = Geometry(distance, left, right, str(where), notes=tuple(notes.items()))
    check_level(geometry)
    return geometry


def versine_note(chord: Chord) -> str:
    """What a profile recovered from ``chord``'s versine holds and lacks."""
    lo, hi = RECOVERED_BAND
    lost = chord.lost_band()
    weak = ", ".join(f"{a:.3g}-{b:.3g} m" for a, b in lost) or "none"
    return (f"profile recovered from versines over a chord {chord.back_m:g} m behind and "
            f"{chord.front_m:g} m ahead: wavelengths {lo:g}-{hi:g} m, the rest missing; "
            f"lost band (chord gain under the floor, held there): {weak}")  # fmt: skip


def filtered_note(kind: str) -> str:
    """What a filtered longitudinal level of ``kind`` lacks as a profile."""
    lo, hi = FILTERED[kind]
    return (f"{kind.upper()} longitudinal level taken as the profile: wavelengths "
            f"{lo:g}-{hi:g} m; those beyond {hi:g} m (which move the wagon body) and "
            f"under {lo:g} m are missing")  # fmt: skip


def bridge_gaps(distance, rails, lines, max_gap: float, where):
    """The samples with their gaps filled linearly, and a note on what was filled.

    A gap is a run of rows with a missing value (either rail), or a step between rows
    longer than `GAP_STEP` median spacings (rows missing); its length is from the last
    sample before it to the first after it. Gaps up to ``max_gap`` [m] get the rows of the
    median spacing, interpolated linearly; a longer one is refused naming its lines.

    Returns
    -------
    distance : ndarray
        Positions, with rows added in the gaps of missing rows [m].
    rails : tuple of ndarray
        The rails' values at them [m].
    note : str
        What was bridged ("" when nothing).
    """
    d = np.asarray(distance, dtype=float)
    ok = np.all([np.isfinite(z) for z in rails], axis=0)
    dx = float(np.median(np.diff(d)))
    kept = d[ok]
    step = np.diff(kept)
    gaps = np.flatnonzero(step > GAP_STEP * dx)
    if not gaps.size:
        return d, rails, ""
    long_ = gaps[step[gaps] > max_gap]
    if long_.size:
        i = long_[0]
        a, b = lines[ok][i], lines[ok][i + 1]
        raise TrackdynInputError(
            f"{where}: lines {a}-{b}: a gap of {step[i]:g} m in the geometry ({kept[i]:g} to "
            f"{kept[i + 1]:g} m), longer than max_gap_m = {max_gap:g} m bridged; split the "
            "file there (one section each side) or raise [track] max_gap_m"
        )
    added = [kept[i] + dx * np.arange(1, round(step[i] / dx)) for i in gaps]
    x = np.union1d(d, np.concatenate(added))
    filled = tuple(np.interp(x, kept, np.asarray(z)[ok]) for z in rails)
    note = (f"{gaps.size} gap(s) up to {step[gaps].max():g} m bridged by linear "
            f"interpolation, the first at {kept[gaps[0]]:g} m")  # fmt: skip
    return x, filled, note


def check_level(geometry: Geometry) -> None:
    """Refuse a rail whose D1 standard deviation lies outside `D1_SD_MM` (a profile shorter
    than two longest D1 wavelengths, or flat, is not checked)."""
    d = geometry.distance
    if d[-1] - d[0] < 2.0 * WAVEBANDS["D1"][1]:
        return
    lo, hi = D1_SD_MM
    for rail in RAILS:
        sd = float(np.std(longitudinal_level(d, geometry.profile(rail), "D1"))) * 1e3
        if FLAT_SD_MM <= sd < lo:
            raise TrackdynInputError(
                f"{geometry.where}: {rail} rail: D1 SD {sd:.3g} mm, under the plausible "
                f"{lo:g} mm: a profile in metres under a '_mm' header? (name the column "
                f"{rail}_m)"
            )
        if sd > hi:
            raise TrackdynInputError(
                f"{geometry.where}: {rail} rail: D1 SD {sd:.3g} mm, over the plausible "
                f"{hi:g} mm: a profile in millimetres under a '_cm' or '_m' header?"
            )
