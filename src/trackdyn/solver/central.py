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

A run goes through `advance`; runs of one model, in groups of `LANES` (the last with idle
lanes when at least `MIN_LANE_RUNS` are left over), side by side through
`advance_lanes`: each array carries the runs (lanes) along its last, contiguous
axis, and each quantity of a step is a tuple of the lanes' values, which LLVM packs into
vector registers (`trackdyn.lanewise`); a lane's stick/slip states, its Newton
iteration and its end are selects on its own mask. The sums of each lane are done in
`advance`'s order and the loops are compiled without reassociation (`FASTMATH`), so a
run's results in the lanes are those it gives alone, to the bit.

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

from concurrent.futures import ThreadPoolExecutor
from typing import Any, NamedTuple

import numba
import numpy as np
from numba import njit

from trackdyn.errors import TrackdynInputError
from trackdyn.lanewise import FASTMATH, LANES, lanewise, load, store, total, vectorised
from trackdyn.solver.statics import (
    OUTPUTS,
    Problem,
    contact_table,
    contact_table_force,
    failure,
    non_finite,
    start_path,
    table_step,
    track_input,
    wedge_forces,
    wedge_table,
    widths,
)

CHUNK_STEPS = 8192
"""Steps of a run advanced per compiled call, at most: the input of the next block is
sampled while the loop runs this one. A block of 8192 steps keeps more of the lanes' input
in the cache (k and r of a group of 4 contacts, 2 MB each): with 20 000 steps a block, 4
sections of 500 m through 50 MGT took 3 % longer."""

CHUNK_BYTES = 32 * 2**20
"""Memory of a block's sampled track input, all runs of a batch together, at most [B]
(a batch's block is shortened to fit; the nonlinear contacts' tables take most)."""

STAGED = 128
"""Stored steps of the lanes held before they are written to the runs' outputs
(`advance_lanes`): a stored step is a row of `LANES` values per column, written in one
vector store each (staged value by value and lane by lane, 8 runs of the 11-DOF model
over 300 m storing every step took 138 ms in the loop, 124 ms so; `benchmarks/batch.py`),
and a run's rows are then written one block after the other, not one row of each of the
lanes' outputs after the other."""

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

_EXPONENT = 0x7FF0000000000000
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
        if z_bits[i] & _EXPONENT == _EXPONENT:
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


@njit(cache=True, inline="always")
def _stage(stage, at, source, first, rows):
    """Rows ``first`` to ``first + rows`` of ``source`` into the rows from ``at`` on of
    ``stage`` (flat arrays of rows of `LANES` values, `load`)."""
    for i in range(rows):
        store(stage, at + i, load(source, first + i))


@njit(cache=True, inline="always")
def _write_staged(stage, valid, slots, row0, written, outs, offsets):
    """Write the first ``slots`` staged steps of each lane to its outputs.

    ``stage`` is (`STAGED`, columns, lanes): output ``a`` of ``outs`` in the columns from
    ``offsets[a]`` on. Lane ``b``'s steps are the slots where ``valid[slot, b]``; they go
    to the rows from ``row0[b] + written[b]`` on, and ``written[b]`` counts them.
    """
    for b in range(valid.shape[1]):
        for a in range(len(outs)):
            out, o = outs[a], offsets[a]
            row = row0[b] + written[b]
            for k in range(slots):
                if valid[k, b]:
                    for i in range(out.shape[1]):
                        out[row, i] = stage[k, o + i, b]
                    row += 1
        for k in range(slots):
            written[b] += valid[k, b]


