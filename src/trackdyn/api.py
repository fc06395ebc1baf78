"""A scenario as an object: its inputs, solved once, its results, summary and figures.

The commands' work without their files, for a script or a notebook: `Run` (``trackdyn
run``), `Deterioration` (``trackdyn deteriorate``) and `Calibration` (``trackdyn
calibrate``), each made from its scenario file (`from_file`; none: the built-in example)
or, for a run, from a vehicle, a track and options::

    import trackdyn

    run = trackdyn.Run.from_file("run.toml").solve()
    run.summary()              # the command's table (pandas), per contact
    run.plot()                 # the command's figures, {file name: matplotlib Figure}
    run.results                # the xarray Dataset of results.nc

    life = trackdyn.Deterioration.from_file("deteriorate.toml").solve(workers=1)
    life.summary()             # a row per section
    life.results[0].d1_sd      # each section's Dataset

The figures and tables are the commands' own (the same functions draw them), so what a
script shows is what the command writes. A front end beside the CLI: it uses the
commands' scenario models and tables; nothing below it imports it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from trackdyn.errors import TrackdynInputError, named


class _Solved:
    """What every scenario object shares: results once solved, refused before."""

    results: Any = None

    def _solved(self):
        if self.results is None:
            raise TrackdynInputError(f"{type(self).__name__}: call .solve() first")
        return self.results


@dataclasses.dataclass
class Run(_Solved):
    """A vehicle over a track (``trackdyn run``).

    Parameters
    ----------
    vehicle : Vehicle, optional
        The vehicle (`trackdyn.load_vehicle`); default the loaded wagon.
    track : Track, optional
        The track (`trackdyn.load_track`); default the built-in example, whose soft spot,
        voids and structure the figures mark.
    options : RunOptions, optional
        Model, speed, time step, storage (`trackdyn.RunOptions`); default the 11-DOF model
        at 60 km/h.

    Attributes
    ----------
    results : xarray.Dataset or None
        The run (`trackdyn.simulate`), once `solve` is called.
    """

    vehicle: Any = None
    track: Any = None
    options: Any = None
    results: Any = dataclasses.field(default=None, init=False, repr=False)

    def __post_init__(self):
        from trackdyn import RunOptions, load_track, load_vehicle

        self._example = self.track is None
        self.vehicle = load_vehicle("loaded") if self.vehicle is None else self.vehicle
        self.track = load_track() if self.track is None else self.track
        self.options = RunOptions() if self.options is None else self.options

    @classmethod
    def from_file(cls, path=None) -> Run:
        """The run of a scenario TOML (``[vehicle]``, ``[track]``, ``[run]``); None: the
        built-in example."""
        from trackdyn.commands.run import load_scenario

        spec, base = load_scenario(path)
        with named(path or "built-in example"):
            vehicle = spec.vehicle.load(base)
            track = None if spec.track.geometry is None else spec.track.load(base)
        return cls(vehicle, track, spec.run)

    def solve(self, progress: bool = False) -> Run:
        """Simulate (`trackdyn.simulate`); the results in `results`. Returns the run."""
        from trackdyn.simulation import simulate

        self.results = simulate(self.vehicle, self.track, self.options, progress=progress)
        return self

    def summary(self):
        """Per contact, the dynamic wheel load's extremes and SD, the dominant frequency,
        the secondary suspension's largest displacement and the body bounce RMS (the
        command's ``summary.csv``; `trackdyn.results.summary`)."""
        from trackdyn.results import summary

        return summary(self._solved())

    def plot(self) -> dict:
        """The command's figures, by file name (`trackdyn.commands.run.run_figures`)."""
        from trackdyn.commands.run import run_figures
        from trackdyn.plots import example_marks

        marks = example_marks() if self._example else []
        return run_figures(self._solved(), self.options.delta, marks)


