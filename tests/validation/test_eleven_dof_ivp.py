"""11-DOF model with friction wedges against an independent integration of eqs 5.19-5.33.

The equations of motion are typed out below from the seed (5.19-5.29 solved for the
accelerations, friction law 5.30-5.33) without using the package's model matrices, and
integrated with scipy's adaptive 8th-order Runge-Kutta (DOP853, rtol 1e-8). The track
input is the same data: ``lin.sample`` at the four axle positions, combined per side of
each bogie as 5.4.3 says (stiffness summed, loaded profile averaged). Stiffness and static
deflection are piecewise linear with kinks where an axle passes a sleeper, the space curve
a cubic spline; the input is tabulated at every kink and every 20 µs between (0.4 mm of
travel) and interpolated linearly in time.

Both solvers are checked against it: the central scheme (`solver="central"`) to its
discretisation error, and the reference solver (`solver="reference"`, DOP853 at the same
tolerance with the input sampled exactly) to about 1e-6: what is left is this table's
interpolation (tabulated every 0.2 ms, the difference was 1e-4).

Why DOP853 and not Radau: at rtol 1e-8 the step is set by accuracy, not stability (the
stiffest motion, the stuck wedge C_slope on the bogie frame, decays at about 1600 1/s,
well inside DOP853's stability region at the steps accuracy needs, ~0.1 ms). Radau
(rtol 1e-8, atol 1e-11) was tried on the same case and gave the same wheel loads (RMS
differences to the central-difference run equal to 4 digits) at 2-6 times the run time.
The friction law is continuous in the velocity (a clipped line), so its kinks only cost
rejected steps in the error control; ``max_step`` keeps any stick phase from being
stepped over.
"""

import bisect

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from trackdyn.options import RunOptions
from trackdyn.simulation import simulate
from trackdyn.track.track import Geometry, Supports, Track
from trackdyn.vehicle.parameters import load_vehicle

SPEED = 20.0  # [m/s], 72 km/h
LENGTH = 40.0  # [m] section; the vehicle's axles span 10.4 m, so about 1.5 s of running
GEOMETRY_SPACING = 0.25  # [m], a track recording car's usual sampling interval
SLEEPER_SPACING = 0.6  # [m]
K_MEAN, K_COV = 100e6, 0.2  # [N/m], [-]: per-sleeper stiffness as in synthetic tracks
RTOL_IVP, ATOL_IVP = 1e-8, 1e-11  # atol: rtol times the mm-scale displacements
MAX_STEP = 1e-3  # [s], a twentieth of the ~50 Hz wheelset-on-track period
TOLERANCE = 0.01  # brief: RMS difference < 1 % of the RMS of the dynamic wheel load
# Two rtol-1e-8 integrations of the same equations: RMS difference measured 0.9e-6 of the
# dynamic wheel load, the input table's interpolation (module docstring); 3e-6 allows for it.
REFERENCE_TOLERANCE = 3e-6

# Seed coordinate order of 5.19-5.29 and the model's names for them (models.py docstring).
SEED_TO_MODEL = (
    "body_bounce",  # y1
    "body_roll",  # θ
    "body_pitch",  # α
    "front_bogie_bounce",  # yF
    "front_bogie_roll",  # φF
    "back_bogie_bounce",  # yB
    "back_bogie_roll",  # φB
    "front_wheelset_bounce",  # zF
    "front_wheelset_roll",  # ωF
    "back_wheelset_bounce",  # zB
    "back_wheelset_roll",  # ωB
)
CONTACTS = ("FL", "FR", "BL", "BR")


