"""`trackdyn calibrate`: settlement-law parameters fitted to geometry surveys."""

from __future__ import annotations

from trackdyn.commands.tables import alignment_table, fitted_table, frame_table
from trackdyn.errors import require_workers
from trackdyn.staging import output_folder


def calibrate(calibration, out, overwrite: bool, workers, scheduler, console) -> None:
    """Fit the law; write settlement_fitted.toml, calibration.csv and calibration.png.

    Parameters
    ----------
    calibration : path
        Calibration TOML file (surveys, fit).
    out : Path
        Output folder.
    overwrite : bool
        Replace another command's outputs in ``out``.
    workers : int, optional
        Worker processes (default: one per core; 1: serial).
    scheduler : str, optional
        Address of a running Dask scheduler.
    console : rich.console.Console
        Where the alignments, the fit's progress and its result are shown.
    """
    from trackdyn.calibration.fit import fit
    from trackdyn.commands.calibrate.outputs import sd_errors, write_calibration
    from trackdyn.commands.calibrate.spec import calibration_problem, load_calibration
    from trackdyn.deterioration.law_files import law_units
    from trackdyn.parallel import shared_cluster

    require_workers(workers)
    spec, base = load_calibration(calibration)
    problem = calibration_problem(spec, base)
    console.print(alignment_table(spec, problem))
    with output_folder(out, "calibrate", overwrite) as stage, shared_cluster(workers, scheduler):
        result = fit(problem, workers=workers, scheduler=scheduler, log=console.print)
        table = write_calibration(problem, result, stage, str(calibration))
    units = law_units(spec.settlement.law)
    console.print(fitted_table(spec.settlement.law, problem, result, units))
    console.print(
        f"RMS misfit of the D1-band change: {result.rms_start:.3f} mm at the start, "
        f"{result.rms_fit:.3f} mm fitted ({result.message})"
    )
    refined = zip(spec.survey[1:], result.comparison.alignments[1:], strict=True)
    shifts = ", ".join(f"{s.geometry.name} {a.shift:+.3f} m" for s, a in refined)
    console.print(f"shifts aligned to the fitted prediction: {shifts}")
    console.print(
        frame_table(sd_errors(table), "D1 SD per segment, RMS error of the prediction [mm]")
    )
    console.print(f"wrote settlement_fitted.toml, calibration.csv and calibration.png to {out}")
