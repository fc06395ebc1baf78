"""The command line: outputs of each command (bad input: test_bad_input.py)."""

import json

import numpy as np
import pandas as pd
import pytest
from rich.console import Console
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.commands.netcdf import read_netcdf
from trackdyn.commands.tables import deterioration_table, frame_table
from trackdyn.io import write_geometry, write_supports
from trackdyn.labels import header
from trackdyn.track.synthetic import synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

runner = CliRunner()


@pytest.fixture(scope="module")
def short_track(tmp_path_factory):
    """A 300 m synthetic section written as CSV files."""
    folder = tmp_path_factory.mktemp("track")
    trk = synthetic_track(300.0, spectrum="fra5", seed=3)
    write_geometry(trk.geometry, folder / "geometry.csv")
    write_supports(trk.supports, folder / "supports.csv")
    return folder


def test_version_and_help():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.stdout.startswith("trackdyn ")
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0 and "track" in result.stdout and "run" in result.stdout
    result = runner.invoke(app, ["track", "--help"])
    assert result.exit_code == 0 and "Static wheel load Ps [kN]" in result.stdout


@pytest.mark.parametrize(
    ("column", "expected"),
    [
        ("dyn_load_max_kN", "ΔP max\n[kN]"),
        ("k2_mean_kN_per_mm", "k2 mean\n[kN/mm]"),
        ("body_bounce_acc_rms_m_per_s2", "bounce RMS\n[m/s²]"),
        ("ballast_mm", "ballast\n[mm]"),
        ("contact", "contact"),
        ("factor_kp", "factor kp"),  # the factor of parameter kp
    ],
)
def test_table_headers_are_short_with_units(column, expected):
    assert header(column) == expected


