"""A vehicle model on the discrete track (`trackdyn.track.discrete`), one compiled loop.

The vehicle advances as in `trackdyn.solver.kernel` (central differences, implicit in its
dampers and wedges, explicit in the contact forces); the track by central differences with
its lumped masses, explicit in all its forces (the damping forces from the backward
difference of the velocity). Each wheel meets its rail through a linearised Hertz spring
``kH`` that loses contact (no tension), in series with the rail's local bending between
the nodes of its element (the clamped-clamped deflection under a point load,
``a³ b³ / (3 EI L³)``, which with the Hermite interpolation of the nodal values makes the
rail deflection under the wheel exact for the static beam):

    W = max(0, (Dc q - r(x) - (u(x) - u_rest(x)) + Ps / kH) / (1/kH + a³b³/(3 EI L³)))

with ``r`` the unloaded profile at rest and ``u - u_rest`` the rail's deflection from its
rest state; the vehicle feels ``W - Ps`` per axle (its coordinates are those of the
Winkler runs), the rail ``W`` through the element's consistent nodal loads. A contact
that stands for several axles (the bogie approximation of 5.4.3: one lumped wheelset,
the bogie free to pitch) carries the same load on each: ``r + u - u_rest`` and the local
flexibility are its axles' means, as the Winkler contact takes the mean loaded profile. Only the
nodes of a window moving with the vehicle (the axles' span and the margin each side) are
integrated; the nodes ahead are at rest, those behind keep their last state, so a step
costs the same on any length of track. The rail's rotations carry no inertia (an
Euler-Bernoulli beam with its mass lumped at the nodes, the degrees of freedom without
mass condensed out, as the central difference method needs; Bathe 1996, §9.2.1): each
step solves the window's moment balance for them, a tridiagonal system, once the
deflections have moved. With the rail's
own rotary inertia ``ρI`` lumped at the nodes instead, the rotations' modes (near 4.7 kHz)
limited the time step to 0.3 of the one the deflections allow; the wheel loads of the 1 km
example at 60 km/h differ by under 0.04 % at their peaks and 0.003 % in RMS.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.4 (the scheme).

Bathe, K.J. (1996). Finite Element Procedures. Prentice Hall, Englewood Cliffs, §9.2.1
(the central difference method, its stability limit Δt < 2/ω_max, degrees of freedom
without mass).

Timoshenko, S., Young, D.H. (1965). Theory of Structures, 2nd ed. McGraw-Hill (deflection
of a clamped-clamped beam under a point load).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numba import njit
from scipy.interpolate import CubicSpline

from trackdyn.beam.elements import element_stiffness, hermite
from trackdyn.errors import TrackdynInputError
from trackdyn.solver.central import CHUNK_STEPS
from trackdyn.solver.kernel import DONE, NEWTON_FAILED, NOT_FINITE, store_vehicle, vehicle_step
from trackdyn.solver.matrices import step_matrices
from trackdyn.solver.statics import failure, non_finite, widths
from trackdyn.solver.step import ALONE
from trackdyn.track.discrete import hertz_stiffness
from trackdyn.track.track import RAILS
from trackdyn.units import GRAVITY

_wedge_arrays = ALONE["wedge_arrays"]
"""The vehicle step's wedge arrays for a run alone (`trackdyn.solver.step.wedge_arrays`)."""

STABILITY_FRACTION = 0.8
"""Default time step as a fraction of the explicit scheme's limit ``2 / ω_max`` of the track
(`highest_frequency`: the rail's deflection at a wheel between its Hertz spring, pads and
bending, near 1.4 kHz). The pads' damping, explicit as a backward difference, lowers the
limit to about 0.93 of it (``ω² Δt² + 2 cp Δt / m < 4`` of a rail node; Bathe 1996,
§9.2.1), which 0.8 keeps clear of. On the example at 100 km/h, 0.25 instead gives wheel
loads within 0.44 % of their dynamic part (RMS) and peaks within 0.1 %."""

START_ITERATIONS = 6
"""Fixed-point iterations of the static start (wheel loads against track deflection)."""


TRACK_JIT: dict[str, Any] = dict(
    cache=True, fastmath=True, error_model="numpy", nogil=True, inline="always"
)
"""numba options of the phases of `advance`'s step (`wheel_loads`, `rail_forces`,
`follow_axles`, `step_nodes`, `solve_rotations`, and `hand_over`, `factor_rotations`,
`fold_factors`):
those of `advance`, and inlined into it by numba, which keeps the loop as fast as in one
function (LLVM vectorises the same loops; as plain calls, each with its arrays'
fields for arguments, the loop took 5 % longer)."""


