"""What a command tells of the geometry it read: `Geometry.notes` on stderr and in its
record (``summary.json`` and the netCDF files' ``option_geometry_note_<topic>``
attributes)."""

from __future__ import annotations

from trackdyn.progress import note
from trackdyn.track.survey import NOTE_PREFIX as PREFIX


def geometry_notes(notes, source: str, options: dict | None = None) -> None:
    """Show each note (``(topic, text)`` pairs of `Geometry.notes`) on stderr, even with
    ``-q`` (they say what the profile lacks), and put it into ``options`` as
    ``geometry_note_<topic>``.

    Parameters
    ----------
    notes : iterable of (str, str)
        The notes.
    source : str
        The geometry file (or section) named before each note.
    options : dict, optional
        A command record's options, updated.
    """
    for topic, text in notes:
        note(f"{source}: {text}", 0)
        if options is not None:
            options[PREFIX + topic] = text
