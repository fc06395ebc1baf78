"""Simulation results as one labelled xarray Dataset, and the statistics taken from it."""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr
from numba import njit

BODY_MOTIONS = {"body_bounce": "m/s^2", "body_roll": "rad/s^2", "body_pitch": "rad/s^2"}


def make_dataset(model, vehicle, time, centre, out, *, dt, speed, nonlinear) -> xr.Dataset:
    """Assemble the stored arrays of a run into a Dataset with units in the attributes.

    Variables: ``wheel_load`` (time, contact) [N], mean wheel load of each contact with the
    static load included; ``wheel_input`` [m] and ``track_stiffness`` [N/m], the loaded
    profile (mean over the contact's axles) and the summed stiffness each contact sees;
    ``secondary_displacement`` (time, suspension) [m]; ``wedge_force`` (time, wedge) [N];
    ``wedge_velocity`` [m/s]; ``displacement``, ``velocity`` and ``acceleration`` (time,
    dof), in the units of each degree of freedom (coordinate ``dof_units``: ``m`` for a
    bounce, ``rad`` for a roll or pitch; per second and per second squared);
    ``body_<motion>_acceleration`` [m/s^2 or rad/s^2]. A model with single-wheel
    contacts grouped by bogie side (``model.contact_sides``) also gets
    ``wheel_load_side_mean`` (time, side) [N], the mean over the wheels of each side, which
    compares one to one with the ``wheel_load`` of the bogie models (5.4.3), and the
    coordinate ``contact_side`` naming each wheel's side. ``out`` holds the `OUTPUTS`
    arrays of a solver (`trackdyn.solver`), finite.
    """
    dofs = list(model.dof_names)
    data = _variables(out)
    coords = _coordinates(model, time, centre)
    _add_side_means(data, coords, model, out["wl"])
    for name, units in BODY_MOTIONS.items():
        if name in dofs:
            motion = name.replace("_", " ")
            data[f"{name}_acceleration"] = (
                "time",
                out["a"][:, dofs.index(name)],
                {"units": units, "long_name": f"{motion} acceleration"},
            )
    return xr.Dataset(
        data,
        coords=coords,
        attrs={
            "model": model.name,
            "vehicle": vehicle.name,
            "speed_m_per_s": speed,
            "time_step_s": dt,
            "static_wheel_load_N": model.static_wheel_load,
            "track": "nonlinear (5.14)" if nonlinear else "linearised (5.10-5.11)",
        },
    )


def _variables(out) -> dict[str, tuple]:
    """The Dataset's variables from a solver's `OUTPUTS` arrays: (dims, values, attrs)."""
    wedge = ("time", "wedge")
    return {
        "wheel_load": (
            ("time", "contact"),
            out["wl"],
            {
                "units": "N",
                "long_name": "wheel load, static included (mean of the wheels of the contact)",
            },
        ),
        "wheel_input": (
            ("time", "contact"),
            out["r"],
            {
                "units": "m",
                "long_name": "track input under the contact "
                "(loaded profile, or unloaded for the nonlinear track), down positive",
            },
        ),
        "track_stiffness": (
            ("time", "contact"),
            out["k"],
            {
                "units": "N/m",
                "long_name": "track stiffness under the contact (sum over its axles)",
            },
        ),
        "secondary_displacement": (
            ("time", "suspension"),
            out["secondary"],
            {
                "units": "m",
                "long_name": "displacement across the secondary suspension, compression positive",
            },
        ),
        "wedge_force": (
            wedge,
            out["fw"],
            {"units": "N", "long_name": "friction force of the wedge"},
        ),
        "wedge_velocity": (
            wedge,
            out["vw"],
            {"units": "m/s", "long_name": "relative velocity across the secondary suspension"},
        ),
        "displacement": (
            ("time", "dof"),
            out["q"],
            {
                "long_name": "generalised displacement from static equilibrium, down "
                "positive (units per degree of freedom: dof_units)",
            },
        ),
        "velocity": (
            ("time", "dof"),
            out["v"],
            {"long_name": "generalised velocity (units per degree of freedom: dof_units/s)"},
        ),
        "acceleration": (
            ("time", "dof"),
            out["a"],
            {"long_name": "generalised acceleration (units: dof_units/s^2)"},
        ),
    }


