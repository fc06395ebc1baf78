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
costs the same on any length of track.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.4 (the scheme).

Bathe, K.J. (1996). Finite Element Procedures. Prentice Hall, Englewood Cliffs, §9.2.1
(the central difference method and its stability limit Δt < 2/ω_max).

Timoshenko, S., Young, D.H. (1965). Theory of Structures, 2nd ed. McGraw-Hill (deflection
of a clamped-clamped beam under a point load).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numba import njit

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
(the highest modes are the rail's rotations, far above the frequencies of interest: on the
example at 100 km/h, 0.5 gives wheel loads within 0.08 % of their dynamic part)."""

START_ITERATIONS = 6
"""Fixed-point iterations of the static start (wheel loads against track deflection)."""


TRACK_JIT: dict[str, Any] = dict(
    cache=True, fastmath=True, error_model="numpy", nogil=True, inline="always"
)
"""numba options of the phases of `advance`'s step (`wheel_loads`, `rail_forces`,
`step_nodes`): those of `advance`, and inlined into it by numba, which keeps the loop as fast
as in one function (LLVM vectorises the same loops; as plain calls, each with its arrays'
fields for arguments, the loop took 5 % longer)."""


@njit(**TRACK_JIT)
def wheel_loads(
    xc, r_in, ax_off, ax_contact, ax_rail, per_contact, x, track, rest_w, rest_th, EI,
    dc_idx, dc_val, z, static_load, hertz, ax_el, shape, top, flex, rc, wl, fc,
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
    per_contact : ndarray, shape (contacts,)
        Number of axles of each contact [-].
    x : ndarray, shape (nodes,)
        Node positions [m].
    track : ndarray, shape (6, 2, nodes)
        The track's state (`advance`) [m, rad].
    rest_w, rest_th : ndarray, shape (2, nodes)
        Rail deflection [m] and rotation [rad] at rest.
    EI : float
        Bending stiffness of the rail [N m²].
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
        flexibility [m/N] and unloaded profile [m] under each contact's axles; ``wl``
        (contacts,) with each wheel's load ``W`` [N] and ``fc`` with the contact forces on
        the vehicle, ``W - Ps`` per axle [N].
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
        t = (xa - x[e]) / L
        t2 = t * t
        t3 = t2 * t
        shape[a, 0] = 1.0 - 3.0 * t2 + 2.0 * t3
        shape[a, 1] = L * (t - 2.0 * t2 + t3)
        shape[a, 2] = 3.0 * t2 - 2.0 * t3
        shape[a, 3] = L * (t3 - t2)
        u = (shape[a, 0] * (track[0, r, e] - rest_w[r, e])
             + shape[a, 1] * (track[1, r, e] - rest_th[r, e])
             + shape[a, 2] * (track[0, r, e + 1] - rest_w[r, e + 1])
             + shape[a, 3] * (track[1, r, e + 1] - rest_th[r, e + 1]))  # fmt: skip
        pa = t * L
        pb = L - pa
        flex[c] += pa * pa * pa * pb * pb * pb / (3.0 * EI * L * L * L) / per_contact[c]
        top[c] += (r_in[a] + u) / per_contact[c]
        rc[c] += r_in[a] / per_contact[c]
    for c in range(nc):
        dq = 0.0
        for j in range(dc_idx.shape[1]):
            dq += dc_val[c, j] * z[dc_idx[c, j]]
        delta = dq - top[c] + static_load / hertz
        wl[c] = delta / (1.0 / hertz + flex[c]) if delta > 0.0 else 0.0
        fc[c] = per_contact[c] * (wl[c] - static_load)


@njit(**TRACK_JIT)
def rail_forces(track, ea, eb, ec4, ec2, i0, ax_contact, ax_rail, ax_el, wl, shape, fw, fm):
    """The forces on the rail's nodes of the window: its beam elements' and the wheels'.

    Parameters
    ----------
    track : ndarray, shape (6, 2, nodes)
        The track's state (`advance`) [m, rad].
    ea, eb, ec4, ec2 : ndarray, shape (nodes - 1,)
        Each element's stiffness terms ``12 EI/L³`` [N/m], ``6 EI/L²`` [N], ``4 EI/L`` and
        ``2 EI/L`` [N m].
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
        Fills ``fw`` and ``fm`` (2 rails, window) with the force [N] and moment [N m] on
        each node of the window.
    """
    width = fw.shape[1]
    nodes = track.shape[2]
    for r in range(2):
        for k in range(width):
            fw[r, k] = 0.0
            fm[r, k] = 0.0
        for e in range(i0 - 1, i0 + width):
            if e < 0 or e + 1 >= nodes:
                continue
            dw = track[0, r, e] - track[0, r, e + 1]
            t1 = track[1, r, e]
            t2 = track[1, r, e + 1]
            f1 = ea[e] * dw + eb[e] * (t1 + t2)
            m1 = eb[e] * dw + ec4[e] * t1 + ec2[e] * t2
            m2 = eb[e] * dw + ec2[e] * t1 + ec4[e] * t2
            k = e - i0
            if k >= 0:
                fw[r, k] -= f1
                fm[r, k] -= m1
            if k + 1 < width:
                fw[r, k + 1] += f1
                fm[r, k + 1] -= m2
    for a in range(ax_rail.shape[0]):
        r = ax_rail[a]
        k = ax_el[a] - i0
        W = wl[ax_contact[a]]
        if 0 <= k and k + 1 < width:
            fw[r, k] += W * shape[a, 0]
            fm[r, k] += W * shape[a, 1]
            fw[r, k + 1] += W * shape[a, 2]
            fm[r, k + 1] += W * shape[a, 3]


@njit(**TRACK_JIT)
def step_nodes(
    track, fw, fm, i0, xc, x, ax_off, rail_axles, mw, J, ms, kp, cp, kb, cb, sgap, gravity,
    dt, peak,
):  # fmt: skip
    """Advance the window's nodes one step, with the sleepers' pads and ballast contact.

    Parameters
    ----------
    track : ndarray, shape (6, 2, nodes)
        The track's state (`advance`) [m, rad]: the window's nodes are advanced in place.
    fw, fm : ndarray, shape (2 rails, window)
        Force [N] and moment [N m] on the rail's nodes of the window (`rail_forces`).
    i0 : int
        First node of the window [-].
    xc : float
        Position of the vehicle centre [m].
    x : ndarray, shape (nodes,)
        Node positions [m].
    ax_off : ndarray, shape (axles,)
        Each axle's offset ahead of the centre [m].
    rail_axles : ndarray, shape (2, k)
        Each rail's axles from the rear, -1 padded [-].
    mw, J : ndarray, shape (nodes,)
        Rail mass [kg] and rotary inertia [kg m] of each node.
    ms : float
        Sleeper mass (per rail seat) [kg].
    kp, cp : float
        Pad stiffness [N/m] and damping [N s/m].
    kb : ndarray, shape (2, nodes)
        Ballast stiffness under each sleeper [N/m].
    cb : float
        Ballast damping [N s/m].
    sgap : ndarray, shape (2, nodes)
        Seating gap under each sleeper [m].
    gravity : float
        Acceleration of gravity [m/s²].
    dt : float
        Time step [s].
    peak : ndarray, shape (axles, nodes)
        Largest sleeper-ballast force [N] of each sleeper while each axle is the nearest on
        its rail: updated.
    """
    width = fw.shape[1]
    invdt = 1.0 / dt
    dt2 = dt * dt
    for r in range(2):
        j = 0  # the nearest axle on this rail, from the rear
        last = 0
        while last + 1 < rail_axles.shape[1] and rail_axles[r, last + 1] >= 0:
            last += 1
        for k in range(width):
            i = i0 + k
            while j < last and 2.0 * (x[i] - xc) > (
                ax_off[rail_axles[r, j]] + ax_off[rail_axles[r, j + 1]]
            ):
                j += 1
            w0 = track[0, r, i]
            zs0 = track[2, r, i]
            vw = (w0 - track[3, r, i]) * invdt
            vz = (zs0 - track[5, r, i]) * invdt
            pad = kp * (w0 - zs0) + cp * (vw - vz)
            ballast = 0.0
            pen = zs0 - sgap[r, i]
            if pen > 0.0:
                ballast = kb[r, i] * pen + cb * vz
                if ballast < 0.0:
                    ballast = 0.0
            a = rail_axles[r, j]
            if a >= 0 and ballast > peak[a, i]:
                peak[a, i] = ballast
            aw = (fw[r, k] - pad) / mw[i] + gravity
            at = fm[r, k] / J[i]
            az = (pad - ballast) / ms + gravity
            t0 = track[1, r, i]
            t_prev = track[4, r, i]
            track[3, r, i] = w0
            track[4, r, i] = t0
            track[5, r, i] = zs0
            track[0, r, i] = w0 + vw * dt + aw * dt2
            track[1, r, i] = 2.0 * t0 - t_prev + at * dt2
            track[2, r, i] = zs0 + vz * dt + az * dt2


@njit(cache=True, fastmath=True, error_model="numpy", nogil=True)
def advance(
    p_idx, p_val, gc_idx, gc_val, gw_idx, gw_val, dc_idx, dc_val, dw_idx, dw_val,
    ds_idx, ds_val, H, jinv, wedge, static_load,
    ax_off, ax_contact, ax_rail, per_contact, hertz,
    x, ea, eb, ec4, ec2, EI, mw, J, ms, kp, cp, kb, cb, sgap, rest_w, rest_th, gravity,
    track, window, margin, ax_el, rail_axles, z, centre, r_in, k_in, dt, step0, store_every,
    max_iter,
    out_q, out_v, out_a, out_wl, out_secondary, out_fw, out_vw, out_k, out_r, peak,
):  # fmt: skip
    """Advance the vehicle and the track ``centre.size`` steps, updating state in place.

    ``track`` (6, 2, nodes) holds rail deflection, rail rotation and sleeper displacement
    now and one step before; ``window[0]`` is the first node of the window, ``window[1]``
    its number of nodes, kept ``margin`` [m] behind the rearmost axle; ``ax_el`` each
    axle's element (a search start); ``gravity`` [m/s²]. ``peak`` (axles, nodes) collects
    the largest sleeper-ballast force [N] of each sleeper while each axle is the nearest
    on its rail (``rail_axles`` (2, k): each rail's axles from the rear, -1 padded). A step:
    the wheel loads (`wheel_loads`), the vehicle (`trackdyn.solver.kernel.vehicle_step`),
    the forces on the rail (`rail_forces`), the window's nodes (`step_nodes`), the outputs.
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
    outs = (out_q.reshape(-1), out_v.reshape(-1), out_a.reshape(-1),
            out_secondary.reshape(-1), out_fw.reshape(-1), out_vw.reshape(-1))  # fmt: skip
    q1 = np.empty(n)
    fc = np.empty(nc)
    wl = np.empty(nc)
    rc = np.empty(nc)
    top = np.empty(nc)  # mean rail top under the contact's axles
    flex = np.empty(nc)  # mean local flexibility
    wedges = _wedge_arrays(nw, (0.0,))
    shape = np.empty((na, 4))
    fw = np.empty((2, width))
    fm = np.empty((2, width))
    stored = 0
    to_store = -step0 % store_every
    rear = ax_off.min()
    for s in range(centre.shape[0]):
        # the window follows the rearmost axle
        i0 = window[0]
        while i0 + width + 1 < nodes and x[i0 + 1] <= centre[s] + rear - margin:
            i0 += 1
        window[0] = i0
        wheel_loads(
            centre[s], r_in[s], ax_off, ax_contact, ax_rail, per_contact, x, track, rest_w,
            rest_th, EI, dc_idx, dc_val, z, static_load, hertz, ax_el, shape, top, flex, rc,
            wl, fc,
        )  # fmt: skip
        if not vehicle_step(
            p_idx, pv, gc_idx, gcv, gw_idx, gwv, dw_idx, dwv, hv, jv, wv, z, fc, inv2dt, max_iter,
            q1, wedges,
        ):  # fmt: skip
            return NEWTON_FAILED, s
        rail_forces(track, ea, eb, ec4, ec2, i0, ax_contact, ax_rail, ax_el, wl, shape, fw, fm)
        step_nodes(
            track, fw, fm, i0, centre[s], x, ax_off, rail_axles, mw, J, ms, kp, cp, kb, cb,
            sgap, gravity, dt, peak,
        )  # fmt: skip
        if to_store == 0:
            to_store = store_every
            if not store_vehicle(
                z, q1, wedges, ds_idx, dsv, inv2dt, invdt2, stored, *outs,
            ):  # fmt: skip
                return NOT_FINITE, s
            for c in range(nc):
                out_wl[stored, c] = wl[c]
                out_k[stored, c] = k_in[s, c]
                out_r[stored, c] = rc[c]
            stored += 1
        to_store -= 1
        for i in range(n):
            z[n + i] = z[i]
            z[i] = q1[i]
    return DONE, -1


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
    spring on its middle node: an upper estimate for every window.
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
    m = np.tile([track.rail_mass * L, track.rail_rotary * L, p.sleeper_mass], nodes)
    scaled = K / np.sqrt(np.outer(m, m))
    return float(np.sqrt(np.linalg.eigvalsh(scaled).max()))


def stable_step(track, static_load: float) -> float:
    """Largest time step of the track that the defaults allow [s]:
    `STABILITY_FRACTION` of ``2 / ω_max``."""
    hertz = hertz_stiffness(static_load, track.params.wheel_radius)
    return STABILITY_FRACTION * 2.0 / highest_frequency(track, hertz)


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
    return np.r_[q, q], np.concatenate([full, full])


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
    coeff = (12 * EI / L**3, 6 * EI / L**2, 4 * EI / L, 2 * EI / L)
    trib = track.spacing
    per_contact = np.array([float(len(a)) for a in model.contact_axles])
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
    peak = np.zeros((off.size, x.size))
    rail_axles = np.full((len(RAILS), off.size), -1, np.int64)
    for r in range(len(RAILS)):
        mine = np.flatnonzero(rail == r)
        rail_axles[r, : mine.size] = mine[np.argsort(off[mine])]
    sgap = track.sleeper_gap
    point = track.point_stiffness()
    for first in range(0, p.n_steps, CHUNK_STEPS):
        steps = np.arange(first, min(first + CHUNK_STEPS, p.n_steps))
        centre = p.centre0 + p.speed * p.dt * steps
        r_in = np.column_stack(
            [track.geometry.at(RAILS[r], centre + o) for o, r in zip(off, rail, strict=True)]
        )
        k_in = np.zeros((steps.size, len(per_contact)))
        for o, c, r in zip(off, contact, rail, strict=True):
            k_in[:, c] += np.interp(centre + o, x, point[r])
        row = (first + p.store_every - 1) // p.store_every
        status, at = advance(
            *mats[:-1], model.static_wheel_load, off, contact, rail, per_contact, hertz,
            x, *coeff, EI, track.rail_mass * trib, track.rail_rotary * trib, prm.sleeper_mass,
            prm.pad_stiffness, prm.pad_damping, track.kb, prm.ballast_damping, sgap,
            track.rest[0], track.rest[1], GRAVITY, state, window, prm.margin, ax_el, rail_axles, z,
            centre, r_in, k_in, p.dt, first, p.store_every, newton_max_iter,
            *[*(a[row:] for a in out.values()), peak],
        )  # fmt: skip
        if status != DONE:
            stop = failure if status == NEWTON_FAILED else non_finite
            return stop(p, first + int(at))
        if advanced is not None:
            advanced(steps.size)
    wheel = peak[:, track.first : track.first + track.count]
    out["ballast_wheel_peak"] = wheel
    out["ballast_peak"] = np.array([wheel[rail == r].max(axis=0, initial=0.0)
                                    for r in range(len(RAILS))])  # fmt: skip
    return out
