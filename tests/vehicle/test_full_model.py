"""The full model: its layout, and its limit, the 11-DOF model, when the bogie approximation
of 5.4.3 is exact (the same input under both axles of a bogie)."""

import numpy as np
import pytest

from trackdyn.options import RunOptions
from trackdyn.simulation import simulate
from trackdyn.track.track import Geometry, Supports, Track
from trackdyn.vehicle.models import build_model
from trackdyn.vehicle.parameters import load_vehicle

SPEED = 20.0  # [m/s]
LENGTH = 30.0  # [m]: 19.6 m of travel beyond the 10.4 m the axles span, about 1 s


@pytest.fixture(scope="module")
def vehicle():
    return load_vehicle("loaded")


def test_layout(vehicle):
    v = vehicle
    m = build_model("full", v)
    assert m.contact_names == ("1L", "1R", "2L", "2R", "3L", "3R", "4L", "4R")
    assert m.contact_sides == ("FL", "FR", "FL", "FR", "BL", "BR", "BL", "BR")
    assert m.contact_rails == ("left", "right") * 4
    # Axle 1 leads: the front bogie's axles at b_cc ± a, the back bogie's at -b_cc ± a.
    axles = [v.b_cc + v.a, v.b_cc - v.a, -v.b_cc + v.a, -v.b_cc - v.a]
    assert m.contact_axles == tuple((x,) for x in np.repeat(axles, 2))
    assert m.wedge_names == m.suspension_names == ("FL", "FR", "BL", "BR")
    # Same vehicle as the 11-DOF model: same total mass, same static wheel load.
    eleven = build_model("11dof", v)
    bounce = [i for i, n in enumerate(m.dof_names) if n.endswith("bounce")]
    bounce11 = [i for i, n in enumerate(eleven.dof_names) if n.endswith("bounce")]
    assert m.M[bounce, bounce].sum() == pytest.approx(eleven.M[bounce11, bounce11].sum())
    assert m.static_wheel_load == eleven.static_wheel_load


def test_stiffness_modes(vehicle):
    # Off the track the springs leave 7 free motions: bounce, roll and pitch of the whole
    # vehicle, and each side frame pitching about its centre (the secondary sits there)
    # with its two wheels following. The 8 wheel contacts remove them all.
    m = build_model("full", vehicle)
    assert len(m.dof_names) == 19
    np.testing.assert_allclose(m.K, m.K.T, rtol=0, atol=1e-14 * np.abs(m.K).max())
    assert np.linalg.matrix_rank(m.K) == 19 - 7
    Kt = m.K + m.Dc.T @ (1e8 * m.Dc)
    assert np.linalg.eigvalsh(Kt).min() > 0


def wheelbase_periodic_track(v):
    """Rails and supports that repeat every wheelbase 2a: both axles of a bogie see the
    same input at all times. Two harmonics of 2a per rail (phases differ left/right to
    excite roll); sleepers every 2a/3 with a stiffness pattern repeating every three."""
    period = 2 * v.a
    x = np.arange(0.0, LENGTH, period / 40)
    phase = 2 * np.pi * x / period
    left = 1.0e-3 * np.sin(phase) + 0.4e-3 * np.sin(2 * phase + 0.5)
    right = 0.8e-3 * np.sin(phase + 1.2) + 0.5e-3 * np.sin(2 * phase + 2.0)
    sleepers = np.arange(0.0, LENGTH, period / 3)
    k_left = 100e6 * np.resize([1.0, 0.8, 1.25], sleepers.size)
    k_right = 100e6 * np.resize([0.9, 1.2, 1.0], sleepers.size)
    return Track(Geometry(x, left, right), Supports.linear(sleepers, k_left, k_right))