@njit(**TRACK_JIT)
def wheel_loads(
    xc, r_in, ax_off, ax_contact, ax_rail, inv_count, x, inv_len, bend, track, rest_w,
    rest_th, dc_idx, dc_val, z, static_load, hertz, ax_el, shape, top, flex, rc, wl, fc,
):  # fmt: skip
    """The wheel-rail contact loads of a step, from the rail's state and the vehicle's.

    Parameters
    ----------
    xc : float
        Position of the vehicle centre [m].
    r_in : ndarray, shape (axles,)
        Unloaded profile at rest under each axle [m].
    ax_off, ax_contact, ax_rail : ndarray, shape (axles,)
        Each axle's offset ahead of the centre [m], contact and rail (`axle_table`).
    inv_count : ndarray, shape (contacts,)
        One over the number of axles of each contact [-].
    x : ndarray, shape (nodes,)
        Node positions [m].
    inv_len, bend : ndarray, shape (nodes - 1,)
        Each element's ``1 / L`` [1/m] and ``L³ / (3 EI)`` [m/N].
    track : ndarray, shape (5, 2 nodes)
        The track's state (`advance`) [m, rad].
    rest_w, rest_th : ndarray, shape (2 nodes,)
        Rail deflection [m] and rotation [rad] at rest, interleaved (`interleaved`).
    dc_idx, dc_val : ndarray, shape (contacts, k)
        The rows of ``Dc`` (the contacts' displacements from the vehicle's), sparse [-, m/rad].
    z : ndarray, shape (2 dofs,)
        The vehicle's displacement now and one step before [m, rad].
    static_load, hertz : float
        Static wheel load ``Ps`` [N] and linearised Hertz stiffness ``kH`` [N/m].
    ax_el : ndarray, shape (axles,)
        Each axle's element, a search start: updated [-].

    Returns
    -------
    None
        Fills ``shape`` (axles, 4) with the Hermite shape functions at each axle [-, m];
        ``top``, ``flex`` and ``rc`` (contacts,) with the mean rail top [m], local
        flexibility ``a³ b³ / (3 EI L³)`` [m/N] and unloaded profile [m] under each
        contact's axles; ``wl`` (contacts,) with each wheel's load ``W`` [N] and ``fc`` with
        the contact forces on the vehicle, ``W - Ps`` per axle [N].
    """
    nc = dc_idx.shape[0]
    nodes = x.shape[0]
    for c in range(nc):
        top[c] = 0.0
        flex[c] = 0.0
        rc[c] = 0.0
    for a in range(ax_off.shape[0]):
        c = ax_contact[a]
        r = ax_rail[a]
        xa = xc + ax_off[a]
        e = ax_el[a]
        while e + 2 < nodes and x[e + 1] <= xa:
            e += 1
        ax_el[a] = e
        L = x[e + 1] - x[e]
        t = (xa - x[e]) * inv_len[e]
        t2 = t * t
        t3 = t2 * t
        shape[a, 0] = 1.0 - 3.0 * t2 + 2.0 * t3
        shape[a, 1] = L * (t - 2.0 * t2 + t3)
        shape[a, 2] = 3.0 * t2 - 2.0 * t3
        shape[a, 3] = L * (t3 - t2)
        j = 2 * e + r  # node e of rail r
        u = (shape[a, 0] * (track[0, j] - rest_w[j])
             + shape[a, 1] * (track[1, j] - rest_th[j])
             + shape[a, 2] * (track[0, j + 2] - rest_w[j + 2])
             + shape[a, 3] * (track[1, j + 2] - rest_th[j + 2]))  # fmt: skip
        tb = t * (1.0 - t)
        flex[c] += tb * tb * tb * bend[e] * inv_count[c]
        top[c] += (r_in[a] + u) * inv_count[c]
        rc[c] += r_in[a] * inv_count[c]
    for c in range(nc):
        dq = 0.0
        for j in range(dc_idx.shape[1]):
            dq += dc_val[c, j] * z[dc_idx[c, j]]
        delta = dq - top[c] + static_load / hertz
        wl[c] = delta / (1.0 / hertz + flex[c]) if delta > 0.0 else 0.0
        fc[c] = (wl[c] - static_load) / inv_count[c]


@njit(**TRACK_JIT)
def rail_forces(track, ea, eb, i0, ax_contact, ax_rail, ax_el, wl, shape, shear, fw, fm):
    """The forces on the rail's nodes of the window: its beam elements' and the wheels'.

    Parameters
    ----------
    track : ndarray, shape (5, 2 nodes)
        The track's state (`advance`) [m, rad].
    ea, eb : ndarray, shape (2 (nodes - 1),)
        Each element's stiffness terms ``12 EI/L³`` [N/m] and ``6 EI/L²`` [N], for each rail
        (`interleaved`).
    i0 : int
        First node of the window [-].
    ax_contact, ax_rail, ax_el : ndarray, shape (axles,)
        Each axle's contact, rail and element [-].
    wl : ndarray, shape (contacts,)
        Each contact's wheel load [N].
    shape : ndarray, shape (axles, 4)
        The Hermite shape functions at each axle (`wheel_loads`) [-, m].

    Returns
    -------
    None
        Fills ``shear`` (2 (window + 1),) with the shear force [N] of the window's
        elements and of the two that join it to the rest of the rail (``shear[2 k + r]``
        pushes node ``i0 + k`` of rail ``r`` down and node ``i0 + k - 1`` up; 0 beyond the
        rail's end), ``fw`` and ``fm`` (2 window,) with the wheels' force [N] and moment
        [N m] on each node of the window (the element's consistent nodal loads).
    """
    width = fw.shape[0] // 2
    first = max(i0 - 1, 0)
    a, b = ea[2 * first : 2 * (i0 + width)], eb[2 * first : 2 * (i0 + width)]
    w = track[0, 2 * first : 2 * (i0 + width + 1)]
    th = track[1, 2 * first : 2 * (i0 + width + 1)]
    sh = shear[2 * (first - i0 + 1) :]
    shear[0] = shear[1] = 0.0
    for j in range(a.shape[0]):
        sh[j] = a[j] * (w[j] - w[j + 2]) + b[j] * (th[j] + th[j + 2])
    fw[:] = 0.0
    fm[:] = 0.0
    for a in range(ax_rail.shape[0]):
        k = ax_el[a] - i0
        j = 2 * k + ax_rail[a]
        W = wl[ax_contact[a]]
        if 0 <= k and k + 1 < width:
            fw[j] += W * shape[a, 0]
            fm[j] += W * shape[a, 1]
            fw[j + 2] += W * shape[a, 2]
            fm[j + 2] += W * shape[a, 3]


