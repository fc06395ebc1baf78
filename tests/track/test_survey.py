"""Recording-car geometry files: filtered levels and versines taken as the profile, gaps
and chainage, and the checks that refuse a file in the wrong unit. Files are constructed
here: a synthetic profile written as a recording car writes it."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.data import EXAMPLE_GEOMETRY, example_path, load_track
from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_geometry, write_supports
from trackdyn.options import TrackSpec, parse
from trackdyn.track.chord import Chord
from trackdyn.track.formats import TrackFormat
from trackdyn.track.quality import longitudinal_level
from trackdyn.track.survey import MAX_GAP_M, GeometryFormat
from trackdyn.track.synthetic import synthetic_track

STEP = 0.25  # a recording car's sample spacing [m]
TRUE = synthetic_track(600.0, spectrum="fra5", seed=7, sample_spacing=STEP)


def write(path: Path, x, left, right, along="distance_m", scale=1e3) -> Path:
    """A geometry CSV: ``along`` [m, or km if named so], the rails in mm (``scale``)."""
    factor = 1e-3 if along.endswith("_km") else 1.0
    frame = pd.DataFrame({along: x * factor, "left_mm": left * scale, "right_mm": right * scale})
    frame.to_csv(path, index=False, float_format="%.9g")
    return path


def true_file(tmp_path, **options) -> Path:
    g = TRUE.geometry
    return write(tmp_path / "g.csv", g.distance, g.left, g.right, **options)


def test_a_profile_reads_as_before_without_notes(tmp_path):
    g = read_geometry(true_file(tmp_path))
    np.testing.assert_allclose(g.left, TRUE.geometry.left, rtol=1e-8, atol=1e-12)  # %.9g
    assert g.notes == ()


def test_every_shipped_profile_is_read_without_a_note():
    # the built-in section and the calibration example's surveys: no gap, no check fires
    package = example_path(EXAMPLE_GEOMETRY).parents[1]
    files = [example_path(EXAMPLE_GEOMETRY), *package.glob("examples/calibration/survey_*.csv")]
    assert len(files) == 4
    for path in files:
        assert read_geometry(path).notes == ()


@pytest.mark.parametrize(("kind", "beyond"), [("d1", "25 m"), ("d1d2", "70 m")])
def test_a_filtered_level_is_the_profile_with_its_missing_band_stated(tmp_path, kind, beyond):
    g = TRUE.geometry
    d1 = longitudinal_level(g.distance, g.left, "D1"), longitudinal_level(g.distance, g.right)
    path = write(tmp_path / "d1.csv", g.distance, *d1)
    read = read_geometry(path, GeometryFormat(geometry_kind=kind))
    np.testing.assert_allclose(read.left, d1[0], rtol=1e-8, atol=1e-12)  # taken as it is
    text = dict(read.notes)["kind"]
    assert f"beyond {beyond}" in text and "missing" in text


@pytest.mark.parametrize(
    ("keys", "chord"),
    [({"chord_back_m": 2.5, "chord_front_m": 7.5}, Chord(2.5, 7.5)), ({"chord_m": 10}, None)],
)
def test_a_versine_file_gives_the_profile_back(tmp_path, keys, chord):
    # the forward transform of the known profile, written with its NaN ends cut off, read
    # back: in the D1 band the same profile (measured here, 400 m kept of 600 m: the
    # 2.5/7.5 m chord corr 0.99998, SD 0.006 % under; the 10 m chord 0.9945, SD 0.7 % under)
    fmt = GeometryFormat(geometry_kind="versine", **keys)
    g = TRUE.geometry
    versines = [fmt.chord().versine(g.distance, g.profile(r)) for r in ("left", "right")]
    inside = np.isfinite(versines[0])
    path = write(tmp_path / "v.csv", g.distance[inside], *(v[inside] for v in versines))
    read = read_geometry(path, fmt)
    x = read.distance
    core = (x > x[0] + 100) & (x < x[-1] - 100)  # recovery less reliable near the ends
    true_d1 = longitudinal_level(g.distance, g.left)[inside][core]
    got_d1 = longitudinal_level(x, read.left)[core]
    corr = np.corrcoef(true_d1, got_d1)[0, 1]
    assert corr > (0.99 if chord else 0.98)  # the 0.98
    if chord:
        assert np.std(got_d1) == pytest.approx(np.std(true_d1), rel=0.03)  # the 3 %
    text = dict(read.notes)["kind"]
    assert "lost band" in text and "none" not in text  # both lose the longest waves


def test_decreasing_chainage_in_km_is_reversed_and_said(tmp_path):
    g = TRUE.geometry
    path = write(tmp_path / "down.csv", g.distance[::-1], g.left[::-1], g.right[::-1],
                 along="chainage_km")  # fmt: skip
    read = read_geometry(path)
    np.testing.assert_allclose(read.distance, g.distance, atol=1e-9)
    np.testing.assert_allclose(read.left, g.left, rtol=1e-8, atol=1e-12)
    assert "increasing chainage" in dict(read.notes)["direction"]


def test_an_asymmetric_chord_turns_round_with_the_car(tmp_path):
    # the car ran towards decreasing chainage: its chord's back lies at higher chainage,
    # so the file's versine is that of the mirrored chord; the profile must come out the same
    g = TRUE.geometry
    fmt = GeometryFormat(geometry_kind="versine", chord_back_m=2.5, chord_front_m=7.5)
    ahead = [Chord(7.5, 2.5).versine(g.distance, g.profile(r)) for r in ("left", "right")]
    inside = np.isfinite(ahead[0])
    x = g.distance[inside]
    down = write(tmp_path / "down.csv", x[::-1], *(v[inside][::-1] for v in ahead))
    got = read_geometry(down, fmt).left
    want = read_geometry(write(tmp_path / "up.csv", x, g.left[inside], g.right[inside]))
    core = slice(400, -400)  # 100 m from either end
    d1_got, d1_want = longitudinal_level(x, got)[core], longitudinal_level(x, want.left)[core]
    assert np.corrcoef(d1_got, d1_want)[0, 1] > 0.99


def test_short_gaps_are_bridged_linearly_and_flagged(tmp_path):
    g = TRUE.geometry
    left = g.left.copy()
    left[100:104] = np.nan  # 4 rows: 25.0-25.75 m, a gap of 1.25 m from 24.75 to 26 m
    keep = np.ones(g.distance.size, bool)
    keep[2000:2005] = False  # 5 rows missing: 500-501 m, a gap of 1.5 m
    path = write(tmp_path / "gaps.csv", g.distance[keep], left[keep], g.right[keep])
    read = read_geometry(path)
    np.testing.assert_allclose(read.distance, g.distance)  # missing rows put back
    line = np.interp(g.distance[100:104], g.distance[[99, 104]], g.left[[99, 104]])
    np.testing.assert_allclose(read.left[100:104], line, rtol=1e-8, atol=1e-12)
    assert dict(read.notes)["gaps"].startswith("2 gap(s) up to 1.5 m bridged")


def test_a_long_gap_is_refused_naming_its_lines(tmp_path):
    g = TRUE.geometry
    keep = (g.distance <= 100) | (g.distance > 100 + MAX_GAP_M)  # 100 to 102.25 m: 2.25 m
    path = write(tmp_path / "gap.csv", g.distance[keep], g.left[keep], g.right[keep])
    # 100 m is row 400, line 402; the next kept row is 102.25 m, line 403
    with pytest.raises(TrackdynInputError, match=r"gap\.csv: lines 402-403: a gap of 2\.25 m"):
        read_geometry(path)
    read_geometry(path, GeometryFormat(max_gap_m=2.5))  # or bridged when allowed


@pytest.mark.parametrize(
    ("scale", "match"),
    [(1.0, r"D1 SD 0\.00\d+ mm, under the plausible 0\.05 mm: a profile in metres"),
     (1e4, r"D1 SD 33\.7 mm, over the plausible 30 mm: a profile in millimetres under")],
)  # fmt: skip
def test_a_profile_in_the_wrong_unit_is_refused(tmp_path, scale, match):
    # metres written under _mm (scale 1), and 10 times the millimetres under _mm, as a file
    # in mm under a _cm header reads (scale 1e4); the profile's D1 SD is 3.37 mm
    with pytest.raises(TrackdynInputError, match=r"g\.csv: left rail: " + match):
        read_geometry(true_file(tmp_path, scale=scale))


def test_a_profile_positive_up_is_turned(tmp_path):
    g = TRUE.geometry
    path = write(tmp_path / "up.csv", g.distance, -g.left, -g.right)
    read = read_geometry(path, GeometryFormat(profile_sign="up"))
    np.testing.assert_allclose(read.left, g.left, rtol=1e-8, atol=1e-12)
    assert "sign" in dict(read.notes)


@pytest.mark.parametrize(
    ("table", "match"),
    [({"geometry_kind": "versine"}, "needs chord_m, or chord_back_m and chord_front_m"),
     ({"geometry_kind": "versine", "chord_m": 10, "chord_back_m": 2}, "needs chord_m, or"),
     ({"geometry_kind": "versine", "chord_back_m": 2}, "needs chord_m, or"),
     ({"chord_m": 10}, "a chord is for geometry_kind = 'versine', not 'profile'"),
     ({"geometry_kind": "d3"}, "geometry_kind")],
)  # fmt: skip
def test_track_keys_are_checked(table, match):
    with pytest.raises(TrackdynInputError, match=match):
        parse(TrackSpec, table, "s.toml")


def test_the_example_is_no_versine():
    with pytest.raises(TrackdynInputError, match="the built-in example is a profile"):
        load_track(None, None, TrackFormat(geometry_kind="d1"))


def test_a_run_on_a_d1_file_says_what_is_missing(tmp_path):
    g = TRUE.geometry
    d1 = longitudinal_level(g.distance, g.left), longitudinal_level(g.distance, g.right)
    write(tmp_path / "d1.csv", g.distance, *d1)
    write_supports(TRUE.supports, tmp_path / "s.csv")
    scenario = tmp_path / "s.toml"
    scenario.write_text('[track]\ngeometry = "d1.csv"\nsupports = "s.csv"\n'
                        'geometry_kind = "d1"\n[run]\nmodel = "2dof"\nstart_m = 20\n'
                        'end_m = 120\n')  # fmt: skip
    result = CliRunner().invoke(app, ["-q", "run", str(scenario), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert "D1 longitudinal level taken as the profile" in result.stderr  # shown with -q
    options = json.loads((tmp_path / "o" / "summary.json").read_text())["options"]
    assert options["track_geometry_kind"] == "d1"
    assert "beyond 25 m" in options["geometry_note_kind"]
