"""Sections lists and their runs through Dask: same results with 1 and 2 workers."""

import gc
import os

import numpy as np
import pandas as pd
import psutil
import pytest
import xarray as xr

from trackdyn.commands.deteriorate.outputs import (
    FIGURED_SECTIONS,
    SECTION_FIGURES,
    figured,
    summary,
    write_outputs,
)
from trackdyn.commands.deteriorate.scenario import load_deterioration
from trackdyn.commands.deteriorate.sections import read_sections, section_tasks
from trackdyn.commands.drawing import HELPED_FIGURES, helper
from trackdyn.commands.staging import COLLECTIONS
from trackdyn.deterioration.runs import run_sections
from trackdyn.errors import TrackdynInputError
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import SoftSpot, synthetic_track

SCENARIO = """
[run]
model = "7dof"
[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[settlement]
law = "power"
rate_cov = 0.1
seed = 4
[loop]
total_mgt = 2
snapshot_every_mgt = 1
segment_length_m = 50
[track]
sections = "sections.csv"
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Two 100 m sections (one with a soft spot) listed in sections.csv, and a scenario."""
    path = tmp_path_factory.mktemp("sections")
    (path / "tracks").mkdir()
    for name, seed, features in (("a", 1, ()), ("b", 2, (SoftSpot(50.0, 6.0),))):
        trk = synthetic_track(100.0, spectrum="fra5", seed=seed, features=features)
        write_geometry(trk.geometry, path / "tracks" / f"{name}_geometry.csv")
        write_supports(trk.supports, path / "tracks" / f"{name}_supports.csv")
    (path / "sections.csv").write_text(
        "name,geometry,supports\n"
        "a,tracks/a_geometry.csv,tracks/a_supports.csv\n"
        "b,tracks/b_geometry.csv,tracks/b_supports.csv\n"
    )
    (path / "scenario.toml").write_text(SCENARIO)
    return path


def test_one_and_two_workers_give_identical_results(folder, tmp_path):
    spec, base = load_deterioration(folder / "scenario.toml")
    tasks = section_tasks(spec, base)
    assert [t.section.name for t in tasks] == ["a", "b"]
    serial = run_sections(tasks, workers=1)
    cluster = run_sections(tasks, workers=2)  # a real distributed.LocalCluster
    for one, two in zip(serial, cluster, strict=True):
        for ds in (one, two):  # wall-clock times differ, the results may not
            ds.attrs = {k: v for k, v in ds.attrs.items() if not k.startswith("time_")}
        xr.testing.assert_identical(one, two)
    # the sections differ (different tracks, per-section scatter seeds)
    a, b = (ds.settlement.isel(mgt=-1).values for ds in serial)
    assert a.shape == b.shape and not np.allclose(a, b)
    # a line of sections gets one straight-line diagram of the whole line
    for ds, task in zip(serial, tasks, strict=True):
        ds.attrs["section"] = task.section.name
    names = write_outputs(serial, tmp_path)
    assert "line.png" in names and (tmp_path / "line.png").read_bytes()[:4] == b"\x89PNG"
    # a second process drawing the figures meanwhile draws each to the same bytes, and
    # one that dies (killed before it draws) leaves its figures to this process
    figures = [n for n in names if n.endswith(".png")]
    assert len(figures) == 9
    with helper(HELPED_FIGURES - 1) as pool:  # fewer: its start would cost more than it does
        assert pool is None
    for kill in (False, True):
        out = tmp_path / f"helped_{kill}"
        out.mkdir()
        with helper(len(figures)) as pool:
            # no helper on one core: this process draws them all, to the same bytes
            assert (pool is None) == (len(os.sched_getaffinity(0)) < 2)
            if pool is not None:  # it collects garbage as rarely as the command
                assert pool.submit(gc.get_threshold).result() == COLLECTIONS != gc.get_threshold()
            if kill and pool is not None:
                for child in psutil.Process().children():
                    if "spawn_main" in " ".join(child.cmdline()):
                        child.kill()
                        child.wait(5)
            assert write_outputs(serial, out, pool) == names
        for name in figures:
            assert (out / name).read_bytes() == (tmp_path / name).read_bytes(), name


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("name,geometry\na,x.csv\n", "no column 'supports'"),
        ("name,geometry,supports\n", "no rows"),
        ("name,geometry,supports\na,nope.csv,nope.csv\n", "line 2: geometry file 'nope.csv'"),
        (
            "name,geometry,supports\n"
            "a,tracks/a_geometry.csv,tracks/a_supports.csv\n"
            "a,tracks/b_geometry.csv,tracks/b_supports.csv\n",
            "line 3: section name 'a' is empty, repeated",
        ),
        ("name,geometry,supports\na b,tracks/a_geometry.csv,tracks/a_supports.csv\n", "'a b'"),
    ],
)
def test_bad_sections_lists(folder, text, message):
    path = folder / "bad_sections.csv"
    path.write_text(text)
    with pytest.raises(TrackdynInputError, match=message):
        read_sections(path)


