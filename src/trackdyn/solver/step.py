"""The scheme's step (seed eqs 5.15-5.18, 5.30-5.33), written once for any number of runs
side by side: the contact forces, the vehicle's next displacement without the wedges, the
wedges' slip limits, a pass of their Newton iteration and their forces, and what a stored
step keeps. The loops around them (a step's Newton passes until the states hold, the
steps, the stores) are their callers'.

Each function works on the tuples of `trackdyn.lanewise`: a quantity is a tuple of the
lanes' values (``zero`` and ``none`` are tuples of zeros, float and integer). Written for
the `LANES` runs side by side of `trackdyn.solver.lanes`, the functions are made for a
run alone (tuples of one value, where they compile to the scalar step) by
`trackdyn.lanewise.widened` (`ALONE`), for `trackdyn.solver.kernel` and
`trackdyn.solver.discrete`. Arrays are flat, one row of the lanes' values after the other
(`trackdyn.lanewise.load`); the sparse rows' column indices are the model's, shared by the
lanes. The functions are inlined into their loops by numba and take their sizes as
arguments: computed inside, they cost the lanes their vectorisation. A lane's stick/slip
states and its Newton iteration are selects on its own mask, so that no lane branches on
its own; the sums are done in one order and compiled without reassociation
(`trackdyn.lanewise.FASTMATH`), so a run's results in the lanes are those it gives alone,
to the bit.

With ``A = M/Δt² + C/(2Δt)`` the step is

    A q1 = (2M/Δt² - K) q0 - (M/Δt² - C/(2Δt)) q-1 - Dc^T f(q0, t0) - Dw^T F(v0, d0),

written ``q1 = P z - Gc^T fc - Gw^T F`` with ``z = [q0, q-1]``; the wedges' forces ``F``
solve ``v + H F(v) = v_free`` (`trackdyn.solver.kernel`).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.4, eqs
5.15-5.18 (central differences with Newton-Raphson), 5.30-5.33 (friction wedges).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from trackdyn.lanewise import FASTMATH, lanewise, load, store, total, widened
from trackdyn.solver.statics import WEDGE_COLUMNS, table_force_at

EXPONENT = 0x7FF0000000000000
"""Exponent bits of a float64, all set for inf and NaN (a test that ``fastmath`` keeps)."""

INLINED: dict[str, Any] = dict(cache=True, fastmath=FASTMATH, error_model="numpy", inline="always")
"""numba options of the step's functions: inlined into the loop that calls them."""

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
_differ = lanewise("1 if h != m else 0")
_not_finite = lanewise("f | (1 if y & E == E else 0)")
_velocity = lanewise("(q - p) * h")
_acceleration = lanewise("(q - 2.0 * z + p) * h")
_wheel_load = lanewise("l + (f + a * d) / x")
"""The step's expressions, each applied in every lane (`trackdyn.lanewise.lanewise`)."""

STEP = ("contact_forces", "free_displacement", "wedge_limits", "newton_pass", "wedge_forces",
        "motion_rows", "wheel_loads", "wedge_arrays")  # fmt: skip
"""The step's functions, in the order they are defined (`ALONE` makes each for a run)."""


@njit(**INLINED)
def contact_forces(s, nc, nonlinear, dc_idx, dcv, zl, kv, rv, tv, grid, y_start, y_step,
                   static_load, zero, fc):  # fmt: skip
    """The contact forces ``fc`` of step ``s`` from the lanes' displacements ``zl``: linear,
    ``f = k (Dc q - r)`` (``kv``, ``rv`` the flat input, (steps, contacts)), unless
    ``nonlinear``, and then tabulated, ``f = P(Dc q - r) - Ps`` (``tv`` the flat (steps,
    contacts, lanes, ``grid``) tables on each lane's grid from ``y_start`` in steps of
    ``y_step``, ``static_load`` each lane's Ps)."""
    lanes = len(zero)
    for c in range(nc):
        x = zero
        for j in range(dc_idx.shape[1]):
            x = _fma(load(dcv, c * dc_idx.shape[1] + j), load(zl, dc_idx[c, j]), x)
        if nonlinear:
            for b in range(lanes):
                at = (s * nc + c) * lanes + b
                y = x[b] - rv[at]
                f = table_force_at(tv, at * grid, grid, y_start[b], y_step[b], y)
                fc[c * lanes + b] = f - static_load[b]
        else:
            store(fc, c, _spring(load(kv, s * nc + c), load(rv, s * nc + c), x))


@njit(**INLINED)
def free_displacement(p_idx, pv, gc_idx, gcv, zl, fc, zero, q1):
    """The next displacement without the wedge forces, ``q1 = P z - Gc^T fc``."""
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


@njit(**INLINED)
def wedge_limits(n, dw_idx, dwv, wv, zl, q1, half, zero, vfree, f_up, f_down):
    """The wedges' velocities if no friction acted, ``v = Dw (q1 - q-1) / 2Δt``
    (``vfree``), and their slip forces in compression and extension, ``f_up`` and
    ``f_down``: the normal force ``N0 + Dw q0`` (not below 0) times the friction
    coefficients of the wedge's table ``wv`` (`trackdyn.solver.statics.wedge_table`)."""
    for w in range(dw_idx.shape[0]):
        d, vv = zero, zero
        for j in range(dw_idx.shape[1]):
            col = dw_idx[w, j]
            a = load(dwv, w * dw_idx.shape[1] + j)
            d = _fma(a, load(zl, col), d)
            vv = _fma_difference(a, vv, load(q1, col), load(zl, n + col))
        store(vfree, w, _product(vv, half))
        normal = _normal(d, load(wv, WEDGE_COLUMNS * w))
        store(f_up, w, _product(normal, load(wv, WEDGE_COLUMNS * w + 1)))
        store(f_down, w, _product(normal, load(wv, WEDGE_COLUMNS * w + 2)))


