"""``report.html`` as an engineer hands it on: the headline figures in a table whose
headers carry units, no ``inf``, ``nan`` or 16-digit floats in a cell, every figure with a
caption and the main one first, links that resolve in the folder, the date and the
versions; read with the standard library's HTML parser."""

import json
import math
import re
from html.parser import HTMLParser

import pytest
from test_provenance import inputs_folder, invoke

import trackdyn
from trackdyn.commands.names import FIGURES, caption, words
from trackdyn.commands.report_tables import BEYOND, csv_preview, headline_tables, label, shown
from trackdyn.commands.tables import MISSING

MAIN = {"run": "wheel_loads", "deteriorate": "quality", "calibrate": "calibration"}
"""The main figure of each command (its file stem, a deterioration section's by its end)."""

NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)(e[-+]?\d+)?")


class _Page(HTMLParser):
    """A report's tables (cells by row, ``th`` marked), figures with their captions, links
    and text."""

    def __init__(self):
        super().__init__()
        self.tables, self.figures, self.links, self.text = [], [], [], []
        self._cell = self._caption = None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = [tag, ""]
        elif tag == "img":
            self.figures.append([attrs["alt"], None])
        elif tag == "figcaption":
            self._caption = ""
        elif tag == "a":
            self.links.append(attrs["href"])

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self.tables[-1][-1].append((self._cell[0], self._cell[1].strip()))
            self._cell = None
        elif tag == "figcaption":
            self.figures[-1][1] = " ".join(self._caption.split())
            self._caption = None

    def handle_data(self, data):
        self.text.append(data)
        if self._cell is not None:
            self._cell[1] += data
        if self._caption is not None:
            self._caption += data


def significant(text: str) -> int:
    """Significant digits of a number written as ``text``."""
    mantissa = text.lower().split("e")[0].lstrip("+-").replace(".", "").lstrip("0")
    return len(mantissa)


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """run, deteriorate and a quick calibrate (test_provenance's inputs): their folders
    and parsed reports."""
    base = tmp_path_factory.mktemp("report")
    inputs_folder(base)
    out = {}
    for command in MAIN:
        out[command] = base / f"{command}-out"
        invoke(command, base / "cal" if command == "calibrate" else base, out[command])
    parsed = {}
    for command, folder in out.items():
        page = _Page()
        page.feed((folder / "report.html").read_text(encoding="utf-8"))
        parsed[command] = page
    return out, parsed


@pytest.mark.parametrize("command", list(MAIN))
def test_headline_table_has_units_in_its_headers(pages, command):
    """The first table is the headline: its header cells (row or column headers) say the
    quantity in words and, for a number, its unit in brackets."""
    _, parsed = pages
    headline = parsed[command].tables[0]
    headers = [text for row in headline for tag, text in row if tag == "th"]
    assert headers and all("_" not in h for h in headers)  # words, not snake_case names
    assert sum("[" in h and h.endswith("]") for h in headers) >= 2


@pytest.mark.parametrize("command", list(MAIN))
def test_no_cell_shows_inf_nan_or_a_long_float(pages, command):
    _, parsed = pages
    cells = [text for table in parsed[command].tables for row in table for _, text in row]
    assert cells
    for text in cells:
        assert text.lower() not in ("inf", "-inf", "nan", "none", "null"), text
        if NUMBER.fullmatch(text) and "." in text:  # a float: at most 6 significant digits
            assert significant(text) <= 6, text


@pytest.mark.parametrize("command", list(MAIN))
def test_figures_have_captions_the_main_one_first(pages, command):
    folder, parsed = pages
    figures = parsed[command].figures
    pngs = sorted(p for p in folder[command].iterdir() if p.suffix == ".png")
    assert len(figures) == len(pngs) > 0
    for alt, text in figures:
        assert alt and text and alt in text and ".png" not in alt  # words, not a file name
    assert figures[0][0].startswith(FIGURES[MAIN[command]])


