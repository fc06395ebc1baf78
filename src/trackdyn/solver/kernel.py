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

This module is the scheme's loop for one run (`advance`) and its per-step helpers; the
same step for runs side by side in the vector lanes is `trackdyn.solver.lanes`, the
driver that sends runs through them block by block `trackdyn.solver.central`, the step's
matrices and time step `trackdyn.solver.matrices`.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria,
§5.4, eqs 5.15-5.18 (central
differences with Newton-Raphson), 5.30-5.33 (friction wedges).

Bathe, K.J. (1996). Finite Element Procedures. Prentice Hall, Englewood Cliffs, §9.2.1
(the central difference method and its stability limit Δt < 2/ω_max).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from trackdyn.lanewise import FASTMATH
from trackdyn.solver.statics import (
    contact_table_force,
)

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

EXPONENT = 0x7FF0000000000000
"""Exponent bits of a float64, all set for inf and NaN (a test that ``fastmath`` keeps)."""


@njit(cache=True, inline="always")
def wedge_step(dw_idx, dw_val, H, jinv, wedge, z, q1, inv2dt, max_iter,
               vfree, rhs, v, f_up, f_down, F, state):  # fmt: skip
    """The wedge friction forces ``F`` and velocities ``v`` of a step (Newton, see above).

    ``q1`` is the next displacement without the wedge forces, ``z = [q0, q-1]``; ``state``
    holds each wedge's stick/slip state from step to step. Returns False if Newton did not
    converge in ``max_iter`` iterations.
    """
    n = q1.shape[0]
    nw = dw_idx.shape[0]
    # wedge velocities if no friction acted, v = Dw (q1 - q-1) / 2Δt
    for w in range(nw):
        dd = 0.0
        vv = 0.0
        for j in range(dw_idx.shape[1]):
            col = dw_idx[w, j]
            dd += dw_val[w, j] * z[col]
            vv += dw_val[w, j] * (q1[col] - z[n + col])
        vfree[w] = vv * inv2dt
        normal = wedge[w, 0] + dd
        if normal < 0.0:
            normal = 0.0
        f_up[w] = normal * wedge[w, 1]
        f_down[w] = normal * wedge[w, 2]
    converged = False
    for _ in range(max_iter):
        mask = 0
        for w in range(nw):
            if state[w] == 0:
                F[w] = 0.0
                mask |= 1 << w
            elif state[w] == 1:
                F[w] = f_up[w]
            else:
                F[w] = -f_down[w]
        for w in range(nw):
            r = vfree[w]
            for u in range(nw):
                r -= H[w, u] * F[u]
            rhs[w] = r
        same = True
        for w in range(nw):
            vv = 0.0
            for u in range(nw):
                vv += jinv[mask, w, u] * rhs[u]
            v[w] = vv
            f = wedge[w, 3] * vv
            new = 1 if f > f_up[w] else (2 if f < -f_down[w] else 0)
            if new != state[w]:
                same = False
                state[w] = new
        if same:
            converged = True
            break
    if not converged:
        return False
    for w in range(nw):
        if state[w] == 0:
            F[w] = wedge[w, 3] * v[w]
    return True


@njit(**STEP_JIT)
def vehicle_step(p_idx, p_val, gc_idx, gc_val, gw_idx, gw_val, dw_idx, dw_val, H, jinv,
                 wedge, z, fc, inv2dt, max_iter, q1, vfree, rhs, v, f_up, f_down, F,
                 state):  # fmt: skip
    """The vehicle's next displacement ``q1`` from ``z = [q0, q-1]`` and the contact forces
    ``fc``: ``P z - Gc^T fc``, then the wedge forces (`wedge_step`) and ``- Gw^T F``.
    Returns False if the wedges' Newton iteration did not converge."""
    n = p_idx.shape[0]
    for i in range(n):
        acc = 0.0
        for j in range(p_idx.shape[1]):
            acc += p_val[i, j] * z[p_idx[i, j]]
        q1[i] = acc
    for c in range(gc_idx.shape[0]):
        f = fc[c]
        for j in range(gc_idx.shape[1]):
            q1[gc_idx[c, j]] -= gc_val[c, j] * f
    nw = dw_idx.shape[0]
    if nw > 0 and not wedge_step(
        dw_idx, dw_val, H, jinv, wedge, z, q1, inv2dt, max_iter,
        vfree, rhs, v, f_up, f_down, F, state,
    ):  # fmt: skip
        return False
    for w in range(nw):
        f = F[w]
        for j in range(gw_idx.shape[1]):
            q1[gw_idx[w, j]] -= gw_val[w, j] * f
    return True


