"""Sections lists of `trackdyn deteriorate`, and the tasks of a scenario.

A sections list is a CSV file naming each section's geometry and supports files, relative
to the CSV file::

    name,geometry,supports
    km12,km12_geometry.csv,km12_supports.csv
    km13,km13_geometry.csv,km13_supports.csv

Each section's whole loop is one task (`trackdyn.deterioration.runs.SectionTask`). The
rate-field seed of section ``i`` is ``(seed, i)``, so results do not depend on how the
sections are spread over workers.
"""

from __future__ import annotations

import re
from pathlib import Path

from trackdyn.commands.deteriorate.scenario import loop_options, resolve_inputs
from trackdyn.data import (
    EXAMPLE_GEOMETRY,
    EXAMPLE_SUPPORTS,
    EXAMPLE_ZONES,
    example_path,
)
from trackdyn.deterioration.ballast import read_rate_field
from trackdyn.deterioration.law_files import load_law
from trackdyn.deterioration.runs import Section, SectionTask
from trackdyn.deterioration.zones import read_zones
from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_table
from trackdyn.provenance import note_read
from trackdyn.track.formats import TrackFormat

NAME = re.compile(r"^[A-Za-z0-9_.-]*[A-Za-z0-9][A-Za-z0-9_.-]*$")
"""Section names become parts of file names: letters, digits, ``_``, ``-`` and ``.``, with
at least one letter or digit (not ``..``)."""


def read_sections(path, track_format: TrackFormat | None = None) -> list[Section]:
    """Read a sections CSV (``name,geometry,supports[,zones]``, paths relative to the CSV
    file; an empty ``zones`` cell: all open track).

    Parameters
    ----------
    path : path
        The CSV file.
    track_format : TrackFormat, optional
        What every section's geometry file holds; None: a profile.
    """
    path = Path(path)
    frame = read_table(path, ("name", "geometry", "supports"), ("zones",))
    sections, seen = [], set()
    for i, row in enumerate(frame.itertuples(index=False)):
        line = f"{path}: line {i + 2}"
        name = str(row.name).strip()
        if not NAME.match(name) or name in seen:
            raise TrackdynInputError(
                f"{line}: section name {name!r} is empty, repeated or not made of "
                "letters, digits, '_', '-' and '.' (with a letter or digit)"
            )
        seen.add(name)
        files: list[str | None] = []
        for key in ("geometry", "supports", "zones"):
            value = getattr(row, key, None)
            if key == "zones" and not isinstance(value, str):
                files.append(None)
                continue
            file = path.parent / str(value).strip()
            if not isinstance(value, str) or not file.is_file():
                raise TrackdynInputError(f"{line}: {key} file {value!r} not found")
            files.append(str(file.resolve()))
        geometry, supports, zones = files
        sections.append(Section(name, geometry, supports, zones, track_format))
    return sections


def sections_of(spec, base: Path) -> list[Section]:
    """The sections a scenario names: a list, one pair of files, or the example (with its
    zones, `trackdyn.data.EXAMPLE_ZONES`, unless ``[track] zones`` gives others).

    Parameters
    ----------
    spec : DeteriorationScenario
        The scenario.
    base : Path
        Folder that relative paths in the scenario start from.
    """
    t = spec.track
    if t.sections is not None:
        return read_sections(base / t.sections, t.track_format())
    zones = None
    if t.zones is not None:
        if not (base / t.zones).is_file():
            raise TrackdynInputError(f"track.zones: {base / t.zones}: no such file")
        zones = str((base / t.zones).resolve())
    if t.geometry is None:
        return [Section("example", zones=zones or str(example_path(EXAMPLE_ZONES)))]
    files = [base / t.geometry, base / t.supports]
    for key, file in zip(("geometry", "supports"), files, strict=True):
        if not file.is_file():
            raise TrackdynInputError(f"track.{key}: {file}: no such file")
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", files[0].stem)
    geometry, supports = (str(f.resolve()) for f in files)
    return [Section(name, geometry, supports, zones, t.track_format())]


def section_tasks(spec, base: Path, progress: bool = False) -> list[SectionTask]:
    """Tasks of a scenario, one per section; input is checked here, before any run.

    Parameters
    ----------
    spec : DeteriorationScenario
        The scenario.
    base : Path
        Folder that relative paths in the scenario start from.
    progress : bool
        Show a tonnage progress bar in each task (for in-process runs).
    """
    traffic, law = resolve_inputs(spec, base)
    s = spec.settlement
    own = None if s.file is None else base / s.file

    def load(kind, file):
        return load_law(s.law, file or own, kind, **s.overrides)

    def options(i, sec):
        o = loop_options(spec, (spec.settlement.seed, i), sec.geometry is None, base)
        if s.rate_field is None:
            return o
        position = sec.track().supports.position
        factor = read_rate_field(base / s.rate_field, position)
        return o.model_copy(update={"rate_factor": tuple(map(tuple, factor.tolist()))})

    sections = sections_of(spec, base)
    for sec in sections:  # read in the workers: noted here for the provenance
        note_read(sec.geometry or example_path(EXAMPLE_GEOMETRY))
        note_read(sec.supports or example_path(EXAMPLE_SUPPORTS))
    return [
        SectionTask(
            sec,
            tuple(traffic),
            law,
            options(i, sec),
            progress,
            tuple(read_zones(sec.zones, load)) if sec.zones else (),
        )  # fmt: skip
        for i, sec in enumerate(sections)
    ]
