"""`trackdyn run`: the scenario file (TOML) and the job, one vehicle over one track.

```toml
[vehicle]
preset = "loaded"          # or: file = "wagon.toml" (relative to this file)
overrides = { mu = 0.3 }   # seed symbols, SI units

[track]                    # omit for the built-in example section
geometry = "geometry.csv"  # distance_m,left_mm,right_mm
supports = "supports.csv"  # distance_m,rail,load_kN,deflection_mm

[run]                      # trackdyn.options.RunOptions
model = "11dof"
speed_kmh = 60
```
"""

from __future__ import annotations

from pathlib import Path

from rich.text import Text

from trackdyn.commands.compiling import say_if_compiling
from trackdyn.commands.geometry_notes import geometry_notes
from trackdyn.commands.netcdf import write_netcdf
from trackdyn.commands.staging import Record, output_folder
from trackdyn.commands.tables import frame_table
from trackdyn.errors import named
from trackdyn.options import RunOptions, Strict, TrackSpec, VehicleSpec, load_toml
from trackdyn.plots import example_marks, save
from trackdyn.plots.run import (
    plot_secondary,
    plot_wedge_friction,
    plot_wheel_load_exceedance,
    plot_wheel_loads,
)
from trackdyn.progress import note, status
from trackdyn.provenance import recorded


class Scenario(Strict):
    """A run scenario: ``[vehicle]``, ``[track]`` and ``[run]``."""

    vehicle: VehicleSpec = VehicleSpec()
    track: TrackSpec = TrackSpec()
    run: RunOptions = RunOptions()


def load_scenario(path=None) -> tuple[Scenario, Path]:
    """The scenario in ``path`` (the built-in example when None) and its folder.

    Parameters
    ----------
    path : path, optional
        Scenario TOML file.
    """
    return load_toml(Scenario, path)


def scenario_record(title: str, scenario, spec, base: Path, role: str = "scenario") -> Record:
    """The record of a run scenario's command: its files, run options and vehicle source.

    Parameters
    ----------
    title : str
        What the outputs are.
    scenario : path, optional
        The scenario file (None: the built-in example).
    spec : Scenario or Study
        The file read, with ``[vehicle]``, ``[track]`` and ``[run]``.
    base : Path
        The folder its relative paths start from.
    role : str
        What the file is called in the record (``scenario``, ``study``).
    """
    from trackdyn.data import EXAMPLE_GEOMETRY, EXAMPLE_SUPPORTS, example_path
    from trackdyn.vehicle.parameters import vehicle_file

    geometry, supports = spec.track.paths(base)
    if geometry is None:
        geometry, supports = example_path(EXAMPLE_GEOMETRY), example_path(EXAMPLE_SUPPORTS)
    inputs = {role: scenario, "geometry": geometry, "supports": supports}
    source = spec.vehicle.source(base)
    inputs["vehicle"] = vehicle_file(source)
    options = {f"run_{k}": v for k, v in spec.run.model_dump().items()}
    given = spec.track.track_format().model_dump(exclude_defaults=True)
    options.update({f"track_{k}": v for k, v in given.items()})
    options["vehicle_source"] = str(source)
    options.update({f"vehicle_override_{k}": v for k, v in spec.vehicle.overrides.items()})
    return Record(title, inputs, options)


def headline(table) -> dict:
    """Run-wide extremes of a run's summary table (`trackdyn.results.summary`)."""
    return {
        "dyn_load_max_kN": float(table["dyn_load_max_kN"].max()),
        "dyn_load_min_kN": float(table["dyn_load_min_kN"].min()),
        "dyn_load_sd_max_kN": float(table["dyn_load_sd_kN"].max()),
        "secondary_max_mm": float(table["secondary_max_mm"].iloc[0]),
        "body_bounce_acc_rms_m_per_s2": float(table["body_bounce_acc_rms_m_per_s2"].iloc[0]),
    }