def test_track_command_on_user_files(short_track, tmp_path):
    out = tmp_path / "out"
    result = runner.invoke(
        app,
        [
            "track",
            "--geometry",
            str(short_track / "geometry.csv"),
            "--supports",
            str(short_track / "supports.csv"),
            "--out",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    names = {p.name for p in out.iterdir()} - {".trackdyn.json"}
    assert names == {
        "summary.json",
        "report.html",
        "track.nc",
        "track_overview.png",
        "load_deflection.png",
        "deflection_basin.png",
    }
    ds = read_netcdf(out / "track.nc")
    assert ds.k2.attrs["units"] == "N/m" and ds.k2.shape == (2, 500)  # 300 m / 0.6 m
    # loaded = unloaded + ys, 127.5 kN default wheel load
    ys_on_grid = np.interp(ds.distance, ds.sleeper_distance, ds.ys.sel(rail="left"))
    np.testing.assert_allclose(
        ds.loaded_profile.sel(rail="left"),
        ds.unloaded_profile.sel(rail="left") + ys_on_grid,
        atol=1e-12,
    )
    assert set(ds.sd_unloaded.band.values) == {"D1", "D2"}


def test_run_command_with_scenario(short_track, tmp_path):
    scenario = tmp_path / "s.toml"
    scenario.write_text(
        '[vehicle]\npreset = "empty"\n'
        f'[track]\ngeometry = "{short_track / "geometry.csv"}"\n'
        f'supports = "{short_track / "supports.csv"}"\n'
        '[run]\nmodel = "7dof"\nspeed_kmh = 40\nstore_every = 4\nstart_m = 20\nend_m = 250\n'
    )
    out = tmp_path / "out"
    result = runner.invoke(app, ["run", str(scenario), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert {p.name for p in out.iterdir()} - {".trackdyn.json"} == {
        "summary.json",
        "report.html",
        "results.nc",
        "summary.csv",
        "wheel_loads.png",
        "wheel_load_exceedance.png",
        "secondary_displacement.png",
        "wedge_friction.png",
    }
    ds = read_netcdf(out / "results.nc")
    assert list(ds.contact.values) == ["FL", "FR", "BL", "BR"]
    assert ds.attrs["model"] == "7dof" and ds.attrs["vehicle"].startswith("empty")
    # rear axle from 20 m, front axle to 250 m: the centre covers 250 - 20 - axle span,
    # the axles 2 (b_cc + a) apart (bogie centres ± half a wheelbase)
    v = load_vehicle("empty")
    span = 2 * (v.b_cc + v.a)
    travelled = float(ds.distance[-1] - ds.distance[0])
    assert 230.0 - span - 0.5 < travelled <= 230.0 - span
    # 40 km/h and every 4th step stored, as the scenario says
    assert ds.attrs["speed_m_per_s"] == pytest.approx(40 / 3.6, rel=1e-12)
    step = float(ds.time[1] - ds.time[0])
    assert step == pytest.approx(4 * ds.attrs["time_step_s"], rel=1e-9)
    # summary.csv holds the statistics of the written wheel loads, recomputed here
    table = pd.read_csv(out / "summary.csv").set_index("contact")
    dyn = (ds.wheel_load - ds.attrs["static_wheel_load_N"]) / 1e3
    for c in ds.contact.values:
        x = dyn.sel(contact=c).values
        assert table.loc[c, "dyn_load_sd_kN"] == pytest.approx(x.std(), rel=1e-3)  # %.4g
        assert table.loc[c, "dyn_load_max_kN"] == pytest.approx(x.max(), rel=1e-3)
    secondary = float(np.abs(ds.secondary_displacement).max()) * 1e3
    assert table["secondary_max_mm"].iloc[0] == pytest.approx(secondary, rel=1e-3)


def test_short_track_refused(tmp_path):
    trk = synthetic_track(8.0, spectrum=None, seed=1)  # shorter than the 10.4 m axle span
    write_geometry(trk.geometry, tmp_path / "g.csv")
    write_supports(trk.supports, tmp_path / "s.csv")
    scenario = tmp_path / "s.toml"
    scenario.write_text('[track]\ngeometry = "g.csv"\nsupports = "s.csv"\n')
    result = runner.invoke(app, ["run", str(scenario), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "shorter than the vehicle's path" in result.stderr


def test_unwritable_output_folder_is_refused_before_any_work(tmp_path):
    blocker = tmp_path / "file.txt"
    blocker.write_text("")
    result = runner.invoke(app, ["run", "--out", str(blocker / "sub")])
    assert result.exit_code == 2 and "cannot write there" in result.stderr
    assert "results" not in result.stdout  # refused before simulating


def test_output_folder_belongs_to_one_command(tmp_path, short_track):
    out = tmp_path / "out"
    files = ["--geometry", str(short_track / "geometry.csv"), "--supports"]
    track = ["track", *files, str(short_track / "supports.csv"), "--out", str(out)]
    assert runner.invoke(app, track).exit_code == 0
    (out / "notes.txt").write_text("mine")  # a user's own file stays
    study = tmp_path / "speed.toml"
    study.write_text('kind = "speed"\n[run]\nmodel = "2dof"\n[speed]\nspeeds_kmh = [40]\n')
    result = runner.invoke(app, ["study", str(study), "--workers", "1", "--out", str(out)])
    assert result.exit_code == 2 and "holds the outputs of 'trackdyn track'" in result.stderr
    assert (out / "track.nc").exists()
    args = ["study", str(study), "--workers", "1", "--out", str(out), "--overwrite"]
    assert runner.invoke(app, args).exit_code == 0
    names = {p.name for p in out.iterdir()}
    assert "track.nc" not in names and {"study.csv", "notes.txt"} <= names


def test_study_table_fits_80_columns_without_cutting_headers():
    columns = ["vehicle", "damping", "case", "dyn_load_max_kN", "dyn_load_min_kN"]
    columns += ["dyn_load_sd_kN", "secondary_max_mm", "body_bounce_acc_rms_m_per_s2"]
    table = pd.DataFrame(
        [["loaded", "high", "iv", 25.0, -25.2, 6.65, 8.23, 0.543]], columns=columns
    )
    table["dominant_frequency_Hz"] = 1.52
    console = Console(width=80, record=True)
    console.print(frame_table(table, "matrix"))
    text = console.export_text()
    assert "…" not in text and "vehicle" in text and "damping" in text and "[m/s²]" in text
    assert max(len(line) for line in text.splitlines()) <= 80


def test_a_staging_folder_of_a_killed_process_is_removed_by_the_next_run(tmp_path):
    """SIGKILL leaves `.staging-<pid>-*` behind (no handler runs); the next command writing
    into the folder removes it, and leaves a live process's staging folder alone."""
    import os
    import subprocess
    import sys

    from trackdyn.commands.staging import output_folder

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    out = tmp_path / "out"
    (out / f".staging-{dead}-abc").mkdir(parents=True)
    (out / f".staging-{dead}-abc" / "half.nc").write_text("half written")
    (out / f".staging-{os.getppid()}-def").mkdir()  # the test runner's parent: running
    with output_folder(out, "run") as stage:
        (stage / "results.nc").write_text("whole")
    names = sorted(p.name for p in out.iterdir())
    assert names == [f".staging-{os.getppid()}-def", ".trackdyn.json", "results.nc"]


def test_results_on_stdout_progress_and_status_on_stderr(short_track, tmp_path):
    scenario = tmp_path / "s.toml"
    scenario.write_text(
        f'[track]\ngeometry = "{short_track / "geometry.csv"}"\n'
        f'supports = "{short_track / "supports.csv"}"\n[run]\nmodel = "2dof"\n'
    )
    args = ["run", str(scenario), "--out", str(tmp_path / "out")]
    normal = runner.invoke(app, args)
    assert normal.exit_code == 0, normal.output
    assert "ΔP max" in normal.stdout and "wrote" not in normal.stdout
    assert "wrote results.nc" in normal.stderr
    quiet = runner.invoke(app, ["-q", *args])
    assert quiet.exit_code == 0 and quiet.stderr == "" and "ΔP max" in quiet.stdout
    verbose = runner.invoke(app, ["-v", *args])
    digest = json.loads((tmp_path / "out" / "summary.json").read_text())["inputs"]
    assert f"input geometry: {short_track / 'geometry.csv'} {digest['geometry']['sha256']}" in (
        verbose.stderr
    )
    assert "time total:" in verbose.stderr and "ΔP max" in verbose.stdout


def test_short_help_option_and_bare_command():
    assert runner.invoke(app, ["-h"]).exit_code == 0
    bare = runner.invoke(app, [])
    assert bare.exit_code == 0 and "Commands" in bare.stdout


def test_deterioration_table_writes_never_for_no_trigger():
    row = dict(section="a", mgt=50.0, steps=3, settlement_min_mm=1.0, settlement_mean_mm=2.0,
               settlement_max_mm=3.0, d1_sd_max_initial_mm=1.0, d1_sd_max_final_mm=1.2,
               first_trigger_mgt=np.inf, hanging_rail_seats_final=0)  # fmt: skip
    console = Console(width=120, record=True)
    console.print(deterioration_table(pd.DataFrame([row]), "x"))
    text = console.export_text()
    assert "never" in text and "inf" not in text and "trigger [MGT]" in text


def test_help_lists_models_presets_and_keys():
    from trackdyn.options import RunOptions
    from trackdyn.vehicle.models import MODELS
    from trackdyn.vehicle.parameters import PRESETS

    text = " ".join(runner.invoke(app, ["run", "-h"]).stdout.split())  # lines joined
    assert f"Models: {', '.join(MODELS)}." in text
    presets = [p.name.removesuffix(".toml") for p in PRESETS.iterdir()]
    assert all(p in text for p in presets)
    assert f"[run] {', '.join(RunOptions.model_fields)}" in text


@pytest.mark.slow
def test_the_cli_starts_without_numpy_or_rich():
    """`trackdyn --version` imports neither (benchmarks/cli.py times it)."""
    import subprocess
    import sys

    code = (
        "import sys; from trackdyn.cli import app; "
        "print(sorted({'numpy', 'rich', 'scipy', 'pandas'} & set(sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.slow
def test_the_command_collects_garbage_rarely():
    """The ``trackdyn`` process sets the collector's thresholds before the command runs
    (`trackdyn.commands.staging.collect_rarely`); a program calling the CLI keeps its own."""
    import gc
    import subprocess
    import sys

    from trackdyn.commands.staging import COLLECTIONS

    code = (
        "import gc, trackdyn.cli, trackdyn.__main__ as entry; "
        "trackdyn.cli.app = lambda **_: print(gc.get_threshold()); entry.main()"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == str(COLLECTIONS) != str(gc.get_threshold())
