"""Files of a calibration: fitted parameter file, fitted values, misfit per segment, the
estimated rate field, figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from trackdyn.calibration.fit import FitResult
from trackdyn.calibration.problem import Calibration
from trackdyn.calibration.surveys import d1_change
from trackdyn.deterioration.law_files import law_file_table, law_table_toml, law_units
from trackdyn.forecast.spread import posterior_toml
from trackdyn.plots import save
from trackdyn.plots.calibrate import plot_calibration, plot_field
from trackdyn.track.quality import segment_sd
from trackdyn.track.track import RAILS
from trackdyn.units import si_factor

FILES = ("settlement_fitted.toml", "fit.csv", "calibration.csv", "calibration.png")
"""Files every calibration writes."""

FIELD_FILES = ("rate_field.csv", "rate_field.png", "rate_field_draws.csv")
"""Files of a calibration that estimates the rate field."""

FIELD_DRAWS = 64
"""Fields drawn from the estimate's posterior into ``rate_field_draws.csv`` (seed 0), for a
deterioration scenario's ``[forecast] rate_field_draws``: a forecast's member ``m`` runs on
draw ``m`` modulo their number."""

POSTERIOR_FILE = "posterior.toml"
"""The fitted parameters' joint posterior (`trackdyn.forecast.spread.posterior_toml`), for a
deterioration scenario's ``[forecast] posterior``; written when every fitted parameter's
variance is finite."""


def _sampleable(result: FitResult) -> bool:
    """The posterior has a finite covariance (every parameter told by the surveys)."""
    return bool(np.all(np.isfinite(result.posterior.covariance)))


def files_of(result: FitResult) -> tuple[str, ...]:
    """The files a calibration with ``result`` writes."""
    posterior = (POSTERIOR_FILE,) if _sampleable(result) else ()
    return FILES + (FIELD_FILES if result.field is not None else ()) + posterior


def status(result: FitResult) -> str:
    """``fitted``, or ``not converged`` with why."""
    if result.converged:
        return "fitted"
    return f"not converged (stopped by {result.stopped_by})"


def fit_table(problem: Calibration, result: FitResult) -> pd.DataFrame:
    """Fitted parameters in the parameter file's units.

    Columns: ``parameter``, ``value``, ``unit``, ``standard_error``, ``start``, ``lower``,
    ``upper`` (the bounds of the fit), all in ``unit``; ``status`` (fitted or not
    converged).

    Parameters
    ----------
    problem : Calibration
        The calibration.
    result : FitResult
        The fit.
    """
    lower = np.where(problem.log, np.exp(problem.lower), problem.lower)
    upper = np.where(problem.log, np.exp(problem.upper), problem.upper)
    rows = zip(problem.names, problem.units, result.values, result.standard_errors,
               result.start, lower, upper, strict=True)  # fmt: skip
    return pd.DataFrame([
        {"parameter": name, "value": v / f, "unit": unit, "standard_error": se / f,
         "start": v0 / f, "lower": lo / f, "upper": hi / f,
         "status": "fitted" if result.converged else "not converged"}
        for name, (unit, f), v, se, v0, lo, hi in rows
    ])  # fmt: skip


def field_table(result: FitResult) -> pd.DataFrame:
    """The estimated settlement-rate factor per rail seat, for ``[settlement] rate_field``.

    Columns: ``distance_m`` [m], ``rail``, ``factor`` [-], ``standard_error`` [-].

    Parameters
    ----------
    result : FitResult
        A fit with an estimated field.
    """
    field = result.field
    assert field is not None  # called for a fit with an estimated field
    return pd.DataFrame([
        {"distance_m": x, "rail": rail, "factor": field.factor[r, i],
         "standard_error": field.standard_error[r, i]}
        for i, x in enumerate(field.position) for r, rail in enumerate(RAILS)
    ])  # fmt: skip


def draws_table(result: FitResult) -> pd.DataFrame:
    """`FIELD_DRAWS` fields from the estimated field's posterior
    (`trackdyn.calibration.field.FieldEstimate.draws`, seed 0).

    Columns: ``distance_m`` [m], ``rail``, ``draw`` (1, 2, ...), ``factor`` [-].

    Parameters
    ----------
    result : FitResult
        A fit with an estimated field.
    """
    field = result.field
    assert field is not None  # called for a fit with an estimated field
    draws = field.draws(FIELD_DRAWS, seed=0)
    d, r, i = np.meshgrid(np.arange(FIELD_DRAWS), np.arange(len(RAILS)),
                          np.arange(field.position.size), indexing="ij")  # fmt: skip
    return pd.DataFrame({"distance_m": field.position[i.ravel()],
                         "rail": np.asarray(RAILS)[r.ravel()], "draw": d.ravel() + 1,
                         "factor": draws.ravel()})  # fmt: skip


def _rms(values) -> float:
    return float(np.sqrt(np.mean(np.square(values)))) if np.size(values) else np.nan


def segment_table(problem: Calibration, result: FitResult) -> pd.DataFrame:
    """Misfit and D1 standard deviation per later survey, rail and segment.

    Columns: ``survey``, ``mgt`` [MGT], ``role`` (fit or check), ``rail``,
    ``segment_start_m``, ``segment_end_m`` [m], ``shift_m`` [m] (at the fit),
    ``change_rms_mm`` (measured D1-band change), ``misfit_rms_mm`` and
    ``misfit_rms_start_mm`` (predicted minus measured change with the fitted and the
    starting values), ``d1_sd_mm`` (measured), ``d1_sd_predicted_mm`` and
    ``d1_sd_predicted_start_mm`` [mm]: the first survey's D1 level plus the predicted change.
    Points near the ends and in ignored ranges are left out.

    Parameters
    ----------
    problem : Calibration
        The calibration.
    result : FitResult
        The fit.
    """
    x, valid = problem.x, problem.valid
    bounds = segment_sd(x, np.zeros_like(x), problem.spec.loop.segment_length_m)
    first = d1_change(x, problem.first)
    fit, start = result.comparison, result.start_comparison
    rows = []
    for k in range(1, problem.mgt.size):
        for r, rail in enumerate(RAILS):
            for lo, hi in zip(bounds["segment_start_m"], bounds["segment_end_m"], strict=True):
                at = valid & (x >= lo) & (x <= hi)
                meas, pred, pred0 = (c[k, r, at] * 1e3 for c in
                                     (fit.measured, fit.predicted, start.predicted))  # fmt: skip
                base = first[r, at] * 1e3
                rows.append({
                    "survey": Path(problem.spec.survey[k].geometry).name,
                    "mgt": problem.spec.survey[k].mgt,
                    "role": "fit" if problem.fitted[k] else "check",
                    "rail": rail,
                    "segment_start_m": lo,
                    "segment_end_m": hi,
                    "shift_m": fit.alignments[k].shift,
                    "change_rms_mm": _rms(meas),
                    "misfit_rms_mm": _rms(pred - meas),
                    "misfit_rms_start_mm": _rms(pred0 - meas),
                    "d1_sd_mm": np.std(base + meas) if at.any() else np.nan,
                    "d1_sd_predicted_mm": np.std(base + pred) if at.any() else np.nan,
                    "d1_sd_predicted_start_mm": np.std(base + pred0) if at.any() else np.nan,
                })  # fmt: skip
    return pd.DataFrame(rows)


def sd_errors(table: pd.DataFrame) -> pd.DataFrame:
    """RMS over rails and segments of the predicted minus measured D1 SD per survey [mm],
    with the fitted (``error_mm``) and the starting values (``error_start_mm``).

    Parameters
    ----------
    table : DataFrame
        `segment_table` of a calibration.
    """
    t = table.dropna(subset=["d1_sd_mm"])
    rows = []
    for (survey, mgt, role), g in t.groupby(["survey", "mgt", "role"], sort=False):
        rows.append({
            "survey": survey, "mgt": mgt, "role": role,
            "error_mm": _rms(g.d1_sd_predicted_mm - g.d1_sd_mm),
            "error_start_mm": _rms(g.d1_sd_predicted_start_mm - g.d1_sd_mm),
        })  # fmt: skip
    return pd.DataFrame(rows)


def parameter_file(problem: Calibration, result: FitResult, where: str) -> str:
    """A settlement parameter file (TOML) with the fitted values, for `trackdyn
    deteriorate`'s ``[settlement] file``.

    Fitted parameters keep the unit and bounds of the file they started from, with the
    surveys and the standard error as source; overridden ones are written in SI units;
    the others are copied.

    Parameters
    ----------
    problem : Calibration
        The calibration.
    result : FitResult
        The fit.
    where : str
        The calibration file, named in the sources.
    """
    s = problem.spec.settlement
    table = law_file_table(s.law, None if s.file is None else problem.base / s.file)
    surveys = ", ".join(
        f"{Path(v.geometry).name} ({v.mgt:g} MGT)"
        for v, used in zip(problem.spec.survey, problem.fitted, strict=True)
        if used or v is problem.spec.survey[0]
    )
    fitted = dict(zip(problem.names, zip(result.values, result.standard_errors, strict=True),
                      strict=True))  # fmt: skip
    lo, hi = problem.fitted_extent
    if result.field is None:
        ballast = (
            "# Settlement-rate field: uniform (factor 1 at every rail seat, fit.rate_field).\n"
        )
    else:
        ballast = (
            "# Settlement-rate field: estimated per rail seat with these values, in\n"
            '# rate_field.csv; use both: [settlement] rate_field = "rate_field.csv".\n'
        )
    header = (
        f"# Settlement law parameters {status(result)} by "
        f"`trackdyn calibrate {Path(where).name}`.\n"
        f"# Surveys: {surveys}; supports {Path(problem.spec.track.supports).name}.\n"
        f"# Compared: {lo:.1f}-{hi:.1f} m ({hi - lo:.1f} m) of the first survey's distances.\n"
        f"{ballast}\n"
    )
    entries = {}
    for name, si_unit in law_units(s.law).items():
        entry = dict(table.get(name, {}))
        if name in fitted:
            value, se = fitted[name]
            factor = si_factor(entry["unit"], si_unit)
            entry["value"] = value / factor
            entry["source"] = (
                f"{status(result)} by trackdyn calibrate ({Path(where).name}) to "
                f"the D1-band change of the surveys {surveys}; standard error "
                f"{se / factor:.3g} {entry['unit']}"
            )
        elif name in s.overrides:
            entry = {"value": s.overrides[name], "unit": si_unit,
                     "source": f"[settlement] overrides of {Path(where).name}"}  # fmt: skip
        entries[name] = entry
    return header + law_table_toml(s.law, entries, table.get("description"))


def calibration_figures(problem: Calibration, result: FitResult, table=None) -> dict:
    """A calibration's figures by file name: the fit against the surveys and, with the rate
    field estimated, the field (`trackdyn.plots.calibrate`).

    Parameters
    ----------
    problem : Calibration
        The calibration.
    result : FitResult
        The fit.
    table : pandas.DataFrame, optional
        Its `segment_table` (made when not given).
    """
    table = segment_table(problem, result) if table is None else table
    figures = {FILES[3]: plot_calibration(result, problem=problem, table=table)}
    if result.field is not None:
        figures[FIELD_FILES[1]] = plot_field(result.field, extent=problem.fitted_extent)
    return figures


def write_calibration(problem: Calibration, result: FitResult, folder, where: str) -> pd.DataFrame:
    """Write `files_of` the result into ``folder``; returns the segment table.

    Parameters
    ----------
    problem : Calibration
        The calibration.
    result : FitResult
        The fit.
    folder : Path
        Output (staging) folder.
    where : str
        The calibration file.
    """
    folder = Path(folder)
    (folder / FILES[0]).write_text(parameter_file(problem, result, where))
    fit_table(problem, result).to_csv(folder / FILES[1], index=False, float_format="%.6g")
    table = segment_table(problem, result)
    table.to_csv(folder / FILES[2], index=False, float_format="%.4g")
    for name, fig in calibration_figures(problem, result, table).items():
        save(fig, folder / name)
    if result.field is not None:
        field_table(result).to_csv(folder / FIELD_FILES[0], index=False, float_format="%.6g")
        draws_table(result).to_csv(folder / FIELD_FILES[2], index=False, float_format="%.6g")
    if _sampleable(result):
        text = posterior_toml(result.posterior, problem.spec.settlement.law, f"fitted by {where}")
        (folder / POSTERIOR_FILE).write_text(text)
    return table