@njit(**TRACK_JIT)
def step_nodes(
    track, fw, shear, i0, step_w, step_s, kp, cp_dt, kb, cb_dt, sgap, fall, ballast,
):  # fmt: skip
    """Advance the window's rail deflections and sleepers one step (central differences).

    A loop without branches over the window of both rails side by side (`interleaved`), its
    arrays as 1D views, which LLVM vectorises (indexed in 3D they were not, and the loop
    took twice as long; a loop per rail, with the rest of the step in the same layout, made
    the compiled loop 12 % slower).

    Parameters
    ----------
    track : ndarray, shape (5, 2 nodes)
        The track's state (`advance`) [m, rad]: the window's deflections and sleeper
        displacements are advanced in place.
    fw, shear : ndarray
        The wheels' forces on the window's nodes and the shear forces of its elements
        (`rail_forces`) [N].
    i0 : int
        First node of the window [-].
    step_w : ndarray, shape (2 nodes,)
        ``Δt² / m`` of each rail node [s²/kg], for each rail.
    step_s : float
        ``Δt² / Ms`` of a sleeper (per rail seat) [s²/kg].
    kp, cp_dt : float
        Pad stiffness [N/m] and damping over the time step ``cp / Δt`` [N/m].
    kb : ndarray, shape (2 nodes,)
        Ballast stiffness under each sleeper [N/m].
    cb_dt : float
        Ballast damping over the time step ``cb / Δt`` [N/m].
    sgap : ndarray, shape (2 nodes,)
        Seating gap under each sleeper [m].
    fall : float
        Fall under gravity in a step ``g Δt²`` [m].
    ballast : ndarray, shape (2 nodes,)
        Largest sleeper-ballast force [N] of each sleeper since it was last handed over
        (`follow_axles`): updated.
    """
    lo, hi = 2 * i0, 2 * i0 + fw.shape[0]
    m, k_b, gap, most = step_w[lo:hi], kb[lo:hi], sgap[lo:hi], ballast[lo:hi]
    w, zs, w_prev, zs_prev = track[0, lo:hi], track[2, lo:hi], track[3, lo:hi], track[4, lo:hi]
    for k in range(hi - lo):
        w0 = w[k]
        zs0 = zs[k]
        dw = w0 - w_prev[k]
        dz = zs0 - zs_prev[k]
        pad = kp * (w0 - zs0) + cp_dt * (dw - dz)
        pen = zs0 - gap[k]
        bk = k_b[k] * pen + cb_dt * dz
        bk = bk if pen > 0.0 and bk > 0.0 else 0.0
        most[k] = max(most[k], bk)
        w_prev[k] = w0
        zs_prev[k] = zs0
        w[k] = w0 + dw + (fw[k] + shear[k] - shear[k + 2] - pad) * m[k] + fall
        zs[k] = zs0 + dz + (pad - bk) * step_s + fall


@njit(**TRACK_JIT)
def hand_over(r, i, rail_axles, bound, ballast, peak):
    """Add a sleeper's largest ballast force since its last hand-over to its nearest axle's.

    Parameters
    ----------
    r, i : int
        Rail and node [-].
    rail_axles : ndarray, shape (2, k)
        Each rail's axles from the rear, -1 padded [-].
    bound : ndarray, shape (2, k - 1)
        Each rail's first node nearer its axle ``j + 1`` than its axle ``j`` [-].
    ballast : ndarray, shape (2 nodes,)
        Largest sleeper-ballast force since the last hand-over [N]: cleared.
    peak : ndarray, shape (axles + 1, nodes)
        Largest sleeper-ballast force [N] of each sleeper while each axle is the nearest on
        its rail, its last row that of a rail without axles (-1): updated.
    """
    j = 0
    while j + 1 < rail_axles.shape[1] and rail_axles[r, j + 1] >= 0 and bound[r, j] <= i:
        j += 1
    a = rail_axles[r, j]
    peak[a, i] = max(peak[a, i], ballast[2 * i + r])
    ballast[2 * i + r] = 0.0


@njit(**TRACK_JIT)
def follow_axles(x, xc, ax_off, rail_axles, bound, ballast, peak):
    """Move each rail's boundaries between neighbouring axles with the vehicle.

    A sleeper nearer the axle behind than before (the boundary has passed it) hands its
    largest ballast force since its last hand-over to the axle ahead (`hand_over`).

    Parameters
    ----------
    x : ndarray, shape (nodes,)
        Node positions [m].
    xc : float
        Position of the vehicle centre [m].
    ax_off : ndarray, shape (axles,)
        Each axle's offset ahead of the centre [m].
    rail_axles, bound, ballast, peak : ndarray
        As `hand_over`; ``bound`` is moved on (a start at or behind it).
    """
    nodes = x.shape[0]
    for r in range(2):
        for j in range(bound.shape[1]):
            ahead = rail_axles[r, j + 1]
            if ahead < 0:
                break
            mid = ax_off[rail_axles[r, j]] + ax_off[ahead]
            b = bound[r, j]
            while b < nodes and not 2.0 * (x[b] - xc) > mid:
                peak[ahead, b] = max(peak[ahead, b], ballast[2 * b + r])
                ballast[2 * b + r] = 0.0
                b += 1
            bound[r, j] = b