_fma = lanewise("c + a * b")
_fms = lanewise("c - a * b")
_fma_difference = lanewise("c + a * (p - q)")
_product = lanewise("a * b")
_spring = lanewise("k * (x - r)")
_normal = lanewise("0.0 if d + o < 0.0 else d + o")
_slip_force = lanewise("(s == 1) * u - (s == 2) * d")
_stick_bit = lanewise("m + (K if s == 0 else 0)")
_new_state = lanewise("(c * v > u) + 2 * ((c * v < -d) & (c * v <= u))")
_changed = lanewise("h | (1 if n != s else 0)")
_stick_force = lanewise("c * v if s == 0 else f")
_select = lanewise("x if g else y")
_differ = lanewise("1 if h != m else 0")
_not_finite = lanewise("f | (1 if y & E == E else 0)")
_velocity = lanewise("(q - p) * h")
_acceleration = lanewise("(q - 2.0 * z + p) * h")
_wheel_load = lanewise("l + (f + a * d) / x")
_pending = lanewise("h if g else 0")
"""Operations of `advance_lanes` on the tuples of its lanes (`lanewise`): each the
expression written in `advance` or `wedge_step`, in every lane."""


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_rows(n, zl, zb, q1, ds_idx, dsv, dc_idx, dcv, cv, cc, fc, half, per_dt2, static,
               zero, none, out_v_l, out_a_l, out_sec_l, out_wl_l):  # fmt: skip
    """What `store_vehicle` writes of a stored step, each a row of the lanes: velocities,
    accelerations, secondary displacements and wheel loads; returns each lane's flag of a
    displacement not finite."""
    bad = none
    for i in range(n):
        zi, zp, qi = load(zl, i), load(zl, n + i), load(q1, i)
        bad = _not_finite(bad, load(zb, i), _EXPONENT)
        store(out_v_l, i, _velocity(half, zp, qi))
        store(out_a_l, i, _acceleration(per_dt2, zp, qi, zi))
    for u in range(ds_idx.shape[0]):
        acc = zero
        for j in range(ds_idx.shape[1]):
            acc = _fma(load(dsv, u * ds_idx.shape[1] + j), load(zl, ds_idx[u, j]), acc)
        store(out_sec_l, u, acc)
    for c in range(dc_idx.shape[0]):
        dv = zero
        for j in range(dc_idx.shape[1]):
            dv = _fma(load(dcv, c * dc_idx.shape[1] + j), load(out_v_l, dc_idx[c, j]), dv)
        wl = _wheel_load(load(cv, cc * c), dv, load(fc, c), static, load(cv, cc * c + 1))
        store(out_wl_l, c, wl)
    return bad


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_free(p_idx, pv, gc_idx, gcv, zl, fc, zero, q1):
    """The lanes' next displacement without the wedge forces, ``q1 = P z - Gc^T fc``
    (`vehicle_step`'s)."""
    for i in range(p_idx.shape[0]):
        acc = zero
        for j in range(p_idx.shape[1]):
            acc = _fma(load(pv, i * p_idx.shape[1] + j), load(zl, p_idx[i, j]), acc)
        store(q1, i, acc)
    for c in range(gc_idx.shape[0]):
        f = load(fc, c)
        for j in range(gc_idx.shape[1]):
            row = gc_idx[c, j]
            store(q1, row, _fms(load(gcv, c * gc_idx.shape[1] + j), f, load(q1, row)))


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_wedge_limits(n, dw_idx, dwv, wv, wc, zl, q1, half, zero, vfree, f_up, f_down):
    """The lanes' wedge velocities without friction ``vfree`` and slip forces ``f_up``,
    ``f_down`` of a step (`wedge_step`'s)."""
    for w in range(dw_idx.shape[0]):
        d, vv = zero, zero
        for j in range(dw_idx.shape[1]):
            col = dw_idx[w, j]
            a = load(dwv, w * dw_idx.shape[1] + j)
            d = _fma(a, load(zl, col), d)
            vv = _fma_difference(a, vv, load(q1, col), load(zl, n + col))
        store(vfree, w, _product(vv, half))
        normal = _normal(d, load(wv, wc * w))
        store(f_up, w, _product(normal, load(wv, wc * w + 1)))
        store(f_down, w, _product(normal, load(wv, wc * w + 2)))


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_wedge_forces(gw_idx, gwv, wv, wc, state, v, F, q1):
    """The lanes' wedge forces ``F`` of the stick/slip states found, and their part of
    ``q1``, ``- Gw^T F`` (`vehicle_step`'s)."""
    for w in range(gw_idx.shape[0]):
        f = _stick_force(load(wv, wc * w + 3), load(F, w), load(state, w), load(v, w))
        store(F, w, f)
        for j in range(gw_idx.shape[1]):
            row = gw_idx[w, j]
            store(q1, row, _fms(load(gwv, w * gw_idx.shape[1] + j), f, load(q1, row)))


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_shift(n, run, q1, zl):
    """``z = [q1, q0]`` in the running lanes, the others left as they are."""
    going = load(run, 0)
    for i in range(n):
        zi = load(zl, i)
        store(zl, n + i, _select(going, zi, load(zl, n + i)))
        store(zl, i, _select(going, load(q1, i), zi))


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_rows_arrays(n, nds, nc):
    """The lanes' rows of a step: ``q1`` and the stored step's velocities, accelerations
    (n each), secondary displacements (``nds``), wheel loads and contact forces (``nc``
    each)."""
    lanes = LANES
    return (np.empty(n * lanes), np.empty(n * lanes), np.empty(n * lanes),
            np.empty(nds * lanes), np.empty(nc * lanes), np.empty(nc * lanes))  # fmt: skip


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_wedge_arrays(nw):
    """The lanes' wedge quantities of `_lane_wedge_limits`, the Newton iteration and
    `_lane_wedge_forces`: free velocities, right-hand sides, velocities, slip forces up and
    down, forces, states (0 stick, 1 slip in compression, 2 in extension), the stick mask,
    the inverse of each lane's states ``held`` and those states."""
    lanes = LANES
    return (np.empty(nw * lanes), np.empty(nw * lanes), np.zeros(nw * lanes),
            np.empty(nw * lanes), np.empty(nw * lanes), np.zeros(nw * lanes),
            np.zeros(nw * lanes, np.int64), np.empty(lanes, np.int64),
            np.empty(nw * nw * lanes), np.full(lanes, -1, np.int64))  # fmt: skip


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_stored(s, bad, due, store_every, run, status, valid):
    """Which lanes store step ``s`` (``valid``, their next ``due`` step moved on); a lane
    whose displacement is not finite (``bad``) stops with `NOT_FINITE`. Returns how many
    store it."""
    kept = 0
    for b in range(LANES):
        valid[b] = 0
        if due[b] != s:
            continue
        due[b] += store_every[b]
        if run[b] and bad[b]:
            status[b, 0], status[b, 1] = NOT_FINITE, s
            run[b] = False
        valid[b] = run[b]
        kept += run[b]
    return kept


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
def _lane_newton(nw, wv, wc, hv, jinv, zero, none, vfree, rhs, v, f_up, f_down, F, state,
                 mask, jl, held):  # fmt: skip
    """One Newton pass of the lanes' wedges (`wedge_step`'s): the forces of the stick/slip
    states, the velocities they give (each lane's inverse of its stick mask, taken where
    its states changed), the new states. Returns each lane's flag of a changed state."""
    lanes = LANES
    m = none
    for w in range(nw):
        st = load(state, w)
        store(F, w, _slip_force(load(f_down, w), st, load(f_up, w)))
        m = _stick_bit(m, st, 1 << w)
    store(mask, 0, m)
    for w in range(nw):
        r = load(vfree, w)
        for u in range(nw):
            r = _fms(load(hv, w * nw + u), load(F, u), r)
        store(rhs, w, r)
    if total(_differ(load(held, 0), m)) > 0:
        for b in range(lanes):  # the lane's inverse, where the loop reads it
            if held[b] != mask[b]:
                held[b] = mask[b]
                for w in range(nw):
                    for u in range(nw):
                        jl[(w * nw + u) * lanes + b] = jinv[mask[b], w, u, b]
    ch = none
    for w in range(nw):
        acc = zero
        for u in range(nw):
            acc = _fma(load(jl, w * nw + u), load(rhs, u), acc)
        store(v, w, acc)
        st = load(state, w)
        new = _new_state(load(wv, wc * w + 3), load(f_down, w), load(f_up, w), acc)
        ch = _changed(ch, new, st)
        store(state, w, new)
    return ch


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", nogil=True)
def advance_lanes(
    p_idx, p_val, gc_idx, gc_val, gw_idx, gw_val, dc_idx, dc_val, dw_idx, dw_val,
    ds_idx, ds_val, H, jinv, wedge, contact, static_load,
    k_in, r_in, table, y_start, y_step, count,
    z, dt, step0, store_every, max_iter, row0,
    out_q, out_v, out_a, out_wl, out_secondary, out_fw, out_vw, out_k, out_r, status,
):  # fmt: skip
    """`advance` for `LANES` runs of one model side by side in the vector lanes.

    Every array of a run carries the lane axis last, `LANES` long (``z`` is (2n, LANES),
    ``p_val`` (n, width, LANES), ``k_in`` (steps, contacts, LANES), ``table`` (steps,
    contacts, LANES, grid), ...); the sparse rows' column indices are the model's, shared.
    Lane ``b`` advances ``count[b]`` steps. Each quantity of a step is a tuple of the
    lanes' values (`trackdyn.lanewise`); stick/slip and the end of a run are
    selects on each lane's own mask, so that no lane branches on its own. The Newton
    iteration goes on while a running lane's states change; a lane whose iteration fails
    or whose stored displacement is not finite stops (its ``status`` row gets what
    `advance` would return) and is left as it is while the others go on. Its stored steps
    go to the output rows from ``row0[b]`` on; a lane whose ``status[b, 0]`` is not `DONE`
    is left alone.
    """
    n = p_idx.shape[0]
    nc = dc_idx.shape[0]
    nw = dw_idx.shape[0]
    lanes = LANES
    nonlinear = table.shape[0] > 0
    # flat, one row of `LANES` values after the other (`load`, `store`)
    pv, gcv, gwv = p_val.reshape(-1), gc_val.reshape(-1), gw_val.reshape(-1)
    dcv, dwv, hv = dc_val.reshape(-1), dw_val.reshape(-1), H.reshape(-1)
    wv, kv, rv, zl = wedge.reshape(-1), k_in.reshape(-1), r_in.reshape(-1), z.reshape(-1)
    dsv, cv, zb = ds_val.reshape(-1), contact.reshape(-1), z.view(np.int64).reshape(-1)
    wc, cc = wedge.shape[1], contact.shape[1]  # rows of a wedge's and a contact's table
    inv2dt = 0.5 / dt
    invdt2 = 1.0 / (dt * dt)
    half, per_dt2, static = load(inv2dt, 0), load(invdt2, 0), load(static_load, 0)
    zero = load(np.zeros(lanes), 0)
    none = load(np.zeros(lanes, np.int64), 0)
    every = load(np.ones(lanes, np.int64), 0)
    q1, out_v_l, out_a_l, out_sec_l, out_wl_l, fc = _lane_rows_arrays(n, ds_idx.shape[0], nc)
    vfree, rhs, v, f_up, f_down, F, state, mask, jl, held = _lane_wedge_arrays(nw)
    run = np.empty(lanes, np.bool_)
    # the stored steps, `STAGED` at a time, a row of the lanes per column of the kept
    # outputs (the others have none), and in which lanes each slot is a stored step
    outs = (out_q, out_v, out_a, out_wl, out_secondary, out_fw, out_vw, out_k, out_r)
    offsets = np.zeros(len(outs) + 1, np.int64)
    for a in range(len(outs)):
        offsets[a + 1] = offsets[a] + outs[a].shape[1]
    stage = np.empty((STAGED, offsets[-1], lanes))
    stage_l, valid, slot = stage.reshape(-1), np.zeros((STAGED, lanes), np.int64), 0
    written = np.zeros(lanes, np.int64)
    due = -step0 % store_every  # each lane's next stored step
    next_due = due.min()
    steps = count.max()
    next_end = 0  # the next step at which a lane's run may end
    for s in range(steps):
        if s == next_end:
            next_end = steps
            for b in range(lanes):
                run[b] = status[b, 0] == DONE and s < count[b]
                next_end = min(next_end, count[b]) if count[b] > s else next_end
        for c in range(nc):
            x = zero
            for j in range(dc_idx.shape[1]):
                x = _fma(load(dcv, c * dc_idx.shape[1] + j), load(zl, dc_idx[c, j]), x)
            if nonlinear:
                for b in range(lanes):
                    y = x[b] - r_in[s, c, b]
                    fc[c * lanes + b] = contact_table_force(
                        table[s, c, b], y_start[b], y_step[b], y
                    )
                    fc[c * lanes + b] -= static_load[b]
            else:
                store(fc, c, _spring(load(kv, s * nc + c), load(rv, s * nc + c), x))
        _lane_free(p_idx, pv, gc_idx, gcv, zl, fc, zero, q1)  # q1 without the wedge forces
        if nw > 0:
            # the wedges: free velocities and slip forces (`wedge_step`), then Newton
            _lane_wedge_limits(n, dw_idx, dwv, wv, wc, zl, q1, half, zero, vfree, f_up, f_down)
            going = load(run, 0)
            ch, pending = every, 1  # as if every lane's states changed
            for _ in range(max_iter):
                ch = _lane_newton(nw, wv, wc, hv, jinv, zero, none, vfree, rhs, v, f_up, f_down, F,
                                  state, mask, jl, held)  # fmt: skip
                pending = total(_pending(going, ch))
                if pending == 0:
                    break
            if pending > 0:
                for b in range(lanes):
                    if run[b] and ch[b]:
                        status[b, 0], status[b, 1] = NEWTON_FAILED, s
                        run[b] = False
            _lane_wedge_forces(gw_idx, gwv, wv, wc, state, v, F, q1)
        if s == next_due:
            bad = _lane_rows(n, zl, zb, q1, ds_idx, dsv, dc_idx, dcv, cv, cc, fc, half, per_dt2,
                             static, zero, none, out_v_l, out_a_l, out_sec_l, out_wl_l)  # fmt: skip
            kept = _lane_stored(s, bad, due, store_every, run, status, valid[slot])
            if kept:
                at = slot * offsets[-1]  # the kept outputs, in the order of `outs`
                _stage(stage_l, at + offsets[0], zl, 0, out_q.shape[1])
                _stage(stage_l, at + offsets[1], out_v_l, 0, out_v.shape[1])
                _stage(stage_l, at + offsets[2], out_a_l, 0, out_a.shape[1])
                _stage(stage_l, at + offsets[3], out_wl_l, 0, out_wl.shape[1])
                _stage(stage_l, at + offsets[4], out_sec_l, 0, out_secondary.shape[1])
                _stage(stage_l, at + offsets[5], F, 0, out_fw.shape[1])
                _stage(stage_l, at + offsets[6], v, 0, out_vw.shape[1])
                _stage(stage_l, at + offsets[7], kv, s * nc, out_k.shape[1])
                _stage(stage_l, at + offsets[8], rv, s * nc, out_r.shape[1])
                slot += 1
                if slot == STAGED:
                    _write_staged(stage, valid, slot, row0, written, outs, offsets)
                    slot = 0
            next_due = due.min()
        _lane_shift(n, run, q1, zl)
    _write_staged(stage, valid, slot, row0, written, outs, offsets)


