"""Full model against an independent integration of its equations of motion.

The equations are written out below from the force balance of each body, without the
package's assembly: car body (bounce y1, roll θ, pitch α), per bogie e (centre at x_e =
±b_cc) a left and a right side frame s (bounce y_es, pitch β_es; lateral sign σ = +1
left, -1 right) and a leading and trailing wheelset i (bounce z_i, roll ω_i; axle at
λ_i = ±a from the bogie centre). Displacements are positive down, a point ahead of a
body's centre by x moves by ``bounce - x pitch``, a point to the left by y by
``bounce + y roll`` (seed 5.30). Forces, compression positive:

- secondary of side es: ``S = k1 d + F(d', d)``, ``d = y1 + σ b θ - x_e α - y_es``,
  with F the wedge friction of 5.30-5.33;
- primary axlebox (i, s): ``P = kp/2 p + ρp/2 p'``, ``p = y_es - λ_i β_es - z_i - σ b ω_i``;
- wheel (i, s): ``W = k2_is (w - r_is) + ρ2 w'``, ``w = z_i + σ l ω_i``, with its own
  track stiffness and loaded profile at its own axle position.

Then ``m1 y1'' = -ΣS``, ``I1 θ'' = -Σ σ b S``, ``Ip α'' = Σ x_e S``;
``(m2/2) y_es'' = S - Σ_i P``, ``Isf β_es'' = Σ_i λ_i P``; ``mw1 z_i'' = Σ_s (P - W)``,
``Iw1 ω_i'' = Σ_s σ (b P - l W)``. Integrated with scipy's DOP853 (rtol 1e-8) as in
`test_eleven_dof_ivp`, whose track and input tabulation this test shares.
"""

import bisect

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from test_eleven_dof_ivp import MAX_STEP, SPEED, irregular_track

from trackdyn.options import RunOptions
from trackdyn.simulation import simulate
from trackdyn.vehicle.parameters import load_vehicle

END = 22.0  # [m] the foremost axle stops here: 11.6 m of travel, 0.58 s (test time)
TOLERANCE = 0.01  # brief: RMS difference < 1 % of the RMS of the dynamic wheel load
# DOP853 tolerances: looser than test_eleven_dof_ivp's 1e-8 / 1e-11 to keep the pure-Python
# right-hand side of 19 coordinates fast (3 s instead of 17 s); at 1e-8 the wheel-load
# difference to simulate changes by 3e-6 of the dynamic load (0.1385 % -> 0.1382 %), so
# the reference's own error is far below what is tested. atol: rtol times mm.
RTOL_IVP, ATOL_IVP = 1e-6, 1e-9
SIDES = ((1.0, "left", "L"), (-1.0, "right", "R"))


def layout(v):
    """Bogies as (name, centre, [(axle number, offset from the centre)]), front first."""
    return (
        ("F", v.b_cc, ((1, v.a), (2, -v.a))),
        ("B", -v.b_cc, ((3, v.a), (4, -v.a))),
    )


def wedge_friction(v, vel, d):
    """5.30-5.33 at relative velocity ``vel`` and displacement ``d``; no pulling spring."""
    normal = max(v.x_ss + d, 0.0) * v.k_ss
    ta = np.tan(v.alpha_w)
    f = 0.0
    if vel > 0.0:
        f = normal * v.mu / (ta - v.mu)
    if vel < 0.0:
        f = -normal * v.mu / (ta + v.mu)
    return v.C_slope * vel if abs(v.C_slope * vel) < abs(f) else f


