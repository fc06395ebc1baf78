"""The discrete track (`trackdyn.track.discrete`, `trackdyn.solver.discrete`) against an
independent integration of the same equations and against the static rail beam."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from trackdyn import load_vehicle
from trackdyn.beam.elements import element_stiffness, hermite
from trackdyn.beam.static import linear_supports, solve_beam
from trackdyn.errors import Failure, TrackdynInputError
from trackdyn.options import RunOptions
from trackdyn.simulation import run_batch
from trackdyn.solver.discrete import (
    axle_table,
    first_window,
    sample_profile,
    stability_limit,
    start,
    vehicle_model,
)
from trackdyn.track.discrete import discrete_track, hertz_stiffness
from trackdyn.track.track import Geometry, Supports, Track
from trackdyn.units import GRAVITY
from trackdyn.vehicle.models import MODELS

SPACING = 0.6


def small_track(n=60, stiffness=100e6, seed=None, dip=0.0):
    """``n`` sleepers at 0.6 m; point stiffness ``stiffness`` [N/m] (scattered by 30 % with
    a seed); a cosine dip of depth ``dip`` [m] and 1 m length at 11 m."""
    pos = np.arange(n) * SPACING
    k = np.full(n, stiffness)
    if seed is not None:
        k = k * np.random.default_rng(seed).uniform(0.7, 1.3, n)
    x = np.arange(0.0, pos[-1] + 0.01, 0.25)
    y = np.where(np.abs(x - 11.0) < 0.5, 0.5 * dip * (1 + np.cos(np.pi * (x - 11.0) / 0.5)), 0)
    return Track(Geometry(x, y, y), Supports.linear(pos, k, k))


def run(vehicle, track, **options):
    (r,) = run_batch([vehicle], [track], [RunOptions(track="discrete", **options)])
    if isinstance(r, Failure):
        raise r.error()
    return r


def reference(p, t_eval):
    """The same equations through scipy's DOP853, every node free (no window)."""
    track, model = p.inputs, vehicle_model(p.model)
    prm = track.params
    axles = axle_table(model)
    off, contact, rail = axles
    x = track.position
    N = x.size
    z0, state0 = start(p, track, model, axles, first_window(p, track, off))
    nq = len(model.dof_names)
    K = np.zeros((2 * N, 2 * N))
    for e, ke in enumerate(element_stiffness(np.diff(x), track.EI)):
        K[2 * e : 2 * e + 4, 2 * e : 2 * e + 4] += ke
    trib = np.gradient(x)
    mass = np.empty(2 * N)
    mass[0::2], mass[1::2] = track.rail_mass * trib, track.rail_rotary * trib
    ps = model.static_wheel_load
    kH = hertz_stiffness(ps, prm.wheel_radius)
    Minv = 1 / np.diag(model.M)
    sgap = track.sleeper_gap
    rest = track.rest

    def wheel(t, q, u):
        """Wheel load of each axle [N] (a contact's axles share it) and the nodal load
        vectors per rail."""
        xa = p.centre0 + p.speed * t + off
        nc = len(model.contact_names)
        top, flex, count = np.zeros(nc), np.zeros(nc), np.bincount(contact, minlength=nc)
        shapes = []
        for a in range(off.size):
            r = rail[a]
            e = min(np.searchsorted(x, xa[a], side="right") - 1, N - 2)
            L = x[e + 1] - x[e]
            s = (xa[a] - x[e]) / L
            shape = hermite(s, L)
            dofs = slice(2 * e, 2 * e + 4)
            rel = u[r, dofs] - np.ravel(rest[:2, r, e : e + 2].T)
            prof = track.geometry.at(["left", "right"][r], xa[a])
            top[contact[a]] += (prof + shape @ rel) / count[contact[a]]
            flex[contact[a]] += (
                (s * L) ** 3 * ((1 - s) * L) ** 3 / (3 * track.EI * L**3) / count[contact[a]]
            )
            shapes.append((r, dofs, shape))
        delta = model.Dc @ q - top + ps / kH
        Wc = np.maximum(delta, 0.0) / (1 / kH + flex)
        W = Wc[contact]
        loads = np.zeros((2, 2 * N))
        for a, (r, dofs, shape) in enumerate(shapes):
            loads[r, dofs] += W[a] * shape
        return W, loads

    def rhs(t, y):
        q, qd = y[:nq], y[nq : 2 * nq]
        rs = y[2 * nq :].reshape(2, 2, 3 * N)  # (disp/vel, rail, [u (2N), zs (N)])
        u, zs = rs[0, :, : 2 * N], rs[0, :, 2 * N :]
        ud, zsd = rs[1, :, : 2 * N], rs[1, :, 2 * N :]
        W, loads = wheel(t, q, u)
        f = np.zeros(nq)
        for a in range(off.size):
            f += model.Dc[contact[a]] * (W[a] - ps)
        qdd = Minv * (-model.C @ qd - model.K @ q - f)
        acc = np.empty((2, 3 * N))
        for r in range(2):
            pad = prm.pad_stiffness * (u[r, 0::2] - zs[r]) + prm.pad_damping * (
                ud[r, 0::2] - zsd[r]
            )
            on = zs[r] > sgap[r]
            ballast = np.where(
                on, track.kb[r] * (zs[r] - sgap[r]) + prm.ballast_damping * zsd[r], 0
            )
            ballast = np.maximum(ballast, 0.0)
            force = -K @ u[r] + loads[r]
            force[0::2] += mass[0::2] * GRAVITY - pad
            acc[r, : 2 * N] = force / mass
            acc[r, 2 * N :] = (prm.sleeper_mass * GRAVITY + pad - ballast) / prm.sleeper_mass
        return np.r_[qd, qdd, np.ravel(rs[1]), np.ravel(acc)]

    u0 = np.zeros((2, 3 * N))
    for r in range(2):
        u0[r, 0 : 2 * N : 2], u0[r, 1 : 2 * N : 2] = state0[0, r], state0[1, r]
        u0[r, 2 * N :] = state0[2, r]
    y0 = np.r_[z0[:nq], np.zeros(nq), u0.ravel(), np.zeros(6 * N)]
    sol = solve_ivp(rhs, (0, t_eval[-1]), y0, method="DOP853", t_eval=t_eval,
                    rtol=1e-9, atol=1e-12)  # fmt: skip
    assert sol.success
    loads = []
    for i, t in enumerate(sol.t):
        y = sol.y[:, i]
        u = y[2 * nq :].reshape(2, 2, 3 * N)[0, :, : 2 * N]
        W, _ = wheel(t, y[:nq], u)
        loads.append(np.bincount(contact, W, len(model.contact_names))
                     / np.bincount(contact, minlength=len(model.contact_names)))  # fmt: skip
    return np.array(loads)


