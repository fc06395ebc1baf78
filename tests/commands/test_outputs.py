"""What the commands write for toolchains: CF-1.8 netCDF with provenance, summary.json,
the same bytes for the same run."""

import base64
import hashlib
import json
import shutil
import subprocess
import warnings
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from typer.testing import CliRunner

import trackdyn
from trackdyn.cli import app
from trackdyn.commands.netcdf import read_netcdf
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import synthetic_track

runner = CliRunner()

SUMMARY_KEYS = {
    "trackdyn_version",
    "versions",
    "created",
    "command",
    "command_line",
    "title",
    "inputs",
    "options",
    "vehicle",
    "headline",
    "timings_s",
    "files",
}
DETERIORATION = """
[run]
model = "7dof"
[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[loop]
total_mgt = 1
snapshot_every_mgt = 1
segment_length_m = 60
[track]
geometry = "geometry.csv"
supports = "supports.csv"
"""

MAINTENANCE = """
[maintenance]
policy = "threshold"
"""
INTERVENTIONS = """
kind = "interventions"
scenario = "maintained.toml"
[[alternative]]
name = "base"
[[alternative]]
name = "later"
threshold_sd_mm = 2.5
"""
COMMAND = {"sensitivity": "study", "interventions": "study"}
"""The command of each output folder that is not named after its command."""


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """run, track, study and deteriorate on a 150 m synthetic section: their folders (the
    date fixed by SOURCE_DATE_EPOCH, so that a second run can write the same bytes)."""
    with pytest.MonkeyPatch.context() as env:
        env.setenv("SOURCE_DATE_EPOCH", EPOCH)
        yield _outputs(tmp_path_factory.mktemp("outputs"))


EPOCH = "1700000000"
"""A fixed date for the files (2023-11-14 22:13:20 UTC)."""


def _outputs(base):
    trk = synthetic_track(150.0, spectrum="fra5", seed=5)
    write_geometry(trk.geometry, base / "geometry.csv")
    write_supports(trk.supports, base / "supports.csv")
    track = '[track]\ngeometry = "geometry.csv"\nsupports = "supports.csv"\n'
    (base / "run.toml").write_text(track + '[run]\nmodel = "7dof"\nstore_every = 4\n')
    (base / "study.toml").write_text(
        'kind = "speed"\n' + track + '[run]\nmodel = "2dof"\n[speed]\nspeeds_kmh = [40, 60]\n'
    )
    (base / "sensitivity.toml").write_text(
        'kind = "sensitivity"\n' + track + '[run]\nmodel = "2dof"\n[sensitivity]\n'
        'parameters = ["k1", "mu"]\nfactors = [0.5]\n'
    )
    (base / "det.toml").write_text(DETERIORATION)
    (base / "maintained.toml").write_text(DETERIORATION + MAINTENANCE)
    (base / "interventions.toml").write_text(INTERVENTIONS)
    files = ["--geometry", str(base / "geometry.csv"), "--supports", str(base / "supports.csv")]
    commands = {
        "run": ["run", str(base / "run.toml")],
        "track": ["track", *files],
        "study": ["study", str(base / "study.toml"), "--workers", "1"],
        "deteriorate": ["deteriorate", str(base / "det.toml"), "--workers", "1"],
        "sensitivity": ["study", str(base / "sensitivity.toml"), "--workers", "1"],
        "interventions": ["study", str(base / "interventions.toml"), "--workers", "1"],
    }
    folders = {}
    for name, args in commands.items():
        folders[name] = base / name
        result = runner.invoke(app, [*args, "--out", str(folders[name])])
        assert result.exit_code == 0, result.output
    return base, folders


def cf_messages(path, tmp_path) -> list[str]:
    """Every message of the IOOS compliance checker's CF-1.8 suite on ``path``, and any
    exception the checker met (reported as a message too)."""
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    report = tmp_path / "report.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the checker's own deprecation warnings
        CheckSuite.load_all_available_checkers()
        _, crashed = ComplianceChecker.run_checker(
            str(path), ["cf:1.8"], 0, "lenient", output_filename=str(report),
            output_format="json",
        )  # fmt: skip
    result = json.loads(report.read_text())["cf:1.8"]
    messages = [f"{p['name']}: {m}" for p in result["all_priorities"] for m in p["msgs"]]
    return messages + (["the checker raised an exception"] if crashed else [])


