"""Files shipped with trackdyn: the built-in example section."""

from __future__ import annotations

import functools
import os
from importlib.resources import files
from pathlib import Path

import numpy as np

from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_geometry, read_measured_stiffness, read_supports
from trackdyn.track.formats import TrackFormat
from trackdyn.track.measured import measured_supports
from trackdyn.track.support import SupportCurve
from trackdyn.track.track import Track

EXAMPLE_GEOMETRY = "example_geometry.csv"
EXAMPLE_SUPPORTS = "example_supports.csv"
EXAMPLE_ZONES = "example_zones.csv"
"""Zones of the example for `trackdyn deteriorate`: its 40 m structure and approaches."""


def example_path(name: str) -> Path:
    """Path of a file shipped in ``trackdyn/data``."""
    return Path(str(files(__name__).joinpath(name)))


def load_track(geometry=None, supports=None, track_format=None) -> Track:
    """Read a track from CSV files; with neither given, the built-in example section.

    Parameters
    ----------
    geometry : path, optional
        Geometry CSV, ``distance_m,left_mm,right_mm``.
    supports : path, optional
        Supports CSV, ``distance_m,rail,load_kN,deflection_mm`` or
        ``distance_m,rail,stiffness_kN_per_mm``.
    track_format : TrackFormat, optional
        What the geometry and the supports files hold (`trackdyn.track.formats`); default
        a profile and per-sleeper curves.
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
        if track_format not in (None, TrackFormat()):
            raise TrackdynInputError(
                "the [track] keys of geometry_kind, chord, max_gap_m, profile_sign and "
                "supports_kind describe files; the built-in example is a profile with "
                "per-sleeper curves"
            )
        geometry, supports = example_path(EXAMPLE_GEOMETRY), example_path(EXAMPLE_SUPPORTS)
    fmt = TrackFormat() if track_format is None else track_format
    profile = read_geometry(geometry, fmt)
    if fmt.supports_kind == "measured":
        span = (float(profile.distance[0]), float(profile.distance[-1]))
        measured = read_measured_stiffness(supports)
        return Track(profile, measured_supports(measured, fmt, span, example_shape(), supports))
    track = Track(profile, read_supports(supports))
    check_coverage(track, supports)
    return track


@functools.cache
def example_shape() -> SupportCurve:
    """The built-in example's median support curve: at each of its load points, the median
    deflection of its 3334 curves (both rails; they share the load points), the shape
    given to supports made of a measured stiffness (`trackdyn.track.measured`)."""
    example = read_supports(example_path(EXAMPLE_SUPPORTS))
    curves = [example.left, example.right]
    load = curves[0].load[: curves[0].start[1]]
    deflection = np.concatenate([c.deflection.reshape(-1, load.size) for c in curves])
    return SupportCurve(load, np.median(deflection, axis=0), "the example's median curve")


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
            f"{g[0]:g} to {g[-1]:g} m ({track.geometry.where}); give supports along the "
            "whole geometry"
        )
