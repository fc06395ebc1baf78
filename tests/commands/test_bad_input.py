"""Bad input of every command, one row each: refused with exit code 2, one line, no files.

A row gives the command line, the files it reads (text, or bytes where the encoding is
the point) and a fragment of the expected message.
In the files and arguments ``{track}`` stands for a folder holding a 300 m section
(``g.csv``, ``s.csv``), that geometry with a NaN at line 12 (``gnan.csv``), supports
covering only its first 50 m (``s50.csv``) and every 17th sleeper only, 10.2 m apart
(``s10.csv``). Each case
runs in a folder of its own, with ``--out out`` unless the row gives ``--out``; afterwards
that folder holds the row's files and nothing else.
"""

import errno
import os
import shutil

import pandas as pd
import pytest
import xarray as xr
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import synthetic_track

runner = CliRunner()

WAGON_K1_IN_N = 'base = "loaded"\n[k1]\nvalue = 4.0\nunit = "N/m"\nsource = "typed"\n'
TRACK = '[track]\ngeometry = "{track}/g.csv"\nsupports = "{track}/s50.csv"\n'
NAN_TRACK = '[track]\ngeometry = "{track}/gnan.csv"\nsupports = "{track}/s.csv"\n'

GEOMETRY_KM_HOLDING_M = "distance_km,left_mm,right_mm\n" + "".join(
    f"{0.25 * i:g},0,0\n" for i in range(1201)
)  # 300 m of samples 0.25 m apart, the column saying km

RATE_FIELD = '[settlement]\nrate_field = "f.csv"\n[loop]\ntotal_mgt = 0.1\n'


def rate_rows(factor, upto_m: float) -> str:
    """A rate-field file, both rails every 0.6 m from 0 to ``upto_m``."""
    rows = (f"{0.6 * i:.1f},{rail},{factor},0.1\n" for i in range(int(upto_m / 0.6) + 1)
            for rail in ("left", "right"))  # fmt: skip
    return "distance_m,rail,factor,standard_error\n" + "".join(rows)


CALIBRATION = (
    '[track]\nsupports = "s.csv"\n[[survey]]\ngeometry = "a.csv"\nmgt = 0\n'
    '[[survey]]\ngeometry = "b.csv"\nmgt = 1\n[fit]\nparameters = ["K_s"]\n'
)