NETCDF = {
    "run": "results.nc",
    "track": "track.nc",
    "study": "study.nc",
    "deteriorate": "deterioration_geometry.nc",
    "sensitivity": "study.nc",
    "interventions": "interventions_compared.nc",
}
CHECKER_HEURISTIC = (
    "§5.1 Independent Latitude, Longitude, Vertical, and Time Axes: Coordinate variable "
    "'time' should have standard_name='time', found: 'None'"
)
"""The one message the checker gives on a run's file: it takes a dimension named ``time``
for calendar time by its name, where CF 1.8 (4.4) tells a time coordinate by its units
(``<unit> since <date>``); a run's ``time`` is in seconds from its start."""


@pytest.mark.parametrize("command", list(NETCDF))
def test_netcdf_files_pass_the_cf_checker(outputs, command, tmp_path):
    pytest.importorskip("compliance_checker")
    _, folders = outputs
    expected = [CHECKER_HEURISTIC] if command == "run" else []
    assert sorted(set(cf_messages(folders[command] / NETCDF[command], tmp_path))) == expected


@pytest.mark.parametrize("command", list(NETCDF))
def test_netcdf_files_say_what_made_them(outputs, command):
    base, folders = outputs
    with xr.open_dataset(folders[command] / NETCDF[command]) as ds:
        attrs = dict(ds.attrs)
        for name, var in ds.variables.items():
            assert var.attrs.get("long_name"), name
            assert "_FillValue" not in var.encoding or name not in ds.coords, name
        assert set(ds.dims) <= set(ds.indexes)  # every dimension has an index coordinate
        if "sleeper" in ds.dims:  # the positions: ds.k2.plot() draws against distance
            np.testing.assert_array_equal(ds.sleeper, ds.sleeper_distance)
            assert ds.sleeper.attrs["units"] == "m"
    assert attrs["Conventions"] == "CF-1.8"
    assert attrs["trackdyn_version"] == trackdyn.__version__
    ran = COMMAND.get(command, command)
    assert attrs["title"] and attrs["history"].startswith(f"2023-11-14T22:13:20Z trackdyn {ran}")
    if command in ("deteriorate", "interventions"):
        return  # the sections name their own track files
    geometry = base / "geometry.csv"
    assert attrs["input_geometry"] == str(geometry)
    assert attrs["input_geometry_sha256"] == hashlib.sha256(geometry.read_bytes()).hexdigest()
    if command == "run":
        assert attrs["option_run_model"] == "7dof" and attrs["vehicle_mu"] == 0.25  # preset


LABELS = {  # a selection by label in each file, and the dimension left
    "run": ({"contact": "FL"}, "wheel_load", "time"),
    "track": ({"rail": "left", "band": "D1"}, "sd_loaded", "segment"),
    "study": ({"speed_kmh": 60.0}, "wheel_load_psd", "frequency"),
    "deteriorate": ({"rail": "right", "vehicle": "loaded"}, "settlement_by_vehicle", "sleeper"),
    "sensitivity": ({"parameter": "mu"}, "dyn_load_sd_kN", None),
    "interventions": ({"alternative": "later"}, "tampings", None),
}


@pytest.mark.parametrize("command", list(NETCDF))
def test_plain_xarray_selects_by_label(outputs, command):
    """``xr.open_dataset``, no trackdyn reader: names as coordinates, the swept quantity of
    a study along ``run`` (made an index with ``set_xindex`` to select on it)."""
    _, folders = outputs
    where, name, left = LABELS[command]
    with xr.open_dataset(folders[command] / NETCDF[command]) as ds:
        assert set(ds.dims) <= set(ds.indexes) and "run_time" not in ds.dims
        for key in where:
            if key not in ds.dims:
                ds = ds.set_xindex(key)
        picked = ds[name].sel(where)
        assert picked.dims == ((left,) if left else ())
        if command == "sensitivity":  # one run varies mu (factor 0.5)
            assert float(picked.factor) == 0.5
        assert all(ds[label].dtype.kind in "UOf" for label in where)


def test_interventions_file_has_counts_and_words(outputs):
    _, folders = outputs
    table = pd.read_csv(folders["interventions"] / "interventions_compared.csv")
    with xr.open_dataset(folders["interventions"] / "interventions_compared.nc") as ds:
        assert list(ds.alternative.values) == ["base", "later"]
        assert ds.tampings.dtype.kind == "i" and ds.tampings.attrs["units"] == "1"
        np.testing.assert_array_equal(ds.tampings.values, table["tampings"])  # the same counts
        assert ds.tamped_m_per_100_mgt.attrs["units"] == "m/(100 Mt)"
        assert ds.tamped_m_per_100_mgt.attrs["long_name"] == "length of track tamped per 100 MGT"


def test_long_names_are_words(outputs):
    """No long_name is made of a name's abbreviations (``dyn load max``)."""
    _, folders = outputs
    abbreviations = {"dyn", "sd", "acc", "rms", "mgt", "max", "min"}
    for command, name in NETCDF.items():
        with xr.open_dataset(folders[command] / name) as ds:
            for var, v in ds.variables.items():
                tokens = set(v.attrs["long_name"].replace(",", " ").split())
                assert not tokens & abbreviations, (command, var, v.attrs["long_name"])