def irregular_track(seed=11):
    """A 40 m section: two different irregular rails and a different stiffness per sleeper.

    Geometry: seven sines of 2-25 m wavelength, amplitude proportional to wavelength
    (1.5 mm at 25 m), random phases, plus 0.1 mm white noise per sample; a few mm in all,
    the size of the irregularities of a good heavy-haul track.
    """
    rng = np.random.default_rng(seed)
    x = np.arange(0.0, LENGTH + GEOMETRY_SPACING / 2, GEOMETRY_SPACING)
    wavelengths = np.array([25.0, 14.0, 9.0, 6.3, 4.1, 2.9, 2.0])
    amplitudes = 1.5e-3 * wavelengths / 25.0

    def rail():
        phases = rng.uniform(0, 2 * np.pi, wavelengths.size)
        waves = amplitudes[:, None] * np.sin(
            2 * np.pi * x[None, :] / wavelengths[:, None] + phases[:, None]
        )
        return waves.sum(axis=0) + rng.normal(0.0, 0.1e-3, x.size)

    left, right = rail(), rail()
    sleepers = np.arange(0.0, LENGTH + SLEEPER_SPACING / 2, SLEEPER_SPACING)

    def stiffness():
        return K_MEAN * np.clip(1 + K_COV * rng.standard_normal(sleepers.size), 0.4, None)

    return Track(Geometry(x, left, right), Supports.linear(sleepers, stiffness(), stiffness()))