def _coordinates(model, time, centre) -> dict[str, tuple]:
    """The Dataset's coordinates: time and vehicle position of each stored step, and the
    model's contacts, suspensions, wedges and degrees of freedom."""
    dofs = list(model.dof_names)
    return {
        "time": ("time", time, {"units": "s", "long_name": "time from the start of the run"}),
        "distance": ("time", centre, {"units": "m", "long_name": "vehicle centre position"}),
        "contact": ("contact", list(model.contact_names), {"long_name": "wheel contact"}),
        "contact_offset": (
            "contact",
            [float(np.mean(a)) for a in model.contact_axles],
            {"units": "m", "long_name": "contact position ahead of the vehicle centre"},
        ),
        "contact_rail": (
            "contact",
            list(model.contact_rails),
            {"long_name": "rail of the contact"},
        ),
        "suspension": (
            "suspension",
            list(model.suspension_names),
            {"long_name": "secondary suspension"},
        ),
        "wedge": ("wedge", list(model.wedge_names), {"long_name": "friction wedge"}),
        "dof": ("dof", dofs, {"long_name": "degree of freedom"}),
        "dof_units": (
            "dof",
            ["m" if d.endswith("bounce") else "rad" for d in dofs],
            {"long_name": "unit of the degree of freedom's displacement"},
        ),
    }


@njit(cache=True, nogil=True)
def _side_means(wheel_load, side, first, wheels, out):
    """Write the mean wheel load [N] of each side's ``wheels`` to ``out`` (time, side),
    row by row: the loads of a side's contacts (``side``: each contact's side, -1 none;
    ``first``: the side's first contact) added in contact order and divided by their
    number. With the two wheels a side of the models has, this is what xarray's grouped
    mean (numpy's nanmean of each row's wheels) gives, to the bit, in one pass (30 times
    faster for the full model's 8 wheels)."""
    for t in range(wheel_load.shape[0]):
        for c in range(side.size):
            s = side[c]
            if s < 0:
                continue
            if first[c]:
                out[t, s] = wheel_load[t, c]
            else:
                out[t, s] += wheel_load[t, c]
        for s in range(wheels.size):
            out[t, s] /= wheels[s]


def _add_side_means(data, coords, model, wheel_load) -> None:
    """``wheel_load_side_mean`` and the side coordinates, for a model with single-wheel
    contacts grouped by bogie side (nothing for the others)."""
    sides = [s for s in dict.fromkeys(model.contact_sides) if s]
    if sides:
        coords["contact_side"] = (
            "contact",
            list(model.contact_sides),
            {"long_name": "bogie side of the contact"},
        )
        coords["side"] = ("side", sides, {"long_name": "bogie side"})
        side = np.array([sides.index(s) if s else -1 for s in model.contact_sides])
        first = np.array([s >= 0 and s not in side[:c] for c, s in enumerate(side)])
        wheels = np.bincount(side[side >= 0], minlength=len(sides)).astype(float)
        side_mean = np.empty((wheel_load.shape[0], len(sides)))
        _side_means(wheel_load, side, first, wheels, side_mean)
        data["wheel_load_side_mean"] = (
            ("time", "side"),
            side_mean,
            {"units": "N", "long_name": "mean wheel load of each bogie side"},
        )


def dominant_frequency(signal: np.ndarray, dt: float) -> float:
    """Frequency of the largest peak of the spectrum of ``signal`` (mean removed) [Hz]."""
    x = np.asarray(signal, dtype=float) - np.mean(signal)
    if x.size < 4:
        return float("nan")
    spectrum = np.abs(np.fft.rfft(x * np.hanning(x.size)))
    freq = np.fft.rfftfreq(x.size, dt)
    return float(freq[1:][np.argmax(spectrum[1:])])


def summary(ds: xr.Dataset) -> pd.DataFrame:
    """Per contact: max, min and SD of the dynamic wheel load [kN]; run-wide extremes.

    Columns carry units: ``dyn_load_max_kN`` etc. are of the wheel load minus the static
    load; ``secondary_max_mm`` is the largest displacement across any secondary
    suspension; ``body_bounce_acc_rms_m_per_s2`` the body bounce acceleration RMS.
    """
    dyn = (ds.wheel_load - ds.attrs["static_wheel_load_N"]) / 1e3
    dt = float(ds.time[1] - ds.time[0]) if ds.time.size > 1 else float("nan")
    rows = []
    for c in ds.contact.values:
        x = dyn.sel(contact=c).values
        rows.append(
            {
                "contact": str(c),
                "dyn_load_max_kN": x.max(),
                "dyn_load_min_kN": x.min(),
                "dyn_load_sd_kN": x.std(),
                "dominant_frequency_Hz": dominant_frequency(x, dt),
            }
        )
    table = pd.DataFrame(rows)
    sec = ds.secondary_displacement
    table["secondary_max_mm"] = float(np.abs(sec).max()) * 1e3 if sec.size else np.nan
    table["body_bounce_acc_rms_m_per_s2"] = float(
        np.sqrt((ds.acceleration.sel(dof=ds.dof.values[0]) ** 2).mean())
    )
    return table
