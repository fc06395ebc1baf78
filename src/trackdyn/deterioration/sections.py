"""Many track sections: one deterioration loop per section, run through Dask.

A sections list is a CSV file naming each section's geometry and supports files, relative
to the CSV file::

    name,geometry,supports
    km12,km12_geometry.csv,km12_supports.csv
    km13,km13_geometry.csv,km13_supports.csv

Each section's whole loop is one task of `trackdyn.parallel.run_tasks`; the task
carries the file paths, the traffic, the law and the options, never the track arrays.
The rate-field seed of section ``i`` is ``(seed, i)``, so results do not depend on how the
sections are spread over workers.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trackdyn.data import EXAMPLE_ZONES, example_path, load_track
from trackdyn.deterioration.law_files import load_law
from trackdyn.deterioration.loop import LoopOptions, predict
from trackdyn.deterioration.scenario import loop_options, resolve_inputs
from trackdyn.deterioration.settlement import SettlementLaw
from trackdyn.deterioration.zones import check_zones, read_zones
from trackdyn.errors import TrackdynInputError, error_message

NAME = re.compile(r"^[A-Za-z0-9_.-]+$")
"""Section names become parts of file names."""


@dataclass(frozen=True)
class Section:
    """A track section.

    Parameters
    ----------
    name : str
        Name, used in file names.
    geometry, supports : str, optional
        CSV files; None for both: the built-in example.
    zones : str, optional
        Zone table (`trackdyn.deterioration.zones`); None: all open track.
    """

    name: str
    geometry: str | None = None
    supports: str | None = None
    zones: str | None = None


def read_sections(path) -> list[Section]:
    """Read a sections CSV (``name,geometry,supports[,zones]``, paths relative to the CSV
    file; an empty ``zones`` cell: all open track).

    Parameters
    ----------
    path : path
        The CSV file.
    """
    path = Path(path)
    if not path.is_file():
        raise TrackdynInputError(f"{path}: no such file")
    try:
        frame = pd.read_csv(path, comment="#", skipinitialspace=True, dtype=str)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise TrackdynInputError(f"{path}: not a readable CSV file ({exc})") from None
    missing = [c for c in ("name", "geometry", "supports") if c not in frame.columns]
    if missing:
        raise TrackdynInputError(f"{path}: no column {missing[0]!r} (name,geometry,supports)")
    if frame.empty:
        raise TrackdynInputError(f"{path}: no sections listed")
    sections, seen = [], set()
    for i, row in enumerate(frame.itertuples(index=False)):
        line = f"{path}: line {i + 2}"
        name = str(row.name).strip()
        if not NAME.match(name) or name in seen:
            raise TrackdynInputError(
                f"{line}: section name {name!r} is empty, repeated or not made of "
                "letters, digits, '_', '-' and '.'"
            )
        seen.add(name)
        files = []
        for key in ("geometry", "supports", "zones"):
            value = getattr(row, key, None)
            if key == "zones" and not isinstance(value, str):
                files.append(None)
                continue
            file = path.parent / str(value).strip()
            if not isinstance(value, str) or not file.is_file():
                raise TrackdynInputError(f"{line}: {key} file {value!r} not found")
            files.append(str(file.resolve()))
        sections.append(Section(name, *files))
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
        return read_sections(base / t.sections)
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
    return [Section(name, str(files[0].resolve()), str(files[1].resolve()), zones)]


@dataclass(frozen=True)
class SectionTask:
    """One section's whole loop: small and picklable.

    Parameters
    ----------
    section : Section
        The section (file paths, not arrays).
    traffic : tuple of Traffic
        The traffic mix.
    law : SettlementLaw
        The settlement law.
    options : LoopOptions
        The loop options, with this section's rate-field seed.
    progress : bool
        Show a tonnage progress bar (in-process runs).
    zones : tuple of Zone
        The section's zones, read from ``section.zones``.
    """

    section: Section
    traffic: tuple
    law: SettlementLaw
    options: LoopOptions
    progress: bool = False
    zones: tuple = ()


def run_section(task: SectionTask) -> dict:
    """Run the loop on one section; never raises (a failure is returned as ``error``).

    Parameters
    ----------
    task : SectionTask
        The section and what to run on it.

    Returns
    -------
    dict
        ``name`` and ``dataset``, or ``name`` and ``error``.
    """

    name = task.section.name
    try:
        track = load_track(task.section.geometry, task.section.supports)
        position = track.supports.position
        check_zones(task.zones, (position[0], position[-1]), task.section.zones or "zones")
        ds = predict(track, task.traffic, task.law, task.options, zones=task.zones,
                     progress=task.progress)  # fmt: skip
    except Exception as exc:  # noqa: BLE001 - reported with the section, others go on
        return {"name": name, "error": error_message(exc)}
    ds.attrs["section"] = name
    return {"name": name, "dataset": ds}


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

    def options(i, example):
        return loop_options(spec, (spec.settlement.seed, i), example)

    return [
        SectionTask(
            sec,
            tuple(traffic),
            law,
            options(i, sec.geometry is None),
            progress,
            tuple(read_zones(sec.zones, load)) if sec.zones else (),
        )  # fmt: skip
        for i, sec in enumerate(sections_of(spec, base))
    ]


def run_sections(tasks, *, workers=None, scheduler=None, progress=False) -> list:
    """Run the tasks through `run_tasks`; the Datasets in task order.

    One section without a scheduler runs in this process unless ``workers`` says
    otherwise. A failed section is a `TrackdynInputError` naming it (nothing is written).

    Parameters
    ----------
    tasks : list of SectionTask
        The sections.
    workers : int, optional
        Worker processes (default one per core; 1 runs in this process).
    scheduler : str, optional
        Address of a running Dask scheduler.
    progress : bool
        Show a progress bar counting finished sections.
    """
    from trackdyn.parallel import run_tasks

    if workers is None and scheduler is None and len(tasks) == 1:
        workers = 1
    results = run_tasks(
        tasks, run_section, workers=workers, scheduler=scheduler, progress=progress,
        label="sections",
    )  # fmt: skip
    failed = [r for r in results if "error" in r]
    if failed:
        more = f" ({len(failed) - 1} more sections failed)" if len(failed) > 1 else ""
        raise TrackdynInputError(f"section {failed[0]['name']}: {failed[0]['error']}{more}")
    return [r["dataset"] for r in results]


def summary(datasets) -> pd.DataFrame:
    """One row per section: steps, final settlement and D1 SD, first maintenance trigger.

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Results of `trackdyn.deterioration.predict` with a ``section`` attribute.
    """
    rows = []
    for ds in datasets:
        final = ds.settlement.isel(mgt=-1) * 1e3
        trigger = ds.trigger_mgt_any_rail.values
        rows.append(
            {
                "section": ds.attrs["section"],
                "mgt": float(ds.mgt[-1]),
                "steps": int(ds.attrs["steps"]),
                "settlement_min_mm": float(final.min()),
                "settlement_mean_mm": float(final.mean()),
                "settlement_max_mm": float(final.max()),
                "d1_sd_max_initial_mm": float(ds.d1_sd.isel(mgt=0).max()),
                "d1_sd_max_final_mm": float(ds.d1_sd.isel(mgt=-1).max()),
                "first_trigger_mgt": float(np.min(trigger)) if trigger.size else np.inf,
            }
        )
    return pd.DataFrame(rows)