class SeedEquations:
    """Eqs 5.19-5.33 for the vehicle ``v``, with the contact inputs as functions of time."""

    def __init__(self, v, knots, k_table, r_table):
        self.p = (
            v.m1, v.I1, v.Ip, v.m2, v.I2, v.mw, v.Iw, v.k1, v.kp, v.rho_p, v.rho2,
            v.b, v.b_cc, v.l, v.k_ss, v.x_ss, v.mu, float(np.tan(v.alpha_w)), v.C_slope,
        )  # fmt: skip
        self.knots = knots.tolist()
        self.k_table = k_table.tolist()  # per knot: k2FL, k2FR, k2BL, k2BR [N/m]
        self.r_table = r_table.tolist()  # per knot: yFLi, yFRi, yBLi, yBRi [m]

    def inputs(self, t):
        """Track stiffness and input of the four contacts at time ``t`` (linear in time)."""
        kn = self.knots
        i = min(max(bisect.bisect_right(kn, t) - 1, 0), len(kn) - 2)
        w = (t - kn[i]) / (kn[i + 1] - kn[i])
        ka, kb, ra, rb = self.k_table[i], self.k_table[i + 1], self.r_table[i], self.r_table[i + 1]
        k = [x + w * (y - x) for x, y in zip(ka, kb, strict=True)]
        r = [x + w * (y - x) for x, y in zip(ra, rb, strict=True)]
        return k, r

    def friction(self, vel, d):
        """5.30: wedge friction force at relative velocity ``vel`` and displacement ``d``.

        The wedge spring cannot pull (docs/model.md, departures): negative normal force is zero.
        """
        *_, kss, xss, mu, ta, cs = self.p
        normal = max(xss + d, 0.0) * kss
        f = 0.0
        if vel < 0.0:
            f = -normal * mu / (ta + mu)
        if vel > 0.0:
            f = normal * mu / (ta - mu)
        if abs(cs * vel) < abs(f):
            f = cs * vel
        return f

    def suspension(self, s):
        """Relative displacement and velocity across FL, FR, BL, BR (5.30-5.33)."""
        b, bcc = self.p[11], self.p[12]
        y1, th, al, yF, phF, yB, phB = s[0:7]
        y1d, thd, ald, yFd, phFd, yBd, phBd = s[11:18]
        d = (
            y1 - yF + b * th - b * phF - bcc * al,
            y1 - yF - b * th + b * phF - bcc * al,
            y1 - yB + b * th - b * phB + bcc * al,
            y1 - yB - b * th + b * phB + bcc * al,
        )
        vel = (
            y1d - yFd + b * thd - b * phFd - bcc * ald,
            y1d - yFd - b * thd + b * phFd - bcc * ald,
            y1d - yBd + b * thd - b * phBd + bcc * ald,
            y1d - yBd - b * thd + b * phBd + bcc * ald,
        )
        return d, vel

    def rhs(self, t, state, friction=True):
        s = state.tolist()
        m1, I1, Ip, m2, I2, mw, Iw, k1, kp, rp, r2, b, bcc, l, *_ = self.p  # noqa: E741
        (kFL, kFR, kBL, kBR), (yFLi, yFRi, yBLi, yBRi) = self.inputs(t)
        y1, th, al, yF, phF, yB, phB, zF, omF, zB, omB = s[:11]
        y1d, thd, ald, yFd, phFd, yBd, phBd, zFd, omFd, zBd, omBd = s[11:]
        FFL = FFR = FBL = FBR = 0.0
        if friction:
            d, vel = self.suspension(s)
            FFL, FFR, FBL, FBR = (self.friction(vi, di) for vi, di in zip(vel, d, strict=True))
        acc = [
            # (5.19)
            -(FFL + FFR + FBL + FBR + 4 * k1 * y1 - 2 * k1 * yF - 2 * k1 * yB) / m1,
            # (5.20)
            -(
                b * FFL - b * FFR + b * FBL - b * FBR
                + 4 * b**2 * k1 * th - 2 * b**2 * k1 * phF - 2 * b**2 * k1 * phB
            ) / I1,
            # (5.21)
            -(
                -bcc * FFL - bcc * FFR + bcc * FBL + bcc * FBR
                + 4 * bcc**2 * k1 * al + 2 * bcc * k1 * yF - 2 * bcc * k1 * yB
            ) / Ip,
            # (5.22)
            -(
                -FFL - FFR + 2 * rp * yFd - 2 * k1 * (y1 - yF) + 2 * kp * (yF - zF)
                + 2 * k1 * bcc * al - 2 * rp * zFd
            ) / m2,
            # (5.23)
            -(
                -b * FFL + b * FFR + 2 * b**2 * rp * phFd - 2 * b * k1 * (b * th - b * phF)
                + 2 * b**2 * kp * phF - 2 * b**2 * rp * omFd - 2 * b**2 * kp * omF
            ) / I2,
            # (5.24)
            -(
                -FBL - FBR + 2 * rp * yBd - 2 * k1 * (y1 - yB) + 2 * kp * (yB - zB)
                - 2 * k1 * bcc * al - 2 * rp * zBd
            ) / m2,
            # (5.25)
            -(
                -b * FBL + b * FBR + 2 * b**2 * rp * phBd - 2 * b * k1 * (b * th - b * phB)
                + 2 * b**2 * kp * phB - 2 * b**2 * rp * omBd - 2 * b**2 * kp * omB
            ) / I2,
            # (5.26)
            -(
                2 * (rp + r2) * zFd + 2 * kp * zF + kFL * zF + kFR * zF - 2 * rp * yFd
                - 2 * kp * yF - kFL * yFLi - kFR * yFRi + kFL * l * omF - kFR * l * omF
            ) / mw,
            # (5.27)
            -(
                2 * (b**2 * rp + l**2 * r2) * omFd + 2 * b**2 * kp * omF + kFL * l**2 * omF
                + kFR * l**2 * omF - 2 * rp * b**2 * phFd - 2 * kp * b**2 * phF
                - kFL * l * yFLi + kFR * l * yFRi + kFL * l * zF - kFR * l * zF
            ) / Iw,
            # (5.28)
            -(
                2 * (rp + r2) * zBd + 2 * kp * zB + kBL * zB + kBR * zB - 2 * rp * yBd
                - 2 * kp * yB - kBL * yBLi - kBR * yBRi + kBL * l * omB - kBR * l * omB
            ) / mw,
            # (5.29)
            -(
                2 * (b**2 * rp + l**2 * r2) * omBd + 2 * b**2 * kp * omB + kBL * l**2 * omB
                + kBR * l**2 * omB - 2 * rp * b**2 * phBd - 2 * kp * b**2 * phB
                - kBL * l * yBLi + kBR * l * yBRi + kBL * l * zB - kBR * l * zB
            ) / Iw,
        ]  # fmt: skip
        return np.array(s[11:] + acc)

    def static_state(self, t=0.0):
        """Equilibrium for the input at time t: zero velocity, so zero friction
        (F = C_slope v = 0) and the equations are linear, ``A q + c = 0``; A and c are
        read off the accelerations."""
        zero = np.zeros(22)
        c = self.rhs(t, zero, friction=False)[11:]
        a = np.column_stack(
            [self.rhs(t, np.r_[e, np.zeros(11)], friction=False)[11:] - c for e in np.eye(11)]
        )
        return np.linalg.solve(a, -c)

    def wheel_loads(self, t, state, static_load):
        """Mean wheel load of each side of each bogie: static load plus the contact force of
        5.26-5.29 (k2 terms and track damping ρ2) over the two wheels (5.4.3)."""
        l, r2 = self.p[13], self.p[10]  # noqa: E741 - the seed's symbol
        k, r = self.inputs(t)
        zF, omF, zB, omB = state[7:11]
        zFd, omFd, zBd, omBd = state[18:22]
        disp = (zF + l * omF, zF - l * omF, zB + l * omB, zB - l * omB)
        vel = (zFd + l * omFd, zFd - l * omFd, zBd + l * omBd, zBd - l * omBd)
        return [
            static_load + (ki * (di - ri) + r2 * vi) / 2
            for ki, di, ri, vi in zip(k, disp, r, vel, strict=True)
        ]