def test_run_file_reads_back_as_the_command_had_it(outputs):
    _, folders = outputs
    ds = read_netcdf(folders["run"] / "results.nc")
    assert list(ds.contact.values) == ["FL", "FR", "BL", "BR"]
    assert ds.wheel_load.dims == ("time", "contact")
    assert list(ds.dof_units.values[:3]) == ["m", "rad", "rad"]  # body bounce, roll, pitch


def strict_json(text: str):
    """JSON as the standard has it: NaN and Infinity refused."""

    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.parametrize("command", ["run", "track", "study", "deteriorate"])
def test_summary_json_describes_the_run(outputs, command):
    _, folders = outputs
    summary = strict_json((folders[command] / "summary.json").read_text())
    assert set(summary) == SUMMARY_KEYS
    assert summary["command"] == command and summary["trackdyn_version"] == trackdyn.__version__
    names = {p.name for p in folders[command].iterdir()} - {".trackdyn.json"}
    assert set(summary["files"]) == names
    assert summary["timings_s"]["total"] > 0
    headline = summary["headline"]
    if command == "deteriorate":  # one section, 1 MGT; the timings of its parts kept here
        assert [s["section"] for s in headline["sections"]] == ["geometry"]
        assert headline["sections"][0]["mgt"] == 1.0
        assert {"time_vehicle_runs_s", "time_beam_solves_s"} <= set(summary["timings_s"])
        return
    assert summary["inputs"]["geometry"]["sha256"]
    if command == "run":
        table = np.genfromtxt(folders["run"] / "summary.csv", delimiter=",", names=True)
        assert headline["dyn_load_max_kN"] == pytest.approx(table["dyn_load_max_kN"].max(), 1e-3)
    if command == "study":
        assert headline["runs"] == 2 and headline["failed_runs"] == 0


def test_identical_runs_write_identical_netcdf_files(outputs, monkeypatch):
    base, folders = outputs
    monkeypatch.setenv("SOURCE_DATE_EPOCH", EPOCH)  # the date of the first runs
    first = {name: (folders[c] / name).read_bytes() for c, name in NETCDF.items()}
    commands = {
        "run": ["run", str(base / "run.toml")],
        "deteriorate": ["deteriorate", str(base / "det.toml"), "--workers", "1"],
    }
    for command, args in commands.items():  # into the same folder: the same command line
        result = runner.invoke(app, [*args, "--out", str(folders[command])])
        assert result.exit_code == 0, result.output
        assert (folders[command] / NETCDF[command]).read_bytes() == first[NETCDF[command]]


class _Page(HTMLParser):
    """The tags, image sources and text of an HTML page."""

    def __init__(self):
        super().__init__()
        self.tags, self.images, self.text = [], [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag == "img":
            self.images.append(dict(attrs)["src"])

    def handle_data(self, data):
        self.text.append(data)


@pytest.mark.parametrize("command", ["run", "track", "study", "deteriorate"])
def test_report_holds_provenance_tables_and_every_figure(outputs, command):
    _, folders = outputs
    folder = folders[command]
    page = _Page()
    page.feed((folder / "report.html").read_text(encoding="utf-8"))
    text = " ".join(page.text)
    summary = json.loads((folder / "summary.json").read_text())
    pngs = sorted(p for p in folder.iterdir() if p.suffix == ".png")
    assert len(page.images) == len(pngs) > 0
    embedded = {"data:image/png;base64," + base64.b64encode(p.read_bytes()).decode() for p in pngs}
    assert set(page.images) == embedded  # each once (their order: test_report.py)
    csvs = [p.name for p in folder.iterdir() if p.suffix == ".csv"]
    assert all(name in text for name in csvs) and page.tags.count("table") >= 3 + len(csvs)
    assert summary["title"] in text and summary["command_line"] in text
    assert all(item["sha256"] in text for item in summary["inputs"].values())


@pytest.mark.slow
def test_report_renders_in_a_browser(outputs, tmp_path):
    """Where chromium is installed (CI installs Debian's), a headless screenshot of the run's
    report is not blank."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("no chromium")
    from PIL import Image

    _, folders = outputs
    shot = tmp_path / "shot.png"
    subprocess.run(
        [browser, "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}",
         "--window-size=1200,2000", (folders["run"] / "report.html").as_uri()],
        check=True, capture_output=True, timeout=120,
    )  # fmt: skip
    pixels = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert pixels.std() > 10  # text, tables and figures, not one colour
