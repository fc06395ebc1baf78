"""Many deterioration runs through Dask: one section (or one law) per task.

Each task (`SectionTask`) runs the whole loop of one section; it carries the file paths,
the traffic, the law and the options, never the track arrays, and its section is read in
the worker. `run_sections` runs them through `trackdyn.parallel.run_tasks`; a failed run
is reported with its section's name.
"""

from __future__ import annotations

from dataclasses import dataclass

from trackdyn.data import load_track
from trackdyn.deterioration.loop import LoopOptions, predict
from trackdyn.deterioration.settlement import SettlementLaw
from trackdyn.deterioration.zones import check_zones
from trackdyn.errors import TrackdynInputError, error_message


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
