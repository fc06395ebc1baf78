"""Run a list of independent simulations through Dask and gather one table.

Each task carries parameters and a reference to the track (file paths, or the built-in
example), never the track arrays; workers read and linearise the track once and keep it.
By default the tasks go to a `distributed.LocalCluster` sized to the machine; with
``workers=1`` they run one after another in this process; with ``scheduler`` they go to an
existing cluster. A failing run is reported with its labels and the others still finish.
"""

from __future__ import annotations

import functools
import os
import traceback
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import signal

from trackdyn.errors import TrackdynInputError

SPECTRUM_FREQUENCY = np.arange(0.0, 40.0 + 1e-9, 0.125)
"""Common frequency grid of the runs' wheel-load spectra [Hz]."""


@dataclass(frozen=True)
class TrackRef:
    """Where a worker finds the track: CSV paths, or None for the built-in example.

    ``case`` names a §5.4.1 excitation case applied after linearisation (see
    `trackdyn.studies.scenarios.excitation_case`); ``"iv"`` is the track as measured.
    """

    geometry: str | None = None
    supports: str | None = None
    case: str = "iv"


@dataclass(frozen=True)
class Task:
    """One simulation: labels for the table, vehicle, track reference and run options."""

    labels: dict
    vehicle: str = "loaded"
    overrides: dict = field(default_factory=dict)
    track: TrackRef = TrackRef()
    model: str = "11dof"
    speed_kmh: float = 60.0
    dt_s: float | None = None
    store_every: int | None = None
    delta: float = 0.3
    extrapolate: bool = False
    nonlinear: bool = False


@functools.lru_cache(maxsize=8)
def _track(geometry, supports):
    from trackdyn.data import load_track

    return load_track(geometry, supports)


@functools.lru_cache(maxsize=32)
def _linearised(ref: TrackRef, static_load: float, delta: float, extrapolate: bool):
    from trackdyn.studies.scenarios import excitation_case

    lin = _track(ref.geometry, ref.supports).linearise(static_load, delta, extrapolate=extrapolate)
    return excitation_case(lin, ref.case)


def run_task(task: Task) -> dict:
    """Simulate one task; return its labels, statistics and wheel-load spectrum.

    Never raises: a failure comes back as ``{"labels", "error"}``.
    """
    from trackdyn.results import summary
    from trackdyn.simulation import simulate
    from trackdyn.vehicle.parameters import load_vehicle

    try:
        vehicle = load_vehicle(task.vehicle, **task.overrides)
        lin = _linearised(task.track, vehicle.static_wheel_load, task.delta, task.extrapolate)
        speed = task.speed_kmh / 3.6
        ds = simulate(
            vehicle,
            lin,
            speed,
            task.model,
            dt=task.dt_s,
            store_every=task.store_every,
            delta=task.delta,
            nonlinear=task.nonlinear,
        )
    except TrackdynInputError as exc:
        return {"labels": task.labels, "error": str(exc)}
    except Exception as exc:  # noqa: BLE001 - reported with the run's labels, others go on
        last = traceback.extract_tb(exc.__traceback__)[-1]
        return {
            "labels": task.labels,
            "error": f"{type(exc).__name__}: {exc} ({last.filename}:{last.lineno})",
        }
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
    return {"labels": task.labels, "row": row, "psd": psd}


def _client(workers: int | None, scheduler: str | None):
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError) as exc:
            raise TrackdynInputError(
                f"cannot reach the Dask scheduler {scheduler}: {exc}"
            ) from None
    # Two Dask defaults made a run (1 km, 11-DOF) take 0.56-0.78 s in a worker instead of
    # 0.38 s: MALLOC_TRIM_THRESHOLD_ turns off glibc's adaptive mmap threshold, so every
    # large array is mmapped and page-faulted afresh; and the statistical profiler takes
    # the GIL every 10 ms. Local workers run with neither.
    settings = {
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
        "distributed.worker.profile.enabled": False,
    }
    with dask.config.set(settings):
        cluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
        )
    return Client(cluster), cluster


def run_tasks(
    tasks: list,
    *,
    func=run_task,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
) -> list[dict]:
    """Run ``func`` on every task; results in the order of ``tasks``.

    Parameters
    ----------
    tasks : list
        Independent runs (`Task` for `run_task`); small picklable objects.
    func : callable
        Module-level function run on each task; it should report failures in its result
        rather than raise.
    workers : int, optional
        Worker processes of the local cluster (default: one per core); 1 runs the tasks
        serially in this process.
    scheduler : str, optional
        Address of an existing Dask scheduler, e.g. ``tcp://10.0.0.5:8786``.
    progress : bool
        Show a progress bar counting finished runs.
    """
    if workers is not None and workers < 1:
        raise TrackdynInputError(f"--workers must be >= 1, got {workers}")
    bar = _Bar(progress, len(tasks))
    if workers == 1 and not scheduler:
        results = []
        for t in tasks:
            results.append(func(t))
            bar.advance()
        bar.close()
        return results
    from distributed import as_completed

    client, cluster = _client(workers, scheduler)
    try:
        futures = client.map(func, tasks, pure=False)
        for _ in as_completed(futures):
            bar.advance()
        return client.gather(futures)
    finally:
        bar.close()
        client.close()
        if cluster is not None:
            cluster.close()


class _Bar:
    """A rich progress bar counting finished runs (silent when not shown)."""

    def __init__(self, show: bool, total: int):
        self.progress = None
        if show:
            from rich.progress import Progress

            self.progress = Progress(transient=True)
            self.task = self.progress.add_task("runs", total=total)
            self.progress.start()

    def advance(self):
        if self.progress is not None:
            self.progress.advance(self.task)

    def close(self):
        if self.progress is not None:
            self.progress.stop()


def gather(results: list[dict]):
    """One tidy Dataset of the runs: labels, statistics, wheel-load spectrum, errors.

    Failed runs keep their labels, NaN statistics and the error message in ``error``.
    """
    import xarray as xr

    rows = [{**r["labels"], **r.get("row", {}), "error": r.get("error", "")} for r in results]
    table = pd.DataFrame(rows)
    nan = np.full(SPECTRUM_FREQUENCY.size, np.nan)
    ds = xr.Dataset.from_dataframe(table.rename_axis("run"))
    ds["wheel_load_psd"] = xr.DataArray(
        np.array([r.get("psd", nan) for r in results]),
        dims=("run", "frequency"),
        attrs={
            "units": "kN^2/Hz",
            "long_name": "PSD of the dynamic wheel load, mean of the contacts",
        },
    )
    ds = ds.assign_coords(frequency=("frequency", SPECTRUM_FREQUENCY, {"units": "Hz"}))
    for name in ds.data_vars:
        unit = str(name).rsplit("_", 1)[-1] if "_" in str(name) else ""
        if unit in {"kN", "mm", "Hz", "kmh", "s2"}:
            ds[name].attrs["units"] = {"kmh": "km/h", "s2": "m/s^2"}.get(unit, unit)
    return table, ds