def in_threads(kernel, calls: list[tuple]) -> list:
    """``kernel(*args)`` for each ``args`` of ``calls``, their results in order: in numba's
    number of threads at once when that is more than one (the loops release the GIL), else
    one after the other.

    The runs one by one and the groups of lanes are spread over threads here, in Python,
    rather than by a compiled ``prange`` loop around `advance` and `advance_lanes`: such a
    loop is a kernel of its own to compile (5 s for the groups', 2.3 s for the runs' on
    this project's machine, beyond the loops they call), on every first run, for a call
    per block of 8192 steps.
    """
    threads = min(numba.get_num_threads(), len(calls))
    if threads <= 1:
        return [kernel(*args) for args in calls]
    with ThreadPoolExecutor(max_workers=threads) as pool:
        return [done.result() for done in [pool.submit(kernel, *args) for args in calls]]


def start_state(p: Problem, wedge) -> np.ndarray:
    """``z = [q0, q-1]`` for a start on the static path (`start_path`).

    The acceleration follows from the equations of motion (springs and track balance at
    static equilibrium, leaving damping and friction): ``q-1 = q0 - dt v0 + dt²/2 a0``, a
    start that keeps the scheme second-order accurate.
    """
    m, dt = p.model, p.dt
    q0, v0 = start_path(p)
    friction = wedge_forces(wedge, m.Dw @ q0, m.Dw @ v0)
    a0 = -(m.C @ v0 + m.Dw.T @ friction) / np.diag(m.M)
    return np.r_[q0, q0 - dt * v0 + 0.5 * dt**2 * a0]


