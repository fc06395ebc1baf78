"""Central differences with Newton-Raphson at every step (seed eqs 5.15-5.18).

The one compiled time-stepping loop of trackdyn. With ``A = M/Δt² + C/(2Δt)`` the scheme

    A q1 = (2M/Δt² - K) q0 - (M/Δt² - C/(2Δt)) q-1 - Dc^T f(q0, t0) - Dw^T F(v0, d0)

is explicit in the springs and the contact forces (evaluated at ``q0``, as 5.18 does with
``k2(y2(0), x)``) and implicit in the dampers and in the wedge friction, whose velocity
``v0 = Dw (q1 - q-1) / (2Δt)`` depends on ``q1``. ``A`` is constant, so its inverse is
formed once; each step then solves only the small nonlinear system of the wedges,

    v + H F(v) = v_free,    H = Dw A^-1 Dw^T / (2Δt),

by Newton-Raphson. ``F`` is piecewise linear and monotone in ``v`` (eqs 5.30-5.33): each
wedge sticks (``F = C_slope v``) or slips (``F = ±`` the slip force), and Newton from a
point solves the linear system of the stick/slip states there. The solution is exact as
soon as the states it lands in are the ones it assumed, so the iteration stops then; it
starts from the previous step's states and usually needs one solve. The matrices
``(I + H diag(C_slope·stick))^-1`` of all ``2^nw`` state combinations are formed once.

This module is the scheme's loop for one run (`advance`) and the vehicle's step of a run
alone (`vehicle_step`, `store_vehicle`, which `trackdyn.solver.discrete` shares). The
step's equations are written once, in `trackdyn.solver.step`, for any number of runs side
by side: made for one run here, used at the lanes' width by `trackdyn.solver.lanes`. The
driver that sends runs through them block by block is `trackdyn.solver.central`, the
step's matrices and time step `trackdyn.solver.matrices`.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria,
§5.4, eqs 5.15-5.18 (central differences with Newton-Raphson), 5.30-5.33 (friction wedges).

Bathe, K.J. (1996). Finite Element Procedures. Prentice Hall, Englewood Cliffs, §9.2.1
(the central difference method and its stability limit Δt < 2/ω_max).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from trackdyn.lanewise import FASTMATH
from trackdyn.solver.step import ALONE

DONE, NEWTON_FAILED, NOT_FINITE, NOT_STARTED = 0, 1, 2, 3
"""How `advance` ends: all steps done; no Newton solution at a step; a stored
displacement not finite. `advance_lanes` leaves runs in any state but `DONE` alone
(`NOT_STARTED`: no start state)."""

STEP_JIT: dict[str, Any] = dict(
    cache=True, fastmath=FASTMATH, error_model="numpy", nogil=True, _nrt=False
)
"""numba options of the helpers the loops call at every step (`vehicle_step`,
`store_vehicle`): compiled without numba's reference counting (they allocate nothing), so
that a call does not count a reference to each of its arrays, which cost more than the
whole step of the small models (2dof, every 10th step stored: 177 ns a step with the
counting, 41 without)."""


_contact_forces = ALONE["contact_forces"]
_free_displacement = ALONE["free_displacement"]
_wedge_limits = ALONE["wedge_limits"]
_newton_pass = ALONE["newton_pass"]
_wedge_forces = ALONE["wedge_forces"]
_motion_rows = ALONE["motion_rows"]
_wheel_loads = ALONE["wheel_loads"]
_wedge_arrays = ALONE["wedge_arrays"]
"""`trackdyn.solver.step`'s functions for a run alone (`trackdyn.solver.step.ALONE`)."""


@njit(**STEP_JIT)
def vehicle_step(p_idx, pv, gc_idx, gcv, gw_idx, gwv, dw_idx, dwv, hv, jv, wv, zl, fc, half,
                 max_iter, q1, wedges):  # fmt: skip
    """One run's next displacement ``q1`` from ``z = [q0, q-1]`` (``zl``) and the contact
    forces ``fc``, all arrays flat (`trackdyn.solver.step`): ``P z - Gc^T fc``, the wedges'
    limits and Newton iteration, ``- Gw^T F`` (``wedges``: the wedge arrays,
    `trackdyn.solver.step.wedge_arrays`). Returns False if the Newton iteration did not
    converge in ``max_iter`` passes."""
    zero, none = (0.0,), (0,)
    _free_displacement(p_idx, pv, gc_idx, gcv, zl, fc, zero, q1)
    nw = dw_idx.shape[0]
    if nw == 0:
        return True
    vfree, rhs, v, f_up, f_down, F, state, masks, jl = wedges
    _wedge_limits(p_idx.shape[0], dw_idx, dwv, wv, zl, q1, (half,), zero, vfree, f_up, f_down)
    for _ in range(max_iter):
        if not _newton_pass(nw, wv, hv, jv, zero, none, vfree, rhs, v, f_up, f_down, F, state,
                            masks, jl)[0]:  # fmt: skip
            _wedge_forces(gw_idx, gwv, wv, zero, v, F, state, q1)
            return True
    return False


