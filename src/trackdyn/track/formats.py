"""What a track's files hold: the ``[track]`` keys shared by every command.

The geometry file's keys (`trackdyn.track.survey.GeometryFormat`: a profile, a filtered
longitudinal level or chord versines; gaps, sign) and the supports file's
(`trackdyn.track.measured.SupportsFormat`: per-sleeper curves, or a measured stiffness at
one load), in one table.
"""

from __future__ import annotations

from trackdyn.track.measured import SupportsFormat
from trackdyn.track.survey import GeometryFormat


class TrackFormat(GeometryFormat, SupportsFormat):
    """What the geometry and the supports files hold (each base's keys)."""

    def track_format(self) -> TrackFormat:
        """These keys alone (of a ``[track]`` table that holds more)."""
        return TrackFormat(**{k: getattr(self, k) for k in TrackFormat.model_fields})
