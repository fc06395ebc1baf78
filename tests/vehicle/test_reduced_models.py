"""Relations between the models: 11-DOF -> 7-DOF limit, the seed's nonlinear-track finding,
and left/right symmetry."""

import numpy as np
import pytest

from trackdyn.options import RunOptions
from trackdyn.simulation import simulate
from trackdyn.track.support import SupportCurve
from trackdyn.track.track import Geometry, Supports, Track
from trackdyn.vehicle.parameters import load_vehicle

SPEED = 20.0  # [m/s]
LENGTH = 40.0  # [m]
GEOMETRY_SPACING = 0.25  # [m], a recording car's sampling interval
SLEEPER_SPACING = 0.6  # [m]
SEATING_LOAD = 32.5e3  # [N], the seed's seating load (§5.1, Ebersöhn et al. 1993)


def rms(x, axis=0):
    return np.sqrt(np.mean(np.square(x), axis=axis))


def irregular_track(seed, symmetric=False):
    """Irregular rails (seven sines of 2-25 m, 1.5 mm at 25 m, plus 0.1 mm noise) on
    sleepers of random stiffness (100 MN/m, 20 % scatter); with ``symmetric`` the right
    rail is a copy of the left, geometry and stiffness."""
    rng = np.random.default_rng(seed)
    x = np.arange(0.0, LENGTH + GEOMETRY_SPACING / 2, GEOMETRY_SPACING)
    sleepers = np.arange(0.0, LENGTH + SLEEPER_SPACING / 2, SLEEPER_SPACING)
    wavelengths = np.array([25.0, 14.0, 9.0, 6.3, 4.1, 2.9, 2.0])

    def rail():
        phases = rng.uniform(0, 2 * np.pi, wavelengths.size)
        waves = (1.5e-3 * wavelengths / 25.0)[:, None] * np.sin(
            2 * np.pi * x[None, :] / wavelengths[:, None] + phases[:, None]
        )
        return waves.sum(axis=0) + rng.normal(0.0, 0.1e-3, x.size)

    def stiffness():
        return 100e6 * np.clip(1 + 0.2 * rng.standard_normal(sleepers.size), 0.4, None)

    left, k_left = rail(), stiffness()
    right, k_right = (left.copy(), k_left.copy()) if symmetric else (rail(), stiffness())
    return Track(Geometry(x, left, right), Supports.linear(sleepers, k_left, k_right))


# --- (a) 11-DOF with a rigid primary suspension is the 7-DOF model --------------------


@pytest.fixture(scope="module")
def stiff_primary():
    """11-DOF runs with kp x 1e3 and x 1e4, and 7-DOF runs on the same time steps."""
    v = load_vehicle("loaded")  # friction wedges on (mu = 0.25): both models have them
    lin = irregular_track(seed=3).linearise(v.static_wheel_load)
    out = {"v": v, "lin": lin}
    for factor in (1e3, 1e4):
        # simulate picks dt from the highest natural frequency (the frame on the primary
        # springs, about 3.3 kHz at x 1e4) and refuses an unstable one; the 7-DOF run uses
        # the same dt so that the comparison is of the models, not of the time steps.
        eleven = simulate(
            v.replace(kp=v.kp * factor), lin, RunOptions(speed_kmh=SPEED * 3.6, store_every=1)
        )
        seven = simulate(
            v,
            lin,
            RunOptions(
                model="7dof", speed_kmh=SPEED * 3.6, dt_s=eleven.attrs["time_step_s"], store_every=1
            ),
        )
        n = min(eleven.time.size, seven.time.size)
        out[factor] = (eleven.isel(time=slice(0, n)), seven.isel(time=slice(0, n)))
    return out


def wheel_load_difference(eleven, seven, static_load):
    """RMS difference of the wheel loads relative to the RMS dynamic load, per contact."""
    dynamic = seven.wheel_load.values - static_load
    return rms(eleven.wheel_load.values - seven.wheel_load.values) / rms(dynamic)


def test_rigid_primary_eleven_dof_is_seven_dof(stiff_primary):
    # Tolerance: with the primary suspension (kp per side) in series with the track (k2 per
    # side, the sum over two axles) the wheelset sees k2 kp / (k2 + kp) = k2 (1 - ε + ...),
    # ε = k2 / kp; the frame and wheelset masses and inertias then add up as the 7-DOF
    # model lumps them (mw + m2, Iw + I2). The wheel loads differ at order ε; allow 2 ε
    # with the stiffest sleeper pair on the section (ε = 1.5e-3 here).
    v, lin = stiff_primary["v"], stiff_primary["lin"]
    eleven, seven = stiff_primary[1e4]
    eps = 2 * lin.k2.max() / (v.kp * 1e4)
    assert seven.contact.values.tolist() == eleven.contact.values.tolist()
    dynamic = rms(seven.wheel_load.values - v.static_wheel_load)
    assert dynamic.min() > 0.02 * v.static_wheel_load  # real dynamics: > 2.5 kN RMS
    difference = wheel_load_difference(eleven, seven, v.static_wheel_load)
    assert difference.max() < 2 * eps, difference
    # The body moves the same way too.
    for dof in ("body_bounce", "body_roll", "body_pitch"):
        a = eleven.displacement.sel(dof=dof).values
        b = seven.displacement.sel(dof=dof).values
        assert rms(a - b) < 2 * eps * rms(b), dof


def test_difference_to_seven_dof_falls_like_one_over_kp(stiff_primary):
    # The difference is first order in ε = k2 / kp: ten times the primary stiffness gives
    # a tenth of the difference (between 1/20 and 1/5 allowed).
    v = stiff_primary["v"]
    d3 = wheel_load_difference(*stiff_primary[1e3], v.static_wheel_load).max()
    d4 = wheel_load_difference(*stiff_primary[1e4], v.static_wheel_load).max()
    assert 5 < d3 / d4 < 20, (d3, d4)