@njit(**STEP_JIT)
def store_vehicle(zl, q1, wedges, ds_idx, dsv, half, per_dt2, row,
                  out_q, out_v, out_a, out_secondary, out_fw, out_vw):  # fmt: skip
    """Write one run's displacement, velocity, acceleration, secondary displacement and
    wedge force and velocity of a step to row ``row`` of its flat outputs (of widths n, n,
    n, secondary, wedges, wedges); False if ``q0`` is not finite."""
    n = q1.shape[0]
    bad = _motion_rows(n, row, zl, zl.view(np.int64), q1, ds_idx, dsv, (half,), (per_dt2,),
                       (0.0,), (0,), out_v, out_a, out_secondary)  # fmt: skip
    if bad[0]:
        return False
    for i in range(n):
        out_q[row * n + i] = zl[i]
    v, F = wedges[2], wedges[5]
    nw = F.shape[0]
    for w in range(nw):
        out_fw[row * nw + w] = F[w]
        out_vw[row * nw + w] = v[w]
    return True


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", nogil=True)
def advance(
    p_idx, p_val, gc_idx, gc_val, gw_idx, gw_val, dc_idx, dc_val, dw_idx, dw_val,
    ds_idx, ds_val, H, jinv, wedge, contact, static_load,
    k_in, r_in, table, y_start, y_step,
    z, dt, step0, store_every, max_iter,
    out_q, out_v, out_a, out_wl, out_secondary, out_fw, out_vw, out_k, out_r,
):  # fmt: skip
    """Advance one run ``k_in.shape[0]`` steps from ``z = [q0, q-1]``, updated in place.

    Contacts are linear, ``f = k (Dc q - r)``, when ``table`` has no rows, and tabulated
    (``f = P(Dc q - r) - Ps``) otherwise. Every ``store_every``-th global step is written
    to the ``out_*`` arrays from their first row on (`OUTPUTS`); the wheel load is
    ``static_load + (f + c_d Dc v) / axles`` with ``contact`` rows ``(c_d, axles)``. The
    step is `trackdyn.solver.step`'s, made for one run (`trackdyn.solver.step.ALONE`).

    Returns
    -------
    tuple of int
        `DONE`, `NEWTON_FAILED` or `NOT_FINITE`, and the chunk-local index of that step
        (-1 when done).
    """
    n = p_idx.shape[0]
    nc = dc_idx.shape[0]
    nw = dw_idx.shape[0]
    zero = (0.0,)
    half, per_dt2 = 0.5 / dt, 1.0 / (dt * dt)
    # flat, the run's values one after the other (`trackdyn.lanewise.load`)
    pv, gcv, gwv = p_val.reshape(-1), gc_val.reshape(-1), gw_val.reshape(-1)
    dcv, dwv, hv, jv = dc_val.reshape(-1), dw_val.reshape(-1), H.reshape(-1), jinv.reshape(-1)
    wv, kv, rv, cv = wedge.reshape(-1), k_in.reshape(-1), r_in.reshape(-1), contact.reshape(-1)
    dsv, cc = ds_val.reshape(-1), contact.shape[1]
    # the tabulated contacts' arrays as a group of one lane's
    lane_static = np.full(1, static_load)
    lane_start, lane_step = np.full(1, y_start), np.full(1, y_step)
    # the outputs flat (each its own variable: an array taken from a tuple in the loop
    # counts a reference at every stored step, +60 ns a step of the 2-DOF model)
    oq, ov, oa, owl = out_q.reshape(-1), out_v.reshape(-1), out_a.reshape(-1), out_wl.reshape(-1)
    osec, ofw, ovw = out_secondary.reshape(-1), out_fw.reshape(-1), out_vw.reshape(-1)
    nonlinear, tv, grid = table.shape[0] > 0, table.reshape(-1), table.shape[-1]
    q1 = np.empty(n)
    fc = np.empty(nc)
    wedges = _wedge_arrays(nw, zero)
    stored = 0
    to_store = -step0 % store_every  # steps until the next stored one (no modulo per step)
    for s in range(k_in.shape[0]):
        _contact_forces(s, nc, nonlinear, dc_idx, dcv, z, kv, rv, tv, grid, lane_start, lane_step,
                        lane_static, zero, fc)  # fmt: skip
        if not vehicle_step(
            p_idx, pv, gc_idx, gcv, gw_idx, gwv, dw_idx, dwv, hv, jv, wv, z, fc, half, max_iter,
            q1, wedges,
        ):  # fmt: skip
            return NEWTON_FAILED, s
        if to_store == 0:
            to_store = store_every
            if not store_vehicle(
                z, q1, wedges, ds_idx, dsv, half, per_dt2, stored, oq, ov, oa, osec, ofw, ovw,
            ):  # fmt: skip
                return NOT_FINITE, s
            _wheel_loads(n, nc, stored, dc_idx, dcv, cv, cc, fc, (static_load,), zero, ov, owl)
            for c in range(nc):
                out_k[stored, c] = k_in[s, c]
                out_r[stored, c] = r_in[s, c]
            stored += 1
        to_store -= 1
        for i in range(n):
            z[n + i] = z[i]
            z[i] = q1[i]
    return DONE, -1
