"""The forecast's quantiles and probabilities on members whose answers are known."""

import numpy as np
import pytest
import xarray as xr

from trackdyn.forecast.summary import (
    coverage,
    forecast_table,
    quantile_row,
    reach_probability,
)


def member(trigger, sd_end, tampings=None):
    """A deterioration result reduced to what the forecast reads: 3 segments of 200 m."""
    ds = xr.Dataset(
        {
            "trigger_mgt_any_rail": ("segment", np.asarray(trigger, dtype=float)),
            "d1_sd": (("mgt", "rail", "segment"), np.stack([np.zeros((2, 3)), sd_end])),
        },
        coords={
            "segment_start": ("segment", [0.0, 200.0, 400.0]),
            "segment_end": ("segment", [200.0, 400.0, 600.0]),
        },  # fmt: skip
    )
    if tampings is not None:
        ds["interventions"] = ("segment", np.asarray(tampings))
    return ds


def test_quantiles_are_members_values_and_inf_stays_beyond_the_horizon():
    # 10 members: 1..9 MGT and one that never reaches the threshold
    values = [*range(1, 10), np.inf]
    row = quantile_row(values)
    # inverted CDF: the smallest value with at least q of the members at or below it
    assert (row["p10"], row["p50"], row["p90"]) == (1.0, 5.0, 9.0)
    assert row["mean"] == np.inf and row["members"] == 10
    assert quantile_row([*range(1, 9), np.inf, np.inf])["p90"] == np.inf


def test_forecast_table_rows_per_segment_and_quantity():
    sd = np.full((2, 3), 1.0)
    members = [member([m, 2 * m, np.inf], sd * m, [1, 0, 0]) for m in (1.0, 2.0, 3.0)]
    table = forecast_table(members, years=[lambda x: x / 10.0] * 3)
    first = table[(table.quantity == "first_tamping_mgt")]
    assert first.p50.tolist() == [2.0, 4.0, np.inf]
    year = table[(table.quantity == "first_tamping_year")]
    assert year.p50.tolist() == [0.2, 0.4, np.inf]
    left = table[(table.quantity == "d1_sd_at_horizon_mm_left")]
    assert left.p10.tolist() == [1.0, 1.0, 1.0] and left.p90.tolist() == [3.0, 3.0, 3.0]
    assert set(table.columns) == {"segment_start_m", "segment_end_m", "quantity", "p10",
                                  "p50", "p90", "mean", "members"}  # fmt: skip


def test_reach_probability_and_coverage_count_members():
    first = np.array([[1.0, 5.0], [2.0, np.inf], [3.0, 6.0], [4.0, np.inf]])
    p = reach_probability(first, [0.5, 2.0, 10.0])
    np.testing.assert_array_equal(p, [[0.0, 0.0], [0.5, 0.0], [1.0, 0.5]])
    assert coverage([1.0, 5.0, np.inf, 9.0], [0.0, 6.0, 3.0, 1.0],
                    [2.0, 7.0, np.inf, 8.0]) == pytest.approx(0.5)  # fmt: skip
