"""Many deterioration runs through Dask: a few sections (or laws) per task.

A `SectionTask` is the whole loop of one section; it carries the file paths, the traffic,
the law and the options, never the track arrays, and its section is read in the worker.
`run_sections` sends them through `trackdyn.parallel.run_tasks` up to `TOGETHER` at a
time, stepped together (`run_group`) so that their vehicle runs share the solver's vector
lanes; a section that fails gives a `Failure` named with the section.
"""

from __future__ import annotations

from dataclasses import dataclass

from trackdyn.data import load_track
from trackdyn.deterioration.driver import step_together
from trackdyn.deterioration.loop import SectionLoop
from trackdyn.deterioration.options import LoopOptions
from trackdyn.deterioration.results import make_dataset
from trackdyn.deterioration.settlement import SettlementLaw
from trackdyn.deterioration.zones import check_zones
from trackdyn.errors import Failure
from trackdyn.track.formats import TrackFormat
from trackdyn.track.survey import NOTE_PREFIX
from trackdyn.track.track import Track


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
    track_format : TrackFormat, optional
        What the geometry and supports files hold (`trackdyn.track.formats`); None: a
        profile and per-sleeper curves.
    """

    name: str
    geometry: str | None = None
    supports: str | None = None
    zones: str | None = None
    track_format: TrackFormat | None = None

    def track(self) -> Track:
        """The section's track, read from its files (`trackdyn.data.load_track`)."""
        return load_track(self.geometry, self.supports, self.track_format)


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


TOGETHER = 8
"""Sections a task steps together (`run_group`). The empty wagon is held in most steps, so
a step of 8 sections runs 8 to 16 vehicles: whole groups of the solver's vector lanes (8
runs). On a line of 1 km sections on one worker, 8 sections a task took 7 % less time
than 4 (13.0 s against 13.9 s through 50 MGT) and 25 % more memory (647 MB against 518 MB
a worker process, when a section's beam held 25 MB per km; its windows no longer keep
their inverses, 11 MB per km: now 556 MB, about 20 MB per km of section)."""


def run_section(task: SectionTask):
    """Run the loop on one section; never raises (a failure is returned).

    Parameters
    ----------
    task : SectionTask
        The section and what to run on it.

    Returns
    -------
    xarray.Dataset or Failure
        The section's Dataset (its ``section`` attribute its name), or its `Failure`,
        named with it (``"section <name>: ..."``).
    """
    return run_group([task])[0]


def run_group(tasks: list[SectionTask]) -> list:
    """Run the loops of several sections stepped together (`step_together`: their vehicle
    runs share the solver's vector lanes); never raises. Each section's result is what
    `run_section` gives for it alone; a tonnage progress bar when every task asks for one.

    Parameters
    ----------
    tasks : list of SectionTask
        The sections and what to run on each.

    Returns
    -------
    list
        Per section, its Dataset or its `Failure` (as `run_section`).
    """
    loops: dict[int, SectionLoop] = {}
    notes: dict[int, tuple] = {}
    results: list = [None] * len(tasks)
    for i, task in enumerate(tasks):
        try:
            sec = task.section
            track = sec.track()
            position = track.supports.position
            check_zones(task.zones, (position[0], position[-1]), task.section.zones or "zones")
            loops[i] = SectionLoop(track, task.traffic, task.law, task.options, zones=task.zones)
            notes[i] = track.geometry.notes
        except Exception as exc:  # noqa: BLE001 - reported with the section, others go on
            results[i] = Failure.of(exc).named(f"section {task.section.name}")
    progress = all(t.progress for t in tasks)
    for i, out in zip(loops, step_together(list(loops.values()), progress), strict=True):
        name = tasks[i].section.name
        if isinstance(out, Failure):
            results[i] = out.named(f"section {name}")
        else:
            ds = results[i] = make_dataset(out)
            ds.attrs["section"] = name
            ds.attrs.update({NOTE_PREFIX + topic: text for topic, text in notes[i]})
    return results


IN_PROCESS_MGT = 200.0
"""Sections times tonnage [MGT] up to which the sections (at most `TOGETHER`, one task) run
in this process by default, stepped together, rather than on a new local cluster: starting
one (its processes, trackdyn imported and the compiled loops loaded in each) costs more
than a second worker saves on them. 4 sections of 500 m through 50 MGT: 5.7 s in this
process against 9.6 s on 2 workers, the command's whole wall time (benchmarks/command.py,
2 cores)."""


def in_process(tasks: list[SectionTask], workers: int | None, scheduler: str | None) -> bool:
    """Whether `run_sections` runs ``tasks`` in this process: with ``workers=1`` and no
    scheduler, or by default (no workers, scheduler or `trackdyn.parallel.shared_cluster`
    given) when they are few and short (`IN_PROCESS_MGT`).

    Parameters
    ----------
    tasks : list of SectionTask
        The sections.
    workers : int, optional
        Worker processes asked for.
    scheduler : str, optional
        Address of a running Dask scheduler.
    """
    from trackdyn.parallel import sharing

    if scheduler is not None or workers not in (None, 1):
        return False
    if workers == 1:
        return True
    work = sum(t.options.total_mgt for t in tasks)
    return not sharing() and len(tasks) <= TOGETHER and work <= IN_PROCESS_MGT


def run_sections(tasks, *, workers=None, scheduler=None, progress=False) -> list:
    """Run the tasks through `run_tasks`; the Datasets in task order.

    Few and short sections (`in_process`) run in this process unless ``workers`` says
    otherwise. A failed section is raised (`Failure.error`), its message naming it
    (nothing is written).

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

    if in_process(tasks, workers, scheduler):
        workers = 1
    results = run_tasks(
        tasks, run_group, workers=workers, scheduler=scheduler, progress=progress,
        label="sections", together=TOGETHER,
    )  # fmt: skip
    failed = [r for r in results if isinstance(r, Failure)]
    if failed:
        more = f" ({len(failed) - 1} more sections failed)" if len(failed) > 1 else ""
        raise Failure(failed[0].status, f"{failed[0].message}{more}").error()
    return results
