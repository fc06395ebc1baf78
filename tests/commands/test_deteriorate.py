"""`trackdyn deteriorate`: files written, and bad input refused with exit code 2."""

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import SoftSpot, synthetic_track

runner = CliRunner()

SCENARIO = """
[run]
model = "7dof"
[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[[traffic]]
vehicle = "empty"
speed_kmh = 70
passages_per_mgt = 8065
[settlement]
law = "sato"
rate_cov = 0.0                  # uniform ballast: only the soft spot makes it uneven
[loop]
total_mgt = 4
snapshot_every_mgt = 2
segment_length_m = 60
threshold_sd_mm = 0.01
[track]
geometry = "geometry.csv"
supports = "supports.csv"
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A 120 m level section with a soft spot written as CSV files, and a scenario."""
    path = tmp_path_factory.mktemp("det")
    spot = SoftSpot(centre=30.0, length=6.0, factor=0.45, gap=1.5e-3)
    trk = synthetic_track(120.0, spectrum=None, stiffness_cov=0.0, seed=1, features=(spot,))
    write_geometry(trk.geometry, path / "geometry.csv")
    write_supports(trk.supports, path / "supports.csv")
    (path / "scenario.toml").write_text(SCENARIO)
    return path


def test_deteriorate_writes_dataset_tables_and_figures(folder, tmp_path):
    out = tmp_path / "out"
    result = runner.invoke(app, ["deteriorate", str(folder / "scenario.toml"), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert {p.name for p in out.iterdir()} - {".trackdyn.json", "summary.json", "report.html"} == {
        "deterioration_geometry.nc",
        "settlement_geometry.csv",
        "geometry_geometry.png",
        "geometry_quality.png",
        "geometry_settlement_map.png",
        "geometry_straight_line.png",
        "summary.csv",
        "quality.csv",
        "maintenance.csv",
        "steps.csv",
        "vehicle_shares.csv",
    }
    ds = xr.load_dataset(out / "deterioration_geometry.nc")
    assert ds.settlement.attrs["units"] == "m" and float(ds.mgt[-1]) == 4.0
    assert list(ds.snapshot_mgt.values) == [0.0, 2.0, 4.0]
    # the rail rests on its ballast: where no sleeper hangs, the profile drops with the
    # ballast, give or take the change of its self-weight deflection (rail 60 kg/m over
    # 0.6 m plus 125.5 kg of sleeper on 60-150 kN/mm track: < 0.05 mm in all)
    bears = (ds.hanging_gap.isel(rail=0) == 0).all("mgt").values
    change = ds.profile.isel(snapshot=-1, rail=0) - ds.profile.isel(snapshot=0, rail=0)
    at_sleepers = np.interp(ds.sleeper_distance, ds.distance, change)[bears]
    np.testing.assert_allclose(
        at_sleepers, ds.settlement.isel(mgt=-1, rail=0).values[bears], atol=5e-5
    )
    table = pd.read_csv(out / "maintenance.csv")
    # Both segments start level (SD 0). Only the one with the soft spot (0-60 m) settles
    # unevenly enough to reach 0.01 mm: the other sees just the vehicle's decaying
    # oscillation after the spot (about 0.002 mm here), so it never triggers.
    assert 0 < table["trigger_mgt"].iloc[0] < 4
    assert np.isinf(table["trigger_mgt"].iloc[1])
    steps = pd.read_csv(out / "steps.csv")
    assert len(steps) == ds.attrs["steps"]
    # the straight-line diagram spans the section: no margin before its start (there was)
    import matplotlib.pyplot as plt

    from trackdyn.plots.deteriorate import plot_straight_line

    fig = plot_straight_line(ds)
    assert fig.axes[1].get_xlim() == (float(ds.distance[0]), float(ds.distance[-1]))
    plt.close(fig)


BAD = {
    "unknown key": ("[loop]\ntotal_tonnes = 5\n", "unknown key 'loop.total_tonnes'"),
    "negative tonnage": ("[loop]\ntotal_mgt = -5\n", "loop.total_mgt: Input should be greater"),
    "unknown law": ('[settlement]\nlaw = "linear"\n', "settlement.law: unknown"),
    "moved key": ('model = "7dof"\n', "key 'model' belongs in the [run] table now"),
    "one-rail model": ('[run]\nmodel = "2dof"\n', "traffic 1: model 2dof has no contact"),
    "missing file": (
        '[track]\ngeometry = "nope.csv"\nsupports = "supports.csv"\n',
        "track.geometry:",
    ),
    "unit": (
        '[settlement]\nfile = "law.toml"\n',
        "unit 'furlong' of K_s does not parse as m",
    ),
    "missing vehicle": (
        '[[traffic]]\nvehicle = "tram.toml"\npassages_per_mgt = 10\n',
        "traffic 1: ",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, case):
    text, message = BAD[case]
    (tmp_path / "law.toml").write_text(
        '[power]\nK_s = { value = 1, unit = "furlong", source = "x" }\n'
    )
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "out"
    result = runner.invoke(app, ["deteriorate", str(tmp_path / "s.toml"), "--out", str(out)])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], lines
    assert not out.exists()


def test_bad_workers_option(tmp_path):
    result = runner.invoke(app, ["deteriorate", "--workers", "0", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "--workers must be >= 1" in result.stderr
