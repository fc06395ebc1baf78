"""Command-line interface: parses arguments, calls the API, reports errors in one line."""

from __future__ import annotations

import functools
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer
from rich import box
from rich.console import Console
from rich.table import Table
from rich.text import Text

from trackdyn import __version__
from trackdyn.errors import TrackdynInputError
from trackdyn.io import write_netcdf
from trackdyn.staging import output_folder

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    help="Railway vehicle/track vertical dynamics and track deterioration prediction.",
)
console = Console()
OutOption = Annotated[Path, typer.Option("--out", help="Output folder.")]
OverwriteOption = Annotated[
    bool, typer.Option(help="Replace another command's outputs in the output folder.")
]


def refuse_bad_input(command):
    """Turn TrackdynInputError into a one-line message and exit code 2."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except TrackdynInputError as exc:
            print(f"error: {exc}", file=sys.stderr)
            raise typer.Exit(2) from None

    return wrapper


@contextmanager
def _named(source):
    """Prefix a refusal with the scenario file it comes from (if it does not name it)."""
    try:
        yield
    except TrackdynInputError as exc:
        where = str(source) if source is not None else "built-in example"
        if str(exc).startswith(where):
            raise
        raise TrackdynInputError(f"{where}: {exc}") from None


# Unit suffixes of table columns (longest first, so ``_kN_per_mm`` wins over ``_mm``).
UNITS = {
    "_kN_per_mm": "kN/mm",
    "_m_per_s2": "m/s²",
    "_m_per_s": "m/s",
    "_kmh": "km/h",
    "_kN": "kN",
    "_mm": "mm",
    "_Hz": "Hz",
}
# Short names of known quantities (column name without its unit suffix).
SHORT_NAMES = {
    "dyn_load_max": "ΔP max",
    "dyn_load_min": "ΔP min",
    "dyn_load_sd": "ΔP SD",
    "dominant_frequency": "f dom.",
    "secondary_max": "sec. max",
    "body_bounce_acc_rms": "bounce RMS",
    "k2_mean": "k2 mean",
    "k2_min": "k2 min",
    "k2_max": "k2 max",
    "ys_mean": "ys mean",
    "d1_sd_max": "D1 SD max",
    "d2_sd_max": "D2 SD max",
}
# Notes printed under a table whose headers use the symbol.
NOTES = {"ΔP": "ΔP: dynamic wheel load (wheel load - static wheel load)"}


def header(column: str) -> str:
    """Short table header of a column: its quantity, then its unit in brackets.

    Parameters
    ----------
    column : str
        Column name with an optional unit suffix (``dyn_load_max_kN``).

    Returns
    -------
    str
        ``"ΔP max\\n[kN]"`` for a known quantity and unit; the column as it is if its
        suffix is not a known unit.
    """
    for suffix, unit in UNITS.items():
        if column.endswith(suffix):
            stem = column.removesuffix(suffix)
            return f"{SHORT_NAMES.get(stem, stem)}\n[{unit}]"
    return column


def _show(table, title: str) -> None:
    """Print a DataFrame as a rich table, short headers with units, 3 significant digits.

    No column is narrower than its widest value or header word: at a narrow terminal the
    headers wrap between words instead of being cut.
    """
    headers = [header(str(col)) for col in table.columns]
    notes = [note for symbol, note in NOTES.items() if any(symbol in h for h in headers)]
    show = Table(title=title, caption="\n".join(notes) or None, box=box.SIMPLE_HEAD)
    rows = [
        [v if isinstance(v, str) else f"{v:.3g}" for v in row]
        for row in table.itertuples(index=False)
    ]
    for j, h in enumerate(headers):
        show.add_column(Text(h), min_width=max(len(w) for w in [*h.split(), *(r[j] for r in rows)]))
    for row in rows:
        show.add_row(*map(Text, row))
    console.print(show)


def _version(value: bool):
    if value:
        print(f"trackdyn {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Show version.")
    ] = False,
):
    """Railway vehicle/track vertical dynamics and track deterioration prediction."""


@app.command()
@refuse_bad_input
def track(
    geometry: Annotated[
        Path | None, typer.Option(help="Geometry CSV (distance_m,left_mm,right_mm).")
    ] = None,
    supports: Annotated[
        Path | None,
        typer.Option(help="Supports CSV (distance_m,rail,load_kN,deflection_mm)."),
    ] = None,
    wheel_load_kN: Annotated[float, typer.Option(help="Static wheel load Ps [kN].")] = 127.5,
    delta: Annotated[float, typer.Option(help="Dynamic wheel load increment δ [-].")] = 0.3,
    rail: Annotated[str, typer.Option(help="Rail section (60E1, 54E1, 136RE).")] = "60E1",
    extrapolate: Annotated[
        bool, typer.Option(help="Allow Ps ± ΔP beyond the measured curves.")
    ] = False,
    out: OutOption = Path("trackdyn-out"),
    overwrite: OverwriteOption = False,
):
    """Analyse a track section: loaded profile, linearised stiffness, geometry quality.

    Without --geometry and --supports, the built-in 1 km example section is used.
    """
    from trackdyn.commands.track import analyse_sections
    from trackdyn.data import EXAMPLE_GEOMETRY, EXAMPLE_SUPPORTS, example_path
    from trackdyn.errors import require_positive
    from trackdyn.track.analysis import write_track_outputs
    from trackdyn.track.rails import rail_section

    require_positive("--wheel-load-kN", wheel_load_kN)
    if (geometry is None) != (supports is None):
        raise TrackdynInputError("give both --geometry and --supports, or neither for the example")
    if geometry is None:
        geometry, supports = example_path(EXAMPLE_GEOMETRY), example_path(EXAMPLE_SUPPORTS)
    section = rail_section(rail)
    with output_folder(out, "track", overwrite) as stage:
        with console.status("reading and linearising the track, section by section"):
            ds, picks, basin = analyse_sections(
                geometry, supports, wheel_load_kN * 1e3, delta, section, extrapolate=extrapolate
            )
        table = write_track_outputs(ds, picks, basin, stage)
    _show(table, f"Track summary ({ds.attrs['geometry_source']})")
    console.print(f"wrote track.nc and 3 figures to {out}")


@app.command()
@refuse_bad_input
def run(
    scenario: Annotated[
        Path | None, typer.Argument(help="Scenario TOML; default: the built-in example.")
    ] = None,
    out: OutOption = Path("trackdyn-out"),
    overwrite: OverwriteOption = False,
):
    """Simulate a vehicle over a track and write results.nc, summary.csv and figures.

    With no scenario: the loaded wagon, 11-DOF model, the example 1 km section, 60 km/h.
    """
    from trackdyn.commands import plots
    from trackdyn.commands.run import load_scenario
    from trackdyn.results import summary
    from trackdyn.simulation import simulate

    spec, base = load_scenario(scenario)
    vehicle = spec.vehicle.load(base)
    with output_folder(out, "run", overwrite) as stage:
        with console.status("reading the track"):
            trk = spec.track.load(base)
        with _named(scenario):
            ds = simulate(vehicle, trk, spec.run, progress=True)
        table = summary(ds)
        write_netcdf(ds, stage / "results.nc")
        table.to_csv(stage / "summary.csv", index=False, float_format="%.4g")
        plots.wheel_loads(ds, stage / "wheel_loads.png")
        plots.secondary(ds, stage / "secondary_displacement.png")
        plots.wedge_friction(ds, stage / "wedge_friction.png")
    _show(table, f"{ds.attrs['model']}: {vehicle.name}, {spec.run.speed_kmh:g} km/h")
    console.print(f"wrote results.nc, summary.csv and 3 figures to {out}")


@app.command()
@refuse_bad_input
def study(
    study_file: Annotated[
        Path | None,
        typer.Argument(help="Study TOML; default: the 2-DOF scenario matrix of §5.4.1."),
    ] = None,
    out: OutOption = Path("trackdyn-out"),
    overwrite: OverwriteOption = False,
    workers: Annotated[
        int | None, typer.Option(help="Worker processes (default: one per core; 1: serial).")
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="Address of a running Dask scheduler, tcp://HOST:PORT.")
    ] = None,
):
    """Run a study (scenario matrix, parameter variation or speed sweep) on Dask."""
    from trackdyn.commands.study import write_study
    from trackdyn.studies.runner import gather, run_study
    from trackdyn.studies.scenarios import load_study, tasks

    spec, base = load_study(study_file)
    runs = tasks(spec, base)
    with output_folder(out, "study", overwrite) as stage:
        results = run_study(runs, workers=workers, scheduler=scheduler, progress=True)
        table, ds = gather(results)
        ds.attrs.update(kind=spec.kind, model=spec.run.model)
        write_study(table, ds, spec, stage)
    _show(table.drop(columns="error"), f"{spec.kind} study, {spec.run.model}: {len(runs)} runs")
    for _, row in table[table["error"] != ""].iterrows():
        labels = ", ".join(f"{c}={row[c]}" for c in runs[0].labels)
        console.print(f"[red]failed[/red] ({labels}): {row['error']}")
    console.print(f"wrote study.nc, study.csv and figures to {out}")


@app.command()
@refuse_bad_input
def deteriorate(
    scenario: Annotated[
        Path | None,
        typer.Argument(help="Deterioration scenario TOML; default: the built-in example."),
    ] = None,
    out: OutOption = Path("trackdyn-out"),
    overwrite: OverwriteOption = False,
    workers: Annotated[
        int | None,
        typer.Option(help="Worker processes (default: one per core, 1 for one section)."),
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="Address of a running Dask scheduler, tcp://HOST:PORT.")
    ] = None,
):
    """Predict track deterioration over accumulated traffic (settlement, geometry, D1 SD).

    With no scenario: alternating loaded and empty coal wagons at 60 km/h over the example
    section for 50 MGT, 11-DOF model, the shipped illustrative (uncalibrated) power law.
    """
    import dataclasses

    from trackdyn.deterioration.outputs import write_outputs
    from trackdyn.deterioration.scenario import load_deterioration
    from trackdyn.deterioration.sections import run_sections, section_tasks, summary

    spec, base = load_deterioration(scenario)
    if workers is not None and workers < 1:
        raise TrackdynInputError(f"--workers must be >= 1, got {workers}")
    tasks = section_tasks(spec, base)
    serial = scheduler is None and (workers == 1 or (workers is None and len(tasks) == 1))
    if serial:
        tasks = [dataclasses.replace(t, progress=True) for t in tasks]
    with output_folder(out, "deteriorate", overwrite) as stage:
        datasets = run_sections(tasks, workers=workers, scheduler=scheduler, progress=not serial)
        files = write_outputs(datasets, stage)
    table = summary(datasets)
    show = Table(title=f"Deterioration, {spec.run.model}: {len(datasets)} section(s)")
    for col in ("section", "MGT", "steps", "settlement min/mean/max [mm]", "D1 SD max [mm]",
                "trigger [MGT]"):  # fmt: skip
        show.add_column(Text(col))
    for r in table.itertuples(index=False):
        show.add_row(
            r.section,
            f"{r.mgt:g}",
            str(r.steps),
            f"{r.settlement_min_mm:.2f} / {r.settlement_mean_mm:.2f} / {r.settlement_max_mm:.2f}",
            f"{r.d1_sd_max_initial_mm:.2f} -> {r.d1_sd_max_final_mm:.2f}",
            f"{r.first_trigger_mgt:.3g}",
        )
    console.print(show)
    console.print(f"wrote {len(files)} files (deterioration_*.nc, CSV tables, figures) to {out}")


@app.command()
@refuse_bad_input
def calibrate(
    calibration: Annotated[Path, typer.Argument(help="Calibration TOML (surveys, fit).")],
    out: OutOption = Path("trackdyn-out"),
    overwrite: OverwriteOption = False,
    workers: Annotated[
        int | None,
        typer.Option(help="Worker processes (default: one per core; 1: serial)."),
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="Address of a running Dask scheduler, tcp://HOST:PORT.")
    ] = None,
):
    """Fit settlement-law parameters to two or more geometry surveys of one section.

    Writes settlement_fitted.toml (for deteriorate's [settlement] file), calibration.csv
    (misfit and D1 SD per survey, rail and segment) and calibration.png.
    """
    from trackdyn.deterioration.calibrate import prepare
    from trackdyn.deterioration.calibration_outputs import sd_errors, write_calibration
    from trackdyn.deterioration.calibration_spec import load_calibration
    from trackdyn.deterioration.fitting import fit
    from trackdyn.deterioration.law_files import law_units
    from trackdyn.parallel import shared_cluster

    if workers is not None and workers < 1:
        raise TrackdynInputError(f"--workers must be >= 1, got {workers}")
    spec, base = load_calibration(calibration)
    problem = prepare(spec, base)
    show = Table(title="Surveys aligned to the first (D1-band cross-correlation)")
    for col in ("survey", "MGT", "role", "shift [m]", "correlation"):
        show.add_column(col)
    for s, a, used in zip(spec.survey, problem.alignments, problem.fitted, strict=True):
        role = "first" if s is spec.survey[0] else "fit" if used else "check"
        show.add_row(s.geometry.name, f"{s.mgt:g}", role, f"{a.shift:+.3f}", f"{a.correlation:.3f}")
    console.print(show)
    with output_folder(out, "calibrate", overwrite) as stage, shared_cluster(workers, scheduler):
        result = fit(problem, workers=workers, scheduler=scheduler, log=console.print)
        table = write_calibration(problem, result, stage, str(calibration))
    units = law_units(spec.settlement.law)
    show = Table(title=f"Fitted {spec.settlement.law} law ({result.runs} model runs)")
    for col in ("parameter", "start", "fitted", "standard error", "unit (SI)"):
        show.add_column(col)
    for name, v0, v, se in zip(problem.names, result.start, result.values,
                               result.standard_errors, strict=True):  # fmt: skip
        show.add_row(name, f"{v0:.4g}", f"{v:.4g}", f"{se:.2g}", units[name])
    console.print(show)
    console.print(
        f"RMS misfit of the D1-band change: {result.rms_start:.3f} mm at the start, "
        f"{result.rms_fit:.3f} mm fitted ({result.message})"
    )
    refined = zip(spec.survey[1:], result.comparison.alignments[1:], strict=True)
    shifts = ", ".join(f"{s.geometry.name} {a.shift:+.3f} m" for s, a in refined)
    console.print(f"shifts aligned to the fitted prediction: {shifts}")
    _show(sd_errors(table), "D1 SD per segment, RMS error of the prediction [mm]")
    console.print(f"wrote settlement_fitted.toml, calibration.csv and calibration.png to {out}")
