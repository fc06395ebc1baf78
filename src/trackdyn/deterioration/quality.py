"""Geometry quality as the deterioration loop assesses it: the D1 standard deviation of
each rail per segment (EN 13848-5), set up once per grid of distances."""

from __future__ import annotations

import numpy as np

from trackdyn.track.quality import LevelFilter, Segments
from trackdyn.track.track import RAILS


def d1_sd(geometry, extent, segment_length: float):
    """D1 standard deviation of each rail per segment [mm], and the segment bounds [m].

    Parameters
    ----------
    geometry : Geometry
        Unloaded space curve.
    extent : tuple of float
        Part of the track to assess (where geometry and supports overlap) [m].
    segment_length : float
        Segment length [m].
    """
    return D1Assessment(extent, segment_length)(geometry)


class D1Assessment:
    """`d1_sd` of many geometries, the filter and the segments set up once for a grid of
    distances (`trackdyn.track.quality.LevelFilter`, `Segments`) and kept while the
    geometries stay on it: the deterioration loop assesses every step's geometry, and
    the maintenance each trial step's, on the same grid.

    Parameters
    ----------
    extent, segment_length
        As `d1_sd`.
    """

    def __init__(self, extent, segment_length: float):
        self.extent, self.segment_length = extent, segment_length
        self._grid: tuple = ()  # distance, the part inside, its filter and segments

    def _on(self, distance) -> tuple:
        if not self._grid or not np.array_equal(self._grid[0], distance):
            inside = (distance >= self.extent[0]) & (distance <= self.extent[1])
            x = distance[inside]
            self._grid = (distance, inside, LevelFilter(x, "D1"), Segments(x, self.segment_length))
        return self._grid

    def rail(self, distance, profile):
        """`d1_sd` of one rail's ``profile`` at ``distance``: segment starts and ends [m] and
        the D1 standard deviation of each segment [mm]."""
        _, inside, level, segments = self._on(distance)
        return segments.starts, segments.ends, segments.sd(level(profile[inside]))

    def __call__(self, geometry):
        """As `d1_sd`."""
        tables = [self.rail(geometry.distance, geometry.profile(r)) for r in RAILS]
        return np.array([sd for _, _, sd in tables]), tables[0][0], tables[0][1]
