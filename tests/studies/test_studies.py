"""Studies: task expansion, excitation cases, and the Dask runner (real LocalCluster)."""

import dataclasses

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.errors import Failure, Status
from trackdyn.io import write_geometry, write_supports
from trackdyn.options import RunOptions
from trackdyn.parallel import run_tasks
from trackdyn.simulation import simulate
from trackdyn.studies.runner import (
    Task,
    TrackRef,
    batches,
    gather,
    in_order,
    run_batch,
    run_study,
    run_task,
)
from trackdyn.studies.scenarios import Study, tasks
from trackdyn.track.excitation import RIGID_STIFFNESS, excitation_case
from trackdyn.track.synthetic import SoftSpot, synthetic_track
from trackdyn.vehicle.parameters import load_vehicle


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("study")
    trk = synthetic_track(120.0, spectrum="fra5", seed=11, features=(SoftSpot(60.0, 5.0),))
    write_geometry(trk.geometry, folder / "g.csv")
    write_supports(trk.supports, folder / "s.csv")
    return folder


def test_matrix_expands_to_every_combination(tmp_path):
    study = Study.model_validate({"kind": "matrix", "run": {"model": "2dof"}})
    runs = tasks(study, tmp_path)
    # 2 vehicles x 2 damping levels x 4 cases (§5.4.1)
    assert len(runs) == 16
    labels = pd.DataFrame([r.labels for r in runs])
    assert labels.drop_duplicates().shape[0] == 16
    high = next(
        r for r in runs if r.labels == {"vehicle": "loaded", "damping": "high", "case": "i"}
    )
    loaded = load_vehicle("loaded")
    # default high damping: rho1 x 4 and mu x 1.4 of the preset's values
    assert high.overrides["rho1"] == pytest.approx(4 * loaded.rho1)
    assert high.overrides["mu"] == pytest.approx(1.4 * loaded.mu)


def test_sensitivity_one_at_a_time_and_grid(tmp_path):
    oat = Study.model_validate(
        {"kind": "sensitivity", "sensitivity": {"parameters": ["kp", "mu"], "factors": [0.5, 1.5]}}
    )
    runs = tasks(oat, tmp_path)
    assert len(runs) == 1 + 2 * 2  # baseline + parameters x factors
    grid = Study.model_validate(
        {
            "kind": "sensitivity",
            "sensitivity": {"parameters": ["kp", "mu"], "factors": [0.5, 1.5], "grid": True},
        }
    )
    assert len(tasks(grid, tmp_path)) == 2**2


def test_excitation_cases(files):
    from trackdyn.data import load_track

    v = load_vehicle("loaded")
    lin = load_track(files / "g.csv", files / "s.csv").linearise(v.static_wheel_load)
    ds = simulate(v, excitation_case(lin, "i"), RunOptions(model="2dof", speed_kmh=54.0))
    # (i) rigid track: the wheel follows the unloaded space curve; the contact spring
    # (1e11 N/m) compresses by (load change)/k, below 1 micrometre here
    wheel = ds.displacement.sel(dof="wheel_bounce")
    assert np.abs(wheel - ds.wheel_input.isel(contact=0)).max() < 1e-6
    assert float(ds.track_stiffness.min()) == RIGID_STIFFNESS
    # (iii) level track: the input is the static deflection alone
    level = excitation_case(lin, "iii")
    assert np.all(level.track.geometry.left == 0)
    np.testing.assert_array_equal(level.k2, lin.k2)
    # (ii) constant stiffness and static deflection: the mean of the measured ones
    const = excitation_case(lin, "ii")
    assert np.ptp(const.k2) == 0 and const.k2[0, 0] == pytest.approx(lin.k2.mean())


def small_tasks(files):
    ref = TrackRef(str(files / "g.csv"), str(files / "s.csv"))
    base = Task(labels={}, track=ref, run=RunOptions(model="2dof", speed_kmh=50.0))
    runs = [
        dataclasses.replace(
            base, vehicle=v, run=base.run.with_(speed_kmh=s), labels={"vehicle": v, "speed": s}
        )
        for v in ("loaded", "empty")
        for s in (40.0, 80.0)
    ]
    bad = dataclasses.replace(
        base, overrides={"k1": -1.0}, labels={"vehicle": "bad", "speed": 40.0}
    )
    return [*runs[:2], bad, *runs[2:]]


