"""`trackdyn calibrate`: settlement-law parameters fitted to geometry surveys."""

from __future__ import annotations

import numpy as np

from trackdyn.commands.compiling import say_if_compiling
from trackdyn.commands.staging import Record, output_folder
from trackdyn.commands.tables import alignment_table, fitted_table, frame_table
from trackdyn.errors import require_workers
from trackdyn.progress import note
from trackdyn.provenance import recorded


@recorded
def calibrate(calibration, out, overwrite: bool, workers, scheduler, console) -> bool:
    """Fit the law (and the rate field); write the files of
    `trackdyn.commands.calibrate.outputs.files_of`, ``summary.json`` and ``report.html``.

    Parameters
    ----------
    calibration : path, optional
        Calibration TOML file (surveys, fit); None: the built-in example (`trackdyn example
        calibration`).
    out : Path
        Output folder.
    overwrite : bool
        Replace another command's outputs in ``out``.
    workers : int, optional
        Worker processes (default: one per core; 1: serial).
    scheduler : str, optional
        Address of a running Dask scheduler.
    console : rich.console.Console
        Where the tables are shown (stdout): the alignments, the fit, the errors; the
        fit's progress and notes go to stderr.

    Returns
    -------
    bool
        The fit converged (False: stopped by ``fit.max_iterations``; the files say so).
    """
    from trackdyn.calibration.fit import fit
    from trackdyn.commands.calibrate.outputs import (
        files_of,
        fit_table,
        sd_errors,
        write_calibration,
    )
    from trackdyn.commands.calibrate.spec import calibration_problem, load_calibration
    from trackdyn.commands.examples import example_file
    from trackdyn.parallel import shared_cluster

    require_workers(workers)
    source = example_file("calibration", "calibration.toml") if calibration is None else calibration
    spec, base = load_calibration(source)
    problem = calibration_problem(spec, base)
    console.print(alignment_table(spec, problem))
    lo, hi = problem.fitted_extent
    note(
        f"compared: {lo:.1f}-{hi:.1f} m ({hi - lo:.1f} m) of the first survey's distances "
        "(the stretch every aligned survey and the supports cover, less the band-pass ends)"
    )
    field = "estimated per rail seat" if spec.fit.rate_field == "estimate" else "uniform"
    note(f"settlement-rate field: {field} (fit.rate_field)")
    title = f"trackdyn calibrate: {spec.settlement.law} law, {len(spec.survey)} surveys"
    record = Record(title, {"calibration": source}, spec.model_dump(mode="json"))
    with (
        output_folder(out, "calibrate", overwrite, record) as stage,
        shared_cluster(workers, scheduler),
    ):
        say_if_compiling("calibrate", scheduler)
        result = fit(problem, workers=workers, scheduler=scheduler, log=_log)
        record.headline = headline(problem, result)
        table = write_calibration(problem, result, stage, str(source))
    note(f"the optimiser: {result.message}", 2 if result.converged else 1)
    refined = zip(spec.survey[1:], result.comparison.alignments[1:], strict=True)
    shifts = ", ".join(f"{s.geometry.name} {a.shift:+.3f} m" for s, a in refined)
    note(f"shifts aligned to the fitted prediction: {shifts}")
    found = "\n".join(_fit_lines(problem, result))
    console.print(fitted_table(spec.settlement.law, fit_table(problem, result), result.runs, found))
    console.print(
        frame_table(sd_errors(table), "D1 SD per segment, RMS error of the prediction [mm]")
    )
    note(f"wrote {', '.join(files_of(result))}, summary.json and report.html to {out}")
    note("\n".join(record.lines()), 2)
    return result.converged


def _log(text: str, detail: bool = False) -> None:
    """The fit's progress on stderr; its details (failed trial runs) with -v only."""
    note(text, 2 if detail else 1)


def headline(problem, result) -> dict:
    """The fit in ``summary.json``: its status, the RMS misfit of the D1-band change at the
    start and fitted [mm], the model runs and the fitted parameters (the parameter file's
    units, `trackdyn.commands.calibrate.outputs.fit_table`)."""
    from trackdyn.commands.calibrate.outputs import fit_table, status

    table = fit_table(problem, result)[["parameter", "value", "unit", "standard_error"]]
    return {
        "status": status(result),
        "rms_misfit_start_mm": result.rms_start,
        "rms_misfit_fitted_mm": result.rms_fit,
        "model_runs": result.runs,
        "parameters": table.to_dict(orient="records"),
    }


def _fit_lines(problem, result) -> list[str]:
    """What the fit found beside its table: the misfit and status, the parameters' error
    correlations, the rate field."""
    from trackdyn.commands.calibrate.outputs import status

    lines = [
        f"RMS misfit of the D1-band change: {result.rms_start:.3f} mm at the start, "
        f"{result.rms_fit:.3f} mm fitted: {status(result)}"
    ]
    for i, j in zip(*np.triu_indices(len(problem.names), 1), strict=True):
        lines.append(
            f"{problem.names[i]} and {problem.names[j]}: errors correlated "
            f"{result.correlation[i, j]:+.2f}"
        )
    if result.field is not None:
        f = result.field
        lines.append(
            f"rate field: {result.rounds} round(s); prior cov {f.cov:.2f} chosen by marginal "
            f"likelihood, noise {f.noise_mm:.3f} mm; factor {f.factor.min():.2f}-"
            f"{f.factor.max():.2f}, median standard error "
            f"{float(np.median(f.standard_error[:, f.observed])):.2f} where compared"
        )
    return lines