CASES = [
    # (command line, files {name: text}, message fragment)
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": '[maintenance]\npolicy = "fixed"\n'},
        "maintenance policy 'fixed' needs interval_mgt",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[loop]\ntotal_mgt = 5\n[maintenance]\nhorizon_years = 3\nannual_mgt = 10\n"},
        "give the horizon as [loop] total_mgt or as [maintenance] horizon_years",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[maintenance]\nhorizon_years = 3\n"},
        "give horizon_years and annual_mgt together",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[maintenance]\nrecovery_slope = 1.5\n"},
        "recovery_slope",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[settlement]\noverrides = { K_s = 0.5 }\n[loop]\ntotal_mgt = 0.1\n"},
        "K_s = 0.5 m is outside the plausible 1e-05 to 0.01 m",
    ),
    (
        ["run", "bad.toml"],
        {
            "bad.toml": '[track]\ngeometry = "gkm.csv"\nsupports = "{track}/s.csv"\n',
            "gkm.csv": GEOMETRY_KM_HOLDING_M,
        },
        "gkm.csv: the profile samples are 250 m apart by column 'distance_km'",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[settlement]\noverrides = { K_s = -0.5 }\n[loop]\ntotal_mgt = 0.1\n"},
        "[settlement] overrides of [power] K_s = -0.5 m is outside the plausible",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[settlement]\nrate_cov = 100\n[loop]\ntotal_mgt = 0.1\n"},
        "rate_cov is 100.0, outside the plausible 0 to 3",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[loop]\nsegment_length_m = 1e6\ntotal_mgt = 0.1\n"},
        "segment_length_m = 1e+06 m is longer than the track",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nspeed_kmh = 1e6\n"},
        "run.speed_kmh: Input should be less than or equal to 400",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[run]\nspeed_kmh = "60"\n'},
        "run.speed_kmh: Input should be a valid number",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\ndt_s = 0.1\n"},
        "bad.toml: time step dt_s = 0.1 s is beyond the stability limit",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { muu = 0.3 }\n"},
        "unknown vehicle parameter 'muu'",
    ),
    (["run", "bad.toml"], {"bad.toml": "[vehicle]\noverrides = { mu = 0.9 }\n"}, "locks the wedge"),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { k1 = -5.0 }\n"},
        "k1 is -5 N/m, outside the plausible",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[vehicle]\npreset = "tanker"\n'},
        "unknown vehicle preset 'tanker'",
    ),
    (["run", "bad.toml"], {"bad.toml": "[run]\nspeed_kmh = 0\n"}, "run.speed_kmh"),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nspeed_kmh = 60\ndt_s = 0.01\n"},
        "beyond the stability limit",
    ),
    (["run", "bad.toml"], {"bad.toml": '[run]\nmodel = "3dof"\n'}, "run.model"),
    (["run", "bad.toml"], {"bad.toml": "[run]\nspeeed = 3\n"}, "unknown key 'run.speeed'"),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[track]\ngeometry = "missing.csv"\nsupports = "missing.csv"\n'},
        "missing.csv: no such file",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[track]\ngeometry = "missing.csv"\n'},
        "give both a geometry and a supports file",
    ),
    (["run", "bad.toml"], {"bad.toml": "not toml ["}, "not valid TOML"),
    (
        ["run", "bad.toml"],
        {"bad.toml": "# Prüfstrecke\n[run]\nspeed_kmh = 60\n".encode("latin-1")},
        "bad.toml: line 1: byte 0xfc is not UTF-8 (saved as Latin-1",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nspeed_kmh = 60\n".encode("utf-16")},
        "bad.toml: saved as UTF-16 (or not text); save it as UTF-8",
    ),
    (
        ["track", "--geometry", "g.csv", "--supports", "{track}/s.csv"],
        {"g.csv": "distance_m;left_mm;right_mm\n0;1,5;2,0\n0,25;1,5;2,0\n"},
        "g.csv: columns separated by ';' (a spreadsheet's CSV with decimal commas?)",
    ),
    (["track", "--wheel-load-kN", "0"], {}, "--wheel-load-kN is 0 kN, outside the plausible"),
    (["track", "--wheel-load-kN", "-3"], {}, "--wheel-load-kN is -3 kN, outside the plausible"),
    (["track", "--rail", "UIC99"], {}, "unknown rail section"),
    (["track", "--wheel-load-kN", "400"], {}, "outside the measured curve"),
    (["track", "--delta", "1.5"], {}, "delta must be in (0, 1)"),
    (
        ["track", "--geometry", "geometry.csv", "--supports", "{track}/s.csv"],
        {"geometry.csv": "distance_m,left_mm,right_mm\n0,1,1\n0.25,nan,1\n"},
        "geometry.csv: column 'left_mm' is empty, NaN, infinite or not a number at line 3",
    ),
    (
        ["study", "speed.toml"],
        {"speed.toml": 'kind = "speed"\n[speed]\nspeeds_kmh = []\n'},
        "speed.toml: speed.speeds_kmh: List should have at least 1",
    ),
    (
        ["study", "--scheduler", "garbage"],
        {},
        "--scheduler 'garbage' is not an address like tcp://HOST:PORT",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { k1 = 4.0 }\n"},
        "bad.toml: vehicle parameter k1 is 4 N/m, outside the plausible 100000 to 1e+09 N/m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { m1 = 94.4 }\n"},
        "vehicle parameter m1 is 94.4 kg, outside the plausible 1000 to 1e+06 kg",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { kp = 1e15 }\n"},
        "vehicle parameter kp is 1e+15 N/m, outside the plausible 100000 to 1e+12 N/m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[vehicle]\noverrides = { mu = "0.3" }\n'},
        "bad.toml: vehicle.overrides.mu: Input should be a valid number",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[vehicle]\nfile = "wagon.toml"\n', "wagon.toml": WAGON_K1_IN_N},
        "wagon.toml: vehicle parameter k1 is 4 N/m, outside the plausible",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[vehicle]\npreset = "empty"\nfile = "wagon.toml"\n'},
        "bad.toml: vehicle: give a preset or a file, not both",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\ndt_s = 1e-9\n"},
        "bad.toml: time step dt_s = 1e-09 s gives",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nend_m = 5000.0\n"},
        "bad.toml: end_m = 5000 m is outside the track, 0.3 to 999.9 m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nstart_m = -500.0\n"},
        "bad.toml: start_m = -500 m is outside the track, 0.3 to 999.9 m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": TRACK},
        "s50.csv: supports cover 0.3 to 49.5 m, the geometry 0 to 300 m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": TRACK.replace("s50.csv", "s10.csv")},
        "s10.csv: sleepers at 0.3 and 10.5 m are 10.2 m apart, more than the plausible 3 m",
    ),
    (
        ["track", "--geometry", "{track}/g.csv", "--supports", "{track}/s10.csv"],
        {},
        "s10.csv: sleepers at 0.3 and 10.5 m are 10.2 m apart, more than the plausible 3 m",
    ),
    (["run", "--out", ""], {}, "--out is empty"),
    (
        ["study", "bad.toml"],
        {"bad.toml": "[run]\nspeed_kmh = 60\n"},
        "bad.toml: no kind, matrix, sensitivity, speed: a run scenario",
    ),
    (
        ["study", "bad.toml"],
        {"bad.toml": 'kind = "speed"\n' + NAN_TRACK},
        "gnan.csv: column 'left_mm' is empty, NaN, infinite or not a number at line 12",
    ),
    (["study", "--workers", "100000"], {}, "--workers 100000 is outside the plausible 1 to"),
    (
        ["track", "--wheel-load-kN", "0.001"],
        {},
        "--wheel-load-kN is 0.001 kN, outside the plausible 1 to 500 kN",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": RATE_FIELD, "f.csv": rate_rows(1.0, 100.0)},  # the example is 1 km
        "the field must cover the track",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": RATE_FIELD, "f.csv": rate_rows("none", 1100.0)},
        "f.csv: line 2: needs distance_m a number, rail left or right and factor in (0, 100]",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": RATE_FIELD.replace("[loop]", "seed = 3\n[loop]")},
        "settlement: give rate_field or rate_cov and seed, not both",
    ),
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": CALIBRATION + "[settlement]\nrate_cov = 0\n"},
        "settlement.rate_cov: a calibration estimates the rate field or takes it uniform",
    ),
]