def test_cluster_gives_the_serial_results_and_reports_failures(files):
    runs = small_tasks(files)
    serial_table, serial_ds = gather(run_tasks(runs, run_task, workers=1))
    cluster_table, cluster_ds = gather(run_tasks(runs, run_task, workers=2))
    pd.testing.assert_frame_equal(serial_table, cluster_table)
    np.testing.assert_array_equal(serial_ds.wheel_load_psd, cluster_ds.wheel_load_psd)
    failed = serial_table[serial_table["error"] != ""]
    assert list(failed["vehicle"]) == ["bad"]
    assert "k1 is -1 N/m, outside the plausible" in failed["error"].iloc[0]
    ok = serial_table[serial_table["error"] == ""]
    assert len(ok) == 4 and ok["dyn_load_sd_kN"].notna().all()


def test_study_command(files, tmp_path):
    study = tmp_path / "speed.toml"
    study.write_text(
        f'kind = "speed"\n[track]\ngeometry = "{files / "g.csv"}"\n'
        f'supports = "{files / "s.csv"}"\n[run]\nmodel = "2dof"\n'
        "[speed]\nspeeds_kmh = [30, 60]\n"
    )
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["study", str(study), "--out", str(out), "--workers", "1"])
    assert result.exit_code == 0, result.output
    assert {p.name for p in out.iterdir()} - {".trackdyn.json", "summary.json", "report.html"} == {
        "study.nc",
        "study.csv",
        "speed_sweep.png",
        "spectra.png",
    }
    table = pd.read_csv(out / "study.csv")
    assert list(table["speed_kmh"]) == [30, 60]


def test_sensitivity_study_whose_varied_runs_all_fail(files, tmp_path):
    # Only the baseline runs: the failed runs are listed, the rest saved with its figures.
    study = tmp_path / "sens.toml"
    study.write_text(
        f'kind = "sensitivity"\n[track]\ngeometry = "{files / "g.csv"}"\n'
        f'supports = "{files / "s.csv"}"\n[run]\nmodel = "2dof"\n'
        '[sensitivity]\nparameters = ["mu"]\nfactors = [10.0]\n'
    )
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["study", str(study), "--out", str(out), "--workers", "1"])
    assert result.exit_code == 0, result.output
    assert "failed (parameter=mu, factor=10.0): vehicle parameter mu is 2.5" in result.stderr
    assert {"study.csv", "tornado.png", "spectra.png"} <= {p.name for p in out.iterdir()}
    table = pd.read_csv(out / "study.csv", keep_default_na=False)
    assert list(table["error"] == "") == [True, False]


def test_study_refuses_bad_file(tmp_path):
    study = tmp_path / "bad.toml"
    study.write_text('kind = "matrix"\n[matrix]\ndamping = { high = { muu = 2.0 } }\n')
    result = CliRunner().invoke(app, ["study", str(study), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "unknown vehicle parameter 'muu'" in result.stderr


def test_batched_study_gives_the_one_by_one_table(files):
    runs = small_tasks(files)
    grouped = batches(runs, size=3)
    # the failing run is in a batch with good ones; the batches hold at most 3 runs
    assert sorted(len(b) for b in grouped) == [2, 3]
    one_by_one = gather(run_tasks(runs, run_task, workers=1))
    batched = gather(in_order(run_tasks(grouped, run_batch, workers=1)))
    pd.testing.assert_frame_equal(one_by_one[0], batched[0])
    xr.testing.assert_identical(one_by_one[1], batched[1])


def test_the_runs_of_a_batch_whose_worker_was_lost_keep_their_labels(monkeypatch):
    # `run_tasks` gives a batch whose worker died on every retry as one Failure: each run
    # of the batch gets a row with its labels and the failure's message
    from trackdyn import parallel

    lost = Failure(Status.WORKER_LOST, "its Dask worker process died running it (tries: 4)")
    monkeypatch.setattr(parallel, "run_tasks", lambda groups, func, **_: [lost] * len(groups))
    runs = [Task(labels={"speed_kmh": v}) for v in (40.0, 60.0, 80.0)]
    table, ds = gather(run_study(runs, workers=1))
    assert list(table["speed_kmh"]) == [40.0, 60.0, 80.0]
    assert list(table["error"]) == [lost.message] * 3
    assert np.isnan(ds.wheel_load_psd).all()
