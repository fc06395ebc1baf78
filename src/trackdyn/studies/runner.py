"""One study run as a task for `trackdyn.parallel.run_tasks`, and the table they make.

Each task carries parameters and a reference to the track (file paths, or the built-in
example), never the track arrays; workers read and linearise the track once and keep it.
A failing run comes back as a `trackdyn.errors.Failure` with its labels, and the others
still finish. `batches` groups the tasks that share a track and model, and `run_batch` runs
such a group side by side in one compiled call per block of steps:
``in_order(run_tasks(batches(tasks), run_batch))`` gives the table
``run_tasks(tasks, run_task)`` gives.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from os import cpu_count

import numpy as np
import pandas as pd
from scipy import signal

from trackdyn.errors import Failure
from trackdyn.options import RunOptions
from trackdyn.track.formats import TrackFormat
from trackdyn.units import name_unit

SPECTRUM_FREQUENCY = np.arange(0.0, 40.0 + 1e-9, 0.125)
"""Common frequency grid of the runs' wheel-load spectra [Hz]."""


@dataclass(frozen=True)
class TrackRef:
    """Where a worker finds the track: CSV paths, or None for the built-in example.

    ``case`` names a §5.4.1 excitation case applied after linearisation (see
    `trackdyn.track.excitation`); ``"iv"`` is the track as measured. ``track_format``
    says what the geometry file holds (`trackdyn.track.survey`; None: a profile).
    """

    geometry: str | None = None
    supports: str | None = None
    case: str = "iv"
    track_format: TrackFormat | None = None


@dataclass(frozen=True)
class Task:
    """One simulation: labels for the table, vehicle source, track reference, run options."""

    labels: dict
    vehicle: str = "loaded"
    overrides: dict = field(default_factory=dict)
    track: TrackRef = TrackRef()
    run: RunOptions = RunOptions()


@dataclass(frozen=True)
class Statistics:
    """What one study run gives: its row of the table and its wheel-load spectrum.

    Parameters
    ----------
    row : dict
        Statistics by column name, their units in the names (``dyn_load_sd_kN``).
    psd : ndarray
        PSD of the dynamic wheel load on `SPECTRUM_FREQUENCY`, mean of the contacts
        [kN²/Hz].
    """

    row: dict
    psd: np.ndarray


Result = tuple[dict, Statistics | Failure]
"""A study run's labels and its statistics, or its failure."""


@functools.lru_cache(maxsize=8)
def _track(geometry, supports, track_format):
    from trackdyn.data import load_track

    return load_track(geometry, supports, track_format)


@functools.lru_cache(maxsize=32)
def _linearised(ref: TrackRef, static_load: float, delta: float, extrapolate: bool):
    from trackdyn.track.excitation import excitation_case

    track = _track(ref.geometry, ref.supports, ref.track_format)
    lin = track.linearise(static_load, delta, extrapolate=extrapolate)
    return excitation_case(lin, ref.case)


def run_task(task: Task) -> Result:
    """Simulate one task; return its labels and its `Statistics`.

    Never raises: a failure comes back as a `Failure` in place of the statistics.
    """
    return run_batch([(0, task)])[0][1]


BATCH_RUNS = 8
"""Runs of a batch, at most. A batch holds the stored steps of all its runs at once: 32
runs of 1 km (every 10th step stored, 500 MB) took 1.3 times as long as one by one, from
touching that much new memory; 4 to 8 runs took 0.9-0.95 times (benchmarks/study.py)."""


def batches(tasks: list[Task], size: int = BATCH_RUNS) -> list[list[tuple[int, Task]]]:
    """Tasks grouped for `run_batch`: same track, model, solver and track law, at most
    ``size`` each, with their positions in ``tasks`` (`in_order` puts results back)."""
    groups: dict = {}
    for i, t in enumerate(tasks):
        key = (t.track, t.run.model, t.run.solver, t.run.nonlinear)
        groups.setdefault(key, []).append((i, t))
    return [g[j : j + size] for g in groups.values() for j in range(0, len(g), size)]


def run_batch(batch: list[tuple[int, Task]]) -> list[tuple[int, Result]]:
    """Simulate a batch of tasks side by side (`trackdyn.simulation.simulate_batch`).

    Each result is the one `run_task` gives for the task alone, with the task's position.
    Never raises: a failure comes back as a `Failure` and the others finish.
    """
    from trackdyn.simulation import simulate_batch
    from trackdyn.vehicle.parameters import load_vehicle

    results: dict[int, Result] = {}
    ready = []
    for i, task in batch:
        try:
            vehicle = load_vehicle(task.vehicle, **task.overrides)
            r = task.run
            lin = _linearised(task.track, vehicle.static_wheel_load, r.delta, r.extrapolate)
            ready.append((i, task, vehicle, lin))
        except Exception as exc:  # noqa: BLE001 - reported with the run's labels, others go on
            results[i] = (task.labels, Failure.of(exc))
    if ready:
        index, tasks, vehicles, lins = map(list, zip(*ready, strict=True))
        solved = simulate_batch(vehicles, lins, [t.run for t in tasks])
        for i, task, ds in zip(index, tasks, solved, strict=True):
            results[i] = (task.labels, ds if isinstance(ds, Failure) else _statistics(ds))
    return [(i, results[i]) for i, _ in batch]