@njit(**STEP_JIT)
def store_vehicle(z, q1, F, v, ds_idx, ds_val, inv2dt, invdt2, row,
                  out_q, out_v, out_a, out_secondary, out_fw, out_vw):  # fmt: skip
    """Write the step's displacement, velocity, acceleration, secondary displacement and
    wedge force and velocity to row ``row`` of the outputs; False if ``q0`` is not finite."""
    n = q1.shape[0]
    z_bits = z.view(np.int64)
    for i in range(n):
        if z_bits[i] & EXPONENT == EXPONENT:
            return False
        out_q[row, i] = z[i]
        out_v[row, i] = (q1[i] - z[n + i]) * inv2dt
        out_a[row, i] = (q1[i] - 2.0 * z[i] + z[n + i]) * invdt2
    for u in range(ds_idx.shape[0]):
        d = 0.0
        for j in range(ds_idx.shape[1]):
            d += ds_val[u, j] * z[ds_idx[u, j]]
        out_secondary[row, u] = d
    for w in range(F.shape[0]):
        out_fw[row, w] = F[w]
        out_vw[row, w] = v[w]
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
    ``static_load + (f + c_d Dc v) / axles`` with ``contact`` rows ``(c_d, axles)``.

    Returns
    -------
    tuple of int
        `DONE`, `NEWTON_FAILED` or `NOT_FINITE`, and the chunk-local index of that step
        (-1 when done).
    """
    n = p_idx.shape[0]
    nc = dc_idx.shape[0]
    nw = dw_idx.shape[0]
    inv2dt = 0.5 / dt
    invdt2 = 1.0 / (dt * dt)
    nonlinear = table.shape[0] > 0
    q1 = np.empty(n)
    fc = np.empty(nc)
    vfree = np.empty(nw)
    rhs = np.empty(nw)
    v = np.zeros(nw)
    f_up = np.empty(nw)
    f_down = np.empty(nw)
    F = np.zeros(nw)
    state = np.zeros(nw, np.int64)  # 0 stick, 1 slip in compression, 2 slip in extension
    stored = 0
    to_store = -step0 % store_every  # steps until the next stored one (no modulo per step)
    for s in range(k_in.shape[0]):
        for c in range(nc):
            x = 0.0
            for j in range(dc_idx.shape[1]):
                x += dc_val[c, j] * z[dc_idx[c, j]]
            if nonlinear:
                fc[c] = contact_table_force(table[s, c], y_start, y_step, x - r_in[s, c])
                fc[c] -= static_load
            else:
                fc[c] = k_in[s, c] * (x - r_in[s, c])
        if not vehicle_step(
            p_idx, p_val, gc_idx, gc_val, gw_idx, gw_val, dw_idx, dw_val, H, jinv, wedge,
            z, fc, inv2dt, max_iter, q1, vfree, rhs, v, f_up, f_down, F, state,
        ):  # fmt: skip
            return NEWTON_FAILED, s
        if to_store == 0:
            to_store = store_every
            if not store_vehicle(
                z, q1, F, v, ds_idx, ds_val, inv2dt, invdt2, stored,
                out_q, out_v, out_a, out_secondary, out_fw, out_vw,
            ):  # fmt: skip
                return NOT_FINITE, s
            for c in range(nc):
                dv = 0.0
                for j in range(dc_idx.shape[1]):
                    dv += dc_val[c, j] * out_v[stored, dc_idx[c, j]]
                out_wl[stored, c] = static_load + (fc[c] + contact[c, 0] * dv) / contact[c, 1]
                out_k[stored, c] = k_in[s, c]
                out_r[stored, c] = r_in[s, c]
            stored += 1
        to_store -= 1
        for i in range(n):
            z[n + i] = z[i]
            z[i] = q1[i]
    return DONE, -1
