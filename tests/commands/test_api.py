"""The scenario objects (`trackdyn.api`): what a script gets is what the command writes,
to the bit, and the same figures."""

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from matplotlib.figure import Figure
from test_provenance import inputs_folder, invoke

import trackdyn
from trackdyn.errors import TrackdynInputError


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    """The provenance tests' inputs (a 150 m section, a 4-DOF run, 0.5 MGT of
    deterioration, the calibration example cut to a quick fit) and each command's outputs."""
    base = tmp_path_factory.mktemp("api")
    inputs_folder(base)
    for command in ("run", "deteriorate"):
        invoke(command, base, base / command)
    return base


def pngs(folder):
    return sorted(p.name for p in folder.glob("*.png"))


def test_a_run_is_the_commands_run(folders):
    run = trackdyn.Run.from_file(folders / "run.toml").solve()
    written = xr.open_dataset(folders / "run" / "results.nc")
    np.testing.assert_array_equal(run.results.wheel_load.values, written.wheel_load.values)
    table = pd.read_csv(folders / "run" / "summary.csv")
    np.testing.assert_allclose(run.summary()["dyn_load_max_kN"], table["dyn_load_max_kN"],
                               rtol=5e-4)  # fmt: skip  # summary.csv: 4 significant digits
    figures = run.plot()
    assert sorted(figures) == pngs(folders / "run")
    assert all(isinstance(f, Figure) for f in figures.values())


def test_a_run_of_its_parts_is_simulate():
    # the built-in example by default; the same Dataset simulate gives, to the bit
    options = trackdyn.RunOptions(model="2dof", end_m=200)
    run = trackdyn.Run(options=options).solve()
    alone = trackdyn.simulate(trackdyn.load_vehicle("loaded"), trackdyn.load_track(), options)
    xr.testing.assert_identical(run.results, alone)
    assert len(run.summary()) == 1  # the 2-DOF model: one contact


def test_results_are_asked_for_before_solving():
    with pytest.raises(TrackdynInputError, match=r"Run: call \.solve\(\) first"):
        trackdyn.Run(options=trackdyn.RunOptions(model="2dof")).plot()


def test_a_deterioration_is_the_commands(folders):
    life = trackdyn.Deterioration.from_file(folders / "det.toml").solve(workers=1)
    (ds,) = life.results
    name = ds.attrs["section"]
    written = xr.open_dataset(folders / "deteriorate" / f"deterioration_{name}.nc")
    np.testing.assert_array_equal(ds.settlement.values, written.settlement.values)
    table = pd.read_csv(folders / "deteriorate" / "summary.csv")
    np.testing.assert_allclose(life.summary()["d1_sd_max_final_mm"], table["d1_sd_max_final_mm"],
                               rtol=1e-5)  # fmt: skip  # summary.csv: 6 significant digits
    assert sorted(life.plot()) == pngs(folders / "deteriorate")


def test_a_bad_scenario_is_refused_when_made(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[loop]\ntotal_mgt = -1\n")
    with pytest.raises(TrackdynInputError, match="total_mgt"):
        trackdyn.Deterioration.from_file(bad)


def test_a_calibration_is_the_commands(folders):
    invoke("calibrate", folders / "cal", folders / "calibrate")
    cal = trackdyn.Calibration.from_file(folders / "cal" / "quick.toml").solve(workers=1)
    table = pd.read_csv(folders / "calibrate" / "fit.csv")
    mine = cal.summary()
    assert list(mine.columns) == list(table.columns)
    numbers = mine.select_dtypes("number").columns
    np.testing.assert_allclose(mine[numbers], table[numbers], rtol=1e-5)
    assert sorted(cal.plot()) == pngs(folders / "calibrate")
