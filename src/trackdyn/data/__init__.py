"""Files shipped with trackdyn: the built-in example section."""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

import numpy as np

from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_geometry, read_supports
from trackdyn.track.survey import GeometryFormat
from trackdyn.track.track import Track

EXAMPLE_GEOMETRY = "example_geometry.csv"
EXAMPLE_SUPPORTS = "example_supports.csv"
EXAMPLE_ZONES = "example_zones.csv"
"""Zones of the example for `trackdyn deteriorate`: its 40 m structure and approaches."""


def example_path(name: str) -> Path:
    """Path of a file shipped in ``trackdyn/data``."""
    return Path(str(files(__name__).joinpath(name)))


def load_track(geometry=None, supports=None, geometry_format=None) -> Track:
    """Read a track from CSV files; with neither given, the built-in example section.

    Parameters
    ----------
    geometry : path, optional
        Geometry CSV, ``distance_m,left_mm,right_mm``.
    supports : path, optional
        Supports CSV, ``distance_m,rail,load_kN,deflection_mm`` or
        ``distance_m,rail,stiffness_kN_per_mm``.
    geometry_format : GeometryFormat, optional
        What the geometry file holds (`trackdyn.track.survey`); default a profile.
    """
    for name, value in (("geometry", geometry), ("supports", supports)):
        if value is not None and not isinstance(value, str | os.PathLike):
            raise TrackdynInputError(
                f"load_track: {name} must be a file path (str or Path), got {type(value).__name__}"
            )
    if (geometry is None) != (supports is None):
        raise TrackdynInputError(
            "give both a geometry and a supports file, or neither for the built-in example"
        )
    if geometry is None:
        if geometry_format not in (None, GeometryFormat()):
            raise TrackdynInputError(
                "geometry_kind, chord, max_gap_m and profile_sign describe a geometry file; "
                "the built-in example is a profile"
            )
        geometry, supports = example_path(EXAMPLE_GEOMETRY), example_path(EXAMPLE_SUPPORTS)
    track = Track(read_geometry(geometry, geometry_format), read_supports(supports))
    check_coverage(track, supports)
    return track


def check_coverage(track: Track, supports) -> None:
    """Refuse supports that leave more than a sleeper spacing of either end of the geometry.

    Parameters
    ----------
    track : Track
        The track read from the files.
    supports : path
        Its supports file, named in the message.
    """
    g, s = track.geometry.distance, track.supports.position
    spacing = float(np.max(np.diff(s), initial=0.0))
    if s[0] - g[0] > spacing or g[-1] - s[-1] > spacing:
        raise TrackdynInputError(
            f"{supports}: supports cover {s[0]:g} to {s[-1]:g} m, the geometry "
            f"{g[0]:g} to {g[-1]:g} m; give supports along the whole geometry"
        )