def _sparse_rows(D):
    """Column indices of the nonzeros of each row of the matrices ``D`` (runs, rows,
    columns), zero-padded, and the runs' values there (runs, rows, width).

    The models' matrices are mostly zeros (``A`` is block diagonal: no damper crosses the
    secondary suspension), so the loop runs over nonzeros only; the columns are those
    where any run has a nonzero (the runs of a batch share them).
    """
    nonzero = (D != 0).any(axis=0)
    width = max(1, int(nonzero.sum(axis=1).max())) if nonzero.size else 1
    idx = np.zeros((D.shape[1], width), np.int64)
    val = np.zeros((D.shape[0], D.shape[1], width))
    for r, row in enumerate(nonzero):
        nz = np.flatnonzero(row)
        idx[r, : nz.size], val[:, r, : nz.size] = nz, D[:, r, nz]
    return idx, val


class StepMatrices(NamedTuple):
    """Constant arrays of the scheme (`step_matrices`), in the order `advance` takes them."""

    p_idx: np.ndarray
    p_val: np.ndarray
    gc_idx: np.ndarray
    gc_val: np.ndarray
    gw_idx: np.ndarray
    gw_val: np.ndarray
    dc_idx: np.ndarray
    dc_val: np.ndarray
    dw_idx: np.ndarray
    dw_val: np.ndarray
    ds_idx: np.ndarray
    ds_val: np.ndarray
    H: np.ndarray
    jinv: np.ndarray
    wedge: np.ndarray
    contact: np.ndarray