@njit(**INLINED)
def newton_pass(nw, wv, hv, jv, zero, none, vfree, rhs, v, f_up, f_down, F, state, masks, jl):
    """One Newton pass of the wedges: the forces of the stick/slip states, the velocities
    they give (each lane's inverse of its stick mask, copied where its states changed),
    the new states. Returns each lane's flag of a changed state.

    ``jv`` is the flat (2^nw, nw, nw, lanes) inverse of ``I + H diag(C_slope·stick)`` for
    every stick mask; the others are the step's wedge arrays (`wedge_arrays`; ``masks``
    each lane's stick mask and the mask of its inverse in ``jl``).
    """
    lanes = len(zero)
    m = none
    for w in range(nw):
        st = load(state, w)
        store(F, w, _slip_force(load(f_down, w), st, load(f_up, w)))
        m = _stick_bit(m, st, 1 << w)
    store(masks, 0, m)
    for w in range(nw):
        r = load(vfree, w)
        for u in range(nw):
            r = _fms(load(hv, w * nw + u), load(F, u), r)
        store(rhs, w, r)
    if total(_differ(load(masks, 1), m)) > 0:
        for b in range(lanes):  # the lane's inverse, where the loop reads it
            mask = masks[b]
            if masks[lanes + b] != mask:
                masks[lanes + b] = mask
                for wu in range(nw * nw):
                    jl[wu * lanes + b] = jv[(mask * nw * nw + wu) * lanes + b]
    ch = none
    for w in range(nw):
        acc = zero
        for u in range(nw):
            acc = _fma(load(jl, w * nw + u), load(rhs, u), acc)
        store(v, w, acc)
        st = load(state, w)
        new = _new_state(load(wv, WEDGE_COLUMNS * w + 3), load(f_down, w), load(f_up, w),
                         acc)  # fmt: skip
        ch = _changed(ch, new, st)
        store(state, w, new)
    return ch


@njit(**INLINED)
def wedge_forces(gw_idx, gwv, wv, zero, v, F, state, q1):
    """The wedge forces ``F`` of the stick/slip states found (``C_slope v`` where a wedge
    sticks), and their part of ``q1``, ``- Gw^T F``."""
    for w in range(gw_idx.shape[0]):
        f = _stick_force(load(wv, WEDGE_COLUMNS * w + 3), load(F, w), load(state, w),
                         load(v, w))  # fmt: skip
        store(F, w, f)
        for j in range(gw_idx.shape[1]):
            row = gw_idx[w, j]
            store(q1, row, _fms(load(gwv, w * gw_idx.shape[1] + j), f, load(q1, row)))


@njit(**INLINED)
def motion_rows(n, row, zl, zb, q1, ds_idx, dsv, half, per_dt2, zero, none, out_v, out_a,
                out_sec):  # fmt: skip
    """Row ``row`` of a stored step's velocities, accelerations (``n`` each) and secondary
    displacements, each a row of the lanes; returns each lane's flag of a displacement
    ``q0`` not finite (``zb``, ``zl``'s bits)."""
    bad = none
    for i in range(n):
        zi, zp, qi = load(zl, i), load(zl, n + i), load(q1, i)
        bad = _not_finite(bad, load(zb, i), EXPONENT)
        store(out_v, row * n + i, _velocity(half, zp, qi))
        store(out_a, row * n + i, _acceleration(per_dt2, zp, qi, zi))
    nds = ds_idx.shape[0]
    for u in range(nds):
        acc = zero
        for j in range(ds_idx.shape[1]):
            acc = _fma(load(dsv, u * ds_idx.shape[1] + j), load(zl, ds_idx[u, j]), acc)
        store(out_sec, row * nds + u, acc)
    return bad


@njit(**INLINED)
def wheel_loads(n, nc, row, dc_idx, dcv, cv, cc, fc, static, zero, out_v, out_wl):
    """Row ``row`` of a stored step's wheel loads, ``Ps + (f + c_d Dc v) / axles`` with the
    contact table ``cv`` (rows of ``cc``: c_d, axles) and the step's velocities ``out_v``
    (`motion_rows`)."""
    for c in range(nc):
        dv = zero
        for j in range(dc_idx.shape[1]):
            dv = _fma(load(dcv, c * dc_idx.shape[1] + j),
                      load(out_v, row * n + dc_idx[c, j]), dv)  # fmt: skip
        wl = _wheel_load(load(cv, cc * c), dv, load(fc, c), static,
                         load(cv, cc * c + 1))  # fmt: skip
        store(out_wl, row * nc + c, wl)


@njit(**INLINED)
def wedge_arrays(nw, zero):
    """The step's wedge arrays, flat rows of the lanes (`newton_pass`): free velocities,
    right-hand sides, velocities, slip forces up and down, forces, states (0 stick, 1 slip
    in compression, 2 in extension), each lane's stick mask and the mask of the inverse held
    (-1: none yet), the inverse held."""
    lanes = len(zero)
    return (np.empty(nw * lanes), np.empty(nw * lanes), np.zeros(nw * lanes),
            np.empty(nw * lanes), np.empty(nw * lanes), np.zeros(nw * lanes),
            np.zeros(nw * lanes, np.int64), np.full(2 * lanes, -1, np.int64),
            np.empty(nw * nw * lanes))  # fmt: skip


ALONE = widened(globals(), STEP, 1)
"""The step's functions for a run alone (tuples of one value), by name."""