@pytest.mark.parametrize("gap", [0.0, pytest.param(1.0e-3, marks=pytest.mark.slow)])
def test_against_solve_ivp(gap):
    """2-DOF vehicle at 80 km/h over a 2 mm dip on scattered stiffness, with and without a
    1 mm void under the sleeper at 12 m: the compiled loop's wheel load against DOP853 on
    the same equations (every node free, so the window is checked too), < 1 % RMS."""
    v = load_vehicle("loaded")
    track = small_track(n=40, seed=1, dip=2e-3)
    lin = track.linearise(v.static_wheel_load, 0.3)
    voids = np.zeros((2, 40))
    voids[:, 20] = gap
    dt_track = discrete_track(lin, gap=voids)
    r = run(v, dt_track, model="2dof", speed_kmh=80.0, start_m=9.5, end_m=13.0, dt_s=1e-5,
            store_every=20)  # fmt: skip
    times = r.time[r.time <= 0.1]
    ref = reference(r.problem, times)[:, 0]
    got = r.wheel_load[: times.size, 0]
    rms = np.sqrt(np.mean((got - ref) ** 2))
    assert rms < 0.01 * np.sqrt(np.mean(ref**2))
    assert np.ptp(ref) > 0.2 * v.static_wheel_load  # the dip excites the wheel


