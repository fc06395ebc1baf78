"""Tables the commands print: short headers with units, values to 3 significant digits."""

from __future__ import annotations

import math

from rich import box
from rich.table import Table
from rich.text import Text

# Units shown for column-name suffixes (longest first, so ``_kN_per_mm`` wins over ``_mm``).
HEADER_UNITS = {
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
    for suffix, unit in HEADER_UNITS.items():
        if column.endswith(suffix):
            stem = column.removesuffix(suffix)
            return f"{SHORT_NAMES.get(stem, stem)}\n[{unit}]"
    return column


def frame_table(table, title: str) -> Table:
    """A DataFrame as a rich table, short headers with units, 3 significant digits.

    No column is narrower than its widest value or header word: at a narrow terminal the
    headers wrap between words instead of being cut.

    Parameters
    ----------
    table : pandas.DataFrame
        Columns named with unit suffixes (`header`).
    title : str
        Title above the table.
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
    return show


def deterioration_table(table, title: str) -> Table:
    """The per-section summary of `trackdyn deteriorate`.

    Parameters
    ----------
    table : pandas.DataFrame
        `trackdyn.commands.deteriorate.outputs.summary`: settlement [mm], D1 SD [mm], tonnages
        [MGT].
    title : str
        Title above the table.
    """
    show = Table(title=title)
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
            "never" if math.isinf(r.first_trigger_mgt) else f"{r.first_trigger_mgt:.3g}",
        )
    return show


def forecast_table(table, title: str) -> Table:
    """The first tamping of every segment in an ensemble forecast: p10, p50, p90 [MGT].

    Parameters
    ----------
    table : pandas.DataFrame
        ``forecast.csv``'s table (`trackdyn.forecast.summary.forecast_table` per section).
    title : str
        Title above the table.
    """
    show = Table(title=title)
    for col in ("section", "segment [m]", "p10 [MGT]", "p50 [MGT]", "p90 [MGT]"):
        show.add_column(Text(col))
    first = table[table.quantity == "first_tamping_mgt"]
    for r in first.itertuples(index=False):
        shown = ("beyond" if math.isinf(v) else f"{v:.3g}" for v in (r.p10, r.p50, r.p90))
        show.add_row(r.section, f"{r.segment_start_m:g}-{r.segment_end_m:g}", *shown)
    if not first.empty:
        show.caption = "beyond: after the horizon"
    return show


def alignment_table(spec, problem) -> Table:
    """The surveys of a calibration, aligned to the first: shift [m] and correlation.

    Parameters
    ----------
    spec : trackdyn.commands.calibrate.spec.CalibrationScenario
        The calibration file (its surveys).
    problem : trackdyn.calibration.problem.Calibration
        The prepared fit (alignments, which surveys are fitted).
    """
    show = Table(title="Surveys aligned to the first (D1-band cross-correlation)")
    for col in ("survey", "MGT", "role", "shift [m]", "correlation"):
        show.add_column(Text(col))  # Text: "[m]" is not rich markup
    for s, a, used in zip(spec.survey, problem.alignments, problem.fitted, strict=True):
        role = "first" if s is spec.survey[0] else "fit" if used else "check"
        show.add_row(s.geometry.name, f"{s.mgt:g}", role, f"{a.shift:+.3f}", f"{a.correlation:.3f}")
    return show


def fitted_table(law: str, fit, runs: int) -> Table:
    """The fitted settlement-law parameters in the parameter file's units.

    Parameters
    ----------
    law : str
        Settlement law name.
    fit : pandas.DataFrame
        `trackdyn.commands.calibrate.outputs.fit_table` of the fit.
    runs : int
        Model runs of the fit.
    """
    show = Table(title=f"Fitted {law} law ({runs} model runs)")
    for col in ("parameter", "start", "fitted", "standard error", "bounds", "unit", "status"):
        show.add_column(Text(col))
    for row in fit.itertuples(index=False):
        show.add_row(row.parameter, f"{row.start:.4g}", f"{row.value:.4g}",
                     f"{row.standard_error:.2g}", f"{row.lower:g}-{row.upper:g}", row.unit,
                     row.status)  # fmt: skip
    return show