RUN_WIDE = ("secondary_max_mm", "body_bounce_acc_rms_m_per_s2")
"""Columns of a run's summary table that hold one value for the run, not per contact:
printed in a line under the table (`run_wide`), kept whole in ``summary.csv``."""


def run_wide(ds, table) -> str:
    """The line under a run's table: the largest displacement across each secondary
    suspension [mm] (the run's ``sec. max`` is the largest of them) and the body bounce
    RMS [m/s²].

    Parameters
    ----------
    ds : xarray.Dataset
        The run.
    table : pandas.DataFrame
        Its summary table (`trackdyn.results.summary`).
    """
    bounce = f"body bounce RMS {table['body_bounce_acc_rms_m_per_s2'].iloc[0]:.3g} m/s²"
    sec = ds.secondary_displacement
    if not sec.size:
        return bounce
    each = abs(sec).max("time") * 1e3
    shown = ", ".join(f"{s} {v:.3g}" for s, v in zip(sec.suspension.values, each.values,
                                                       strict=True))  # fmt: skip
    return f"largest displacement across each secondary suspension [mm]: {shown}; {bounce}"


def run_figures(ds, delta: float, marks=()) -> dict:
    """A run's figures by file name: wheel loads, their exceedance, secondary displacement
    and, with friction wedges, wedge friction (`trackdyn.plots.run`).

    Parameters
    ----------
    ds : xarray.Dataset
        The run.
    delta : float
        The dynamic wheel load increment δ of the Ps ± δPs lines [-].
    marks : sequence of trackdyn.plots.Mark
        Stretches of track marked (the built-in example's soft spot, voids and structure:
        `trackdyn.plots.example_marks`).
    """
    return {
        "wheel_loads.png": plot_wheel_loads(ds, delta=delta, marks=marks),
        "wheel_load_exceedance.png": plot_wheel_load_exceedance(ds, delta=delta),
        "secondary_displacement.png": plot_secondary(ds, marks=marks),
        "wedge_friction.png": plot_wedge_friction(ds),
    }


@recorded
def run(scenario, out, overwrite: bool, console) -> None:
    """Simulate the scenario; write results.nc, summary.csv, summary.json and four figures.

    Parameters
    ----------
    scenario : path, optional
        Scenario TOML file; None: the built-in example.
    out : str or Path
        Output folder.
    overwrite : bool
        Replace another command's outputs in ``out``.
    console : rich.console.Console
        Where the summary table is shown (stdout); progress goes to stderr.
    """
    from trackdyn.results import summary
    from trackdyn.simulation import simulate

    spec, base = load_scenario(scenario)
    with named(scenario):
        vehicle = spec.vehicle.load(base)
    title = f"trackdyn run: {spec.run.model}, {vehicle.name}, {spec.run.speed_kmh:g} km/h"
    record = scenario_record(title, scenario, spec, base)
    record.vehicle = vehicle.as_dict()
    with output_folder(out, "run", overwrite, record) as stage:
        say_if_compiling("run")
        with status("reading the track"):
            trk = spec.track.load(base)
        geometry_notes(trk.geometry.notes, trk.geometry.where, record.options)
        with named(scenario):
            ds = simulate(vehicle, trk, spec.run, progress=True)
        table = summary(ds)
        record.headline = headline(table)
        write_netcdf(ds, stage / "results.nc")
        table.to_csv(stage / "summary.csv", index=False, float_format="%.4g")
        marks = example_marks() if spec.track.geometry is None else []
        for name, fig in run_figures(ds, spec.run.delta, marks).items():
            save(fig, stage / name)
    title = f"{ds.attrs['model']}: {vehicle.name}, {spec.run.speed_kmh:g} km/h"
    console.print(frame_table(table.drop(columns=list(RUN_WIDE)), title))
    console.print(Text(run_wide(ds, table)))
    note(f"wrote results.nc, summary.csv, summary.json and 4 figures to {out}")
    note("\n".join(record.lines()), 2)
