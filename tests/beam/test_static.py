"""Tests for the finite-element rail on discrete nonlinear supports (trackdyn.beam.static)."""

import numpy as np
import pytest
from scipy.optimize import brentq

from trackdyn.beam.static import BeamSupports, linear_supports, solve_beam
from trackdyn.errors import TrackdynInputError
from trackdyn.track import winkler
from trackdyn.track.rails import rail_section

EI = rail_section("60E1").EI  # 210 GPa * 3038 cm^4 = 6.38e6 N m^2 (EN 13674-1)
U = 40e6  # track modulus per rail [N/m^2]: the value suggested in the task brief
LC = winkler.characteristic_length(EI, U)  # (4 EI / u)^(1/4) = 0.894 m
K_SEAT = 60e6  # rail seat stiffness (pad, sleeper, ballast in series), chosen realistic [N/m]
SPACING = 0.6  # common concrete sleeper spacing [m]
WHEEL = 130e3  # 26 t axle / 2 wheels, quasi-static wheel load [N]


def uniform_track(spacing, half_length=12.0, **kw):
    """Supports every ``spacing`` from -half_length to +half_length; k_s = u * spacing."""
    # half_length 12 m = 13.4 L_c > the 10 L_c each side asked for; k_s = u s lumps the
    # Winkler foundation of one bay onto its sleeper.
    n = round(2 * half_length / spacing)
    return linear_supports(np.linspace(-half_length, half_length, n + 1), U * spacing, **kw)


def sleepers(n=41, gap=0.0, **kw):
    """n sleepers at SPACING with rail seat stiffness K_SEAT, middle one at index n // 2."""
    return linear_supports(np.arange(n) * SPACING, K_SEAT, gap, **kw)