class FullEquations:
    """State: [y1, θ, α, (y_es, β_es) for FL FR BL BR, (z_i, ω_i) for i = 1..4], then rates."""

    N = 19
    WHEELS = tuple(f"{i}{s}" for i in range(1, 5) for s in "LR")

    def __init__(self, v, knots, k_table, r_table):
        self.v = v
        self.knots = knots.tolist()
        self.k_table = k_table.tolist()  # per knot, per wheel 1L..4R [N/m]
        self.r_table = r_table.tolist()  # per knot, per wheel [m]

    def inputs(self, t):
        kn = self.knots
        i = min(max(bisect.bisect_right(kn, t) - 1, 0), len(kn) - 2)
        w = (t - kn[i]) / (kn[i + 1] - kn[i])
        ka, kb, ra, rb = self.k_table[i], self.k_table[i + 1], self.r_table[i], self.r_table[i + 1]
        return (
            {n: x + w * (y - x) for n, x, y in zip(self.WHEELS, ka, kb, strict=True)},
            {n: x + w * (y - x) for n, x, y in zip(self.WHEELS, ra, rb, strict=True)},
        )

    @staticmethod
    def frame(e, s):
        """Index of side frame (e, s) bounce; its pitch is the next one."""
        return 3 + 2 * ("FB".index(e) * 2 + "LR".index(s))

    @staticmethod
    def wheelset(i):
        return 11 + 2 * (i - 1)

    def forces(self, t, state, friction=True):
        """Secondary (per side), primary (per axlebox) and wheel forces [N]."""
        v = self.v
        q, qd = state[: self.N], state[self.N :]
        k, r = self.inputs(t)
        sec, prim, wheel, d_sec = {}, {}, {}, {}
        for e, x, axles in layout(v):
            for sigma, _, s in SIDES:
                f = self.frame(e, s)
                d = q[0] + sigma * v.b * q[1] - x * q[2] - q[f]
                dd = qd[0] + sigma * v.b * qd[1] - x * qd[2] - qd[f]
                d_sec[e + s] = d
                sec[e + s] = v.k1 * d + (wedge_friction(v, dd, d) if friction else 0.0)
                for i, lam in axles:
                    w = self.wheelset(i)
                    p = q[f] - lam * q[f + 1] - q[w] - sigma * v.b * q[w + 1]
                    pd = qd[f] - lam * qd[f + 1] - qd[w] - sigma * v.b * qd[w + 1]
                    prim[i, s] = v.kp / 2 * p + v.rho_p / 2 * pd
                    n = f"{i}{s}"
                    y = q[w] + sigma * v.l * q[w + 1]
                    yd = qd[w] + sigma * v.l * qd[w + 1]
                    wheel[n] = k[n] * (y - r[n]) + v.rho2 * yd
        return sec, prim, wheel, d_sec

    def rhs(self, t, state, friction=True):
        v = self.v
        sec, prim, wheel, _ = self.forces(t, state.tolist(), friction)
        acc = [0.0] * self.N
        for e, x, axles in layout(v):
            for sigma, _, s in SIDES:
                S, f = sec[e + s], self.frame(e, s)
                acc[0] -= S / v.m1
                acc[1] -= sigma * v.b * S / v.I1
                acc[2] += x * S / v.Ip
                acc[f] += (S - sum(prim[i, s] for i, _ in axles)) / (v.m2 / 2)
                acc[f + 1] += sum(lam * prim[i, s] for i, lam in axles) / v.Isf
                for i, _ in axles:
                    w, P, W = self.wheelset(i), prim[i, s], wheel[f"{i}{s}"]
                    acc[w] += (P - W) / v.mw1
                    acc[w + 1] += sigma * (v.b * P - v.l * W) / v.Iw1
        return np.r_[state[self.N :], acc]

    def static_state(self, t=0.0):
        """Equilibrium at time t (at rest: no friction, so linear, ``A q + c = 0``)."""
        n = self.N
        c = self.rhs(t, np.zeros(2 * n), friction=False)[n:]
        a = np.column_stack(
            [self.rhs(t, np.r_[e, np.zeros(n)], friction=False)[n:] - c for e in np.eye(n)]
        )
        return np.linalg.solve(a, -c)


# The model's names of the coordinates above (models.full docstring), in state order.
STATE_TO_MODEL = (
    "body_bounce", "body_roll", "body_pitch",
    "front_left_frame_bounce", "front_left_frame_pitch",
    "front_right_frame_bounce", "front_right_frame_pitch",
    "back_left_frame_bounce", "back_left_frame_pitch",
    "back_right_frame_bounce", "back_right_frame_pitch",
    "wheelset_1_bounce", "wheelset_1_roll", "wheelset_2_bounce", "wheelset_2_roll",
    "wheelset_3_bounce", "wheelset_3_roll", "wheelset_4_bounce", "wheelset_4_roll",
)  # fmt: skip


