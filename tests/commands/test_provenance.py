"""Provenance: every input file of run, deteriorate and calibrate with its SHA-256 in
``summary.json`` and the netCDF attributes, built-in files with theirs, the date and the
versions (`trackdyn.provenance`)."""

import hashlib
import json
import re
import shutil
from pathlib import Path

import pytest
import xarray as xr
from typer.testing import CliRunner

import trackdyn
from trackdyn.cli import app
from trackdyn.commands.examples import write_example
from trackdyn.io import read_geometry, write_geometry, write_supports
from trackdyn.provenance import BUILT_IN, PACKAGES
from trackdyn.track.synthetic import synthetic_track
from trackdyn.track.track import Geometry

runner = CliRunner()

RUN = '[run]\nmodel = "4dof"\nstore_every = 8\n[track]\ngeometry = "geometry.csv"\n' \
      'supports = "supports.csv"\n'  # fmt: skip
DETERIORATE = """
[run]
model = "4dof"
[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[loop]
total_mgt = 0.5
snapshot_every_mgt = 0.5
segment_length_m = 50
[track]
geometry = "geometry.csv"
supports = "supports.csv"
zones = "zones.csv"
"""
ZONES = "start_m,end_m,kind\n60,80,structure\n"
QUICK_FIT = {  # the shipped calibration example cut to a few model runs: seconds, not minutes
    'model = "7dof"': 'model = "4dof"',
    'parameters = ["K_s", "load_exponent"]': 'parameters = ["K_s"]',
    'rate_field = "estimate"': 'rate_field = "uniform"\nmax_iterations = 2',
}
USER_FILES = {  # the files each command reads from the folder (besides the built-in ones)
    "run": {"run.toml", "geometry.csv", "supports.csv"},
    "deteriorate": {"det.toml", "geometry.csv", "supports.csv", "zones.csv"},
    "calibrate": {"quick.toml", "supports.csv", "survey_1.csv", "survey_2.csv", "survey_3.csv"},
}
BUILT_IN_FILES = {  # the shipped files each command reads
    "run": {"vehicle/presets/loaded.toml"},
    "deteriorate": {"vehicle/presets/loaded.toml", "deterioration/settlement.toml"},
    "calibrate": {"vehicle/presets/loaded.toml", "vehicle/presets/empty.toml",
                  "deterioration/settlement.toml"},
}  # fmt: skip


def invoke(command: str, base, out):
    """Run ``command`` on the files in ``base`` into ``out``; its exit code checked."""
    args = {
        "run": ["run", str(base / "run.toml")],
        "deteriorate": ["deteriorate", str(base / "det.toml"), "--workers", "1"],
        "calibrate": ["calibrate", str(base / "quick.toml"), "--workers", "1",
                      "--allow-not-converged"],
    }[command]  # fmt: skip
    result = runner.invoke(app, ["-q", *args, "--out", str(out)])
    assert result.exit_code == 0, result.output


def inputs_folder(base):
    """A 150 m synthetic section with zones, a run and a deterioration scenario, and the
    calibration example with its quick fit, all in ``base``."""
    trk = synthetic_track(150.0, spectrum="fra5", seed=5)
    write_geometry(trk.geometry, base / "geometry.csv")
    write_supports(trk.supports, base / "supports.csv")
    (base / "zones.csv").write_text(ZONES)
    (base / "run.toml").write_text(RUN)
    (base / "det.toml").write_text(DETERIORATE)
    write_example("calibration", base / "cal")
    text = (base / "cal" / "calibration.toml").read_text()
    for old, new in QUICK_FIT.items():
        assert old in text
        text = text.replace(old, new)
    (base / "cal" / "quick.toml").write_text(text)


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    """The inputs and the output folder of each command."""
    base = tmp_path_factory.mktemp("provenance")
    inputs_folder(base)
    out = {}
    for command in USER_FILES:
        out[command] = base / f"{command}-out"
        invoke(command, base / "cal" if command == "calibrate" else base, out[command])
    return base, out


