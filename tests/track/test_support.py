"""Load-deflection curves and the secant linearisation of eqs 5.9-5.11."""

import numpy as np
import pytest

from trackdyn.errors import TrackdynInputError
from trackdyn.track.support import SupportCurve, secant_linearisation


def test_linear_support_gives_k():
    # Secant of a straight line is its slope; ys = Ps / k (5.11 on a line through 0).
    k2, ys = secant_linearisation(SupportCurve.linear(80e6), 127.5e3, 0.3)
    assert k2 == pytest.approx(80e6, rel=1e-12)
    assert ys == pytest.approx(127.5e3 / 80e6, rel=1e-12)


def test_printed_5_10_is_one_over_two_delta_times_secant():
    # docs/model.md, departures from the printed 5.10: the numerator Ps gives 1/(2 delta)
    # = 1.667 times the slope.
    k2, _ = secant_linearisation(SupportCurve.linear(80e6), 127.5e3, 0.3, printed_5_10=True)
    assert k2 == pytest.approx(80e6 / 0.6, rel=1e-12)


def test_cubic_curve_hand_computed():
    # y(P) = a P + c P^3 with a = 1e-8 m/N, c = 2e-19 m/N^3, sampled at 6 loads; the
    # not-a-knot spline reproduces a cubic exactly. Ps = 100 kN, delta = 0.3:
    # y(70 kN)  = 7.0e-4 + 2e-19 * 3.43e14  = 7.686e-4 m
    # y(130 kN) = 1.3e-3 + 2e-19 * 2.197e15 = 1.7394e-3 m
    # k2 = 60e3 / (1.7394e-3 - 7.686e-4) = 61.80e6 N/m; ys = 1.2540e-3 m
    p = np.linspace(0, 250e3, 6)
    curve = SupportCurve(p, 1e-8 * p + 2e-19 * p**3)
    k2, ys = secant_linearisation(curve, 100e3, 0.3)
    assert k2 == pytest.approx(60e3 / (1.7394e-3 - 7.686e-4), rel=1e-9)
    assert ys == pytest.approx(0.5 * (1.7394e-3 + 7.686e-4), rel=1e-9)


def test_seating_gap_shows_in_ys_not_k2():
    # A curve with a 2 mm gap closed below the load range: k2 stays the linear slope,
    # ys grows by the gap. Points on the straight part only above 40 kN.
    p = np.array([0, 10, 20, 40, 80, 120, 160, 200, 250.0]) * 1e3
    y = np.where(p < 40e3, p / 20e6, 2e-3 + p / 100e6)
    y[3] = 2e-3 + 40e3 / 100e6
    k2, ys = secant_linearisation(SupportCurve(p, y), 127.5e3, 0.3, method="pchip")
    assert k2 == pytest.approx(100e6, rel=1e-9)  # pchip is exact on a straight stretch
    assert ys == pytest.approx(2e-3 + 127.5e3 / 100e6, rel=1e-9)


@pytest.mark.parametrize(
    ("load", "defl", "match"),
    [
        ([0, 50e3, 40e3], [0, 1e-3, 2e-3], "not monotonic"),
        ([0, 50e3, 100e3], [0, 1e-3, 0.9e-3], "not monotonic"),
        ([0, 50e3, np.nan], [0, 1e-3, 2e-3], "NaN"),
        ([-5e3, 50e3, 100e3], [0, 1e-3, 2e-3], "negative load"),
    ],
)
def test_bad_curves_refused(load, defl, match):
    with pytest.raises(TrackdynInputError, match=match):
        SupportCurve(np.array(load), np.array(defl), "sleeper 7")


def test_curve_must_cover_load_range_unless_extrapolating():
    curve = SupportCurve(np.array([0, 50e3, 100e3, 150e3]), np.array([0, 0.6e-3, 1.1e-3, 1.6e-3]))
    with pytest.raises(TrackdynInputError, match="outside the measured curve"):
        secant_linearisation(curve, 127.5e3, 0.3)  # needs 165.75 kN
    k2, _ = secant_linearisation(curve, 127.5e3, 0.3, extrapolate=True)
    assert np.isfinite(k2) and k2 > 0


@pytest.mark.parametrize("bad", [0.0, -10e3, np.nan])
def test_static_load_must_be_positive(bad):
    with pytest.raises(TrackdynInputError, match="static wheel load"):
        secant_linearisation(SupportCurve.linear(80e6), bad)


def test_zero_stiffness_refused():
    with pytest.raises(TrackdynInputError, match="stiffness is 0 kN/mm, outside the plausible"):
        SupportCurve.linear(0.0)
