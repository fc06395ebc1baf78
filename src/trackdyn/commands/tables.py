"""Tables the commands print: headers in words with units, values to 3 significant digits.

A table wider than the console is folded, not cut: its number columns go into as many
tables as the width needs, each repeating the label columns (`FoldedTable`).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from rich import box
from rich.measure import Measurement
from rich.table import Table
from rich.text import Text

from trackdyn.labels import NOTES, header

MISSING = "–"
"""A value that is missing (NaN: a failed run, a quantity without data)."""


def cell(value, digits: int = 3) -> str:
    """A value as the tables show it: text as it is; numbers to ``digits`` significant
    digits, from 1000 on in full without an exponent (a length of 1199 m, not 1.2e+03); NaN
    and None as `MISSING`.

    Parameters
    ----------
    value : str or number
        The value.
    digits : int
        Significant digits of a number below 1000.
    """
    if isinstance(value, str):
        return value
    if value is None:
        return MISSING
    if isinstance(value, numbers.Integral):  # numpy's integers too
        return str(value)
    if math.isnan(value):
        return MISSING
    if math.isinf(value) or abs(value) < 1000:
        return f"{value:.{digits}g}"
    return f"{value:.0f}"


@dataclass
class FoldedTable:
    """A table that, too wide for the console, prints as several: the label columns (the
    leading text columns) in each, the other columns in as many groups as the width
    needs; the title above the first, the caption under the last.

    Parameters
    ----------
    title : str
        Title above the (first) table.
    caption : str or None
        Text under the (last) table.
    labels : list of (str, list of str)
        Label columns: header and cells.
    columns : list of (str, list of str)
        The other columns: header and cells.
    """

    title: str
    caption: str | None
    labels: list
    columns: list

    def table(self, columns: list, first: bool = True, last: bool = True, narrow=False) -> Table:
        """The rich table of the label columns and ``columns``; ``narrow``: each column as
        wide as its widest value or header word (rich, left to fit a table to the width,
        may cut a column below that)."""
        show = Table(title=self.title if first else None,
                     caption=self.caption if last else None, box=box.SIMPLE_HEAD)  # fmt: skip
        pairs = [*self.labels, *columns]
        for h, cells in pairs:
            least = max(len(w) for w in [*h.split(), *cells])
            show.add_column(Text(h), min_width=least, width=least if narrow else None)
        for row in zip(*(cells for _, cells in pairs), strict=True):
            show.add_row(*map(Text, row))
        return show

    def groups(self, console, options) -> list[list]:
        """The columns in consecutive groups, each as many as fit the width with the
        labels when narrow (at least one)."""
        out: list[list] = [[]]
        for column in self.columns:
            trial = [*out[-1], column]
            if out[-1] and _width(console, self.table(trial, narrow=True)) > options.max_width:
                out.append([column])
            else:
                out[-1] = trial
        return out

    def __rich_console__(self, console, options):
        groups = self.groups(console, options)
        for k, group in enumerate(groups):
            show = self.table(group, first=k == 0, last=k == len(groups) - 1)
            if _width(console, show) > options.max_width:
                show = self.table(group, first=k == 0, last=k == len(groups) - 1, narrow=True)
            yield show


def _width(console, table: Table) -> int:
    """The width ``table`` takes when nothing limits it [characters]."""
    return Measurement.get(console, console.options.update(max_width=10**6), table).maximum


def frame_table(table, title: str, currency: str | None = None) -> FoldedTable:
    """A DataFrame as a table: headers in words with units, values by `cell`.

    No column is narrower than its widest value or header word: at a narrow terminal the
    headers wrap between words, and a table that still does not fit is folded
    (`FoldedTable`) instead of being cut.

    Parameters
    ----------
    table : pandas.DataFrame
        Columns named with unit suffixes (`header`).
    title : str
        Title above the table.
    currency : str, optional
        The currency that ends the names of costs (`header`).
    """
    headers = [header(str(col), currency) for col in table.columns]
    notes = [note for symbol, note in NOTES.items() if any(symbol in h for h in headers)]
    cells = [[cell(v) for v in table[col]] for col in table.columns]
    text = [table[col].dtype.kind not in "biufc" for col in table.columns]
    leading = next((j for j, t in enumerate(text) if not t), len(text))
    pairs = list(zip(headers, cells, strict=True))
    return FoldedTable(title, "\n".join(notes) or None, pairs[:leading], pairs[leading:])


def deterioration_table(table, title: str) -> Table:
    """The per-section summary of `trackdyn deteriorate`.

    Parameters
    ----------
    table : pandas.DataFrame
        `trackdyn.commands.deteriorate.outputs.summary`: settlement [mm], D1 SD [mm], tonnages
        [MGT], hanging sleeper rail seats at the end.
    title : str
        Title above the table.
    """
    show = Table(title=title)
    for col in ("section", "MGT", "steps", "settlement min/mean/max [mm]", "D1 SD max [mm]",
                "trigger [MGT]", "hanging rail seats"):  # fmt: skip
        show.add_column(Text(col))
    for r in table.itertuples(index=False):
        show.add_row(
            r.section,
            f"{r.mgt:g}",
            str(r.steps),
            f"{r.settlement_min_mm:.2f} / {r.settlement_mean_mm:.2f} / {r.settlement_max_mm:.2f}",
            f"{r.d1_sd_max_initial_mm:.2f} -> {r.d1_sd_max_final_mm:.2f}",
            "never" if math.isinf(r.first_trigger_mgt) else f"{r.first_trigger_mgt:.3g}",
            str(r.hanging_rail_seats_final),
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


def fitted_table(law: str, fit, runs: int, caption: str | None = None) -> Table:
    """The fitted settlement-law parameters in the parameter file's units.

    Parameters
    ----------
    law : str
        Settlement law name.
    fit : pandas.DataFrame
        `trackdyn.commands.calibrate.outputs.fit_table` of the fit.
    runs : int
        Model runs of the fit.
    caption : str, optional
        Text under the table (what the fit found beside it).
    """
    show = Table(title=f"Fitted {law} law ({runs} model runs)",
                 caption=None if caption is None else Text(caption))  # fmt: skip
    for col in ("parameter", "start", "fitted", "standard error", "bounds", "unit", "status"):
        show.add_column(Text(col))
    for row in fit.itertuples(index=False):
        show.add_row(row.parameter, f"{row.start:.4g}", f"{row.value:.4g}",
                     f"{row.standard_error:.2g}", f"{row.lower:g}-{row.upper:g}", row.unit,
                     row.status)  # fmt: skip
    return show