def _scheme(model, dt) -> tuple[list, list]:
    """The dense matrices of `step_matrices` (``P``, ``Gc^T``, ``Gw^T``, ``Dc``, ``Dw``,
    ``Ds``) and its other arrays (``H``, the inverses, the wedge and contact tables)."""
    M, C, K, Dc, Dw = model.M, model.C, model.K, model.Dc, model.Dw
    A = M / dt**2 + C / (2 * dt)
    Ainv = np.linalg.inv(A)
    P = np.hstack([Ainv @ (2 * M / dt**2 - K), -Ainv @ (M / dt**2 - C / (2 * dt))])
    Gw = Ainv @ Dw.T
    H = Dw @ Gw / (2 * dt)
    wedge = wedge_table(model)
    c_slope = wedge[:, 3]
    nw = Dw.shape[0]
    jinv = np.empty((2**nw, nw, nw))
    for mask in range(2**nw):
        stick = np.array([(mask >> w) & 1 for w in range(nw)], dtype=float)
        jinv[mask] = np.linalg.inv(np.eye(nw) + H * (c_slope * stick)[None, :])
    dense = [P, (Ainv @ Dc.T).T, Gw.T, Dc, Dw, model.Ds]
    return dense, [H, jinv, wedge, contact_table(model)]


def run_matrices(models, dts) -> StepMatrices:
    """`StepMatrices` of runs of one model (`step_matrices` of each): the sparse rows'
    indices shared, every other array with a leading run axis."""
    dense, rest = zip(*(_scheme(m, dt) for m, dt in zip(models, dts, strict=True)), strict=True)
    sparse = [_sparse_rows(np.stack(d)) for d in zip(*dense, strict=True)]
    pairs = (a for pair in sparse for a in pair)
    return StepMatrices._make([*pairs, *(np.stack(r) for r in zip(*rest, strict=True))])