def relative_max(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


# --- 1, 2: bilateral linear supports reproduce the Winkler beam --------------------------


@pytest.mark.parametrize(("spacing", "offset"), [(0.1, 0.0), (0.1, 0.05), (0.6, 0.3)])
def test_single_load_matches_winkler(spacing, offset):
    # offset 0 puts the load on a support, spacing / 2 mid-bay. 0.1 m is "dense" (L_c / 9);
    # 0.6 m (L_c / 1.5, a real sleeper spacing) is included to show it still holds.
    sol = solve_beam(uniform_track(spacing, tensionless=False), EI, offset, 100e3)
    r = np.array([0.0, 0.3, 0.6, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0])  # distances from the load
    exact = winkler.deflection(r, 100e3, EI, U)
    for y in (sol.deflection_at(offset + r), sol.deflection_at(offset - r)):
        assert np.max(np.abs(y - exact)) < 0.01 * exact[0]  # 1 % of the peak
    assert sol.support_force.sum() == pytest.approx(100e3, rel=1e-9)  # vertical equilibrium
    assert sol.support_force @ sol.support_position == pytest.approx(100e3 * offset, abs=1e-4)


def test_two_loads_superpose_winkler_basins():
    # 1.8 m: a typical bogie wheelbase
    sol = solve_beam(uniform_track(0.1, tensionless=False), EI, [-0.9, 0.9], 100e3)
    x = np.linspace(-6, 6, 121)
    exact = winkler.deflection(x + 0.9, 100e3, EI, U) + winkler.deflection(x - 0.9, 100e3, EI, U)
    assert np.max(np.abs(sol.deflection_at(x) - exact)) < 0.01 * exact.max()  # 1 % of peak
    assert sol.support_force.sum() == pytest.approx(200e3, rel=1e-9)


def test_tensionless_supports_let_the_weightless_rail_lift():
    # Same track, default tensionless supports: Winkler's foundation pulls the rail down
    # beyond 3 pi L_c / 4 = 2.1 m; without that pull the rail lifts and the peak grows.
    sol = solve_beam(uniform_track(0.1), EI, 0.0, 100e3)
    peak = winkler.deflection(0.0, 100e3, EI, U)
    assert sol.deflection_at(0.0) > 1.05 * peak  # measured +9.0 %
    far = np.abs(sol.support_position) > 3 * LC
    assert np.all(sol.support_force[far] == 0) and np.all(sol.support_deflection[far] < 0)
    assert np.all(sol.support_force >= 0)
    assert sol.support_force.sum() == pytest.approx(100e3, rel=1e-9)


# --- 3: linearity ------------------------------------------------------------------------


@pytest.mark.parametrize("tensionless", [False, True])
def test_deflection_is_linear_in_load(tensionless):
    # Without gaps both problems are positively homogeneous: y(2P) = 2 y(P).
    supports = sleepers(tensionless=tensionless)
    one = solve_beam(supports, EI, 12.2, WHEEL)
    two = solve_beam(supports, EI, 12.2, 2 * WHEEL)
    assert relative_max(two.deflection, 2 * one.deflection) < 1e-9
    assert relative_max(two.support_force, 2 * one.support_force) < 1e-9


# --- 4: voided sleeper -------------------------------------------------------------------


def three_support_deflections(load, k, gap, s=SPACING):
    """Rail on a sleeper (gap ``gap``) and its two neighbours, load on the middle one.

    Unknowns y0 (middle) and y1 (neighbours): vertical equilibrium
    k (y0 - gap) + 2 k y1 = P, and compatibility of a simply supported span 2s loaded by
    P - R0 at mid-span: y0 - y1 = (P - R0) (2s)^3 / (48 EI).
    """
    c = (2 * s) ** 3 / (48 * EI)
    a = np.array([[k, 2 * k], [1 + k * c, -1.0]])
    return np.linalg.solve(a, [load + k * gap, (load + k * gap) * c])


def test_uniform_sleepers_three_carry_the_wheel():
    # With K_SEAT = 60 MN/m the tensionless rail lifts off beyond the neighbours, so the
    # 41-sleeper beam reduces to the three-support problem above.
    sol = solve_beam(sleepers(), EI, 12.0, WHEEL)
    y0, y1 = three_support_deflections(WHEEL, K_SEAT, 0.0)
    assert sol.support_deflection[20] == pytest.approx(y0, rel=1e-9)
    assert sol.support_deflection[[19, 21]] == pytest.approx([y1, y1], rel=1e-9)
    assert np.count_nonzero(sol.support_force) == 3


def test_voided_sleeper_open_gap():
    gap = np.zeros(41)
    gap[20] = 2e-3  # 2 mm void under the loaded sleeper
    uniform = solve_beam(sleepers(), EI, 12.0, WHEEL)
    voided = solve_beam(sleepers(gap=gap), EI, 12.0, WHEEL)
    assert voided.support_force[20] == 0.0  # gap not closed
    assert voided.support_deflection[20] < 2e-3
    assert np.all(voided.support_force[[19, 21]] > uniform.support_force[[19, 21]])
    assert voided.support_force[[19, 21]] == pytest.approx([WHEEL / 2] * 2, rel=1e-9)  # statics
    # span 1.2 m on two springs: y = (P/2)/k + P L^3 / (48 EI)
    assert voided.deflection.max() == pytest.approx(
        WHEEL / 2 / K_SEAT + WHEEL * 1.2**3 / (48 * EI), rel=1e-9
    )
    assert voided.deflection.max() > uniform.deflection.max()
    assert voided.support_force.sum() == pytest.approx(WHEEL, rel=1e-9)
    # an open void is the same as no sleeper at all
    removed = solve_beam(
        linear_supports(np.delete(np.arange(41) * SPACING, 20), K_SEAT), EI, 12.0, WHEEL
    )
    assert relative_max(removed.deflection_at(voided.x), voided.deflection) < 1e-9


def test_voided_sleeper_gap_closes_under_a_heavier_load():
    # The open-gap deflection above is 1.82 mm at 130 kN, so the 2 mm gap closes at
    # 143 kN; 250 kN is a heavy impact load.
    gap = np.zeros(41)
    gap[20] = 2e-3
    load = 250e3
    uniform = solve_beam(sleepers(), EI, 12.0, load)
    voided = solve_beam(sleepers(gap=gap), EI, 12.0, load)
    assert 0 < voided.support_force[20] < uniform.support_force[20]
    assert np.all(voided.support_force[[19, 21]] > uniform.support_force[[19, 21]])
    assert voided.support_force.sum() == pytest.approx(load, rel=1e-9)
    assert voided.deflection.max() > uniform.deflection.max()
    y0, y1 = three_support_deflections(load, K_SEAT, 2e-3)
    assert np.count_nonzero(voided.support_force) == 3
    assert voided.support_deflection[20] == pytest.approx(y0, rel=1e-9)
    assert voided.support_force[20] == pytest.approx(K_SEAT * (y0 - 2e-3), rel=1e-9)


def test_closed_gap_equals_extra_load_on_bilateral_track():
    # Bilateral springs with gap g: force k (y - g) = k y - k g, so by superposition the
    # answer is the gap-free one plus that of a point load k g at the voided sleeper.
    gap = np.zeros(41)
    gap[20] = 0.5e-3
    voided = solve_beam(sleepers(gap=gap, tensionless=False), EI, 12.3, WHEEL)
    plain = solve_beam(sleepers(tensionless=False), EI, 12.3, WHEEL)
    extra = solve_beam(sleepers(tensionless=False), EI, 12.0, K_SEAT * 0.5e-3)
    x = np.linspace(0, 24, 97)
    expected = plain.deflection_at(x) + extra.deflection_at(x)
    assert relative_max(voided.deflection_at(x), expected) < 1e-9


def test_all_sleepers_voided():
    # Every sleeper 2 mm below the rail: at the start no support touches (the rigid-body modes
    # are free) and the answer is the seated one shifted down by the gap.
    seated = solve_beam(sleepers(), EI, 12.2, WHEEL)
    voided = solve_beam(sleepers(gap=2e-3), EI, 12.2, WHEEL)
    # 1e-8, not 1e-9: the lifted rail ends are 12 m levers and a residual at rounding level
    # (4e-7 N) tilts them by ~3e-11 m (measured 2.3e-9 relative)
    assert relative_max(voided.deflection, seated.deflection + 2e-3) < 1e-8
    assert relative_max(voided.support_force, seated.support_force) < 1e-9


# --- 5: nonlinear support curves ---------------------------------------------------------

# Stiffening rail seat: 20 MN/m for the first 0.5 mm (soft pad), then 100 MN/m.
BILINEAR_D = [0.0, 0.5e-3, 1.5e-3]
BILINEAR_F = [0.0, 10e3, 110e3]


def bilinear(position):
    n = len(position)
    return BeamSupports(position, np.tile(BILINEAR_D, (n, 1)), np.tile(BILINEAR_F, (n, 1)))


def inverse(force):
    return np.interp(force, BILINEAR_F, BILINEAR_D)


def test_two_bilinear_supports_statically_determinate():
    # Load 0.4 m from the first of two supports 0.6 m apart: reactions by statics, support
    # deflections by inverting the curve, plus the simply supported span's own deflection.
    p, a, b = WHEEL, 0.4, 0.2
    sol = solve_beam(bilinear([0.0, 0.6]), EI, a, p)
    r = np.array([p * b / 0.6, p * a / 0.6])
    assert sol.support_force == pytest.approx(r, rel=1e-9)
    assert sol.support_deflection == pytest.approx(inverse(r), rel=1e-9)
    span = p * a**2 * b**2 / (3 * EI * 0.6)
    y = inverse(r[0]) + (inverse(r[1]) - inverse(r[0])) * a / 0.6 + span
    assert sol.deflection_at(a) == pytest.approx(y, rel=1e-9)


def test_load_off_node_is_exact_between_nodes():
    # 2 cm from a support is closer than max_element / 4, so no node is made there; the load
    # enters as consistent nodal loads and deflection_at adds the in-element part.
    p, a = WHEEL, 0.02
    sol = solve_beam(linear_supports([0.0, 0.6], K_SEAT), EI, a, p)
    assert not np.any(np.isclose(sol.x, a))
    y0, y1 = p * (0.6 - a) / 0.6 / K_SEAT, p * a / 0.6 / K_SEAT
    xs = np.array([0.01, a, 0.3])
    # simply supported span with a point load at a (x <= a and x >= a branches)
    b = 0.6 - a
    span = np.where(
        xs <= a,
        p * b * xs * (0.6**2 - b**2 - xs**2) / (6 * EI * 0.6),
        p * a * (0.6 - xs) * (0.6**2 - a**2 - (0.6 - xs) ** 2) / (6 * EI * 0.6),
    )
    assert sol.deflection_at(xs) == pytest.approx(y0 + (y1 - y0) * xs / 0.6 + span, rel=1e-9)


def test_three_bilinear_supports_against_root_finding():
    # Load on the middle of three supports: the statically indeterminate problem of
    # three_support_deflections with the bilinear curve, solved by brentq.
    p, s = WHEEL, SPACING
    c = (2 * s) ** 3 / (48 * EI)

    def force(y):
        return np.interp(y, BILINEAR_D, BILINEAR_F, left=0.0) + (
            100e6 * max(y - BILINEAR_D[-1], 0.0)
        )

    def mismatch(y0):
        r0 = force(y0)
        return y0 - inverse((p - r0) / 2) - (p - r0) * c

    y0 = brentq(mismatch, 0.0, 2e-3, xtol=1e-15)
    sol = solve_beam(bilinear([0.0, s, 2 * s]), EI, s, p)
    assert sol.support_deflection[1] == pytest.approx(y0, rel=1e-9)
    assert sol.support_force[1] == pytest.approx(force(y0), rel=1e-9)


def test_bilinear_track_equilibrium_and_load_step_independence():
    position = np.arange(41) * SPACING
    loads = [12.25, 14.05]  # two wheels 1.8 m apart, off the sleepers
    ten = solve_beam(bilinear(position), EI, loads, WHEEL, load_steps=10)
    forty = solve_beam(bilinear(position), EI, loads, WHEEL, load_steps=40)
    assert relative_max(forty.deflection, ten.deflection) < 1e-8
    assert relative_max(forty.support_force, ten.support_force) < 1e-8
    assert ten.support_force.sum() == pytest.approx(2 * WHEEL, rel=1e-9)
    moment = ten.support_force @ ten.support_position
    assert moment == pytest.approx(WHEEL * sum(loads), rel=1e-9)
    curve_force, _ = bilinear(position).force_and_tangent(ten.support_deflection)
    assert ten.support_force == pytest.approx(curve_force, rel=1e-12)
    assert np.count_nonzero(ten.support_force > BILINEAR_F[1]) >= 2  # stiff branch reached


def test_force_and_tangent():
    curves = BeamSupports(
        [0.0, 1.0, 2.0],
        [[0.0, 1e-3, 2e-3], [1e-3, 2e-3, 3e-3], [0.0, 1e-3, 2e-3]],
        [[0.0, 10e3, 30e3], [0.0, 10e3, 30e3], [0.0, 0.0, 5e3]],
    )
    f, k = curves.force_and_tangent(np.array([1.5e-3, 0.5e-3, 3e-3]))
    assert f == pytest.approx([20e3, 0.0, 10e3])  # mid-segment, in the gap, extrapolated
    assert k == pytest.approx([20e6, 0.0, 5e6])
    f, k = curves.force_and_tangent(np.array([-1e-3, 1e-3, 0.0]))
    assert f == pytest.approx([0.0, 0.0, 0.0])  # uplift, at the gap, on a flat start
    assert k == pytest.approx([0.0, 10e6, 0.0])  # right-hand derivative at a kink
    pulling = BeamSupports(curves.position, curves.deflection, curves.force, tensionless=False)
    assert pulling.force_and_tangent(np.array([-1e-3, 0.0, 0.0]))[0] == pytest.approx(
        [-10e3, -10e3, 0.0]
    )


def test_mesh_and_solution_layout():
    sol = solve_beam(sleepers(11), EI, [1.5, 3.3], WHEEL, max_element=0.1)
    assert np.max(np.diff(sol.x)) <= 0.1 + 1e-12
    assert np.all(np.isin([1.5, 3.3], sol.x)) and np.all(np.isin(sol.support_position, sol.x))
    assert sol.deflection_at(sol.x) == pytest.approx(sol.deflection, rel=1e-12, abs=1e-18)


def test_thousand_sleepers():
    # 1000 sleepers (600 m), one wheel: the long weightless overhangs lift off
    sol = solve_beam(linear_supports(np.arange(1000) * SPACING, K_SEAT), EI, 300.2, WHEEL)
    assert sol.support_force.sum() == pytest.approx(WHEEL, rel=1e-8)
    assert np.count_nonzero(sol.support_force) <= 4


# --- 6: bad input ------------------------------------------------------------------------


def curves_with(**change):
    args = {
        "position": [0.0, 0.6, 1.2],
        "deflection": np.tile([0.0, 1e-3, 2e-3], (3, 1)),
        "force": np.tile([0.0, 10e3, 30e3], (3, 1)),
    }
    for key, (row, values) in change.items():
        args[key] = np.array(args[key], dtype=float)
        args[key][row] = values
    return args


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (curves_with(force=(2, [0.0, 10e3, 5e3])), r"^support 2: force must be non-decreasing"),
        (curves_with(force=(1, [0.0, 10e3, 10e3])), r"^support 1: last segment slope"),
        (curves_with(force=(0, [1.0, 10e3, 30e3])), r"^support 0: force at the first"),
        (curves_with(deflection=(1, [0.0, np.nan, 2e-3])), r"^support 1: deflection .*finite"),
        (curves_with(force=(2, [0.0, np.inf, 3e4])), r"^support 2: force .*finite"),
        (curves_with(deflection=(0, [0.0, 2e-3, 1e-3])), r"^support 0: deflection .*increasing"),
        (curves_with(deflection=(2, [-1e-3, 1e-3, 2e-3])), r"^support 2: first deflection"),
        (curves_with(position=(2, 0.6)), r"^support 2: position"),
        (curves_with(position=(1, np.nan)), r"^support 1: position is not finite"),
        ({**curves_with(), "force": np.zeros((3, 2))}, r"shape"),
    ],
)
def test_bad_support_curves(args, match):
    with pytest.raises(TrackdynInputError, match=match):
        BeamSupports(**args)


