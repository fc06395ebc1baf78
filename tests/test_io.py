"""CSV readers: units from column names, and every kind of bad input refused by name."""

import numpy as np
import pytest

from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_geometry, read_supports, write_geometry, write_supports
from trackdyn.track.track import Geometry, Supports


def write(tmp_path, text, name="f.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_geometry_units_convert_to_si(tmp_path):
    g = read_geometry(write(tmp_path, "distance_km,left_mm,right_m\n0,1,0.002\n0.001,2,0.003\n"))
    np.testing.assert_array_equal(g.distance, [0.0, 1.0])  # km -> m
    np.testing.assert_allclose(g.left, [1e-3, 2e-3])  # mm -> m
    np.testing.assert_allclose(g.right, [2e-3, 3e-3])


def test_supports_long_table_and_linear(tmp_path):
    s = read_supports(
        write(
            tmp_path,
            "distance_m,rail,load_kN,deflection_mm\n"
            "0.3,left,0,0\n0.3,left,100,1\n0.3,right,0,0\n0.3,right,200,2\n"
            "0.9,left,0,0\n0.9,left,100,2\n0.9,right,0,0\n0.9,right,100,1\n",
        )
    )
    np.testing.assert_array_equal(s.position, [0.3, 0.9])
    np.testing.assert_allclose(s.left[1].load, [0, 100e3])
    np.testing.assert_allclose(s.left[1].deflection, [0, 2e-3])
    lin = read_supports(
        write(
            tmp_path,
            "distance_m,rail,stiffness_kN_per_mm\n"
            "0.3,left,90\n0.9,left,90\n0.3,right,110\n0.9,right,100\n",
            "lin.csv",
        )
    )
    # 90 kN/mm = 90e6 N/m: the curve's slope
    assert lin.left[0].load[-1] / lin.left[0].deflection[-1] == pytest.approx(90e6)


def test_columns_take_any_unit_of_their_kind(tmp_path):
    # units outside the former table of column units: cm (1e-2 m), N, MN_per_mm (1e9 N/m)
    g = read_geometry(write(tmp_path, "distance_cm,left_mm,right_mm\n0,1,1\n25,1,1\n"))
    np.testing.assert_array_equal(g.distance, [0.0, 0.25])
    rows = "".join(f"{x},{r},0,0\n{x},{r},1e5,1\n" for x in (0.3, 0.9) for r in ("left", "right"))
    curves = read_supports(write(tmp_path, "distance_m,rail,load_N,deflection_mm\n" + rows))
    assert curves.left[0].load[-1] == 1e5
    lin = read_supports(
        write(
            tmp_path,
            "distance_m,rail,stiffness_MN_per_mm\n"
            "0.3,left,0.09\n0.9,left,0.09\n0.3,right,0.1\n0.9,right,0.1\n",
        )
    )
    # 0.09 MN/mm = 90e6 N/m: the curve's slope
    assert lin.left[0].load[-1] / lin.left[0].deflection[-1] == pytest.approx(90e6)


def test_round_trip(tmp_path):
    g = Geometry(np.array([0.0, 0.25, 0.5]), np.array([1e-3, 0, -1e-3]), np.zeros(3))
    s = Supports.linear(np.array([0.1, 0.7]), 80e6, np.array([90e6, 95e6]))
    write_geometry(g, tmp_path / "g.csv")
    write_supports(s, tmp_path / "s.csv")
    g2, s2 = read_geometry(tmp_path / "g.csv"), read_supports(tmp_path / "s.csv")
    np.testing.assert_allclose(g2.left, g.left)
    np.testing.assert_allclose(s2.right[1].deflection, s.right[1].deflection, rtol=1e-5)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("distance_m,left_mm,right_mm\n0,1,1\n1,nan,1\n", r"'left_mm'.*line 3"),
        ("distance_m,left_mm,right_mm\n0,1,1\n1,inf,1\n", r"'left_mm'.*line 3"),
        ("distance_m,left_mm,right_mm\n0,1,1\n0,1,1\n", "not strictly increasing at line 3"),
        # neither increasing nor decreasing (a decreasing file is reversed: test_survey.py)
        (
            "distance_m,left_mm,right_mm\n0,1,1\n1,1,1\n0.5,1,1\n",
            "not strictly increasing at line 4",
        ),  # noqa: E501
        ("distance_m,left_mm\n0,1\n1,1\n", "no column right_"),
        ("distance_m,left_inch,right_mm\n0,1,1\n1,1,1\n", "unit 'inch'.*does not parse"),
        # a unit of the registry, but a force: not a length unit
        ("distance_m,left_kN,right_mm\n0,1,1\n1,1,1\n", "unit 'kN' of column 'left_kN' does not"),
        # names spell units by symbol (trackdyn.units): "metre" is not read
        ("distance_metre,left_mm,right_mm\n0,1,1\n1,1,1\n", "unit 'metre'.*length unit"),
        ("distance_m,left_mm,right_mm\n0,1,1\n1,abc,1\n", r"'left_mm'.*line 3"),
        # limits.MAX_PROFILE: ±1 m
        ("distance_m,left_mm,right_mm\n0,1,1\n1,1e300,1\n", r"left profile at row 1 is 1e\+300 mm"),
        ("distance_m,left_mm,right_mm\n0,1,1\n1,1,-1001\n", "outside the plausible -1000 to 1000"),
    ],
)
def test_bad_geometry(tmp_path, text, match):
    path = write(tmp_path, text, "geo.csv")
    with pytest.raises(TrackdynInputError, match=match) as err:
        read_geometry(path)
    assert "geo.csv" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (
            "distance_m,rail,load_kN,deflection_mm\n0.3,left,0,0\n0.3,left,100,1\n",
            "no rows for the right rail",
        ),
        (
            "distance_m,rail,load_kN,deflection_mm\n0.3,left,0,0\n0.3,left,100,1\n0.3,middle,0,0\n",
            "line 4: rail 'middle'",
        ),
        (
            "distance_m,rail,load_kN,deflection_mm\n0.3,left,0,0\n0.3,left,100,0.9\n"
            "0.3,left,150,0.8\n0.3,right,0,0\n0.3,right,100,1\n",
            r"left rail at 0.3 m \(lines 2-4\).*not monotonic",
        ),
        (
            "distance_m,rail,stiffness_kN_per_mm\n0.3,left,-5\n0.3,right,90\n",
            "stiffness is -5 kN/mm, outside the plausible 1 to 10000 kN/mm",
        ),
        (
            "distance_m,rail,stiffness_kN_per_mm\n0.3,left,0\n0.3,right,90\n",
            "stiffness is 0 kN/mm",
        ),
        (  # limits.SUPPORT_STIFFNESS: at most 10 GN/m
            "distance_m,rail,stiffness_N_per_m\n0.3,left,1e30\n0.3,right,90e6\n",
            r"left rail at 0.3 m \(lines 2-2\): stiffness is 1e\+24 kN/mm",
        ),
        (  # a sleeper's block pasted twice
            "distance_m,rail,load_kN,deflection_mm\n0.3,left,0,0\n0.3,left,100,1\n"
            "0.3,left,0,0\n0.3,left,100,1\n0.3,right,0,0\n0.3,right,100,1\n",
            r"left rail at 0.3 m \(lines 2-5\): this sleeper's curve starts again at line 4",
        ),
        (
            "distance_m,rail,stiffness_kN_per_mm\n0.9,left,80\n0.3,left,90\n0.3,right,90\n"
            "0.9,right,90\n",
            "line 3: sleeper positions of the left rail are not increasing",
        ),
        (  # the first bad curve of many is named, with its lines
            "distance_m,rail,load_kN,deflection_mm\n0.3,left,0,0\n0.3,left,9,1\n"
            "0.3,right,0,0\n0.3,right,9,1\n0.9,left,0,0\n0.9,left,9,1\n"
            "0.9,right,0,0\n0.9,right,5,1\n0.9,right,9,0.5\n",
            r"right rail at 0.9 m \(lines 8-10\): load-deflection curve is not monotonic",
        ),
        ("distance_m,rail,load_lbf,deflection_mm\n0.3,left,0,0\n", "unit 'lbf'"),
        (
            "distance_m,rail,stiffness_kN_per_mm\n0.3,left,80\n0.6,right,90\n",
            "different sleeper positions",
        ),
    ],
)
def test_bad_supports(tmp_path, text, match):
    path = write(tmp_path, text, "sup.csv")
    with pytest.raises(TrackdynInputError, match=match) as err:
        read_supports(path)
    assert "sup.csv" in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(TrackdynInputError, match="no such file"):
        read_geometry(tmp_path / "nope.csv")