def step_matrices(model, dt) -> StepMatrices:
    """Constant arrays of the scheme for `advance`, from a `Model` and the step [s].

    The sparse rows (`_sparse_rows`) of ``P = [A^-1 (2M/Δt² - K), -A^-1 (M/Δt² - C/(2Δt))]``
    acting on ``[q0, q-1]``, of ``Gc^T`` and ``Gw^T`` with ``Gc = A^-1 Dc^T`` and
    ``Gw = A^-1 Dw^T``, and of ``Dc``, ``Dw`` and ``Ds``; ``H``; the inverses of
    ``I + H diag(C_slope·stick)`` for every stick/slip combination; per wedge
    ``x_ss [m]``, the slip force per unit spring
    compression in compression and in extension ``k_ss μ / (tan α_w ∓ μ)`` [N/m], and
    ``C_slope`` [N s/m] (`wedge_table`); per contact the track damping [N s/m] and its
    number of axles (`contact_table`).
    """
    m = run_matrices([model], [dt])
    return StepMatrices._make(a if f.endswith("_idx") else a[0] for f, a in m._asdict().items())


MIN_LANE_RUNS = 3
"""Runs left over from the full groups that go into a group of their own, its other lanes
idle; fewer go one by one. A group of the 11-DOF model costs about two runs alone
(`benchmarks/lanes.py`), whatever its lanes hold."""