@njit(**TRACK_JIT)
def factor_rotations(ec4, ec2, i0, low, high, inv_piv, back):
    """Factor the window's rotation stiffness (tridiagonal, ``K_θθ``) from both ends.

    A twisted factorisation: Gaussian elimination down from the first node and up from the
    last meets at the middle one, so that a solve (`solve_rotations`) runs two chains of
    half the window's length side by side (it took 220 ns a step from one end).

    Parameters
    ----------
    ec4, ec2 : ndarray, shape (nodes - 1,)
        Each element's ``4 EI/L`` and ``2 EI/L`` [N m].
    i0 : int
        First node of the window [-].

    Returns
    -------
    None
        Fills, per node of the window (``p`` the middle one), ``low`` with the multiplier of
        the row above (nodes 1 to ``p``) [-], ``high`` of the row below (nodes ``p`` to the
        last but one) [-], ``inv_piv`` with one over the pivots [1/(N m)] and ``back`` with
        the coupling to the node towards ``p`` over the pivot [-] (0 at ``p``).
    """
    width = low.shape[0]
    p = width // 2
    nodes = ec4.shape[0] + 1
    low[:] = 0.0
    high[:] = 0.0
    for k in range(width):
        i = i0 + k
        inv_piv[k] = (ec4[i - 1] if i > 0 else 0.0) + (ec4[i] if i + 1 < nodes else 0.0)
    for k in range(p):  # down to the middle
        if k > 0:
            low[k] = ec2[i0 + k - 1] * inv_piv[k - 1]
            inv_piv[k] -= low[k] * ec2[i0 + k - 1]
        inv_piv[k] = 1.0 / inv_piv[k]
        back[k] = ec2[i0 + k] * inv_piv[k]
    for k in range(width - 1, p, -1):  # up to the middle
        if k < width - 1:
            high[k] = ec2[i0 + k] * inv_piv[k + 1]
            inv_piv[k] -= high[k] * ec2[i0 + k]
        inv_piv[k] = 1.0 / inv_piv[k]
        back[k] = ec2[i0 + k - 1] * inv_piv[k]
    low[p] = ec2[i0 + p - 1] * inv_piv[p - 1]
    high[p] = ec2[i0 + p] * inv_piv[p + 1]
    inv_piv[p] = 1.0 / (inv_piv[p] - low[p] * ec2[i0 + p - 1] - high[p] * ec2[i0 + p])
    back[p] = 0.0


@njit(**TRACK_JIT)
def fold_factors(low, high, inv_piv, back, fold, up):
    """The factors of `factor_rotations` in four lanes a row, as `solve_rotations` takes them.

    Row ``k`` of a lane holds the elimination's ``k``-th step: lanes 0 and 1 (the two rails)
    down from the first node, node ``k``; lanes 2 and 3 up from the last, node ``up[k]``.
    With a window of an even number of nodes the upward chain is one node shorter: its
    first row is a dummy on the last node (multiplier and pivot 0, coupling -1), which
    leaves the chain at 0 and gives the last node's rotation back unchanged.

    Parameters
    ----------
    low, high, inv_piv, back : ndarray, shape (window,)
        The factors (`factor_rotations`).

    Returns
    -------
    None
        Fills ``fold`` (3, middle node, 4 lanes) with the multiplier [-], one over the pivot
        [1/(N m)] and the coupling over the pivot [-] of each row and lane, ``up``
        (middle node,) with the upward lanes' node of each row [-].
    """
    width = low.shape[0]
    p = width // 2
    shift = 2 * p + 1 - width  # 1: a dummy first row
    for k in range(p):
        q = width - 1 - k + shift
        dummy = q == width
        up[k] = width - 1 if dummy else q
        for lane in range(2):
            fold[0, k, lane] = low[k]
            fold[1, k, lane] = inv_piv[k]
            fold[2, k, lane] = back[k]
            fold[0, k, 2 + lane] = 0.0 if dummy else high[q]
            fold[1, k, 2 + lane] = 0.0 if dummy else inv_piv[q]
            fold[2, k, 2 + lane] = -1.0 if dummy else back[q]


@njit(**TRACK_JIT)
def solve_rotations(track, eb, ec2, i0, fm, low, high, inv_piv, fold, up, moment, lanes):
    """The window's rail rotations from its deflections and the wheels' moments.

    The rotations carry no inertia (Euler-Bernoulli): at each node the moments of its two
    elements balance the wheels', ``K_θθ θ = M - K_θw w`` (the rotations outside the window
    held), solved with the factors of `factor_rotations`: both rails and both ends at once,
    four chains side by side in the lanes of `fold_factors` (both rails' factors read in one
    row: 12 % faster than the two chains of each rail indexed apart).

    Parameters
    ----------
    track : ndarray, shape (5, 2 nodes)
        The track's state (`advance`) [m, rad]: the window's rotations are set in place.
    eb, ec2 : ndarray, shape (2 (nodes - 1),) and (nodes - 1,)
        Each element's ``6 EI/L²`` [N] for each rail and ``2 EI/L`` [N m].
    i0 : int
        First node of the window [-].
    fm : ndarray, shape (2 window,)
        The wheels' moments on the window's nodes (`rail_forces`) [N m].
    low, high, inv_piv : ndarray, shape (window,)
        The factors (`factor_rotations`; their middle node's used here).
    fold, up : ndarray
        The factors in lanes (`fold_factors`).
    moment : ndarray, shape (2 (window + 1),)
        Work space: each element's moment from the deflections (and the held rotations
        for the two at the window's ends) [N m], then the right-hand side [N m].
    lanes : ndarray, shape (middle node, 4)
        Work space: the eliminated right-hand side over the pivots, per lane [rad].
    """
    width = fm.shape[0] // 2
    p = width // 2
    first = max(i0 - 1, 0)
    b = eb[2 * first : 2 * (i0 + width)]
    w, mo = track[0, 2 * first : 2 * (i0 + width + 1)], moment[2 * (first - i0 + 1) :]
    moment[0] = moment[1] = 0.0
    for j in range(b.shape[0]):
        mo[j] = b[j] * (w[j] - w[j + 2])
    for r in range(2):
        if i0 > 0:
            moment[r] += ec2[i0 - 1] * track[1, 2 * (i0 - 1) + r]
        moment[2 * width + r] += ec2[i0 + width - 1] * track[1, 2 * (i0 + width) + r]
    for k in range(2 * width):  # the right-hand side, M - K_θw w
        moment[k] = fm[k] - moment[k] - moment[k + 2]
    c, ip, bk = fold[0], fold[1], fold[2]
    d0 = d1 = d2 = d3 = 0.0  # eliminated down (rails 0, 1) and up, over the pivots
    for k in range(p):  # both ends towards the middle
        q = up[k]
        d0 = moment[2 * k] - c[k, 0] * d0
        d1 = moment[2 * k + 1] - c[k, 1] * d1
        d2 = moment[2 * q] - c[k, 2] * d2
        d3 = moment[2 * q + 1] - c[k, 3] * d3
        lanes[k, 0] = d0 * ip[k, 0]
        lanes[k, 1] = d1 * ip[k, 1]
        lanes[k, 2] = d2 * ip[k, 2]
        lanes[k, 3] = d3 * ip[k, 3]
    t0 = t2 = (moment[2 * p] - low[p] * d0 - high[p] * d2) * inv_piv[p]
    t1 = t3 = (moment[2 * p + 1] - low[p] * d1 - high[p] * d3) * inv_piv[p]
    th = track[1, 2 * i0 : 2 * (i0 + width)]
    th[2 * p] = t0
    th[2 * p + 1] = t1
    for k in range(p - 1, -1, -1):  # out from the middle
        t0 = lanes[k, 0] - bk[k, 0] * t0
        t1 = lanes[k, 1] - bk[k, 1] * t1
        t2 = lanes[k, 2] - bk[k, 2] * t2
        t3 = lanes[k, 3] - bk[k, 3] * t3
        th[2 * k] = t0
        th[2 * k + 1] = t1
        q = 2 * up[k]
        th[q] = t2
        th[q + 1] = t3