def test_a_long_line_draws_the_figures_of_its_most_urgent_sections(folder, tmp_path):
    """Of a line of more sections than the limit only the most urgent get their own
    figures: those that reach the threshold first, then the worst D1 SD at the end; the
    tables and netCDF files hold every section."""
    a = run_sections(section_tasks(*load_deterioration(folder / "scenario.toml")), workers=1)[0]
    line = []  # five sections of one run, their first triggers and final D1 SD set here
    for i, (trigger, worse) in enumerate(zip([np.inf, 3.0, np.inf, 1.0, np.inf],
                                             [1.0, 1.0, 2.0, 1.0, 1.5], strict=True)):  # fmt: skip
        ds = a.copy(deep=True)
        ds.attrs["section"] = f"s{i}"
        ds["trigger_mgt_any_rail"][:] = trigger
        ds["d1_sd"] = ds.d1_sd * worse
        line.append(ds)
    table = summary(line)
    assert figured(table, 5) == ["s0", "s1", "s2", "s3", "s4"]  # no more than the limit
    assert figured(table, 3) == ["s1", "s2", "s3"]  # at 3 and 1 MGT, then the worst D1 SD
    assert figured(table, 1) == ["s3"] and figured(table, 0) == []
    names = write_outputs(line, tmp_path, figures_of=figured(table, 3))
    pngs = {f"s{i}_{kind}.png" for i in (1, 2, 3) for kind in SECTION_FIGURES}
    assert {n for n in names if n.endswith(".png")} == pngs | {"line.png"}
    assert {p.name for p in tmp_path.glob("*.png")} == pngs | {"line.png"}
    assert all(f"deterioration_s{i}.nc" in names for i in range(5))
    every = [f"s{i}" for i in range(5)]
    assert list(dict.fromkeys(pd.read_csv(tmp_path / "quality.csv").section)) == every


def test_the_command_names_the_sections_it_draws(folder, tmp_path):
    from typer.testing import CliRunner

    from trackdyn.cli import app

    out = tmp_path / "out"
    args = ["deteriorate", str(folder / "scenario.toml"), "--out", str(out), "--workers", "1"]
    result = CliRunner().invoke(app, [*args, "--section-figures", "1"])
    assert result.exit_code == 0, result.output
    drawn = {p.name.split("_")[0] for p in out.glob("*.png")} - {"line.png"}
    assert len(drawn) == 1 and "figures of 1 of the 2 sections: those that reach" in result.output
    assert (out / "deterioration_a.nc").exists() and (out / "deterioration_b.nc").exists()
    help_text = CliRunner().invoke(app, ["deteriorate", "--help"]).output
    assert f"(default {FIGURED_SECTIONS})" in " ".join(help_text.split())  # as the code's
    result = CliRunner().invoke(app, [*args, "--overwrite", "--section-figures", "-1"])
    assert result.exit_code == 2
    assert "'--section-figures': Input should be greater than or equal to 0" in result.output