@pytest.fixture(scope="module")
def track_folder(tmp_path_factory):
    """A 300 m section, its geometry with a NaN, supports covering 50 m or 10 m apart."""
    folder = tmp_path_factory.mktemp("track")
    trk = synthetic_track(300.0, spectrum="fra5", seed=3)
    write_geometry(trk.geometry, folder / "g.csv")
    write_supports(trk.supports, folder / "s.csv")
    geometry = pd.read_csv(folder / "g.csv")
    geometry.loc[10, "left_mm"] = float("nan")
    geometry.to_csv(folder / "gnan.csv", index=False)
    rows = pd.read_csv(folder / "s.csv")
    rows[rows["distance_m"] < 50].to_csv(folder / "s50.csv", index=False)
    every_17th = rows["distance_m"].isin(rows["distance_m"].unique()[::17])
    rows[every_17th].to_csv(folder / "s10.csv", index=False)
    return folder


@pytest.mark.parametrize(("args", "files", "message"), CASES)
def test_bad_input_is_refused(tmp_path, monkeypatch, track_folder, args, files, message):
    monkeypatch.chdir(tmp_path)
    folder = track_folder.as_posix()
    for name, text in files.items():
        if isinstance(text, bytes):
            (tmp_path / name).write_bytes(text)
        else:
            (tmp_path / name).write_text(text.replace("{track}", folder))
    args = [a.replace("{track}", folder) for a in args]
    if "--out" not in args:
        args += ["--out", "out"]
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert message in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1  # one line, no traceback
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(files)  # nothing written


