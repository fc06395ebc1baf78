"""`trackdyn study`: the study file, the runs on Dask, the table, Dataset and figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from trackdyn.commands.compiling import say_if_compiling
from trackdyn.commands.geometry_notes import geometry_notes
from trackdyn.commands.netcdf import write_netcdf
from trackdyn.commands.run import scenario_record
from trackdyn.commands.staging import output_folder
from trackdyn.commands.tables import frame_table
from trackdyn.errors import TrackdynInputError, named
from trackdyn.io import read_toml
from trackdyn.options import RunOptions, load_toml
from trackdyn.plots import save
from trackdyn.plots.study import (
    plot_spectra,
    plot_speed_sweep,
    plot_study_matrix,
    plot_tornado,
)
from trackdyn.progress import note
from trackdyn.provenance import recorded
from trackdyn.studies.scenarios import Study

STUDY_KEYS = {"kind", "matrix", "sensitivity", "speed"}
"""Keys of a study file that a run scenario has not: a study file gives at least one."""


def load_study(path=None) -> tuple[Study, Path]:
    """The study in ``path`` (the built-in example: the 2-DOF §5.4.1 matrix, when None).

    Parameters
    ----------
    path : path, optional
        Study TOML file.
    """
    spec, base = load_toml(Study, path, Study(run=RunOptions(model="2dof")))
    if path is not None and not spec.model_fields_set & STUDY_KEYS:
        raise TrackdynInputError(
            f"{path}: no {', '.join(sorted(STUDY_KEYS))}: a run scenario (trackdyn run) "
            "rather than a study"
        )
    return spec, base


def write_study(table, ds, study, folder, sleeper_spacing=None) -> list[str]:
    """Write ``study.nc``, ``study.csv`` and the figures into ``folder``; return the names.

    A matrix study draws ``study_cases.png``, a one-at-a-time sensitivity study
    ``tornado.png``, a speed study ``speed_sweep.png``; every study with a successful run
    draws ``spectra.png``.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per run (`trackdyn.studies.runner.gather`).
    ds : xarray.Dataset
        The same runs with their spectra.
    study : Study
        The study (its ``kind``).
    folder : Path
        Output folder.
    sleeper_spacing : float, optional
        Sleeper spacing of the track, for the sleeper-passing frequency [m].
    """
    from trackdyn.track.spectra import WAVELENGTH_RANGE

    write_netcdf(ds, folder / "study.nc")
    table.to_csv(folder / "study.csv", index=False, float_format="%.4g")
    names = ["study.nc", "study.csv"]
    if not (table["error"] == "").any():
        return names
    figures = {
        "matrix": ("study_cases.png", plot_study_matrix),
        "speed": ("speed_sweep.png", plot_speed_sweep),
    }
    if not study.sensitivity.grid:
        figures["sensitivity"] = ("tornado.png", plot_tornado)
    if study.kind in figures:
        name, draw = figures[study.kind]
        save(draw(table, context=_context(ds, table, study)), folder / name)
        names.append(name)
    synthetic = WAVELENGTH_RANGE[0] if study.track.geometry is None else None
    fig = plot_spectra(
        ds,
        table=table,
        speed_kmh=study.run.speed_kmh,
        sleeper_spacing=sleeper_spacing,
        shortest_wavelength=synthetic,
    )
    save(fig, folder / "spectra.png")
    return [*names, "spectra.png"]


def _context(ds, table, study) -> str:
    """What a study's runs share, for its figure's title: model, speed, vehicles."""
    parts = [f"{ds.attrs['model']} model"]
    if study.kind != "speed":
        parts.append(f"{study.run.speed_kmh:g} km/h")
    if "vehicle" in table:
        parts.append(", ".join(dict.fromkeys(table["vehicle"].astype(str))))
    return ", ".join(parts)


@recorded
def study(study_file, out, overwrite: bool, workers, scheduler, console) -> None:
    """Run a study and write study.nc, study.csv and its figures into ``out``; an
    interventions study (`trackdyn.commands.interventions`) writes its own files.

    Parameters
    ----------
    study_file : path, optional
        Study TOML file; None: the 2-DOF §5.4.1 matrix.
    out : str or Path
        Output folder.
    overwrite : bool
        Replace another command's outputs in ``out``.
    workers : int, optional
        Worker processes (default: one per core; 1: serial).
    scheduler : str, optional
        Address of a running Dask scheduler.
    console : rich.console.Console
        Where the table is shown (stdout); failed runs and progress go to stderr.
    """
    from trackdyn.studies.runner import gather, run_study
    from trackdyn.studies.scenarios import tasks

    if study_file is not None and read_toml(study_file).get("kind") == "interventions":
        from trackdyn.commands.interventions import interventions

        return interventions(study_file, out, overwrite, workers, scheduler, console)
    spec, base = load_study(study_file)
    with named(study_file):
        track = spec.track.load(base)  # a bad track file is refused before any run
        runs = tasks(spec, base)
    title = f"trackdyn study: {spec.kind} study, {spec.run.model}, {len(runs)} runs"
    record = scenario_record(title, study_file, spec, base, role="study")
    record.options.update({"kind": spec.kind, spec.kind: spec.model_dump(mode="json")[spec.kind]})
    geometry_notes(track.geometry.notes, track.geometry.where, record.options)
    with output_folder(out, "study", overwrite, record) as stage:
        say_if_compiling("study", scheduler)
        results = run_study(runs, workers=workers, scheduler=scheduler, progress=True)
        table, ds = gather(results)
        ds.attrs.update(kind=spec.kind, model=spec.run.model)
        ok = table[table["error"] == ""]
        record.headline = {
            "runs": len(table),
            "failed_runs": len(table) - len(ok),
            "dyn_load_max_kN": float(ok["dyn_load_max_kN"].max()) if len(ok) else None,
            "dyn_load_sd_max_kN": float(ok["dyn_load_sd_kN"].max()) if len(ok) else None,
        }
        spacing = float(np.median(np.diff(track.supports.position)))
        write_study(table, ds, spec, stage, spacing)
    title = f"{spec.kind} study, {spec.run.model}: {len(runs)} runs"
    shown = table.drop(columns="error").rename(columns={"dyn_load_sd_kN": "dyn_load_sd_mean_kN"})
    console.print(frame_table(shown, title))  # a run's SD: the mean over its contacts
    for _, row in table[table["error"] != ""].iterrows():
        labels = ", ".join(f"{c}={row[c]}" for c in runs[0].labels)
        note(f"failed ({labels}): {row['error']}", 0)
    note(f"wrote study.nc, study.csv, summary.json and figures to {out}")
    note("\n".join(record.lines()), 2)