def in_order(batch_results: list[list[tuple[int, Result]]]) -> list[Result]:
    """The results of `run_batch` over `batches` in the order of the tasks."""
    return [r for _, r in sorted((x for b in batch_results for x in b), key=lambda x: x[0])]


def run_study(tasks: list[Task], *, workers=None, scheduler=None, progress=False) -> list[Result]:
    """Run a study's tasks in batches spread over the workers; results in task order.

    Batches hold at most `BATCH_RUNS` runs and are made small enough that every worker
    gets one. The runs of a batch whose worker was lost come back with its `Failure`.

    Parameters
    ----------
    tasks : list of Task
        The runs.
    workers : int, optional
        Worker processes (default one per core; 1 runs in this process).
    scheduler : str, optional
        Address of a running Dask scheduler.
    progress : bool
        Show a progress bar counting finished batches.
    """
    from trackdyn.parallel import run_tasks

    share = -(-len(tasks) // (1 if workers == 1 and not scheduler else workers or cpu_count() or 1))
    groups = batches(tasks, size=max(1, min(BATCH_RUNS, share)))
    done = run_tasks(
        groups, run_batch, workers=workers, scheduler=scheduler, progress=progress,
        label="batches of runs",
    )  # fmt: skip
    return in_order([
        [(i, (t.labels, out)) for i, t in group] if isinstance(out, Failure) else out
        for group, out in zip(groups, done, strict=True)
    ])  # fmt: skip


def _statistics(ds) -> Statistics:
    """Statistics and wheel-load spectrum of one run."""
    from trackdyn.results import summary

    table = summary(ds)
    dyn = ds.wheel_load.values - ds.attrs["static_wheel_load_N"]
    fs = 1.0 / float(ds.time[1] - ds.time[0])
    freq, psd = signal.welch(dyn, fs=fs, nperseg=min(dyn.shape[0], int(fs * 8)), axis=0)
    psd = np.interp(SPECTRUM_FREQUENCY, freq, psd.mean(axis=1) / 1e6)
    row = {
        "dyn_load_max_kN": float(table["dyn_load_max_kN"].max()),
        "dyn_load_min_kN": float(table["dyn_load_min_kN"].min()),
        "dyn_load_sd_kN": float(table["dyn_load_sd_kN"].mean()),
        "secondary_max_mm": float(table["secondary_max_mm"].iloc[0]),
        "body_bounce_acc_rms_m_per_s2": float(table["body_bounce_acc_rms_m_per_s2"].iloc[0]),
        "dominant_frequency_Hz": float(table["dominant_frequency_Hz"].iloc[0]),
    }
    return Statistics(row, psd)


def gather(results: list[Result]):
    """One tidy Dataset of the runs: statistics, wheel-load spectrum, errors, and what
    each run varied (``speed_kmh``, ``parameter`` and ``factor``, ...) as coordinates
    along ``run``.

    Failed runs keep their labels, NaN statistics and the failure's message in ``error``.
    """
    import xarray as xr

    rows = [
        {**labels, "error": str(out)}
        if isinstance(out, Failure)
        else {**labels, **out.row, "error": ""}
        for labels, out in results
    ]
    table = pd.DataFrame(rows)
    nan = np.full(SPECTRUM_FREQUENCY.size, np.nan)
    swept = list(results[0][0]) if results else []
    ds = xr.Dataset.from_dataframe(table.rename_axis("run")).set_coords(swept)
    ds["wheel_load_psd"] = xr.DataArray(
        np.array([nan if isinstance(out, Failure) else out.psd for _, out in results]),
        dims=("run", "frequency"),
        attrs={
            "units": "kN^2/Hz",
            "long_name": "PSD of the dynamic wheel load, mean of the contacts",
        },
    )
    ds = ds.assign_coords(frequency=("frequency", SPECTRUM_FREQUENCY, {"units": "Hz"}))
    for name in [*ds.data_vars, *swept]:
        unit = name_unit(str(name))[1]  # read whole: pad_stiffness_kN_per_mm is kN/mm
        if unit is not None:
            ds[name].attrs["units"] = unit
    return table, ds
