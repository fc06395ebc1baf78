"""Winkler beam on elastic foundation, eqs 5.5-5.8 (corrected 5.6)."""

import numpy as np
import pytest
from scipy.integrate import quad

from trackdyn.errors import TrackdynInputError
from trackdyn.track import winkler
from trackdyn.track.rails import rail_section

EI_60E1 = 210e9 * 3038e-8  # E = 210 GPa, I = 3038 cm^4 (EN 13674-1, 60E1 profile) -> 6.3798e6 N m^2
U = 40e6  # track modulus [N/m^2], a mid-range ballasted-track value


def test_rail_library_ei():
    # 60E1: I = 3038 cm^4 (EN 13674-1 via data.md); E = 210 GPa
    assert rail_section("60e1").EI == pytest.approx(6.3798e6, rel=1e-12)
    # 136RE: I = 94.9 in^4 = 94.9 * 2.54^4 cm^4 = 3950 cm^4 (AREMA)
    assert rail_section("136RE").second_moment == pytest.approx(94.9 * 0.0254**4, rel=2e-3)
    with pytest.raises(TrackdynInputError, match="unknown rail section 'UIC99'"):
        rail_section("UIC99")


def test_closed_form_values():
    # Hand computation: L_c = (4 * 6.3798e6 / 40e6)^(1/4) = 0.63798^(1/4) = 0.893721 m
    lc = winkler.characteristic_length(EI_60E1, U)
    assert lc == pytest.approx(0.8937206, rel=1e-6)
    # k = 2 u L_c = 2 * 40e6 * 0.8937206 = 71.4976e6 N/m (eq 5.8)
    assert winkler.stiffness_from_modulus(U, EI_60E1) == pytest.approx(71.49765e6, rel=1e-6)
    # y(0) = P / (2 u L_c) = 100e3 / 71.4976e6 = 1.398647 mm (eq 5.5 at x = 0)
    assert winkler.deflection(0.0, 100e3, EI_60E1, U) == pytest.approx(1.398647e-3, rel=1e-6)
    # y = 0 where cos + sin = 0: x = 3 pi / 4 L_c
    assert winkler.deflection(0.75 * np.pi * lc, 100e3, EI_60E1, U) == pytest.approx(0, abs=1e-15)
    # M(0) = P L_c / 4; M = 0 at x = pi / 4 L_c
    assert winkler.bending_moment(0.0, 100e3, EI_60E1, U) == pytest.approx(100e3 * lc / 4)
    assert winkler.bending_moment(0.25 * np.pi * lc, 1e5, EI_60E1, U) == pytest.approx(0, abs=1e-9)
    # sleeper under the load carries P s / (2 L_c)
    assert winkler.sleeper_load(0.0, 1e5, EI_60E1, U, 0.6) == pytest.approx(1e5 * 0.6 / (2 * lc))


def test_basin_satisfies_equilibrium_and_the_beam_equation():
    # The foundation carries the whole load: integral of u y dx over the line equals P.
    total, _ = quad(lambda x: U * winkler.deflection(x, 1e5, EI_60E1, U), -30, 30, points=[0])
    assert total == pytest.approx(1e5, rel=1e-8)
    # EI y'''' + u y = 0 away from the load (eq 5.4), by a 5-point finite difference.
    h, x = 3e-3, 1.3  # truncation error O(h^2) ~ 3e-6 relative here
    y = winkler.deflection(x + h * np.arange(-2, 3), 1e5, EI_60E1, U)
    d4 = (y[0] - 4 * y[1] + 6 * y[2] - 4 * y[3] + y[4]) / h**4
    assert EI_60E1 * d4 + U * y[2] == pytest.approx(0, abs=1e-5 * U * y[2])


@pytest.mark.parametrize("k", [20e6, 71.5e6, 150e6])
def test_modulus_stiffness_round_trip(k):
    u = winkler.modulus_from_stiffness(k, EI_60E1)
    assert winkler.stiffness_from_modulus(u, EI_60E1) == pytest.approx(k, rel=1e-12)
    # 5.7 and 5.8 are consistent only with the corrected 5.6: k = 2 u L_c(u)
    assert k == pytest.approx(2 * u * winkler.characteristic_length(EI_60E1, u), rel=1e-12)


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan])
def test_non_positive_modulus_refused(bad):
    with pytest.raises(TrackdynInputError, match="track modulus u"):
        winkler.characteristic_length(EI_60E1, bad)