@pytest.mark.parametrize("command", list(MAIN))
def test_every_link_resolves_in_the_folder(pages, command):
    folder, parsed = pages
    links = parsed[command].links
    names = {p.name for p in folder[command].iterdir() if not p.name.startswith(".")}
    assert set(links) == names  # every file linked, and no link to anything else
    assert all((folder[command] / href).is_file() for href in links)


@pytest.mark.parametrize("command", list(MAIN))
def test_report_says_when_and_with_which_versions(pages, command):
    folder, parsed = pages
    summary = json.loads((folder[command] / "summary.json").read_text())
    text = " ".join(parsed[command].text)
    date = summary["created"].replace("T", " ").replace("Z", " UTC")
    assert f"Written {date} by trackdyn {trackdyn.__version__}" in text
    for name in ("python", "numpy", "numba"):
        assert f"{name} {summary['versions'][name]}" in text


def test_a_long_csv_shows_its_first_rows_and_its_count(pages):
    folder, parsed = pages
    text = " ".join(" ".join(parsed["deteriorate"].text).split())
    rows = len((folder["deteriorate"] / "quality.csv").read_text().splitlines()) - 1
    assert rows > 10  # 3 segments x 2 rails x 2 tonnages (0 and 0.5 MGT) = 12
    assert f"The first 10 of {rows} rows: the whole table is in quality.csv" in text


def test_an_infinite_tonnage_is_beyond_the_horizon():
    assert shown(math.inf, "MGT") == BEYOND
    assert shown(math.inf, "mm") == MISSING and shown(None) == MISSING
    assert shown(math.nan) == MISSING
    assert shown(0.29840095375357456, "m/s²") == "0.2984"  # a run's body bounce RMS
    assert shown(39059.269738109186) == "39059"  # a life-cycle cost: whole from 1000 on
    assert shown(16.0) == "16" and shown(True) == "yes"


def test_headers_take_words_from_the_vocabulary():
    assert label("dyn_load_max_kN") == f"{words('dyn_load_max').capitalize()} [kN]"
    assert label("body_bounce_acc_rms_m_per_s2") == "RMS of the body bounce acceleration [m/s²]"
    assert label("life_cycle_cost_EUR", currency="EUR").endswith("[EUR]")
    assert label("settlement_mm_at_10_MGT") == "Settlement at 10 MGT [mm]"
    assert label("mgt") == "Tonnage [MGT]"
    run, study = (label("dyn_load_sd_max_kN", f"{c} headline") for c in ("run", "study"))
    assert "largest over the contacts" in run and "mean over the contacts" in study


def test_a_forecast_headline_gives_its_quantiles_its_tonnage_unit():
    """``forecast_first_tamping_mgt``'s p10/p50/p90 are tonnages [MGT]: a segment that
    never triggers (infinite) is beyond the horizon."""
    rows = [{"section": "a", "p10": 3.0, "p50": 7.25, "p90": math.inf, "members": 20}]
    (table,) = headline_tables({"forecast_first_tamping_mgt": rows}, "deteriorate")
    assert table.title.endswith("[MGT]")
    assert table.header[1:4] == ["10th percentile [MGT]", "Median [MGT]", "90th percentile [MGT]"]
    assert table.rows == [["a", "3", "7.25", BEYOND, "20"]]


def test_figure_order_puts_the_main_figure_first():
    stems = ["wedge_friction", "wheel_loads", "secondary_displacement"]
    assert sorted(stems, key=lambda s: caption(s)[0])[0] == "wheel_loads"
    assert caption("open_track_straight_line")[1].endswith("section open_track")
    assert caption("with_zones_quality") < caption("with_zones_straight_line")


def test_csv_preview_shows_ten_rows_and_counts_them_all(tmp_path):
    path = tmp_path / "quality.csv"
    path.write_text("mgt,d1_sd_mm\n" + "".join(f"{k},{k / 3}\n" for k in range(500)))
    table = csv_preview(path, "deteriorate")
    assert table.count == 500 and len(table.rows) == 10
    assert table.rows[1] == ["1", "0.3333"]
