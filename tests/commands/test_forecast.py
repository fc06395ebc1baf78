"""`trackdyn deteriorate` with ``[forecast]``: the ensemble's files, a deterministic run
left as it was, and the table refused where it is wrong."""

import json

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.forecast.spread import Posterior, posterior_toml
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import synthetic_track

runner = CliRunner()

SCENARIO = """
[run]
model = "4dof"
[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[settlement]
law = "power"
[loop]
total_mgt = 4
snapshot_every_mgt = 2
segment_length_m = 50
threshold_sd_mm = 1.0
[track]
geometry = "geometry.csv"
supports = "supports.csv"
"""

FORECAST = """
[forecast]
members = 4
seed = 1
posterior = "posterior.toml"
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A 100 m section, a scenario with and without [forecast], and a posterior of the
    power law's K_s and exponent with correlated errors (as a calibration writes it)."""
    path = tmp_path_factory.mktemp("forecast")
    trk = synthetic_track(100.0, spectrum="fra5", seed=5)
    write_geometry(trk.geometry, path / "geometry.csv")
    write_supports(trk.supports, path / "supports.csv")
    (path / "plain.toml").write_text(SCENARIO)
    (path / "forecast.toml").write_text(SCENARIO + FORECAST)
    cov = np.array([[0.04, -0.018], [-0.018, 0.01]])  # ln K_s sd 0.2, ln exponent sd 0.1
    post = Posterior(("K_s", "load_exponent"), np.log([0.9e-3, 2.0]), cov, np.ones(2, bool))
    (path / "posterior.toml").write_text(posterior_toml(post, "power"))
    return path


def run(folder, scenario, out):
    result = runner.invoke(app, ["deteriorate", str(folder / scenario), "--workers", "1",
                                 "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    return result


def test_forecast_writes_its_tables_and_keeps_the_deterministic_run(folder, tmp_path):
    plain, ens = tmp_path / "plain", tmp_path / "ens"
    run(folder, "plain.toml", plain)
    result = run(folder, "forecast.toml", ens)
    assert "First tamping, 4 members" in result.output
    a = xr.open_dataset(plain / "deterioration_geometry.nc")
    b = xr.open_dataset(ens / "deterioration_geometry.nc")
    for name in a.data_vars:  # the deterministic run is the same, to the bit
        np.testing.assert_array_equal(a[name].values, b[name].values)
    table = pd.read_csv(ens / "forecast.csv")
    quantities = {"first_tamping_mgt", "tampings", "d1_sd_at_horizon_mm_left",
                  "d1_sd_at_horizon_mm_right"}  # fmt: skip
    assert set(table.quantity) == quantities and len(table) == 2 * len(quantities)
    assert (table.members == 4).all()
    assert (table.p10 <= table.p50).all() and (table.p50 <= table.p90).all()
    prob = pd.read_csv(ens / "forecast_probability.csv")
    assert prob.columns.tolist() == ["section", "segment_start_m", "segment_end_m", "by_mgt",
                                     "probability"]  # fmt: skip
    for _, seg in prob.groupby("segment_start_m"):  # a share that can only grow
        assert np.all(np.diff(seg.probability.values) >= 0)
    headline = json.loads((ens / "summary.json").read_text())["headline"]
    assert len(headline["forecast_first_tamping_mgt"]) == 2
    for name in ("geometry_forecast_fan.png", "forecast_probability.png"):
        assert (ens / name).stat().st_size > 10_000
    # without the section's figures: the same tables, no figure but the line's (none here)
    bare = tmp_path / "bare"
    result = runner.invoke(app, ["deteriorate", str(folder / "forecast.toml"), "--workers", "1",
                                 "--out", str(bare), "--section-figures", "0"])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert not list(bare.glob("*.png"))
    pd.testing.assert_frame_equal(pd.read_csv(bare / "forecast.csv"), table)


@pytest.mark.parametrize(
    "table, message",
    [
        ("[forecast]\nmembers = 1\n", "members"),
        ("[forecast]\nparameters = { K_s = { cov = 0.2, min = 1 } }\n", "give cov, or min"),
        ("[forecast]\nannual_growth = 0.02\n", "needs the horizon in years"),
        ('[forecast]\nposterior = "missing.toml"\n', "missing.toml"),
        ('[forecast]\nrate_field_draws = "draws.csv"\n', "draws.csv (draw 1): no left-rail row"),
    ],
)
def test_a_wrong_forecast_table_is_refused_in_one_line(folder, tmp_path, table, message):
    # draws of a calibration of another section: a field that does not cover this one
    (tmp_path / "draws.csv").write_text("distance_m,rail,draw,factor\n500,left,1,1.1\n"
                                        "500,right,1,0.9\n")  # fmt: skip
    text = SCENARIO.replace("geometry.csv", str(folder / "geometry.csv"))
    (tmp_path / "bad.toml").write_text(text.replace("supports.csv", str(folder / "supports.csv"))
                                       + table)  # fmt: skip
    result = runner.invoke(app, ["deteriorate", str(tmp_path / "bad.toml"), "--workers", "1",
                                 "--out", str(tmp_path / "o")])  # fmt: skip
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output
    assert not (tmp_path / "o").exists()


def test_the_probability_figure_has_at_most_its_panels(folder, tmp_path):
    """A line of many sections drawn: a fan each, but at most `PROBABILITY_PANELS` panels of
    2.2 in in the probability figure (250 would pass matplotlib's 65 536 pixels)."""
    from trackdyn.commands.deteriorate.forecast import (
        PROBABILITY_PANELS,
        Forecast,
        forecast_figures,
        tables,
    )

    run(folder, "plain.toml", tmp_path / "plain")
    ds = xr.load_dataset(tmp_path / "plain" / "deterioration_geometry.nc")
    names = [f"s{i}" for i in range(PROBABILITY_PANELS + 3)]
    forecast = Forecast(None, [[ds, ds]] * len(names), None, None)  # two members a section
    _, probability = tables(forecast, names)
    figures = forecast_figures(forecast, names, probability, names[1:])  # all but s0
    assert len(figures) == len(names)  # the fans of all but s0, and the probability
    shown = figures["forecast_probability.png"].args[0]
    assert list(dict.fromkeys(shown.section)) == names[1 : PROBABILITY_PANELS + 1]
    assert (
        f"the first {PROBABILITY_PANELS} of the {len(names) - 1}"
        in (figures["forecast_probability.png"].kwargs["title"])
    )
    few = forecast_figures(forecast, names, probability, names[:2])
    assert (
        few["forecast_probability.png"].kwargs["title"] == "Probability of reaching the threshold"
    )
    assert not forecast_figures(forecast, names, probability, [])