def test_quasi_static_sleeper_forces():
    """At 1 km/h on scattered stiffness without gaps, each sleeper's largest ballast force
    is that of the static rail beam (trackdyn.beam.static, the same rail-seat springs, rail
    and sleeper weights as point loads) under the static wheel load, < 1 %."""
    v = load_vehicle("loaded")
    track = small_track(n=40, seed=2)
    lin = track.linearise(v.static_wheel_load, 0.3)
    dtrack = discrete_track(lin, gap=np.zeros((2, 40)))
    r = run(v, dtrack, model="2dof", speed_kmh=1.0, start_m=10.0, end_m=14.0)
    x_wheel = r.centre + r.problem.model.contact_axles[0][0]
    pos = track.supports.position
    weight = (dtrack.rail_mass * np.gradient(pos) + dtrack.params.sleeper_mass) * GRAVITY
    supports = linear_supports(pos, dtrack.kd[0, dtrack.first : dtrack.first + 40])
    inside = np.flatnonzero((pos > x_wheel[0] + 0.7) & (pos < x_wheel[-1] - 0.7))
    static = np.zeros(pos.size)
    for xw in np.linspace(x_wheel[0], x_wheel[-1], 150):
        sol = solve_beam(supports, dtrack.EI, np.r_[pos, xw], np.r_[weight, v.static_wheel_load],
                         max_element=1.0)  # fmt: skip
        static = np.maximum(static, sol.support_force)
    got = r.out["ballast_peak"][0, inside]
    assert got == pytest.approx(static[inside], rel=0.01)


def test_profile_sampled_as_the_geometry():
    """The compiled sampling of the profile under an axle gives `Geometry.at` to the bit,
    beyond the samples at both ends too."""
    track = small_track(dip=2e-3)
    g = track.geometry
    centre = np.linspace(-1.0, g.distance[-1] + 0.5, 2001)
    for rail in ("left", "right"):
        spline = CubicSpline(g.distance, g.profile(rail))
        for off in (-5.2, 0.0, 3.4):
            got = np.empty(centre.size)
            sample_profile(spline.x, spline.c, centre, off, got)
            np.testing.assert_array_equal(got, g.at(rail, centre + off))


def test_refusals():
    """A rail seat as stiff as the pad cannot be split; discrete runs need the central
    solver."""
    v = load_vehicle("loaded")
    lin = small_track(stiffness=2e9).linearise(v.static_wheel_load, 0.3)
    with pytest.raises(TrackdynInputError, match="rail pad"):
        discrete_track(lin)
    with pytest.raises(Exception, match="central"):
        RunOptions(track="discrete", solver="reference")


def test_a_step_the_explicit_damping_makes_unstable_is_refused():
    """The damping forces are explicit, so the limit is below 2/ω_max (0.93 of it here): a
    step between the two is refused (run anyway, at 0.95-0.99 of 2/ω the wheel load swings
    by 300-540 kN over these 6 m, against 4 kN at 0.93); a step just below the damped limit
    runs and carries the static load."""
    v = load_vehicle("loaded")
    lin = small_track(n=60).linearise(v.static_wheel_load, 0.3)
    dtrack = discrete_track(lin)
    limit, omega = stability_limit(dtrack, v.static_wheel_load)
    assert 0.85 < limit * omega / 2.0 < 0.99  # the pads' damping lowers the limit by 1-15 %
    with pytest.raises(TrackdynInputError, match="stability limit"):
        run(v, dtrack, model="2dof", speed_kmh=60.0, start_m=12.0, end_m=18.0,
            dt_s=0.5 * (limit + 2.0 / omega))  # fmt: skip
    r = run(v, dtrack, model="2dof", speed_kmh=60.0, start_m=12.0, end_m=18.0,
            dt_s=0.98 * limit)  # fmt: skip
    assert np.all(np.isfinite(r.wheel_load))
    assert r.wheel_load.mean() == pytest.approx(v.static_wheel_load, rel=0.01)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_every_model_runs_on_the_discrete_track(model):
    """Every vehicle model couples to the discrete track: on level track on uniform
    supports each wheel carries its static load, on average within 0.5 % (the sleeper
    passing and the start leave a small oscillation), and every sleeper the vehicle passed
    on a rail with wheels carries at least its share of it."""
    v = load_vehicle("loaded")
    r = run(v, small_track(n=120), model=model, speed_kmh=60.0, start_m=20.0, end_m=50.0)
    assert np.all(np.isfinite(r.wheel_load))
    assert np.mean(r.wheel_load, axis=0) == pytest.approx(v.static_wheel_load, rel=0.005)
    pos = r.problem.inputs.lin.track.supports.position
    passed = (pos > 25.0) & (pos < 45.0)
    rails = sorted({["left", "right"].index(x) for x in r.problem.model.contact_rails})
    assert np.all(r.out["ballast_peak"][rails][:, passed] > 0.3 * v.static_wheel_load)
