"""Command-line interface: parses arguments, calls the commands, reports errors in one line.

Each command's work is in its module of `trackdyn.commands`. Results go to stdout,
progress and status to stderr (`trackdyn.progress`). Nothing heavy is imported before a
command runs, so ``trackdyn --version`` and ``--help`` answer at once.
"""

from __future__ import annotations

import functools
import os
import sys
from pathlib import Path
from typing import Annotated

import typer

GLOBAL_FLAGS = ("-q", "--quiet", "-v", "--verbose")
"""The flags of `main`, taken before or after the command's name."""


class _Group(typer.core.TyperGroup):
    """The command group: `GLOBAL_FLAGS` given after the command's name (``trackdyn run -q``)
    are moved before it, where they belong; nothing after ``--`` is moved."""

    def parse_args(self, ctx, args):
        end = args.index("--") if "--" in args else len(args)
        flags = [a for a in args[:end] if a in GLOBAL_FLAGS]
        rest = [a for a in args[:end] if a not in GLOBAL_FLAGS]
        return super().parse_args(ctx, [*flags, *rest, *args[end:]])


app = typer.Typer(
    cls=_Group,
    context_settings={"help_option_names": ["-h", "--help"]},
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    help="Railway vehicle/track vertical dynamics and track deterioration prediction.",
)


FILE_WIDTH = 200
"""Width of the tables when stdout is not a terminal (a file, a pipe) and ``COLUMNS`` is
not set [characters]: wide enough that a table is not folded."""


class _Stdout:
    """The console of the results (stdout), made on first use: rich loads only then."""

    def __getattr__(self, name):
        import os

        from rich.console import Console

        console = Console()
        if not console.is_terminal and "COLUMNS" not in os.environ:
            console = Console(width=FILE_WIDTH)
        self.__dict__.update({"print": console.print, "status": console.status})
        return getattr(console, name)


console = _Stdout()


class _Listed(typer.core.TyperCommand):
    """A command whose help ends with the names and keys it accepts, read from the
    registries when the help is shown (`trackdyn.commands.choices`), not at start-up."""

    @property
    def epilog(self):
        from trackdyn.commands.choices import choices

        return choices(self.name)

    @epilog.setter
    def epilog(self, value):
        pass  # always the listing


OUT = "trackdyn-out"
"""Folder of the commands' default output folders, one per command (``trackdyn-out/run``)."""

OutOption = Annotated[str, typer.Option("--out", metavar="PATH", help="Output folder.")]
OverwriteOption = Annotated[
    bool, typer.Option(help="Replace another command's outputs in the output folder.")
]


