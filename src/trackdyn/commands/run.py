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

from trackdyn.commands import plots
from trackdyn.commands.tables import frame_table
from trackdyn.errors import named
from trackdyn.io import write_netcdf
from trackdyn.options import RunOptions, Strict, TrackSpec, VehicleSpec, load_toml
from trackdyn.staging import output_folder


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


def run(scenario, out, overwrite: bool, console) -> None:
    """Simulate the scenario; write results.nc, summary.csv and three figures into ``out``.

    Parameters
    ----------
    scenario : path, optional
        Scenario TOML file; None: the built-in example.
    out : str or Path
        Output folder.
    overwrite : bool
        Replace another command's outputs in ``out``.
    console : rich.console.Console
        Where progress and the summary table are shown.
    """
    from trackdyn.results import summary
    from trackdyn.simulation import simulate

    spec, base = load_scenario(scenario)
    with named(scenario):
        vehicle = spec.vehicle.load(base)
    with output_folder(out, "run", overwrite) as stage:
        with console.status("reading the track"):
            trk = spec.track.load(base)
        with named(scenario):
            ds = simulate(vehicle, trk, spec.run, progress=True)
        table = summary(ds)
        write_netcdf(ds, stage / "results.nc")
        table.to_csv(stage / "summary.csv", index=False, float_format="%.4g")
        plots.wheel_loads(ds, stage / "wheel_loads.png")
        plots.secondary(ds, stage / "secondary_displacement.png")
        plots.wedge_friction(ds, stage / "wedge_friction.png")
    console.print(
        frame_table(table, f"{ds.attrs['model']}: {vehicle.name}, {spec.run.speed_kmh:g} km/h")
    )
    console.print(f"wrote results.nc, summary.csv and 3 figures to {out}")
