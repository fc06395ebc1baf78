"""Command-line interface: parses arguments, calls the commands, reports errors in one line.

Each command's work is in its module of `trackdyn.commands`.
"""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from trackdyn import __version__
from trackdyn.errors import TrackdynInputError

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    help="Railway vehicle/track vertical dynamics and track deterioration prediction.",
)
console = Console()
OutOption = Annotated[str, typer.Option("--out", metavar="PATH", help="Output folder.")]
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
    out: OutOption = "trackdyn-out",
    overwrite: OverwriteOption = False,
):
    """Analyse a track section: loaded profile, linearised stiffness, geometry quality.

    Without --geometry and --supports, the built-in 1 km example section is used.
    """
    from trackdyn.commands.track import track as job

    job(geometry, supports, wheel_load_kN, delta, rail, extrapolate, out, overwrite, console)


@app.command()
@refuse_bad_input
def run(
    scenario: Annotated[
        Path | None, typer.Argument(help="Scenario TOML; default: the built-in example.")
    ] = None,
    out: OutOption = "trackdyn-out",
    overwrite: OverwriteOption = False,
):
    """Simulate a vehicle over a track and write results.nc, summary.csv and figures.

    With no scenario: the loaded wagon, 11-DOF model, the example 1 km section, 60 km/h.
    """
    from trackdyn.commands.run import run as job

    job(scenario, out, overwrite, console)


@app.command()
@refuse_bad_input
def study(
    study_file: Annotated[
        Path | None,
        typer.Argument(help="Study TOML; default: the 2-DOF scenario matrix of §5.4.1."),
    ] = None,
    out: OutOption = "trackdyn-out",
    overwrite: OverwriteOption = False,
    workers: Annotated[
        int | None, typer.Option(help="Worker processes (default: one per core; 1: serial).")
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="Address of a running Dask scheduler, tcp://HOST:PORT.")
    ] = None,
):
    """Run a study (scenario matrix, parameter variation or speed sweep) on Dask."""
    from trackdyn.commands.study import study as job

    job(study_file, out, overwrite, workers, scheduler, console)


@app.command()
@refuse_bad_input
def deteriorate(
    scenario: Annotated[
        Path | None,
        typer.Argument(help="Deterioration scenario TOML; default: the built-in example."),
    ] = None,
    out: OutOption = "trackdyn-out",
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
    from trackdyn.commands.deteriorate import deteriorate as job

    job(scenario, out, overwrite, workers, scheduler, console)


@app.command()
@refuse_bad_input
def calibrate(
    calibration: Annotated[Path, typer.Argument(help="Calibration TOML (surveys, fit).")],
    out: OutOption = "trackdyn-out",
    overwrite: OverwriteOption = False,
    workers: Annotated[
        int | None,
        typer.Option(help="Worker processes (default: one per core; 1: serial)."),
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="Address of a running Dask scheduler, tcp://HOST:PORT.")
    ] = None,
    allow_not_converged: Annotated[
        bool, typer.Option(help="Exit 0 when the fit stops at fit.max_iterations.")
    ] = False,
):
    """Fit settlement-law parameters and each rail seat's settlement-rate factor to two or
    more geometry surveys of one section.

    Writes settlement_fitted.toml (for deteriorate's [settlement] file), rate_field.csv
    (for its [settlement] rate_field), fit.csv (fitted values and standard errors),
    calibration.csv (misfit and D1 SD per survey, rail and segment), calibration.png and
    rate_field.png. A fit that did not converge (fit.max_iterations, or the rate field's
    rounds) exits 1 (files written, marked not converged) unless --allow-not-converged.
    """
    from trackdyn.commands.calibrate import calibrate as job

    converged = job(calibration, out, overwrite, workers, scheduler, console)
    if not converged and not allow_not_converged:
        print(
            "error: the fit did not converge (files written, marked not converged, the reason "
            "above); raise fit.max_iterations, or pass --allow-not-converged",
            file=sys.stderr,
        )
        raise typer.Exit(1)