def sha(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("command", list(USER_FILES))
def test_summary_holds_every_input_file_with_its_hash(folders, command):
    base, out = folders
    folder = base / "cal" if command == "calibrate" else base
    summary = json.loads((out[command] / "summary.json").read_text())
    inputs = {item["path"]: item["sha256"] for item in summary["inputs"].values()}
    mine = {str((folder / n).resolve()): sha(folder / n) for n in USER_FILES[command]}
    root = Path(trackdyn.__file__).parent  # shipped files: hashed as shipped
    shipped = {BUILT_IN + "trackdyn/" + n: sha(root / n) for n in BUILT_IN_FILES[command]}
    assert inputs == mine | shipped


@pytest.mark.parametrize("command", ["run", "deteriorate"])
def test_netcdf_attributes_hold_the_same_inputs(folders, command):
    _, out = folders
    summary = json.loads((out[command] / "summary.json").read_text())
    for path in sorted(out[command].glob("*.nc")):
        with xr.open_dataset(path) as ds:
            attrs = dict(ds.attrs)
        for role, item in summary["inputs"].items():
            assert attrs[f"input_{role}"] == item["path"], (path.name, role)
            assert attrs[f"input_{role}_sha256"] == item["sha256"], (path.name, role)
        assert attrs["date_created"] == summary["created"]
        assert attrs["history"] == f"{summary['created']} {summary['command_line']}"
        for name in ("python", *PACKAGES):
            assert attrs[f"{name}_version"] == summary["versions"][name]


@pytest.mark.parametrize("command", list(USER_FILES))
def test_summary_says_when_and_on_what(folders, command):
    _, out = folders
    summary = json.loads((out[command] / "summary.json").read_text())
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", summary["created"])
    assert set(summary["versions"]) == {"python", *PACKAGES}
    assert summary["versions"]["numpy"] == __import__("numpy").__version__


def test_options_are_json_and_none_is_left_out(folders):
    _, out = folders
    with xr.open_dataset(out["deteriorate"] / "deterioration_geometry.nc") as ds:
        attrs = dict(ds.attrs)
    run = json.loads(attrs["option_run"])  # a table: JSON text
    assert run["model"] == "4dof" and run["dt_s"] is None  # JSON null inside JSON
    assert "option_run_dt_s" not in attrs  # a None option: no attribute
    assert attrs["option_run_nonlinear"] == "false"
    assert json.loads(attrs["settlement_parameters_SI"])["load_exponent"] == 2.0  # shipped
    assert not any(str(v) in ("none", "default", "None") for v in attrs.values())


def test_editing_geometry_changes_the_recorded_hash(folders, tmp_path):
    base, out = folders
    for name in USER_FILES["deteriorate"]:
        shutil.copy(base / name, tmp_path / name)
    g = read_geometry(tmp_path / "geometry.csv")
    write_geometry(Geometry(g.distance, g.left * 1.1, g.right), tmp_path / "geometry.csv")
    invoke("deteriorate", tmp_path, tmp_path / "out")
    before = json.loads((out["deteriorate"] / "summary.json").read_text())["inputs"]
    after = json.loads((tmp_path / "out" / "summary.json").read_text())["inputs"]
    assert after["geometry"]["sha256"] == sha(tmp_path / "geometry.csv")
    assert after["geometry"]["sha256"] != before["geometry"]["sha256"]
    assert after["zones"]["sha256"] == before["zones"]["sha256"]  # the same zones file
    with xr.open_dataset(tmp_path / "out" / "deterioration_geometry.nc") as ds:
        assert ds.attrs["input_geometry_sha256"] == after["geometry"]["sha256"]


def test_source_date_epoch_fixes_the_date(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")  # 2023-11-14 22:13:20 UTC
    inputs_folder(tmp_path)
    invoke("run", tmp_path, tmp_path / "out")
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["created"] == (
        "2023-11-14T22:13:20Z"
    )