def lane_groups(runs: int) -> np.ndarray:
    """The runs of each group of the lanes, (groups, `LANES`), ``-1`` for an idle lane:
    the first runs, in full groups, and the runs left over in a group of their own when
    there are at least `MIN_LANE_RUNS` of them; otherwise they go one by one."""
    grouped = runs if runs % LANES >= MIN_LANE_RUNS else runs // LANES * LANES
    take = np.full(-(-grouped // LANES) * LANES, -1)
    take[:grouped] = np.arange(grouped)
    return take.reshape(-1, LANES)


def in_lanes(a, take):
    """Per-run array ``a`` (runs, ...) in the lanes: (groups, ..., lanes) for the runs
    ``take`` (`lane_groups`; an idle lane gets a copy of the last run's values, which it
    never advances)."""
    return np.ascontiguousarray(np.moveaxis(a[take], 1, -1))


def solve(problems: list[Problem], newton_max_iter: int = 50, advanced=None,
          keep=OUTPUTS) -> list:  # fmt: skip
    """Integrate runs of one model side by side: one compiled call per block of steps.

    The runs go in groups of `LANES` through `advance_lanes` (side by side in the vector
    lanes, the groups in threads, `in_threads`), the last group with idle lanes when at
    least `MIN_LANE_RUNS` runs are left over; fewer go through `advance` (one by one, in
    threads).

    Parameters
    ----------
    problems : list of Problem
        Runs of models with the same degrees of freedom, contacts and wedges, and the
        same kind of contact (linear or tabulated); dt, steps, storage, inputs and
        parameters may differ. A run's results do not depend on the others in the batch.
    newton_max_iter : int
        Newton iterations allowed per step.
    advanced : callable, optional
        Called with the number of steps done after each block.
    keep : sequence of str
        The `OUTPUTS` returned. The lanes neither stage nor write the others (staging
        every output of a stored step, lane by lane, cost a fifth of the 11-DOF model's
        step when only the wheel loads were kept); a run one by one writes them all, to
        arrays of its own (its loop is fastest unguarded).

    Returns
    -------
    list
        Per run, a dict of the kept `OUTPUTS` arrays, or the `TrackdynInputError` that
        stopped it.
    """
    batch = _Batch(problems, newton_max_iter, keep)
    for first, sampled in _sampled_blocks(batch.sample, batch.firsts,
                                          numba.get_num_threads() > 1):  # fmt: skip
        steps = batch.advance(first, sampled)
        if advanced is not None:
            advanced(steps)
    return batch.results()


class _Batch:
    """The runs of a `solve` call: their matrices, start states, outputs and status, the
    track input of a block of steps (`sample`), a block's steps (`advance`) and the
    results.

    Runs in the lanes (the first ``in_groups``) and one by one (the rest) have outputs of
    their own: ``flat`` (the kept arrays' columns) and ``flat_one`` (all columns, from row
    ``split`` on); the rows ``rows[b]:rows[b + 1]`` are run ``b``'s.
    """

    def __init__(self, problems: list[Problem], newton_max_iter: int, keep):
        self.problems, self.newton_max_iter, self.keep = problems, newton_max_iter, keep
        runs = self.runs = len(problems)
        take = self.take = lane_groups(runs)
        self.n_groups, self.in_groups = take.shape[0], np.count_nonzero(take >= 0)
        lanes = self.lanes = take.size
        self.one = slice(self.in_groups, runs)  # the runs one by one
        mats = self.mats = run_matrices([p.model for p in problems], [p.dt for p in problems])
        self.idx = {f for f in mats._fields if f.endswith("_idx")}
        self.lane_mats = [a if f in self.idx else in_lanes(a, take)
                          for f, a in mats._asdict().items()]  # fmt: skip
        self.errors: list = [None] * runs
        # DONE: running; the rows of idle lanes follow the runs' (none one by one)
        status = self.status = np.zeros((max(runs, lanes), 2), np.int64)
        status[runs:, 0] = NOT_STARTED
        z = self.z = np.zeros((runs, 2 * len(problems[0].model.dof_names)))
        for b, p in enumerate(problems):
            try:
                z[b] = start_state(p, mats.wedge[b])
            except TrackdynInputError as exc:
                self.errors[b], status[b, 0] = exc, NOT_STARTED
        self.lane_z = in_lanes(z, take)
        self.lane_status = status[:lanes].reshape(self.n_groups, LANES, 2)
        rows = self.rows = np.cumsum([0] + [p.n_store for p in problems])
        width, split = widths(problems[0].model), rows[self.in_groups]
        self.split = split
        self.flat = {name: np.empty((split, w if name in keep else 0))
                     for name, w in width.items()}  # fmt: skip
        self.flat_one = {name: np.empty((rows[-1] - split, w)) for name, w in width.items()}
        self.per_run = dict(
            static=np.array([p.model.static_wheel_load for p in problems]),
            y_start=np.array([table_step(track_input(p).grid)[0] for p in problems]),
            y_step=np.array([table_step(track_input(p).grid)[1] for p in problems]),
            dt=np.array([p.dt for p in problems]),
            every=np.array([p.store_every for p in problems]),
        )
        self.lane = {name: in_lanes(a, take) for name, a in self.per_run.items()}
        nc, grid = len(problems[0].model.contact_names), track_input(problems[0]).grid.size
        self.nc, self.grid = nc, grid
        step_bytes = 8 * nc * (2 + grid)
        block = self.block = max(1, min(CHUNK_STEPS, CHUNK_BYTES // step_bytes // runs))
        self.firsts = range(0, max(p.n_steps for p in problems), block)
        # the lanes' input (k, r), two blocks' worth, allocated once: the next block is
        # sampled into one while the loop reads the other (`_sampled_blocks`); idle lanes,
        # and the steps past a lane's last in a block, are not read
        depth = min(block, self.firsts.stop)
        self.buffers = np.zeros((2, 2, self.n_groups, depth, nc, LANES))
        # a group's runs are sampled into `staged`, each run's steps in a row, and go into
        # the lanes' layout in one copy: written run by run, each value there is a cache
        # line of its own (a row of the layout is `LANES` doubles)
        self.staged = np.zeros((2, LANES, depth, nc))

    def sample(self, first: int):
        """Track input of the block of steps from ``first`` on (none for stopped runs):
        in the lanes with each lane's number of steps, and of the runs one by one, one
        after the other, with where each starts. Runs on the same input (one object) along
        the same path share one sample of it."""
        problems, block, nc, grid, take = self.problems, self.block, self.nc, self.grid, self.take
        count = np.zeros(max(self.runs, self.lanes), np.int64)
        for b, p in enumerate(problems):
            if self.status[b, 0] == DONE:
                count[b] = max(min(block, p.n_steps - first), 0)
        k, r = self.buffers[first // block % 2]
        shape = (self.n_groups, int(count[: self.lanes].max(initial=0)), nc, LANES)
        table = np.zeros((*shape, grid) if grid else (self.n_groups, 0, nc, LANES, 0))
        sampled: dict = {}

        def inputs(b):
            p = problems[b]
            key = (id(p.inputs), p.centre0, p.speed, p.dt, count[b])
            if key not in sampled:
                at = p.centre0 + p.speed * p.dt * np.arange(first, first + count[b])
                sampled[key] = p.inputs(at)
            return sampled[key]

        for g in range(self.n_groups):
            mine = {b: inputs(b) for b in take[g].tolist() if b >= 0 and count[b]}
            for b, (_, _, tb) in mine.items():
                if grid:
                    table[g, : count[b], :, b % LANES] = tb
            if len({id(x) for x in mine.values()}) == 1:  # one input in every lane
                kb, rb, _ = next(iter(mine.values()))
                k[g, : len(kb)], r[g, : len(kb)] = kb[..., None], rb[..., None]
            elif mine:
                staged = self.staged
                for b, (kb, rb, _) in mine.items():
                    staged[0, b % LANES, : count[b]], staged[1, b % LANES, : count[b]] = kb, rb
                top = int(count[list(mine)].max())
                k[g, :top], r[g, :top] = staged[:, :, :top].transpose(0, 2, 3, 1)
        singly = [inputs(b) for b in range(self.in_groups, self.runs) if count[b]]
        empty = (np.zeros((0, nc)), np.zeros((0, nc)), np.zeros((0, nc, grid)))
        alone = [np.concatenate(a) for a in zip(empty, *singly, strict=True)]
        in_start = np.cumsum([0, *count[self.one]])
        per_lane = count[: self.lanes].reshape(self.n_groups, LANES)
        return (k, r, table, per_lane), (*alone, in_start), int(count.sum())

    def advance(self, first: int, sampled) -> int:
        """The block of steps from ``first`` on, on its ``sampled`` input (`sample`): the
        groups through `advance_lanes`, the runs one by one through `advance`, each in
        threads; a run that stopped gets its error. Returns the steps done."""
        (k, r, table, count), (k1, r1, table1, in_start), steps = sampled
        mats, idx, lane, per_run = self.mats, self.idx, self.lane, self.per_run
        row0 = self.rows[:-1] + (first + per_run["every"] - 1) // per_run["every"]
        lane_row0 = in_lanes(row0, self.take)
        groups = [  # each group's arguments of `advance_lanes`
            (*(a if f in idx else a[g] for f, a in zip(mats._fields, self.lane_mats, strict=True)),
             lane["static"][g], k[g], r[g], table[g], lane["y_start"][g], lane["y_step"][g],
             count[g], self.lane_z[g], lane["dt"][g], first, lane["every"][g],
             self.newton_max_iter, lane_row0[g], *self.flat.values(), self.lane_status[g])
            for g in range(self.n_groups)
        ]  # fmt: skip
        if groups:
            with vectorised():
                in_threads(advance_lanes, groups)
        going = [b for b in range(self.in_groups, self.runs) if self.status[b, 0] == DONE]
        at = {b: slice(in_start[b - self.in_groups], in_start[b - self.in_groups + 1])
              for b in going}  # fmt: skip
        alone = [  # each running run's arguments of `advance`, one by one
            (*(a if f in idx else a[b] for f, a in zip(mats._fields, mats, strict=True)),
             per_run["static"][b], k1[at[b]], r1[at[b]],
             table1[at[b]] if table1.shape[0] else table1,
             per_run["y_start"][b], per_run["y_step"][b], self.z[b], per_run["dt"][b], first,
             per_run["every"][b], self.newton_max_iter,
             *(o[row0[b] - self.split:] for o in self.flat_one.values()))
            for b in going
        ]  # fmt: skip
        for b, ended in zip(going, in_threads(advance, alone), strict=True):
            self.status[b] = ended
        for b in range(self.runs):
            code, step = self.status[b]
            if code in (NEWTON_FAILED, NOT_FINITE) and self.errors[b] is None:
                stop = failure if code == NEWTON_FAILED else non_finite
                self.errors[b] = stop(self.problems[b], first + int(step))
        return steps

    def results(self) -> list:
        """Per run, a dict of its kept outputs, or the error that stopped it."""
        rows, in_groups = self.rows, self.in_groups
        where = [(self.flat, 0)] * in_groups + [(self.flat_one, self.split)] * (
            self.runs - in_groups
        )
        return [
            self.errors[b]
            or {name: out[name][rows[b] - at : rows[b + 1] - at] for name in self.keep}
            for b, (out, at) in enumerate(where)
        ]


def _sampled_blocks(sample, firsts: range, ahead: bool):
    """``(first, sample(first))`` for each block of steps. With ``ahead`` the next block's
    input is sampled in a thread while the compiled loop (which releases the GIL) advances
    this one: faster with a core to spare, as when numba may use more than one thread; a
    Dask worker's task runs on one (`trackdyn.parallel`), a core's worth of work, and a
    second thread there only takes turns with the loop."""
    if not ahead:
        for first in firsts:
            yield first, sample(first)
        return
    with ThreadPoolExecutor(max_workers=1) as pool:
        coming = pool.submit(sample, firsts.start)
        for first in firsts:
            sampled = coming.result()
            if first + firsts.step < firsts.stop:
                coming = pool.submit(sample, first + firsts.step)
            yield first, sampled


def highest_frequency(M, K) -> float:
    """Highest undamped natural angular frequency of ``(K, M)`` [rad/s]."""
    m = np.diag(M)
    scaled = K / np.sqrt(np.outer(m, m))
    return float(np.sqrt(max(np.linalg.eigvalsh(scaled).max(), 0.0)))


STEPS_PER_PERIOD = 50
"""Default Δt gives this many steps per period of the highest natural frequency: the
central-difference period error is about (ωΔt)²/24 = 0.07 %."""