@njit(cache=True, fastmath=True, error_model="numpy", nogil=True)
def advance(
    p_idx, p_val, gc_idx, gc_val, gw_idx, gw_val, dc_idx, dc_val, dw_idx, dw_val,
    ds_idx, ds_val, H, jinv, wedge, static_load,
    ax_off, ax_contact, ax_rail, inv_count, hertz,
    x, inv_len, bend, ea, eb, ec4, ec2, step_w, step_s, kp, cp_dt, kb, cb_dt, sgap, rest_w,
    rest_th, fall, track, window, margin, ax_el, rail_axles, z, centre, r_in, k_in, dt, step0,
    store_every, max_iter,
    out_q, out_v, out_a, out_wl, out_secondary, out_fw, out_vw, out_k, out_r, peak,
):  # fmt: skip
    """Advance the vehicle and the track ``centre.size`` steps, updating state in place.

    ``track`` (5, 2 nodes) holds rail deflection, rail rotation and sleeper displacement
    now, and rail deflection and sleeper displacement one step before, node ``i`` of rail
    ``r`` at ``2 i + r`` (`interleaved`, as the other arrays per rail and node or element);
    ``window[0]`` is the first node of the window, ``window[1]`` its number of nodes, kept
    ``margin`` [m] behind
    the rearmost axle; ``ax_el`` each axle's element (a search start). ``peak``
    (axles + 1, nodes) collects the largest sleeper-ballast force [N] of each sleeper while
    each axle is the nearest on its rail (``rail_axles`` (2, k): each rail's axles from the
    rear, -1 padded, which picks the last row): each sleeper keeps its largest since it last
    changed nearest axle, handed over when it changes again, leaves the window or the call
    ends (`hand_over`, `follow_axles`). ``k_in`` holds the point stiffness under each
    contact of the stored steps only. The element and node arrays are those of
    `wheel_loads`, `rail_forces`, `step_nodes` and `factor_rotations`. A step: the wheel
    loads, the vehicle (`trackdyn.solver.kernel.vehicle_step`), the forces on the rail,
    the window's deflections and sleepers, its rotations (`solve_rotations`), the outputs.
    """
    n = p_idx.shape[0]
    nc = dc_idx.shape[0]
    nw = dw_idx.shape[0]
    na = ax_off.shape[0]
    nodes = x.shape[0]
    width = window[1]
    inv2dt = 0.5 / dt
    invdt2 = 1.0 / (dt * dt)
    # the vehicle's arrays flat, as its step takes them (`trackdyn.solver.step`)
    pv, gcv, gwv = p_val.reshape(-1), gc_val.reshape(-1), gw_val.reshape(-1)
    dwv, hv, jv, wv = dw_val.reshape(-1), H.reshape(-1), jinv.reshape(-1), wedge.reshape(-1)
    dsv = ds_val.reshape(-1)
    oq, ov, oa = out_q.reshape(-1), out_v.reshape(-1), out_a.reshape(-1)
    osec, ofw, ovw = out_secondary.reshape(-1), out_fw.reshape(-1), out_vw.reshape(-1)
    q1 = np.empty(n)
    fc = np.empty(nc)
    wl = np.empty(nc)
    rc = np.empty(nc)
    top = np.empty(nc)  # mean rail top under the contact's axles
    flex = np.empty(nc)  # mean local flexibility
    wedges = _wedge_arrays(nw, (0.0,))
    shape = np.empty((na, 4))
    fw = np.empty(2 * width)
    fm = np.empty(2 * width)
    shear = np.empty(2 * (width + 1))
    moment = np.empty(2 * (width + 1))
    ballast = np.zeros(2 * nodes)  # largest since the last hand-over
    bound = np.full((2, rail_axles.shape[1] - 1), window[0])
    low = np.empty(width)
    high = np.empty(width)
    inv_piv = np.empty(width)
    back = np.empty(width)
    fold = np.empty((3, width // 2, 4))
    up = np.empty(width // 2, np.int64)
    lanes = np.empty((width // 2, 4))
    stored = 0
    to_store = -step0 % store_every
    rear = ax_off.min()
    factor_rotations(ec4, ec2, window[0], low, high, inv_piv, back)
    fold_factors(low, high, inv_piv, back, fold, up)
    for s in range(centre.shape[0]):
        # the window follows the rearmost axle
        i0 = window[0]
        while i0 + width + 1 < nodes and x[i0 + 1] <= centre[s] + rear - margin:
            for r in range(2):
                hand_over(r, i0, rail_axles, bound, ballast, peak)  # it leaves the window
            i0 += 1
        if i0 != window[0]:
            window[0] = i0
            factor_rotations(ec4, ec2, i0, low, high, inv_piv, back)
            fold_factors(low, high, inv_piv, back, fold, up)
        wheel_loads(
            centre[s], r_in[s], ax_off, ax_contact, ax_rail, inv_count, x, inv_len, bend,
            track, rest_w, rest_th, dc_idx, dc_val, z, static_load, hertz, ax_el, shape, top,
            flex, rc, wl, fc,
        )  # fmt: skip
        if not vehicle_step(
            p_idx, pv, gc_idx, gcv, gw_idx, gwv, dw_idx, dwv, hv, jv, wv, z, fc, inv2dt, max_iter,
            q1, wedges,
        ):  # fmt: skip
            return NEWTON_FAILED, s
        rail_forces(track, ea, eb, i0, ax_contact, ax_rail, ax_el, wl, shape, shear, fw, fm)
        follow_axles(x, centre[s], ax_off, rail_axles, bound, ballast, peak)
        step_nodes(
            track, fw, shear, i0, step_w, step_s, kp, cp_dt, kb, cb_dt, sgap, fall, ballast
        )  # fmt: skip
        solve_rotations(track, eb, ec2, i0, fm, low, high, inv_piv, fold, up, moment, lanes)
        if to_store == 0:
            to_store = store_every
            if not store_vehicle(
                z, q1, wedges, ds_idx, dsv, inv2dt, invdt2, stored, oq, ov, oa, osec, ofw, ovw,
            ):  # fmt: skip
                return NOT_FINITE, s
            for c in range(nc):
                out_wl[stored, c] = wl[c]
                out_k[stored, c] = k_in[stored, c]
                out_r[stored, c] = rc[c]
            stored += 1
        to_store -= 1
        for i in range(n):
            z[n + i] = z[i]
            z[i] = q1[i]
    for r in range(2):
        for i in range(window[0], window[0] + width):
            hand_over(r, i, rail_axles, bound, ballast, peak)
    return DONE, -1


@njit(cache=True, error_model="numpy", nogil=True)
def sample_profile(knots, coeffs, centre, off, out):
    """A rail's cubic spline at ``centre + off`` for one axle (`Geometry.at`, compiled).

    The positions rise, so each interval is found from the one before; the polynomial is
    summed in scipy's order (`scipy.interpolate.PPoly`, without fast maths), which gives
    `Geometry.at` bit for bit, in a fifth of its time.

    Parameters
    ----------
    knots : ndarray, shape (n,)
        The spline's knots [m].
    coeffs : ndarray, shape (4, n - 1)
        Its coefficients, highest power first (``CubicSpline.c``) [m^(1-k)].
    centre : ndarray, shape (steps,)
        Position of the vehicle centre at each step, rising [m].
    off : float
        The axle's offset ahead of the centre [m].

    Returns
    -------
    None
        Fills ``out`` (steps,) with the profile under the axle [m] (the end intervals'
        polynomials beyond the knots, as the spline extrapolates).
    """
    last = knots.shape[0] - 2
    i = min(max(np.searchsorted(knots, centre[0] + off, "right") - 1, 0), last)
    for s in range(centre.shape[0]):
        xa = centre[s] + off
        while i < last and knots[i + 1] <= xa:
            i += 1
        d = xa - knots[i]
        res = 0.0
        z = 1.0
        for k in range(3, -1, -1):
            res = res + coeffs[k, i] * z
            z = z * d
        out[s] = res


def interleaved(a):
    """An array as `advance` takes it: both rails side by side, node ``i`` of rail ``r`` at
    ``2 i + r`` of the last axis, so that one loop over the window takes both rails.

    Parameters
    ----------
    a : array_like, shape (..., 2 rails, n) or (n,)
        Values per rail and node or element (the last two axes), or per node or element
        alone, the same for both rails [any unit].

    Returns
    -------
    ndarray, shape (..., 2 n)
        The values interleaved (a C-contiguous copy), those without rails repeated [as ``a``].
    """
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        return np.repeat(a, 2)
    return np.ascontiguousarray(np.swapaxes(a, -1, -2)).reshape(*a.shape[:-2], -1)


def vehicle_model(model):
    """The vehicle of a model without the track damping of its contacts (the discrete
    track has its own)."""
    Dc, c = model.Dc, model.contact_damping
    return replace(model, C=model.C - Dc.T @ (c[:, None] * Dc), contact_damping=0.0 * c)


def axle_table(model):
    """Per axle its offset ahead of the vehicle centre [m], contact and rail index."""
    rows = [(x, c, RAILS.index(rail))
            for c, (axles, rail) in enumerate(zip(model.contact_axles, model.contact_rails,
                                                  strict=True))
            for x in axles]  # fmt: skip
    off, contact, rail = (np.array(v) for v in zip(*rows, strict=True))
    return off.astype(float), contact.astype(np.int64), rail.astype(np.int64)


def highest_frequency(track, hertz: float) -> float:
    """Highest natural angular frequency of the track's elements [rad/s].

    From a stretch of eleven of the shortest bays on the stiffest ballast, a wheel's Hertz
    spring on its middle node, the rotations condensed out (they carry no inertia,
    `solve_rotations`): an upper estimate for every window.
    """
    L = float(np.min(np.diff(track.position)))
    p, nodes = track.params, 11
    nd = 3 * nodes  # w, θ, zs per node
    K = np.zeros((nd, nd))
    ke = element_stiffness(L, track.EI)
    for e in range(nodes - 1):
        dofs = [3 * e, 3 * e + 1, 3 * e + 3, 3 * e + 4]
        K[np.ix_(dofs, dofs)] += ke
    for i in range(nodes):
        w, zs = 3 * i, 3 * i + 2
        K[np.ix_([w, zs], [w, zs])] += p.pad_stiffness * np.array([[1, -1], [-1, 1]])
        K[zs, zs] += float(track.kb.max())
    K[3 * (nodes // 2), 3 * (nodes // 2)] += hertz
    th = np.arange(1, nd, 3)
    keep = np.setdiff1d(np.arange(nd), th)
    K_tw = K[np.ix_(th, keep)]
    condensed = K[np.ix_(keep, keep)] - K_tw.T @ np.linalg.solve(K[np.ix_(th, th)], K_tw)
    m = np.tile([track.rail_mass * L, p.sleeper_mass], nodes)
    scaled = condensed / np.sqrt(np.outer(m, m))
    return float(np.sqrt(np.linalg.eigvalsh(scaled).max()))


def stable_step(track, static_load: float) -> float:
    """Largest time step of the track that the defaults allow [s]:
    `STABILITY_FRACTION` of ``2 / ω_max``."""
    hertz = hertz_stiffness(static_load, track.params.wheel_radius)
    return STABILITY_FRACTION * 2.0 / highest_frequency(track, hertz)


def stability_limit(track, static_load: float) -> tuple[float, float]:
    """The explicit scheme's limit on the time step of the track [s] and ``ω_max`` [rad/s].

    The damping forces are explicit (a backward difference), so a mode of frequency ``ω``
    whose node has damping ``c`` and mass ``m`` is stable while ``ω² Δt² + 2 c Δt / m < 4``
    (the roots of ``λ² + (a + b - 2) λ + 1 - a`` within the unit circle, ``a = c Δt / m``,
    ``b = ω² Δt²``): ``Δt < (√(ζ² + 4ω²) - ζ) / ω²`` with ``ζ = c / m``, below ``2 / ω``.
    ``ζ`` is the larger of a rail node's (the pad's damping on the rail's mass over the
    shortest bay) and a sleeper's (pad and stiffest ballast damping on its mass), so the
    limit holds for every window.
    """
    p = track.params
    omega = highest_frequency(track, hertz_stiffness(static_load, p.wheel_radius))
    bay = float(np.min(np.diff(track.position)))
    zeta = max(p.pad_damping / (track.rail_mass * bay),
               (p.pad_damping + p.ballast_damping) / p.sleeper_mass)  # fmt: skip
    return (np.sqrt(zeta**2 + 4.0 * omega**2) - zeta) / omega**2, omega


def _rest_under(track, r, x):
    """Rail deflection of rail ``r`` at rest at positions ``x`` (Hermite interpolation) [m]."""
    nodes = track.position
    e = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    L = nodes[e + 1] - nodes[e]
    w, th = track.rest[0, r], track.rest[1, r]
    N = hermite((x - nodes[e]) / L, L)
    return N[0] * w[e] + N[1] * th[e] + N[2] * w[e + 1] + N[3] * th[e + 1]


def start(p, track, model, axles, window):
    """Static start: the vehicle on the track under its wheel loads (fixed point).

    Each iteration solves the track under the wheel loads ``W``, then the vehicle on springs
    ``(1/kH + 1/k)^-1`` per axle (``k`` the track's point stiffness; a contact's axles share
    its load, their means taken) to the rail tops less ``(W - Ps) / k``, which gives the
    next ``W``. A contact that would pull (a light vehicle on twisted track) carries no load
    on the track, but the vehicle stands as if it pulled: it settles onto the wheels that
    bear in the first moments of the run. Returns the vehicle's ``z = [q0, q0]`` and the track state
    (6, 2, nodes), at rest outside the window and moving with nothing.
    """
    off, contact, rail = axles
    ps = model.static_wheel_load
    hertz = hertz_stiffness(ps, track.params.wheel_radius)
    xa = p.centre0 + off
    profile = np.array([track.geometry.at(RAILS[r], x) for r, x in zip(rail, xa, strict=True)])
    rest = np.array([_rest_under(track, r, x) for r, x in zip(rail, xa, strict=True)])
    point = track.point_stiffness()
    k2 = np.array([np.interp(x, track.position, point[r]) for r, x in zip(rail, xa, strict=True)])
    nc = len(model.contact_names)
    count = np.bincount(contact, minlength=nc).astype(float)
    mean = np.zeros((nc, off.size))  # a contact's mean over its axles
    mean[contact, np.arange(off.size)] = 1.0 / count[contact]
    kc = count / (1.0 / hertz + mean @ (1.0 / k2))  # tangent stiffness of each contact
    W = np.full(off.size, ps)
    lo, width = window
    part = slice(max(lo - 10, 0), min(lo + width + 10, track.position.size))
    for _ in range(START_ITERATIONS):
        state, under = track.static(xa, rail, W, part)
        ref = mean @ (profile + under - rest - (W - ps) / k2)
        q = np.linalg.solve(model.K + model.Dc.T @ (kc[:, None] * model.Dc),
                            model.Dc.T @ (kc * ref))  # fmt: skip
        W = np.maximum(ps + kc * (model.Dc @ q - ref) / count, 0.0)[contact]
    state, _ = track.static(xa, rail, W, part)
    full = track.rest.copy()
    full[:, :, lo : lo + width] = state[:, :, lo : lo + width]
    return np.r_[q, q], np.concatenate([full, full[[0, 2]]])


def first_window(p, track, off) -> tuple[int, int]:
    """First node and number of nodes of the window at the start: the axles' span and the
    margin each side, on the shortest bays."""
    x = track.position
    span = off.max() - off.min() + 2 * track.params.margin
    width = min(int(np.ceil(span / np.diff(x).min())) + 4, x.size - 1)
    lo = np.searchsorted(x, p.centre0 + off.min() - track.params.margin) - 1
    return int(np.clip(lo, 0, x.size - width - 1)), width


def solve(
    p, newton_max_iter: int = 50, advanced=None
) -> dict[str, np.ndarray] | TrackdynInputError:
    """Integrate one run on the discrete track (``p.inputs`` a `DiscreteTrack`).

    Returns
    -------
    dict
        The `OUTPUTS` arrays of `trackdyn.solver.statics` (``wl`` the load of each of the
        contact's wheels, ``k`` the track's point stiffness under its axles, summed (eq 5.8
        from the rail-seat stiffness, `DiscreteTrack.point_stiffness`), ``r`` the mean
        unloaded profile at rest under its axles); ``ballast_peak`` (2 rails, sleepers)
        [N], the largest sleeper-ballast contact force of each sleeper of the section over
        the run, and
        ``ballast_wheel_peak`` (axles in the order of `axle_table`, sleepers) [N], that
        force while each axle was the nearest on its rail (self-weight included; 0 on a rail
        without wheels; a sleeper
        that axle never came near keeps 0); or the `TrackdynInputError` that stopped it.
    """
    track, model = p.inputs, vehicle_model(p.model)
    prm = track.params
    axles = axle_table(model)
    off, contact, rail = axles
    x = track.position
    L = np.diff(x)
    EI = track.EI
    ea, eb = interleaved(12 * EI / L**3), interleaved(6 * EI / L**2)  # per element and rail
    coeff = (1 / L, L**3 / (3 * EI), ea, eb, 4 * EI / L, 2 * EI / L)
    inv_count = np.array([1.0 / len(a) for a in model.contact_axles])
    hertz = hertz_stiffness(model.static_wheel_load, prm.wheel_radius)
    lo, width = first_window(p, track, off)
    try:
        z, state = start(p, track, model, axles, (lo, width))
    except TrackdynInputError as exc:
        return exc
    window = np.array([lo, width], np.int64)
    ax_el = np.searchsorted(x, p.centre0 + off).astype(np.int64) - 1
    mats = step_matrices(model, p.dt)
    out = {name: np.empty((p.n_store, w)) for name, w in widths(model).items()}
    peak = np.zeros((off.size + 1, x.size))  # the last row for a rail without axles
    rail_axles = np.full((len(RAILS), off.size), -1, np.int64)
    for r in range(len(RAILS)):
        mine = np.flatnonzero(rail == r)
        rail_axles[r, : mine.size] = mine[np.argsort(off[mine])]
    dt2 = p.dt**2
    step_w, kb, gap, rest_w, rest_th = map(
        interleaved,
        (dt2 / (track.rail_mass * track.spacing), track.kb, track.sleeper_gap, *track.rest[:2]),
    )
    nodal = (step_w, dt2 / prm.sleeper_mass, prm.pad_stiffness, prm.pad_damping / p.dt, kb,
             prm.ballast_damping / p.dt, gap, rest_w, rest_th, GRAVITY * dt2)  # fmt: skip
    state = interleaved(state)
    point = track.point_stiffness()
    geometry = track.geometry
    splines = [(s.x, s.c) for s in (CubicSpline(geometry.distance, geometry.profile(r))
                                    for r in RAILS)]  # fmt: skip
    for first in range(0, p.n_steps, CHUNK_STEPS):
        steps = np.arange(first, min(first + CHUNK_STEPS, p.n_steps))
        centre = p.centre0 + p.speed * p.dt * steps
        r_in = np.empty((steps.size, off.size))
        for a, (o, r) in enumerate(zip(off, rail, strict=True)):
            knots, coeffs = splines[r]
            sample_profile(knots, coeffs, centre, o, r_in[:, a])
        kept = centre[-first % p.store_every :: p.store_every]  # the stored steps'
        k_in = np.zeros((kept.size, len(inv_count)))
        for o, c, r in zip(off, contact, rail, strict=True):
            k_in[:, c] += np.interp(kept + o, x, point[r])
        row = (first + p.store_every - 1) // p.store_every
        status, at = advance(
            *mats[:-1], model.static_wheel_load, off, contact, rail, inv_count, hertz,
            x, *coeff, *nodal, state, window, prm.margin, ax_el, rail_axles, z, centre, r_in,
            k_in, p.dt, first, p.store_every, newton_max_iter,
            *[*(a[row:] for a in out.values()), peak],
        )  # fmt: skip
        if status != DONE:
            stop = failure if status == NEWTON_FAILED else non_finite
            return stop(p, first + int(at))
        if advanced is not None:
            advanced(steps.size)
    wheel = peak[:-1, track.first : track.first + track.count]
    out["ballast_wheel_peak"] = wheel
    out["ballast_peak"] = np.array([wheel[rail == r].max(axis=0, initial=0.0)
                                    for r in range(len(RAILS))])  # fmt: skip
    return out