def uniform_stiffness_track(v):
    """Irregular rails (sines of 2-25 m, random phases, a few mm) on sleepers of one
    stiffness per rail: the two axles of a bogie see different profiles, the same k2."""
    rng = np.random.default_rng(7)
    x = np.arange(0.0, LENGTH, 0.25)
    wavelengths = np.array([25.0, 9.0, 2 * v.a * 2, 2.9, 2 * v.a * 2 / 3])  # [m]

    def rail():
        phases = rng.uniform(0, 2 * np.pi, wavelengths.size)
        return (1e-3 * np.sin(2 * np.pi * x[:, None] / wavelengths + phases)).sum(axis=1)

    sleepers = np.arange(0.0, LENGTH, 0.6)
    return Track(Geometry(x, rail(), rail()), Supports.linear(sleepers, 100e6, 80e6))


@pytest.mark.parametrize(
    ("track", "kp_factor"),
    [
        (wheelbase_periodic_track, 1.0),
        (wheelbase_periodic_track, 100.0),
        (uniform_stiffness_track, 1.0),
    ],
    ids=["same-input-nominal-pads", "same-input-stiff-pads", "same-stiffness"],
)
def test_full_model_side_mean_is_the_eleven_dof_model(vehicle, track, kp_factor):
    # The side frame's centre of mass, its secondary and the middle of its two axleboxes
    # coincide, so with the same track stiffness under both axles of a bogie its motions
    # split exactly into a symmetric part (both wheelsets alike, driven by the mean of
    # their inputs) and an antisymmetric one (side frame pitch, driven by the difference).
    # The symmetric part is the 11-DOF model of 5.19-5.29 with mw = 2 mw1, Iw = 2 Iw1,
    # I2 = m2 b² (side frames at ±b) and the two wheels' track damping, 2 ρ2, per bogie side
    # (the printed 5.26-5.29 have one ρ2 per side); the per-side mean wheel load is its
    # output. So the means agree to round-off, for any primary stiffness; the brief's
    # limit (stiff pads, the same input under both axles, < 1 %) is the second case.
    v = vehicle.replace(kp=vehicle.kp * kp_factor, I2=vehicle.m2 * vehicle.b**2)
    lin = track(v).linearise(v.static_wheel_load)
    full = simulate(v, lin, RunOptions(model="full", speed_kmh=SPEED * 3.6, store_every=1))
    eleven = simulate(
        v.replace(rho2=2 * v.rho2),
        lin,
        RunOptions(
            model="11dof", speed_kmh=SPEED * 3.6, dt_s=full.attrs["time_step_s"], store_every=1
        ),
    )
    n = min(full.time.size, eleven.time.size)
    mean = full.wheel_load_side_mean.values[:n]
    lumped = eleven.wheel_load.sel(contact=list(full.side.values)).values[:n]
    dynamic = np.sqrt(np.mean((lumped - v.static_wheel_load) ** 2, axis=0))
    assert dynamic.min() > 0.02 * v.static_wheel_load  # real dynamics: > 2.5 kN RMS
    difference = np.sqrt(np.mean((mean - lumped) ** 2, axis=0)) / dynamic
    assert difference.max() < 1e-9, difference  # round-off over 5000-20000 steps
    if track is uniform_stiffness_track:
        # Not a trivial agreement: the single wheels differ from their side's mean by a
        # large part of the dynamic load (waves of 2 and 2/3 wheelbases put the two axles
        # in antiphase), which the 11-DOF model cannot show.
        side_of = [list(full.side.values).index(s) for s in full.contact_side.values]
        spread = np.sqrt(np.mean((full.wheel_load.values[:n] - mean[:, side_of]) ** 2, axis=0))
        assert spread.min() > 0.3 * dynamic.max(), (spread, dynamic)


def test_side_mean_is_xarrays_grouped_mean_to_the_bit(vehicle):
    # `results` adds each side's wheels in contact order and divides by their number, in
    # one compiled pass; xarray's grouped mean (which it replaced) gives the same bits
    ds = simulate(vehicle, wheelbase_periodic_track(vehicle), RunOptions(model="full"))
    load = ds.wheel_load.assign_coords(contact_side=ds.contact_side)
    grouped = load.groupby("contact_side").mean().rename(contact_side="side")
    expected = grouped.sel(side=ds.side.values).values
    assert np.array_equal(ds.wheel_load_side_mean.values.view(np.int64), expected.view(np.int64))