@dataclasses.dataclass
class Deterioration(_Solved):
    """A deterioration scenario's sections through their tonnage (``trackdyn
    deteriorate``), without its forecast and plan.

    Parameters
    ----------
    path : str or Path, optional
        The scenario TOML; None: the built-in example (50 MGT over the example section).

    Attributes
    ----------
    tasks : list of trackdyn.deterioration.runs.SectionTask
        Each section's loop, as the scenario makes it.
    results : list of xarray.Dataset or None
        A Dataset per section (``deterioration_<section>.nc``), once `solve` is called.
    """

    path: str | Path | None = None
    tasks: Any = dataclasses.field(default=None, init=False, repr=False)
    results: Any = dataclasses.field(default=None, init=False, repr=False)

    def __post_init__(self):
        from trackdyn.commands.deteriorate.scenario import load_deterioration
        from trackdyn.commands.deteriorate.sections import section_tasks

        spec, base = load_deterioration(self.path)
        self.tasks = section_tasks(spec, base)

    @classmethod
    def from_file(cls, path=None) -> Deterioration:
        """The scenario of ``path`` (None: the built-in example), checked now."""
        return cls(path)

    def solve(self, workers: int | None = None, scheduler: str | None = None,
              progress: bool = False) -> Deterioration:  # fmt: skip
        """Run every section (`trackdyn.deterioration.runs.run_sections`: on Dask, or in
        this process for few short sections or ``workers=1``). Returns the object."""
        from trackdyn.deterioration.runs import run_sections
        from trackdyn.errors import require_workers

        require_workers(workers)
        self.results = run_sections(self.tasks, workers=workers, scheduler=scheduler,
                                    progress=progress)  # fmt: skip
        return self

    def summary(self):
        """A row per section: steps, settlement, D1 SD, first trigger, interventions,
        hanging rail seats (the command's ``summary.csv``)."""
        from trackdyn.commands.deteriorate.outputs import summary

        return summary(self._solved())

    def plot(self) -> dict:
        """The command's figures, by file name: each section's four, and the line's."""
        from trackdyn.commands.deteriorate.outputs import line_figure, section_figures

        datasets = self._solved()
        drawings = [*map(section_figures, datasets), line_figure(datasets)]
        return {file: d.figure() for each in drawings for file, d in each.items()}


@dataclasses.dataclass
class Calibration(_Solved):
    """A settlement law fitted to geometry surveys (``trackdyn calibrate``).

    Parameters
    ----------
    path : str or Path, optional
        The calibration TOML; None: the built-in example (three synthetic surveys).

    Attributes
    ----------
    problem : trackdyn.calibration.problem.Calibration
        The surveys, supports and what is fitted.
    results : trackdyn.calibration.fit.FitResult or None
        The fit, once `solve` is called.
    """

    path: str | Path | None = None
    problem: Any = dataclasses.field(default=None, init=False, repr=False)
    results: Any = dataclasses.field(default=None, init=False, repr=False)

    def __post_init__(self):
        from trackdyn.commands.calibrate.spec import calibration_problem, load_calibration
        from trackdyn.commands.examples import example_file

        source = example_file("calibration", "calibration.toml") if self.path is None else self.path
        spec, base = load_calibration(source)
        self.problem = calibration_problem(spec, base)

    @classmethod
    def from_file(cls, path=None) -> Calibration:
        """The calibration of ``path`` (None: the built-in example), checked now."""
        return cls(path)

    def solve(self, workers: int | None = None, scheduler: str | None = None) -> Calibration:
        """Fit (`trackdyn.calibration.fit.fit`); the result in `results`. Returns the object."""
        from trackdyn.calibration.fit import fit
        from trackdyn.errors import require_workers

        require_workers(workers)
        self.results = fit(self.problem, workers=workers, scheduler=scheduler)
        return self

    def summary(self):
        """The fitted parameters with their uncertainty (the command's ``fit.csv``)."""
        from trackdyn.commands.calibrate.outputs import fit_table

        return fit_table(self.problem, self._solved())

    def plot(self) -> dict:
        """The command's figures, by file name: the fit against the surveys and, with the
        rate field estimated, the field."""
        from trackdyn.commands.calibrate.outputs import calibration_figures

        return calibration_figures(self.problem, self._solved())