# --- (b) nonlinear stiffness alone gives no dynamic load; a change in deflection does --
# For the single-wheel models: the 2-DOF model and the full model (one contact per wheel).


def seating_curve(gap, stiffness=100e6):
    """Load-deflection curve with a seating range: ``y = P / k + g (1 - exp(-P / P0))``,
    P0 = 32.5 kN / 3, so the gap is closed (95 %) by the seed's seating load; a linear
    track of 100 MN/m behind it (the shape of the seed's Fig. 5.2)."""
    load = np.array([0, 5, 10, 15, 20, 32.5, 45, 60, 80, 100, 130, 160, 200, 250.0]) * 1e3
    return SupportCurve(load, load / stiffness + gap * (1 - np.exp(-load / (SEATING_LOAD / 3))))


def level_track(gaps):
    """Level rails (no geometry) on sleepers with the given seating gaps [m]."""
    x = np.arange(0.0, LENGTH + GEOMETRY_SPACING / 2, GEOMETRY_SPACING)
    sleepers = np.arange(0.0, LENGTH + SLEEPER_SPACING / 2, SLEEPER_SPACING)
    curves = tuple(seating_curve(g) for g in np.broadcast_to(gaps, sleepers.shape))
    return Track(
        Geometry(x, np.zeros_like(x), np.zeros_like(x)), Supports(sleepers, curves, curves)
    )


UNIFORM_GAP = 1.0e-3  # [m] every sleeper; a realistic seating gap
EXTRA_GAP = 2.0e-3  # [m] more on six sleepers (3 m) mid-section: a few hanging sleepers


@pytest.mark.parametrize("model", ["2dof", "full"])
@pytest.mark.parametrize("nonlinear", [False, True], ids=["linearised", "nonlinear"])
def test_uniform_nonlinear_track_gives_no_dynamic_load(nonlinear, model):
    # Seed §5.4.1: "it is not the nonlinearity of the track stiffness in itself that causes
    # a dynamic input, but the spatial change in track deflection under a given load".
    v = load_vehicle("loaded")
    ps = v.static_wheel_load
    track = level_track(UNIFORM_GAP)
    lin = track.linearise(ps)
    # The curve is nonlinear over the load range: the secant over Ps ± 0.3 Ps differs from
    # the secant from zero load, Ps / ys, by the seating gap.
    assert ps / lin.ys[0, 0] < 0.7 * lin.k2[0, 0]
    ds = simulate(
        v,
        track,
        RunOptions(model=model, speed_kmh=SPEED * 3.6, nonlinear=nonlinear, store_every=1),
    )
    assert np.abs(ds.wheel_load.values - ps).max() < 1e-6 * ps


@pytest.mark.parametrize("model", ["2dof", "full"])
@pytest.mark.parametrize("nonlinear", [False, True], ids=["linearised", "nonlinear"])
def test_spatial_change_in_deflection_gives_dynamic_load(nonlinear, model):
    v = load_vehicle("loaded")
    ps = v.static_wheel_load
    sleepers = np.arange(0.0, LENGTH + SLEEPER_SPACING / 2, SLEEPER_SPACING)
    gaps = np.where(np.abs(sleepers - LENGTH / 2) < 1.6, UNIFORM_GAP + EXTRA_GAP, UNIFORM_GAP)
    assert np.count_nonzero(gaps > UNIFORM_GAP) == 6
    track = level_track(gaps)
    lin = track.linearise(ps)
    # Same stiffness everywhere (the extra gap is closed below Ps - ΔP), only the static
    # deflection changes: ys grows by the extra gap, and the secant is the same to 0.2 %
    # (what is left of a 3 mm gap at Ps - ΔP = 89 kN, 3 mm x exp(-8.2) = 0.8 µm, against
    # ys2 - ys1 = 2ΔP / k = 0.77 mm, changes it by 0.07 %).
    np.testing.assert_allclose(lin.k2, lin.k2[0, 0], rtol=2e-3)
    assert lin.ys.max() - lin.ys.min() == pytest.approx(EXTRA_GAP, rel=1e-3)
    ds = simulate(
        v,
        track,
        RunOptions(model=model, speed_kmh=SPEED * 3.6, nonlinear=nonlinear, store_every=1),
    )
    assert np.abs(ds.wheel_load.values - ps).max() > 0.01 * ps


# --- (c) symmetric input gives no roll ---------------------------------------------------


@pytest.mark.parametrize("model", ["4dof", "7dof", "11dof"])
def test_symmetric_input_gives_no_roll(model):
    # With left = right (geometry and stiffness) the equations for the roll coordinates
    # are forced by nothing and start at rest: roll stays zero to round-off. Friction on.
    v = load_vehicle("loaded")
    ds = simulate(
        v,
        irregular_track(seed=5, symmetric=True),
        RunOptions(model=model, speed_kmh=SPEED * 3.6, store_every=1),
    )
    roll = [d for d in ds.dof.values if str(d).endswith("roll")]
    assert len(roll) == {"4dof": 2, "7dof": 3, "11dof": 5}[model]
    assert np.abs(ds.displacement.sel(dof=roll).values).max() < 1e-12  # [rad]
    # ... while the bounce motion is real, and left and right wheel loads are equal.
    dynamic = ds.wheel_load.values - v.static_wheel_load
    assert rms(dynamic).min() > 0.02 * v.static_wheel_load
    rails = ds.contact_rail.values
    left = ds.wheel_load.values[:, rails == "left"]
    right = ds.wheel_load.values[:, rails == "right"]
    np.testing.assert_allclose(left, right, rtol=0, atol=1e-9 * v.static_wheel_load)
