"""The tables of ``report.html``: headers in words with units, values rounded.

A column or figure name is given its words by `trackdyn.commands.names` and its unit by
the unit registry (`trackdyn.units.name_unit`; a cost by its currency); a value is shown
to `DIGITS` significant digits (`trackdyn.commands.tables.cell`), a missing one as
`MISSING`, an infinite tonnage (one never reached) as `BEYOND`. The headline figures of
``summary.json`` become a table of their single figures and one per group of rows
(`headline_tables`); a CSV file becomes its first `PREVIEW_ROWS` rows (`csv_preview`).
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

from trackdyn.commands.names import GROUPS, words
from trackdyn.commands.tables import MISSING, cell
from trackdyn.units import name_unit, spelled_unit

DIGITS = 4
"""Significant digits of a number in the report (from 1000 on: in full, `cell`)."""

PREVIEW_ROWS = 10
"""Rows of a CSV file shown; the file holds them all and is linked."""

BEYOND = "beyond the horizon"
"""An infinite tonnage: a threshold the run never reached."""

_QUANTILE = re.compile(r"p\d{1,2}")  # p10, p50, p90: in the unit of their group
_AT = re.compile(r"(?P<quantity>.+)_at_(?P<mgt>[0-9.]+)_MGT")  # settlement_mm_at_10_MGT


@dataclass
class Table:
    """A table of the report, its cells as shown.

    Parameters
    ----------
    title : str
        Title above it (empty: none).
    header : list of str
        Column headers, each its words and unit (`label`); empty for a table of pairs,
        whose first cell of each row is its header.
    rows : list of list of str
        The cells.
    file : str
        The file the table shows the first rows of (empty: none).
    count : int
        The rows the file holds.
    """

    title: str
    header: list[str]
    rows: list[list[str]]
    file: str = ""
    count: int = 0


def unit_of(name: str, currency: str | None = None) -> str | None:
    """The unit a name ends in (a cost: its currency; ``mgt``: MGT; a snapshot's column:
    its quantity's), as a reader writes it (``m/s²``)."""
    at = _AT.fullmatch(name)
    if at:
        return unit_of(at["quantity"], currency)
    if currency and name.endswith(f"_{currency}"):
        return currency
    unit = name_unit(name)[1] or spelled_unit(name)
    return None if unit is None else unit.replace("^2", "²").replace("^3", "³")


def label(name: str, command: str | None = None, currency: str | None = None,
          unit: str | None = None) -> str:  # fmt: skip
    """A column's header: its words (`trackdyn.commands.names.words`) and its unit
    in brackets (``unit`` where the name has none).

    Parameters
    ----------
    name : str
        Column or headline name (``dyn_load_max_kN``).
    command : str, optional
        The command whose table holds it (``run``), or the command's headline (``run
        headline``): the words it means there (`trackdyn.commands.names.WORDS`).
    currency : str, optional
        The currency that ends the names of costs.
    unit : str, optional
        Its unit where the name carries none (a quantile of a tonnage).
    """
    own = unit_of(name, currency)
    at = _AT.fullmatch(name)
    if at:
        text = f"{words(at['quantity'], command)} at {at['mgt']} MGT"
    else:
        cost = currency is not None and own == currency
        text = words(name.removesuffix(f"_{currency}") if cost else name, command)
    text = text[0].upper() + text[1:]
    return f"{text} [{own or unit}]" if own or unit else text


def shown(value, unit: str | None = None) -> str:
    """A value as a report cell: text as it is, yes/no, a number to `DIGITS` significant
    digits; None and NaN as `MISSING`; infinity as `BEYOND` for a tonnage, else
    `MISSING`."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float) and math.isinf(value):
        return BEYOND if unit == "MGT" else MISSING
    return cell(value, DIGITS)


def _rows(records: list[dict], command, currency, unit=None) -> Table:
    """A group of headline rows (``sections``) as a table: a column per name."""
    names = list(dict.fromkeys(k for r in records for k in r))
    units = [unit_of(n, currency) or (unit if _QUANTILE.fullmatch(n) else None) for n in names]
    header = [label(n, command, currency, u) for n, u in zip(names, units, strict=True)]
    rows = [[shown(r.get(n), u) for n, u in zip(names, units, strict=True)] for r in records]
    return Table("", header, rows)


def _pairs(values: dict, command, currency) -> Table:
    """Single figures as a table of pairs: the figure's header, its value."""
    rows = [[label(k, command, currency), shown(v, unit_of(k, currency))]
            for k, v in values.items()]  # fmt: skip
    return Table("", [], rows)


def headline_tables(headline: dict, command: str, currency: str | None = None) -> list[Table]:
    """The headline figures of ``summary.json`` as tables: the single figures in one,
    each group of rows (a list of tables, ``sections``) or of figures (``plan``) in one of
    its own, titled from `trackdyn.commands.names.GROUPS`.

    Parameters
    ----------
    headline : dict
        `trackdyn.commands.staging.Record.headline`.
    command : str
        The command that wrote it.
    currency : str, optional
        The currency that ends the names of costs.
    """
    command = f"{command} headline"
    single = {k: v for k, v in headline.items() if not isinstance(v, dict | list)}
    tables = [_pairs(single, command, currency)] if single else []
    for key, value in headline.items():
        if isinstance(value, list):
            table = _rows(value, command, currency, unit_of(key))
        elif isinstance(value, dict):
            table = _pairs(value, command, currency)
        else:
            continue
        title = GROUPS.get(key) or words(key)
        unit = unit_of(key)
        table.title = f"{title} [{unit}]" if unit else title
        tables.append(table)
    return tables


def _value(text: str):
    """A CSV cell as a number where it is one (an integer kept an integer), else text;
    empty: None."""
    if text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            continue
    return text


def csv_preview(path: Path, command: str, currency: str | None = None) -> Table:
    """The first `PREVIEW_ROWS` rows of a CSV file, headers in words with units.

    Parameters
    ----------
    path : Path
        The file (lines starting with ``#`` skipped).
    command : str
        The command that wrote it (the words its columns mean there).
    currency : str, optional
        The currency that ends the names of costs.
    """
    rows: list[list[str]] = []
    count = 0
    with open(path, newline="") as file:
        reader = (row for row in csv.reader(file) if row and not row[0].startswith("#"))
        names = next(reader, [])
        units = [unit_of(n, currency) for n in names]
        for row in reader:
            count += 1
            if count <= PREVIEW_ROWS:
                rows.append([shown(_value(v), u) for v, u in zip(row, units, strict=False)])
    header = [label(n, command, currency) for n in names]
    return Table(path.name, header, rows, path.name, count)
