"""A long track read piece by piece gives what the whole track read at once gives."""

import numpy as np
import pytest
import xarray as xr

from trackdyn.commands.track import analyse_pieces, track_pieces
from trackdyn.data import load_track
from trackdyn.errors import TrackdynInputError
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.analysis import track_dataset, voided_basin
from trackdyn.track.rails import rail_section
from trackdyn.track.synthetic import VoidedSleepers, synthetic_track

PS = 127.5e3
CUTTING = {"length": 1000.0, "margin": 1000.0, "rows": 2000}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("long")
    trk = synthetic_track(
        3100.0, spectrum="fra5", seed=4, features=(VoidedSleepers(2400.0, 3, 1.5e-3),)
    )
    write_geometry(trk.geometry, folder / "geometry.csv")
    write_supports(trk.supports, folder / "supports.csv")
    return folder / "geometry.csv", folder / "supports.csv"


def test_pieces_cover_the_track_in_cores(files):
    keeps = [s.keep for s in track_pieces(*files, **CUTTING)]
    assert len(keeps) == 3 and keeps[0][0] == -np.inf and keeps[-1][1] == np.inf
    assert all(a[1] == b[0] for a, b in zip(keeps, keeps[1:], strict=False))


def test_pieces_give_the_whole_track_results(files):
    lin = load_track(*files).linearise(PS, 0.3)
    whole = track_dataset(lin)
    ds, picks, basin = analyse_pieces(*files, PS, 0.3, rail_section("60E1"), **CUTTING)
    for name in ("k2", "ys", "loaded_profile", "unloaded_profile", "sleeper_distance"):
        np.testing.assert_array_equal(ds[name].values, whole[name].values)
    np.testing.assert_array_equal(ds.distance.values, whole.distance.values)
    for name in ("sd_unloaded", "sd_loaded"):
        np.testing.assert_allclose(ds[name].values, whole[name].values, rtol=0, atol=1e-6)
        np.testing.assert_allclose(ds[name].segment_start, whole[name].segment_start, atol=1e-9)
    assert ds.attrs == whole.attrs
    rail, x0, with_gap, _ = voided_basin(lin, rail_section("60E1"))
    assert (basin[0], basin[1]) == (rail, x0)
    np.testing.assert_array_equal(basin[2].deflection, with_gap.deflection)
    # the figure's curves (kept from their piece, or read again from the file) are the
    # whole track's extremes and median, as read at once
    softest, stiffest = np.argmin(lin.k2), np.argmax(lin.k2)
    median = np.argsort(lin.k2, axis=None)[lin.k2.size // 2]
    expected = {int(f) for f in (softest, stiffest, np.argmax(lin.ys), median)}
    assert len(picks) == len(expected)
    for pick in picks:
        r = ("left", "right").index(pick.rail)
        i = int(np.flatnonzero(lin.track.supports.position == pick.position)[0])
        assert np.ravel_multi_index((r, i), lin.k2.shape) in expected
        assert (pick.k2, pick.ys) == (lin.k2[r, i], lin.ys[r, i])
        whole = getattr(lin.track.supports, pick.rail)[i]
        np.testing.assert_array_equal(pick.curve.load, whole.load)
        np.testing.assert_array_equal(pick.curve.deflection, whole.deflection)


def test_a_bad_row_in_the_last_piece_is_named_by_its_line(files, tmp_path):
    geometry, supports = files
    lines = supports.read_text().splitlines()
    n = len(lines)
    lines[-3] = lines[-3].rsplit(",", 1)[0] + ",oops"
    bad = tmp_path / "supports.csv"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(TrackdynInputError, match=f"{bad}: .*at line {n - 2}$") as whole:
        load_track(geometry, bad)
    with pytest.raises(TrackdynInputError) as pieces:
        analyse_pieces(geometry, bad, PS, 0.3, rail_section("60E1"), **CUTTING)
    assert str(pieces.value) == str(whole.value)
    rows = geometry.read_text().splitlines()
    rows[-2], rows[-3] = rows[-3], rows[-2]
    bad = tmp_path / "geometry.csv"
    bad.write_text("\n".join(rows) + "\n")
    with pytest.raises(TrackdynInputError, match=f"at line {len(rows) - 1}$") as whole:
        load_track(bad, supports)
    with pytest.raises(TrackdynInputError) as pieces:
        analyse_pieces(bad, supports, PS, 0.3, rail_section("60E1"), **CUTTING)
    assert str(pieces.value) == str(whole.value)


def test_joined_dataset_writes_like_the_whole(files, tmp_path):
    ds, _, _ = analyse_pieces(*files, PS, 0.3, rail_section("60E1"), **CUTTING)
    ds.to_netcdf(tmp_path / "t.nc")
    assert xr.load_dataset(tmp_path / "t.nc").sizes == ds.sizes
