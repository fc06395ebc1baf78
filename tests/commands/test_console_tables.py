"""Console tables: headers in words with units, plain numbers, folded instead of cut."""

import numpy as np
import pandas as pd
import pytest
from rich.console import Console

from trackdyn.commands.tables import MISSING, cell, frame_table
from trackdyn.labels import header

# The columns of interventions_compared.csv, values of the kind the example gives (four
# alternatives of a 1 km section over 50 MGT; costs in the user's currency per metre times
# the metres treated), one without two interventions on a segment (no mean interval).
INTERVENTIONS = pd.DataFrame(
    {
        "alternative": ["do nothing", "tamp early", "undercut", "renew approaches"],
        "tampings": [6, 9, 4, 5],
        "renewals": [0, 0, 1, 1],
        "tamped_m": [1198.8, 1800.0, 800.0, 1000.0],
        "renewed_m": [0.0, 0.0, 200.0, 40.0],
        "mean_interval_mgt": [21.5, 14.2, np.nan, 30.1],
        "tamped_m_per_100_mgt": [2397.6, 3600.0, 2000.0, 2080.0],
        "tamping_cost": [59940.0, 90000.0, 40000.0, 50000.0],
        "renewal_cost": [0.0, 0.0, 100000.0, 20000.0],
        "intervention_cost": [0.0, 0.0, 5000.0, 25000.0],
        "life_cycle_cost": [59940.0, 90000.0, 145000.0, 95000.0],
    }
)


def shown(table, width: int) -> str:
    console = Console(width=width, record=True)
    console.print(frame_table(table, "Interventions over 50 MGT"))
    return console.export_text()


@pytest.mark.parametrize("width", [60, 80, 120])
def test_a_wide_table_is_folded_with_every_header_and_the_cost(width):
    text = shown(INTERVENTIONS, width)
    assert max(len(line) for line in text.splitlines()) <= width
    assert "…" not in text and "Interventions over 50 MGT" in text
    words = {w for col in INTERVENTIONS.columns for w in header(col).split()}
    assert all(w in text for w in words), sorted(w for w in words if w not in text)
    assert "life-cycle" in text and "145000" in text and "59940" in text
    # every alternative in each folded part: its label repeated
    parts = text.count("renew approaches")
    assert parts >= (2 if width < 120 else 1)


def test_a_table_that_fits_is_not_folded():
    text = shown(INTERVENTIONS, 200)
    assert text.count("renew approaches") == 1 and text.count("Interventions over") == 1


@pytest.mark.parametrize(
    ("column", "expected"),
    [
        ("tamped_m", "tamped\n[m]"),
        ("mean_interval_mgt", "mean interval\n[MGT]"),
        ("tamped_m_per_100_mgt", "tamped\n[m/100 MGT]"),
        ("life_cycle_cost", "life-cycle cost"),
        ("tamping_cost", "tamping cost"),
        ("error_start_mm", "error at the start\n[mm]"),
        ("speed_kmh", "speed\n[km/h]"),
        ("factor_k_ss", "factor k_ss"),  # the parameter's own name
    ],
)
def test_headers_are_words_with_units(column, expected):
    assert header(column) == expected


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        (1198.8, "1199"),  # a length in full, not 1.2e+03
        (145000.0, "145000"),
        (21.54, "21.5"),
        (-0.0123, "-0.0123"),
        (np.float64(np.nan), MISSING),
        (None, MISSING),
        (np.int64(6), "6"),
        ("open", "open"),
    ],
)
def test_cells_are_plain_numbers_and_missing_is_a_dash(value, expected):
    assert cell(value) == expected


def test_missing_is_shown_as_a_dash_not_nan():
    text = shown(INTERVENTIONS, 200)
    assert "nan" not in text and MISSING in text