def test_a_scenario_with_a_byte_order_mark_is_read(tmp_path, monkeypatch):
    """A TOML saved by Windows Notepad starts with a UTF-8 byte-order mark (before: "not
    valid TOML"); it is refused or accepted as the same file without the mark."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbf[run]\nspeeed = 3\n")
    result = runner.invoke(app, ["run", "bom.toml", "--out", "out"])
    assert result.exit_code == 2
    assert "bom.toml: unknown key 'run.speeed'" in result.stderr  # read past the mark


TRACK_ARGS = ["track", "--geometry", "{track}/g.csv", "--supports", "{track}/s.csv"]


def _full_disk_errors(monkeypatch, how: str):
    """Make every netCDF write fail as on a full file system: with ENOSPC, or as netCDF-4
    reports it (``NetCDF: HDF error``, no errno) with no space left there."""

    def fail(self, *args, **kwargs):
        if how == "errno":
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", fail)
    if how == "hdf":
        full = shutil.disk_usage(".")._replace(free=0)
        monkeypatch.setattr(shutil, "disk_usage", lambda path: full)


@pytest.mark.parametrize("how", ["errno", "hdf"])
def test_a_full_disk_is_one_line_and_keeps_the_previous_outputs(
    tmp_path, monkeypatch, track_folder, how
):
    """The output folder's file system fills up while the outputs are written (before: a
    77-line ``RuntimeError: NetCDF: HDF error``): one line, and the previous run's files
    as they were."""
    monkeypatch.chdir(tmp_path)
    args = [a.replace("{track}", track_folder.as_posix()) for a in TRACK_ARGS]
    assert runner.invoke(app, [*args, "--out", "out"]).exit_code == 0
    before = {p.name: p.read_bytes() for p in (tmp_path / "out").iterdir()}
    _full_disk_errors(monkeypatch, how)
    for out in ("out", "new"):
        result = runner.invoke(app, [*args, "--out", out])
        assert result.exit_code == 2, result.output
        assert result.stderr.startswith(f"error: no space left on {out}: nothing written")
        assert len(result.stderr.strip().splitlines()) == 1
    assert {p.name: p.read_bytes() for p in (tmp_path / "out").iterdir()} == before
    assert not (tmp_path / "new").exists()


UNREADABLE = [
    # (command line, the file made unreadable, files {name: text})
    (["run", "bad.toml"], "bad.toml", {"bad.toml": "[run]\nspeed_kmh = 60\n"}),
    (["run", "bad.toml"], "g.csv", {"bad.toml": '[track]\ngeometry = "g.csv"\n'
                                                'supports = "{track}/s.csv"\n'}),
    (["track", "--geometry", "g.csv", "--supports", "{track}/s.csv"], "g.csv", {}),
    (["deteriorate", "bad.toml"], "z.csv", {"bad.toml": '[track]\ngeometry = "g.csv"\n'
                                            'supports = "{track}/s.csv"\nzones = "z.csv"\n',
                                            "z.csv": "start_m,end_m,kind\n0,50,structure\n"}),
    (["deteriorate", "bad.toml"], "l.csv", {"bad.toml": '[track]\nsections = "l.csv"\n',
                                            "l.csv": "name,geometry,supports\na,g.csv,s.csv\n"}),
]  # fmt: skip


@pytest.mark.parametrize(("args", "unreadable", "files"), UNREADABLE)
def test_an_unreadable_file_is_named(tmp_path, monkeypatch, track_folder, args, unreadable, files):
    """A file without read permission (before: a 68-line PermissionError, or click's
    four-line usage error for a file given on the command line): one line naming it."""
    monkeypatch.chdir(tmp_path)
    folder = track_folder.as_posix()
    shutil.copy(track_folder / "g.csv", tmp_path / "g.csv")
    for name, text in files.items():
        (tmp_path / name).write_text(text.replace("{track}", folder))
    (tmp_path / unreadable).chmod(0)
    if os.access(tmp_path / unreadable, os.R_OK):
        pytest.skip("files without read permission are readable here (root)")
    args = [a.replace("{track}", folder) for a in args]
    result = runner.invoke(app, [*args, "--out", "out"])
    assert result.exit_code == 2, result.output
    assert f"{unreadable}: cannot read the file (Permission denied)" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()
