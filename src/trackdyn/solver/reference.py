"""Reference solver: the equations of motion as a first-order ODE, scipy's DOP853.

``M q'' + C q' + K q + Dw^T F(Dw q, Dw q') + Dc^T f(Dc q, t) = 0`` with the wedge friction
``F`` of eqs 5.30-5.33 and the contact forces ``f = k (Dc q - r)`` (linear) or
``P(Dc q - r) - Ps`` (tabulated), the track input taken from the run's `TrackInput` at the
vehicle-centre position ``centre0 + speed t`` of every evaluation. Adaptive 8th-order
Runge-Kutta at ``rtol`` 1e-8 (``atol`` 1e-11: rtol times the mm-scale displacements):
slow (seconds per 10 m), for checking a case against the central scheme. The steps are
limited to `MAX_STEPS_PER_DT` central-scheme steps (a tenth of the highest natural period)
so that no short stick phase of a wedge is stepped over. It starts where the central scheme
does (`start_path`) and stores the same arrays at the same times; velocities and wedge
velocities are the exact ones, accelerations those of the equations at the stored state.
DOP853 rather than an implicit method: at rtol 1e-8 the step is set by accuracy, not
stability (the stiffest motion, a stuck wedge's ``C_slope`` on the bogie frame, decays at
about 1600 1/s); Radau gave the same wheel loads at 2-6 times the run time.

References
----------
Hairer, E., Nørsett, S.P. & Wanner, G. (1993). Solving Ordinary Differential Equations I:
Nonstiff Problems, 2nd ed. Springer (DOP853, §II.10).

Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, eqs 5.19-5.33.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from trackdyn.errors import TrackdynInputError
from trackdyn.solver.statics import (
    Problem,
    contact_table_force,
    non_finite,
    start_path,
    table_step,
    track_input,
    wedge_forces,
    wedge_table,
    wheel_load,
    widths,
)

RTOL, ATOL = 1e-8, 1e-11
MAX_STEPS_PER_DT = 5
"""Largest DOP853 step in central-scheme steps (which are 1/50 of the highest period)."""


class _Equations:
    """Right-hand side of the first-order system and the forces of a state."""

    def __init__(self, p: Problem):
        self.p, m = p, p.model
        self.Minv = np.linalg.inv(m.M)
        self.wedge = wedge_table(m)
        self.y0, self.dy = table_step(track_input(p).grid)

    def forces(self, t, q, v):
        """Contact forces [N], wedge forces [N], stiffness [N/m] and input [m] at ``t``."""
        p, m = self.p, self.p.model
        k, r, table = p.inputs(np.array([p.centre0 + p.speed * t]))
        k, r = k[0], r[0]
        defl = m.Dc @ q - r
        if table.shape[0]:
            rows = zip(table[0], defl, strict=True)
            fc = np.array([contact_table_force(t, self.y0, self.dy, d) for t, d in rows])
            fc -= m.static_wheel_load
        else:
            fc = k * defl
        fw = wedge_forces(self.wedge, m.Dw @ q, m.Dw @ v)
        return fc, fw, k, r

    def acceleration(self, t, q, v, fc, fw):
        m = self.p.model
        return -self.Minv @ (m.C @ v + m.K @ q + m.Dw.T @ fw + m.Dc.T @ fc)

    def __call__(self, t, y):
        n = y.size // 2
        q, v = y[:n], y[n:]
        return np.r_[v, self.acceleration(t, q, v, *self.forces(t, q, v)[:2])]


def solve(p: Problem, advanced=None):
    """Integrate one run; a dict of the `OUTPUTS` arrays, or the error that stopped it.

    Parameters
    ----------
    p : Problem
        The run; ``dt`` sets the start's static path and the largest step.
    advanced : callable, optional
        Called with ``p.n_steps`` when done.
    """
    try:
        q0, v0 = start_path(p)
    except TrackdynInputError as exc:
        return exc
    eq = _Equations(p)
    n = q0.size
    times = np.arange(p.n_store) * p.store_every * p.dt
    sol = solve_ivp(
        eq,
        (0.0, max(times[-1], p.dt)),
        np.r_[q0, v0],
        method="DOP853",
        t_eval=times,
        rtol=RTOL,
        atol=ATOL,
        max_step=MAX_STEPS_PER_DT * p.dt,
    )
    if sol.status != 0 or sol.t.size != times.size:
        return TrackdynInputError(f"reference solver failed: {sol.message}")
    out = {name: np.empty((times.size, w)) for name, w in widths(p.model).items()}
    m = p.model
    for i, (t, y) in enumerate(zip(times, sol.y.T, strict=True)):
        q, v = y[:n], y[n:]
        fc, fw, k, r = eq.forces(t, q, v)
        out["q"][i], out["v"][i], out["a"][i] = q, v, eq.acceleration(t, q, v, fc, fw)
        out["wl"][i], out["secondary"][i] = wheel_load(m, fc, m.Dc @ v), m.Ds @ q
        out["fw"][i], out["vw"][i] = fw, m.Dw @ v
        out["k"][i], out["r"][i] = k, r
    bad = ~np.isfinite(out["q"]).all(axis=1)
    if bad.any():
        return non_finite(p, int(np.argmax(bad)) * p.store_every)
    if advanced is not None:
        advanced(p.n_steps)
    return out