@pytest.mark.parametrize(
    ("stiffness", "gap", "match"),
    [
        ([60e6, 60e6, -1.0], 0.0, r"^support 2: stiffness"),
        ([60e6, 0.0, 60e6], 0.0, r"^support 1: stiffness"),
        (60e6, [0.0, np.nan, 0.0], r"^support 1: gap"),
        (60e6, -1e-3, r"^support 0: gap"),
        ([60e6, 60e6], 0.0, r"stiffness and gap"),
    ],
)
def test_bad_linear_supports(stiffness, gap, match):
    with pytest.raises(TrackdynInputError, match=match):
        linear_supports([0.0, 0.6, 1.2], stiffness, gap)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        ({"load": 0.0}, r"^load\[0\] must be finite and > 0"),
        ({"load": [1e5, -1e5], "load_position": [1.0, 2.0]}, r"^load\[1\]"),
        ({"load": np.nan}, r"^load\[0\]"),
        ({"load_position": 24.5}, r"^load_position\[0\] = 24.5 m is outside"),
        ({"load_position": [1.0, -0.1], "load": 1e5}, r"^load_position\[1\]"),
        ({"load_position": [1.0, 2.0], "load": [1e5, 1e5, 1e5]}, r"matching shapes"),
        ({"EI": 0.0}, r"^EI must be"),
        ({"EI": np.nan}, r"^EI must be"),
        ({"max_element": -0.1}, r"^max_element"),
        ({"load_steps": 0}, r"^load_steps"),
        ({"load_steps": 2.5}, r"^load_steps"),
        ({"max_iter": 0}, r"^max_iter"),
        ({"tol": 0.0}, r"^tol"),
        ({"supports": linear_supports([0.0], K_SEAT)}, r"at least 2 supports"),
    ],
)
def test_bad_solve_arguments(call, match):
    args = {"supports": sleepers(), "EI": EI, "load_position": 12.0, "load": WHEEL, **call}
    with pytest.raises(TrackdynInputError, match=match):
        solve_beam(**args)


def test_non_convergence_names_the_load_step():
    with pytest.raises(TrackdynInputError, match=r"^load step 1 of 10: Newton-Raphson did not"):
        solve_beam(bilinear(np.arange(41) * SPACING), EI, 12.1, WHEEL, max_iter=1)


def test_deflection_at_outside_beam():
    sol = solve_beam(sleepers(5), EI, 1.0, WHEEL)
    with pytest.raises(TrackdynInputError, match=r"^x must lie within"):
        sol.deflection_at(2.5)