@pytest.fixture(scope="module")
def case():
    v = load_vehicle("loaded")
    lin = irregular_track().linearise(v.static_wheel_load)
    ds = simulate(v, lin, RunOptions(speed_kmh=SPEED * 3.6, store_every=1))
    ds_fine = simulate(
        v, lin, RunOptions(speed_kmh=SPEED * 3.6, dt_s=ds.attrs["time_step_s"] / 4, store_every=1)
    )
    ds_ref = simulate(v, lin, RunOptions(speed_kmh=SPEED * 3.6, store_every=1, solver="reference"))

    # Axles ahead of the vehicle centre: bogie centres at ±b_cc, axles at ±a about them
    # (5.4.3); the rearmost axle starts at the track start, so the centre starts at b_cc + a.
    axles = {"F": (v.b_cc + v.a, v.b_cc - v.a), "B": (-v.b_cc + v.a, -v.b_cc - v.a)}
    c0 = v.b_cc + v.a
    t_end = float(ds.time.values[-1])
    track = lin.track
    breaks = track.supports.position
    knots = np.concatenate([(breaks - x - c0) / SPEED for pair in axles.values() for x in pair])
    dense = np.arange(0.0, t_end, 2e-5)
    dt = ds.attrs["time_step_s"]
    start = [0.0, dt, 2 * dt, t_end]  # the static path's first points (initial velocity)
    knots = np.unique(np.concatenate([start, dense, knots[(knots > 0) & (knots < t_end)]]))
    centre = c0 + SPEED * knots
    k_table = np.zeros((knots.size, 4))
    r_table = np.zeros((knots.size, 4))
    for c, name in enumerate(CONTACTS):
        rail = "left" if name[1] == "L" else "right"
        for x in axles[name[0]]:
            k, r = lin.sample(rail, centre + x)
            k_table[:, c] += k  # 5.4.3: stiffness of the two axles summed
            r_table[:, c] += r / 2  # 5.4.3: mean of the two loaded profiles
    eq = SeedEquations(v, knots, k_table, r_table)

    q0 = eq.static_state()
    # The initial condition is defined as simulate defines it: at rest relative to the
    # track, with the velocity of the static equilibrium carried along the track, taken as
    # the second-order one-sided difference of the static states at t = 0, dt, 2 dt.
    v0 = (-3 * q0 + 4 * eq.static_state(dt) - eq.static_state(2 * dt)) / (2 * dt)
    sol = solve_ivp(
        eq.rhs,
        (0.0, t_end),
        np.r_[q0, v0],
        method="DOP853",
        t_eval=ds.time.values,
        rtol=RTOL_IVP,
        atol=ATOL_IVP,
        max_step=MAX_STEP,
    )
    assert sol.status == 0, sol.message
    loads = np.array(
        [eq.wheel_loads(t, y, v.static_wheel_load) for t, y in zip(sol.t, sol.y.T, strict=True)]
    )
    secondary = np.array([eq.suspension(y.tolist())[0] for y in sol.y.T])
    return {
        "v": v, "ds": ds, "ds_fine": ds_fine, "ds_ref": ds_ref, "eq": eq, "q0": q0, "c0": c0,
        "loads": loads, "secondary": secondary,
    }  # fmt: skip


