"""The seed's check of the bogie approximation (5.4.3): the 11-DOF model against the full model.

The 11-DOF model lumps each bogie's two wheelsets into one fed with the mean input of the
leading and trailing axle and their summed stiffness; the full model (``model = "full"``)
has both wheelsets and both side frames as bodies and one contact per wheel. The seed
found the approximation sufficient for the magnitude of the dynamic wheel load, the
secondary displacement and the dominant frequencies. This script repeats the check:

1. on the built-in example section (1 km, FRA class 5, soft spot, voids, bridge), loaded
   and empty wagon, 40-80 km/h: SD and 99.85th percentile of the dynamic wheel load (the
   11-DOF bogie sides; the full model's per-side means and its single wheels), SD of the
   secondary displacement and dominant frequencies, side by side
   (``bogie_approximation.csv``);
2. on single sine waves of 1-25 m (loaded, 60 km/h, 0.5 mm on both rails, uniform
   100 kN/mm supports): SD of the dynamic wheel load against wavelength
   (``bogie_wavelengths.csv``);

and draws both wheel-load traces over a stretch of the example section and the wavelength
sweep (``bogie_approximation.png``). Run with ``python examples/bogie_approximation.py
--out DIR`` (about a minute).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria. Section 5.4.3.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

import trackdyn  # noqa: E402
from trackdyn.results import dominant_frequency  # noqa: E402

SPEEDS_KMH = (40, 50, 60, 70, 80)
VEHICLES = ("loaded", "empty")
PERCENTILE = 99.85  # the seed's statistic of the dynamic wheel load
STRETCH = (270.0, 340.0)  # [m] front-bogie positions plotted: the soft spot at 300 m
WAVELENGTHS = np.geomspace(1.0, 25.0, 36)  # [m]
SWEEP_KMH, SWEEP_AMPLITUDE_MM, SWEEP_STIFFNESS = 60.0, 0.5, 100.0  # km/h, mm, kN/mm


def dynamic(load, vehicle):
    """Dynamic wheel load [kN] (static removed), as a (time, n) array."""
    return (np.asarray(load) - vehicle.static_wheel_load) / 1e3


def statistics(prefix, loads, secondary, dt):
    """SD (mean over contacts) and 99.85th percentile (largest contact) of the dynamic
    wheel load [kN], SD of the secondary displacement [mm] and dominant frequencies of the
    first contact's load and the first suspension's displacement [Hz]."""
    out = {
        f"sd_{prefix}_kN": loads.std(axis=0).mean(),
        f"p9985_{prefix}_kN": np.percentile(loads, PERCENTILE, axis=0).max(),
        f"f_load_{prefix}_Hz": dominant_frequency(loads[:, 0], dt),
    }
    if secondary is not None:
        out[f"sec_sd_{prefix}_mm"] = 1e3 * secondary.std(axis=0).mean()
        out[f"f_sec_{prefix}_Hz"] = dominant_frequency(secondary[:, 0], dt)
    return out


def example_section(traces):
    """Table of part 1; keeps the loaded 80 km/h runs in ``traces`` for the figure."""
    track = trackdyn.load_track()
    rows = []
    for name in VEHICLES:
        v = trackdyn.load_vehicle(name)
        for kmh in SPEEDS_KMH:
            row = {"vehicle": name, "speed_kmh": kmh}
            eleven = trackdyn.simulate(v, track, trackdyn.RunOptions(model="11dof", speed_kmh=kmh))
            full = trackdyn.simulate(v, track, trackdyn.RunOptions(model="full", speed_kmh=kmh))
            sides = list(full.side.values)  # FL, FR, BL, BR: the 11-DOF contacts
            dt = float(full.time[1] - full.time[0])
            row |= statistics(
                "11dof",
                dynamic(eleven.wheel_load.sel(contact=sides), v),
                eleven.secondary_displacement.values,
                float(eleven.time[1] - eleven.time[0]),
            )
            row |= statistics(
                "full_mean",
                dynamic(full.wheel_load_side_mean.sel(side=sides), v),
                full.secondary_displacement.values,
                dt,
            )
            row |= statistics("full_wheel", dynamic(full.wheel_load, v), None, dt)
            rows.append(row)
            if (name, kmh) == ("loaded", max(SPEEDS_KMH)):
                traces.update(vehicle=v, eleven=eleven, full=full)
    return pd.DataFrame(rows)


def sine_track(directory, wavelength):
    """A 60 m track with a sine of ``wavelength`` [m] on both rails, written as CSV files
    and read back through `trackdyn.load_track`."""
    x = np.arange(0.0, 60.0, min(0.05, wavelength / 40))
    z = SWEEP_AMPLITUDE_MM * np.sin(2 * np.pi * x / wavelength)
    geometry, supports = directory / "sine_geometry.csv", directory / "sine_supports.csv"
    pd.DataFrame({"distance_m": x, "left_mm": z, "right_mm": z}).to_csv(geometry, index=False)
    sleepers = np.arange(0.3, 60.0, 0.6)
    pd.DataFrame(
        {
            "distance_m": np.repeat(sleepers, 2),
            "rail": ["left", "right"] * sleepers.size,
            "stiffness_kN_per_mm": SWEEP_STIFFNESS,
        }
    ).to_csv(supports, index=False)
    return trackdyn.load_track(geometry, supports)


def wavelength_sweep(directory):
    """Table of part 2: SD of the dynamic wheel load per wavelength [kN]."""
    v = trackdyn.load_vehicle("loaded")
    rows = []
    for wavelength in WAVELENGTHS:
        track = sine_track(directory, wavelength)
        run = {
            m: trackdyn.simulate(v, track, trackdyn.RunOptions(model=m, speed_kmh=SWEEP_KMH))
            for m in ("11dof", "full")
        }
        sides = list(run["full"].side.values)
        rows.append(
            {
                "wavelength_m": wavelength,
                "sd_11dof_kN": dynamic(run["11dof"].wheel_load.sel(contact=sides), v).std(0).mean(),
                "sd_full_mean_kN": dynamic(run["full"].wheel_load_side_mean, v).std(0).mean(),
                "sd_full_wheel_kN": dynamic(run["full"].wheel_load, v).std(0).mean(),
            }
        )
    return pd.DataFrame(rows)


def figure(traces, sweep, wheelbase, path):
    v, eleven, full = traces["vehicle"], traces["eleven"], traces["full"]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7.5), constrained_layout=True)
    front = eleven.distance.values + v.b_cc  # front bogie centre [m]
    keep = (front >= STRETCH[0]) & (front <= STRETCH[1])
    top.plot(front[keep], dynamic(eleven.wheel_load.sel(contact="FL"), v)[keep], "k", lw=1.6,
             label="11-DOF, FL (mean input of axles 1 and 2)")  # fmt: skip
    front_full = full.distance.values + v.b_cc
    keep_full = (front_full >= STRETCH[0]) & (front_full <= STRETCH[1])
    top.plot(front_full[keep_full],
             dynamic(full.wheel_load_side_mean.sel(side="FL"), v)[keep_full],
             "C3--", lw=1.2, label="full, mean of 1L and 2L")  # fmt: skip
    for wheel, colour in (("1L", "C0"), ("2L", "C2")):
        top.plot(front_full[keep_full], dynamic(full.wheel_load.sel(contact=wheel), v)[keep_full],
                 colour, lw=0.7, alpha=0.8, label=f"full, wheel {wheel}")  # fmt: skip
    top.set(
        xlabel="front bogie centre [m]",
        ylabel="dynamic wheel load [kN]",
        title=f"Loaded wagon, {full.attrs['speed_m_per_s'] * 3.6:.0f} km/h, example section",
    )
    top.legend(fontsize=8, ncol=2)
    bottom.semilogx(sweep.wavelength_m, sweep.sd_11dof_kN, "k", lw=1.6, label="11-DOF")
    bottom.semilogx(sweep.wavelength_m, sweep.sd_full_mean_kN, "C3--", label="full, side mean")
    bottom.semilogx(sweep.wavelength_m, sweep.sd_full_wheel_kN, "C0", label="full, single wheel")
    for n in (1, 3):
        bottom.axvline(2 * wheelbase / n, color="0.6", ls=":", lw=1)
    bottom.axvline(wheelbase, color="0.6", ls="-.", lw=1)
    bottom.set(
        xlabel="wavelength [m] (dotted: 2 and 2/3 wheelbases, axles in antiphase; "
        "dash-dot: one wheelbase)",
        ylabel="SD of dynamic wheel load [kN]",
        title=f"Sine of {SWEEP_AMPLITUDE_MM} mm on both rails, loaded, {SWEEP_KMH:.0f} km/h",
    )
    bottom.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    out = parser.parse_args(argv).out
    out.mkdir(parents=True, exist_ok=True)
    traces = {}
    table = example_section(traces)
    table.round(3).to_csv(out / "bogie_approximation.csv", index=False)
    sweep = wavelength_sweep(out)
    sweep.round(3).to_csv(out / "bogie_wavelengths.csv", index=False)
    figure(traces, sweep, 2 * traces["vehicle"].a, out / "bogie_approximation.png")
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        print(table.round(2).to_string(index=False))
        print(sweep.round(2).to_string(index=False))


if __name__ == "__main__":
    main()
