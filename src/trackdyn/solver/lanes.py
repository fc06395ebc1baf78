"""The scheme of `trackdyn.solver.kernel` for runs of one model side by side in the
vector lanes.

Runs of one model, in groups of `LANES` (the last with idle lanes when at least
`MIN_LANE_RUNS` are left over), go side by side through `advance_lanes`: each array
carries the runs (lanes) along its last, contiguous axis, and each quantity of a step is a
tuple of the lanes' values, which LLVM packs into vector registers (`trackdyn.lanewise`).
The step is `trackdyn.solver.step`'s, the one a run alone takes in
`trackdyn.solver.kernel.advance`, at the lanes' width, so that a run's results in
the lanes are those it gives alone, to the bit; this module adds what a group needs
besides: each lane's end and status, and the stored steps staged and written lane by lane.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.4, eqs
5.15-5.18 (central differences with Newton-Raphson), 5.30-5.33 (friction wedges).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from trackdyn.lanewise import FASTMATH, LANES, lanewise, load, store, total
from trackdyn.solver.kernel import DONE, NEWTON_FAILED, NOT_FINITE
from trackdyn.solver.statics import table_force_at
from trackdyn.solver.step import (
    free_displacement,
    motion_rows,
    newton_pass,
    wedge_arrays,
    wedge_forces,
    wedge_limits,
    wheel_loads,
)

STAGED = 128
"""Stored steps of the lanes held before they are written to the runs' outputs
(`advance_lanes`): a stored step is a row of `LANES` values per column, written in one
vector store each (staged value by value and lane by lane, 8 runs of the 11-DOF model
over 300 m storing every step took 138 ms in the loop, 124 ms so; `benchmarks/batch.py`),
and a run's rows are then written one block after the other, not one row of each of the
lanes' outputs after the other."""


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
_spring = lanewise("k * (x - r)")
_select = lanewise("x if g else y")
_pending = lanewise("h if g else 0")
"""Each lane's ``x`` where its flag ``g`` is set, its ``y`` elsewhere; its ``h`` where
``g`` is set, 0 elsewhere."""


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
    each), one row of `LANES` values each."""
    lanes = LANES
    return (np.empty(n * lanes), np.empty(n * lanes), np.empty(n * lanes),
            np.empty(nds * lanes), np.empty(nc * lanes), np.empty(nc * lanes))  # fmt: skip


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
    # flat, one row of `LANES` values after the other (`load`, `store`)
    pv, gcv, gwv = p_val.reshape(-1), gc_val.reshape(-1), gw_val.reshape(-1)
    dcv, dwv, hv, jv = dc_val.reshape(-1), dw_val.reshape(-1), H.reshape(-1), jinv.reshape(-1)
    wv, kv, rv, zl = wedge.reshape(-1), k_in.reshape(-1), r_in.reshape(-1), z.reshape(-1)
    dsv, cv, zb = ds_val.reshape(-1), contact.reshape(-1), z.view(np.int64).reshape(-1)
    cc = contact.shape[1]  # a contact's row of its table
    nonlinear, tv, grid = table.shape[0] > 0, table.reshape(-1), table.shape[-1]
    half, per_dt2, static = load(0.5 / dt, 0), load(1.0 / (dt * dt), 0), load(static_load, 0)
    zero, none = load(np.zeros(lanes), 0), load(np.zeros(lanes, np.int64), 0)
    every = load(np.ones(lanes, np.int64), 0)
    q1, out_v_l, out_a_l, out_sec_l, out_wl_l, fc = _lane_rows_arrays(n, ds_idx.shape[0], nc)
    vfree, rhs, v, f_up, f_down, F, state, masks, jl = wedge_arrays(nw, zero)
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
        # the contact forces (`contact_forces`'s, which as a function cost the lanes a third
        # of their speed)
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
        free_displacement(p_idx, pv, gc_idx, gcv, zl, fc, zero, q1)
        if nw > 0:
            # the wedges: their limits, then Newton while a running lane's states change
            wedge_limits(n, dw_idx, dwv, wv, zl, q1, half, zero, vfree, f_up, f_down)
            going = load(run, 0)
            changed, pending = every, 1  # as if every lane's states changed
            for _ in range(max_iter):
                changed = newton_pass(nw, wv, hv, jv, zero, none, vfree, rhs, v, f_up, f_down, F,
                                      state, masks, jl)  # fmt: skip
                pending = total(_pending(going, changed))
                if pending == 0:
                    break
            if pending > 0:
                for b in range(lanes):
                    if run[b] and changed[b]:
                        status[b, 0], status[b, 1] = NEWTON_FAILED, s
                        run[b] = False
            wedge_forces(gw_idx, gwv, wv, zero, v, F, state, q1)
        if s == next_due:
            bad = motion_rows(n, 0, zl, zb, q1, ds_idx, dsv, half, per_dt2, zero, none, out_v_l,
                              out_a_l, out_sec_l)  # fmt: skip
            wheel_loads(n, nc, 0, dc_idx, dcv, cv, cc, fc, static, zero, out_v_l, out_wl_l)
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