@pytest.fixture(scope="module")
def case():
    v = load_vehicle("loaded")
    lin = irregular_track().linearise(v.static_wheel_load)
    ds = simulate(v, lin, RunOptions(model="full", speed_kmh=SPEED * 3.6, store_every=1, end_m=END))
    dt = ds.attrs["time_step_s"]
    fine = simulate(
        v,
        lin,
        RunOptions(model="full", speed_kmh=SPEED * 3.6, dt_s=dt / 4, store_every=4, end_m=END),
    )
    axles = {i: x + lam for _, x, pairs in layout(v) for i, lam in pairs}
    c0 = v.b_cc + v.a  # the rearmost axle starts at the track start
    t_end = float(ds.time.values[-1])
    # Input tabulated at every kink (an axle over a sleeper) and every 0.2 ms between, as
    # in test_eleven_dof_ivp.
    kinks = np.concatenate([(lin.track.supports.position - x - c0) / SPEED for x in axles.values()])
    knots = np.unique(
        np.concatenate(
            [
                [0.0, dt, 2 * dt, t_end],
                np.arange(0.0, t_end, 2e-4),
                kinks[(kinks > 0) & (kinks < t_end)],
            ]
        )
    )
    centre = c0 + SPEED * knots
    k_table = np.zeros((knots.size, 8))
    r_table = np.zeros((knots.size, 8))
    for c, name in enumerate(FullEquations.WHEELS):
        rail = "left" if name[1] == "L" else "right"
        k_table[:, c], r_table[:, c] = lin.sample(rail, centre + axles[int(name[0])])
    eq = FullEquations(v, knots, k_table, r_table)
    q0 = eq.static_state()
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
    forces = [eq.forces(t, y.tolist()) for t, y in zip(sol.t, sol.y.T, strict=True)]
    loads = np.array([[f[2][n] for n in FullEquations.WHEELS] for f in forces])
    secondary = np.array([[f[3][s] for s in ("FL", "FR", "BL", "BR")] for f in forces])
    return {
        "v": v,
        "ds": ds,
        "fine": fine,
        "q0": q0,
        "loads": v.static_wheel_load + loads,
        "secondary": secondary,
    }


def rms(x, axis=0):
    return np.sqrt(np.mean(np.square(x), axis=axis))


def test_names_and_static_state(case):
    ds, q0 = case["ds"], case["q0"]
    assert ds.contact.values.tolist() == list(FullEquations.WHEELS)
    assert ds.suspension.values.tolist() == ["FL", "FR", "BL", "BR"]
    perm = [STATE_TO_MODEL.index(n) for n in ds.dof.values]
    np.testing.assert_allclose(
        ds.displacement.values[0], q0[perm], rtol=0, atol=1e-9 * np.abs(q0).max()
    )
    assert np.abs(q0).max() > 1e-4  # irregular at the start: not a trivial check


def test_wheel_loads_match_independent_integration(case):
    ds, v = case["ds"], case["v"]
    dynamic = ds.wheel_load.values - v.static_wheel_load
    assert rms(dynamic).min() > 0.02 * v.static_wheel_load  # several kN: real dynamics
    error = rms(ds.wheel_load.values - case["loads"]) / rms(dynamic)
    assert error.max() < TOLERANCE, error


def test_secondary_displacement_matches_independent_integration(case):
    sec = case["ds"].secondary_displacement.values
    error = rms(sec - case["secondary"]) / rms(sec - sec.mean(axis=0))
    assert error.max() < TOLERANCE, error


def test_difference_is_discretisation_error(case):
    # At dt/4 the difference shrinks at least fourfold (as in test_eleven_dof_ivp: first
    # order is the least a consistent scheme gives across the friction kinks).
    ds, fine = case["ds"], case["fine"]
    n = min(ds.time.size, fine.time.size)
    np.testing.assert_allclose(fine.time.values[:n], ds.time.values[:n], rtol=1e-12)
    ref = case["loads"][:n]
    coarse = rms(ds.wheel_load.values[:n] - ref)
    finer = rms(fine.wheel_load.values[:n] - ref)
    assert np.all(finer < coarse / 4), coarse / finer


def test_side_frames_pitch_and_wedges_slip(case):
    # The comparison covers what the 11-DOF model lacks: the side frames pitch (the two
    # axles of a side see different inputs) and the friction law switches regime.
    ds, v = case["ds"], case["v"]
    pitch = [d for d in ds.dof.values if str(d).endswith("frame_pitch")]
    assert len(pitch) == 4
    assert np.abs(ds.displacement.sel(dof=pitch).values).max() > 1e-4  # [rad]
    slip = np.abs(v.C_slope * ds.wedge_velocity.values) > np.abs(ds.wedge_force.values) * (1 + 1e-9)
    assert np.all(slip.mean(axis=0) > 0.02)
    assert np.all(slip.mean(axis=0) < 0.98)