def test_curves_given_on_demand_equal_the_rows_read(tmp_path):
    text = (
        "distance_m,rail,load_kN,deflection_mm\n"
        "0.3, Left,0,0\n0.3,right,0,0\n0.3,left,50,1\n0.3,left,100,1.5\n0.3,right,90,2\n"
        "0.9,left,0,0\n0.9,left,100,2\n0.9,RIGHT,10,0.5\n0.9,right,80,1\n0.9,right,120,3\n"
    )
    path = write(tmp_path, text)
    s = read_supports(path)
    expected = {  # rail: (position, load kN, deflection mm, first and last line)
        "left": [(0.3, [0, 50, 100], [0, 1, 1.5], 2, 5), (0.9, [0, 100], [0, 2], 7, 8)],
        "right": [(0.3, [0, 90], [0, 2], 3, 6), (0.9, [10, 80, 120], [0.5, 1, 3], 9, 11)],
    }
    for rail, rows in expected.items():
        curves = getattr(s, rail)
        assert len(curves) == len(rows) == len(list(curves))
        for curve, (pos, load, defl, first, last) in zip(curves, rows, strict=True):
            np.testing.assert_allclose(curve.load, np.array(load) * 1e3)
            np.testing.assert_allclose(curve.deflection, np.array(defl) * 1e-3)
            assert curve.where == f"{path}: {rail} rail at {pos:g} m (lines {first}-{last})"
        assert curves[-1].where == curves[len(rows) - 1].where
        with pytest.raises(IndexError):
            curves[len(rows)]
    again = Supports(s.position, tuple(s.left), list(s.right))  # from SupportCurve objects
    for rail in ("left", "right"):
        for a, b in zip(getattr(again, rail), getattr(s, rail), strict=True):
            np.testing.assert_array_equal(a.load, b.load)
            np.testing.assert_array_equal(a.deflection, b.deflection)
            assert a.where == b.where
