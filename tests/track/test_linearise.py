"""Linearisation of all sleepers in one pass (eqs 5.9-5.11) against curve-by-curve splines.

The reference in every test is computed here curve by curve with scipy's own
``CubicSpline`` (not-a-knot) and ``PchipInterpolator``, extended linearly with the end
slope: what `secant_linearisation` did per curve before the vectorised code, and the
messages are those that code raised.
"""

import re

import numpy as np
import pytest
from scipy.interpolate import CubicSpline, PchipInterpolator

from trackdyn.data import load_track
from trackdyn.errors import TrackdynInputError
from trackdyn.track.support import SupportCurve, linearise_curves, secant_linearisation

PS = 127.53e3  # loaded wagon static wheel load [N], as in test_track.py
HIGH_PS = 200e3  # Ps + 0.3 Ps = 260 kN is beyond the example curves' 250 kN [N]


def reference(curve, static_load, delta, method, printed_5_10=False):
    """k2 [N/m] and ys [m] of one curve with scipy's splines (eqs 5.9-5.11)."""
    if method == "cubic":
        spline = CubicSpline(curve.load, curve.deflection, bc_type="not-a-knot")
    else:
        spline = PchipInterpolator(curve.load, curve.deflection)
    lo, hi = curve.load[0], curve.load[-1]
    dp = delta * static_load
    p = np.array([static_load - dp, static_load + dp])
    inside = np.clip(p, lo, hi)
    y = spline(inside) + (p - inside) * np.where(p < lo, spline(lo, 1), spline(hi, 1))
    numerator = static_load if printed_5_10 else 2 * dp
    return numerator / (y[1] - y[0]), 0.5 * (y[0] + y[1])


def references(curves, static_load, delta, method, printed_5_10=False):
    return np.array([reference(c, static_load, delta, method, printed_5_10) for c in curves]).T


def mixed_curves():
    """Curves of 2 to 13 points on irregular load grids, shuffled by point count."""
    rng = np.random.default_rng(7)
    curves = []
    for i, n in enumerate([5, 2, 8, 3, 13, 4, 8, 2, 5, 3, 13, 4] * 4):
        grid = np.cumsum(rng.uniform(0.5, 2.0, n))
        load = 260e3 * (grid - grid[0]) / (grid[-1] - grid[0])
        k, gap = rng.uniform(50e6, 150e6), rng.uniform(0.0, 2e-3)
        curves.append(SupportCurve(load, load / k + gap * (1 - np.exp(-load / 15e3)), f"c{i}"))
    return curves


@pytest.mark.parametrize("method", ["cubic", "pchip"])
@pytest.mark.parametrize(("static_load", "extrapolate"), [(PS, False), (HIGH_PS, True)])
def test_example_track_matches_curve_by_curve(method, static_load, extrapolate):
    track = load_track()
    lin = track.linearise(static_load, method=method, extrapolate=extrapolate)
    for r, rail in enumerate(("left", "right")):
        k2, ys = references(getattr(track.supports, rail), static_load, 0.3, method)
        np.testing.assert_allclose(lin.k2[r], k2, rtol=1e-12, atol=0)
        np.testing.assert_allclose(lin.ys[r], ys, rtol=1e-12, atol=0)


@pytest.mark.parametrize("method", ["cubic", "pchip"])
@pytest.mark.parametrize("extrapolate", [False, True])
@pytest.mark.parametrize("printed_5_10", [False, True])
def test_curves_of_different_lengths_match_curve_by_curve(method, extrapolate, printed_5_10):
    curves = mixed_curves()
    static_load = 210e3 if extrapolate else PS  # 1.3 x 210 = 273 kN > the 260 kN curve ends
    options = {"method": method, "extrapolate": extrapolate, "printed_5_10": printed_5_10}
    k2, ys = linearise_curves(curves, static_load, 0.3, **options)
    ref_k2, ref_ys = references(curves, static_load, 0.3, method, printed_5_10)
    np.testing.assert_allclose(k2, ref_k2, rtol=1e-12, atol=0)
    np.testing.assert_allclose(ys, ref_ys, rtol=1e-12, atol=0)
    one = secant_linearisation(curves[4], static_load, 0.3, **options)
    assert one == (k2[4], ys[4])  # the single-curve API is the same computation


@pytest.mark.parametrize("method", ["cubic", "pchip"])
def test_deflection_at_matches_scipy_at_knots_between_and_beyond(method):
    curve = mixed_curves()[4]  # 13 points
    scipy_class = CubicSpline if method == "cubic" else PchipInterpolator
    spline = scipy_class(curve.load, curve.deflection)
    between = 0.5 * (curve.load[1:] + curve.load[:-1])
    loads = np.concatenate((curve.load, between))
    np.testing.assert_allclose(
        curve.deflection_at(loads, method=method), spline(loads), rtol=1e-12, atol=0
    )
    for end, step in ((curve.load[0], -10e3), (curve.load[-1], 10e3)):
        expected = spline(end) + step * spline(end, 1)  # straight on with the end slope
        got = curve.deflection_at(end + step, method=method, extrapolate=True)
        assert got.shape == () and got == pytest.approx(expected, rel=1e-12)


def test_first_curve_not_covering_the_load_is_named():
    # c1 and c7 are the 2-point curves of mixed_curves, cut here to end at 150 kN;
    # Ps + 0.3 Ps = 165.8 kN, so both are outside and c1 comes first.
    curves = mixed_curves()
    for i in (1, 7):
        curves[i] = SupportCurve(curves[i].load * 150 / 260, curves[i].deflection, f"c{i}")
    message = (
        "c1: load 165.8 kN is outside the measured curve (0.0-150.0 kN); "
        "extend the curve or allow extrapolation"
    )
    with pytest.raises(TrackdynInputError, match=f"^{re.escape(message)}$"):
        linearise_curves(curves, PS)
    with pytest.raises(TrackdynInputError, match=f"^{re.escape(message)}$"):
        secant_linearisation(curves[1], PS)


def test_overshooting_spline_is_refused_with_the_curve_named():
    # A step from 0.2 to 2.0 mm at 70-80 kN and from 2.01 to 4.0 mm at 170-180 kN: the
    # not-a-knot spline overshoots to 2.91 mm at 89.3 kN and dips to 1.44 mm at 165.8 kN
    # (scipy CubicSpline), so ys2 < ys1; pchip stays monotone.
    load = np.array([0, 70, 80, 170, 180, 250]) * 1e3
    wavy = SupportCurve(load, np.array([0, 0.2, 2.0, 2.01, 4.0, 4.1]) * 1e-3, "sleeper 3")
    curves = [*mixed_curves()[:3], wavy, mixed_curves()[3]]
    message = (
        "sleeper 3: interpolated curve is not increasing over Ps ± ΔP; "
        "use method='pchip' for noisy curves"
    )
    with pytest.raises(TrackdynInputError, match=f"^{re.escape(message)}$"):
        linearise_curves(curves, PS)
    k2, _ = linearise_curves(curves, PS, method="pchip")
    assert np.all(k2 > 0)
