"""One study run as a task for `trackdyn.parallel.run_tasks`, and the table they make.

Each task carries parameters and a reference to the track (file paths, or the built-in
example), never the track arrays; workers read and linearise the track once and keep it.
A failing run is reported with its labels and the others still finish.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import signal

from trackdyn.errors import error_message
from trackdyn.options import RunOptions

SPECTRUM_FREQUENCY = np.arange(0.0, 40.0 + 1e-9, 0.125)
"""Common frequency grid of the runs' wheel-load spectra [Hz]."""


@dataclass(frozen=True)
class TrackRef:
    """Where a worker finds the track: CSV paths, or None for the built-in example.

    ``case`` names a §5.4.1 excitation case applied after linearisation (see
    `trackdyn.track.excitation`); ``"iv"`` is the track as measured.
    """

    geometry: str | None = None
    supports: str | None = None
    case: str = "iv"


@dataclass(frozen=True)
class Task:
    """One simulation: labels for the table, vehicle source, track reference, run options."""

    labels: dict
    vehicle: str = "loaded"
    overrides: dict = field(default_factory=dict)
    track: TrackRef = TrackRef()
    run: RunOptions = RunOptions()


@functools.lru_cache(maxsize=8)
def _track(geometry, supports):
    from trackdyn.data import load_track

    return load_track(geometry, supports)


@functools.lru_cache(maxsize=32)
def _linearised(ref: TrackRef, static_load: float, delta: float, extrapolate: bool):
    from trackdyn.track.excitation import excitation_case

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
        r = task.run
        lin = _linearised(task.track, vehicle.static_wheel_load, r.delta, r.extrapolate)
        ds = simulate(vehicle, lin, r)
    except Exception as exc:  # noqa: BLE001 - reported with the run's labels, others go on
        return {"labels": task.labels, "error": error_message(exc)}
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