def refuse_bad_input(command):
    """Turn a `TrackdynError` (refused input, a numerical failure) into a one-line message
    and exit code 2."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        from trackdyn.errors import TrackdynError

        try:
            return command(*args, **kwargs)
        except TrackdynError as exc:
            print(f"error: {exc}", file=sys.stderr)
            raise typer.Exit(2) from None

    return wrapper


def _version(value: bool):
    if value:
        from trackdyn import __version__

        print(f"trackdyn {__version__}")
        raise typer.Exit()


@app.callback(invoke_without_command=True)
def main(
    ctx: typer.Context,
    version: Annotated[
        bool,
        typer.Option("--version", "-V", callback=_version, is_eager=True, help="Show version."),
    ] = False,
    quiet: Annotated[
        bool, typer.Option("--quiet", "-q", help="Results only: nothing on stderr but errors.")
    ] = False,
    verbose: Annotated[
        bool,
        typer.Option("--verbose", "-v", help="Also the inputs' SHA-256 and timings on stderr."),
    ] = False,
):
    """Railway vehicle/track vertical dynamics and track deterioration prediction.

    Results (tables) go to stdout, progress, status and notes to stderr; every command writes
    its files and a summary.json into its output folder. -q and -v go before or after the
    command's name.
    """
    from trackdyn.progress import set_verbosity

    os.environ["MPLBACKEND"] = "Agg"  # figures into files: no window, no screen needed
    set_verbosity(0 if quiet else 2 if verbose else 1)
    if ctx.invoked_subcommand is None:
        print(ctx.get_help())
        raise typer.Exit()


@app.command(cls=_Listed)
@refuse_bad_input
def track(
    geometry: Annotated[
        Path | None,
        typer.Option(help="Geometry CSV (distance_m,left_mm,right_mm).", readable=False),
    ] = None,
    supports: Annotated[
        Path | None,
        typer.Option(help="Supports CSV (distance_m,rail,load_kN,deflection_mm).", readable=False),
    ] = None,
    wheel_load_kN: Annotated[float, typer.Option(help="Static wheel load Ps [kN].")] = 127.5,
    delta: Annotated[float, typer.Option(help="Dynamic wheel load increment δ [-].")] = 0.3,
    rail: Annotated[str, typer.Option(help="Rail section (60E1, 54E1, 136RE).")] = "60E1",
    extrapolate: Annotated[
        bool, typer.Option(help="Allow Ps ± ΔP beyond the measured curves.")
    ] = False,
    out: OutOption = f"{OUT}/track",
    overwrite: OverwriteOption = False,
):
    """Analyse a track section: loaded profile, linearised stiffness, geometry quality.

    Without --geometry and --supports, the built-in 1 km example section is used.
    """
    from trackdyn.commands.track import track as job

    job(geometry, supports, wheel_load_kN, delta, rail, extrapolate, out, overwrite, console)


@app.command(cls=_Listed)
@refuse_bad_input
def run(
    scenario: Annotated[
        Path | None,
        typer.Argument(help="Scenario TOML; default: the built-in example.", readable=False),
    ] = None,
    out: OutOption = f"{OUT}/run",
    overwrite: OverwriteOption = False,
):
    """Simulate a vehicle over a track and write results.nc, summary.csv and figures.

    With no scenario: the loaded wagon, 11-DOF model, the example 1 km section, 60 km/h.
    """
    from trackdyn.commands.run import run as job

    job(scenario, out, overwrite, console)


@app.command(cls=_Listed)
@refuse_bad_input
def study(
    study_file: Annotated[
        Path | None,
        typer.Argument(
            help="Study TOML; default: the 2-DOF scenario matrix of §5.4.1.", readable=False
        ),
    ] = None,
    out: OutOption = f"{OUT}/study",
    overwrite: OverwriteOption = False,
    workers: Annotated[
        int | None, typer.Option(help="Worker processes (default: one per core; 1: serial).")
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="Address of a running Dask scheduler, tcp://HOST:PORT.")
    ] = None,
):
    """Run a study (scenario matrix, parameter variation, speed sweep or interventions
    compared) on Dask."""
    from trackdyn.commands.study import study as job

    job(study_file, out, overwrite, workers, scheduler, console)


@app.command(cls=_Listed)
@refuse_bad_input
def deteriorate(
    scenario: Annotated[
        Path | None,
        typer.Argument(
            help="Deterioration scenario TOML; default: the built-in example.", readable=False
        ),
    ] = None,
    out: OutOption = f"{OUT}/deteriorate",
    overwrite: OverwriteOption = False,
    workers: Annotated[
        int | None,
        typer.Option(
            help="Worker processes (default: one per core; none, this process only, for up "
            "to 8 sections through 200 MGT in all)."
        ),
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="Address of a running Dask scheduler, tcp://HOST:PORT.")
    ] = None,
    section_figures: Annotated[
        int | None,
        typer.Option(
            min=0,
            help="Sections whose own figures are drawn (default 12): all of a line of up to "
            "that many, else that many, those that reach the maintenance threshold first; "
            "the tables hold every section.",
        ),
    ] = None,
):
    """Predict track deterioration over accumulated traffic (settlement, geometry, D1 SD).

    With no scenario: alternating loaded and empty coal wagons at 60 km/h over the example
    section for 50 MGT, 11-DOF model, the shipped illustrative (uncalibrated) power law.
    """
    from trackdyn.commands.deteriorate import deteriorate as job

    job(scenario, out, overwrite, workers, scheduler, console, section_figures)


@app.command(cls=_Listed)
@refuse_bad_input
def calibrate(
    calibration: Annotated[
        Path | None,
        typer.Argument(
            help="Calibration TOML (surveys, fit); default: the built-in example, three "
            "synthetic surveys of a 200 m section.",
            readable=False,
        ),
    ] = None,
    out: OutOption = f"{OUT}/calibrate",
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
    rate_field.png. With no calibration file: the built-in example (three synthetic surveys
    of a 200 m section, as `trackdyn example calibration` writes). A fit that did not
    converge (fit.max_iterations, or the rate field's rounds) exits 1 (files written,
    marked not converged) unless --allow-not-converged.
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


@app.command()
@refuse_bad_input
def example(
    name: Annotated[
        str | None,
        typer.Argument(
            help="run, deteriorate, sections, study, interventions or calibration; none: list them."
        ),
    ] = None,
    to: Annotated[
        str, typer.Option("--to", metavar="PATH", help="Folder to write the files into.")
    ] = "trackdyn-example",
    overwrite: Annotated[
        bool, typer.Option(help="Replace files of the example's names already in the folder.")
    ] = False,
):
    """Write the input files of a shipped example into a folder, ready to run.

    Files of the example's names already in the folder are refused unless --overwrite;
    other files there are left alone.
    """
    from trackdyn.commands.examples import EXAMPLES, listing, write_example
    from trackdyn.progress import note

    if name is None:
        print(listing())
        return
    names, command = write_example(name, to, overwrite)
    note(f"wrote {', '.join(names)} to {to}: {EXAMPLES[name][0]}")
    print(command)