def rms(x, axis=0):
    return np.sqrt(np.mean(np.square(x), axis=axis))


def test_start_position_and_static_state(case):
    ds, q0 = case["ds"], case["q0"]
    assert float(ds.distance[0]) == pytest.approx(case["c0"], abs=1e-12)
    # The static equilibrium solved above from 5.19-5.29 is where simulate starts.
    perm = [SEED_TO_MODEL.index(n) for n in ds.dof.values]
    np.testing.assert_allclose(
        ds.displacement.values[0], q0[perm], rtol=0, atol=1e-9 * np.abs(q0).max()
    )
    # ... and it is not trivial: the section is irregular at the start.
    assert np.abs(q0).max() > 1e-4


def test_wheel_loads_match_independent_integration(case):
    ds, v = case["ds"], case["v"]
    dynamic = ds.wheel_load.values - v.static_wheel_load
    # The test is only meaningful with real dynamics: several kN of dynamic load.
    assert rms(dynamic).min() > 0.02 * v.static_wheel_load
    error = rms(ds.wheel_load.values - case["loads"]) / rms(dynamic)
    assert error.max() < TOLERANCE, error


def test_reference_solver_matches_independent_integration(case):
    ref, ds, v = case["ds_ref"], case["ds"], case["v"]
    # same start, same stored times as the central scheme
    np.testing.assert_array_equal(ref.time, ds.time)
    np.testing.assert_array_equal(ref.displacement[0], ds.displacement[0])
    dynamic = ref.wheel_load.values - v.static_wheel_load
    error = rms(ref.wheel_load.values - case["loads"]) / rms(dynamic)
    assert error.max() < REFERENCE_TOLERANCE, error
    sec = ref.secondary_displacement.values
    error = rms(sec - case["secondary"]) / rms(sec - sec.mean(axis=0))
    assert error.max() < REFERENCE_TOLERANCE, error


def test_secondary_displacement_matches_independent_integration(case):
    ds = case["ds"]
    sec = ds.secondary_displacement.values
    error = rms(sec - case["secondary"]) / rms(sec - sec.mean(axis=0))
    assert error.max() < TOLERANCE, error


def test_difference_is_discretisation_error(case):
    # At dt/4 the difference shrinks at least fourfold (first order, the least a
    # consistent scheme gives across the friction kinks; second order would give 16):
    # the remaining difference is the time step, not a modelling discrepancy.
    ds, fine = case["ds"], case["ds_fine"]
    n = min(ds.time.size, fine.time[::4].size)
    np.testing.assert_allclose(fine.time.values[::4][:n], ds.time.values[:n], rtol=1e-12)
    ref = case["loads"][:n]
    coarse = rms(ds.wheel_load.values[:n] - ref)
    finer = rms(fine.wheel_load.values[::4][:n] - ref)
    assert np.all(finer < coarse / 4), coarse / finer


def test_wedges_both_stick_and_slip(case):
    # The comparison covers the friction law: every wedge spends a real part of the run in
    # each regime of 5.30 (slipping: |C_slope v| above the slip force; sticking: below it).
    ds, v = case["ds"], case["v"]
    slip = np.abs(v.C_slope * ds.wedge_velocity.values) > np.abs(ds.wedge_force.values) * (1 + 1e-9)
    assert np.all(slip.mean(axis=0) > 0.02)
    assert np.all(slip.mean(axis=0) < 0.98)
