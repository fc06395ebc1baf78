"""Rail-seat forces from the rail as a beam on tensionless supports with seating gaps.

The rail of one side is an Euler-Bernoulli beam on one linear, tensionless spring per
sleeper that only bears once the rail has closed that sleeper's gap (a hanging sleeper).
Its rest state (rail and sleeper self-weight, no wheel) is solved once per step over the
whole section (`rest_state`: a banded solve over the closed supports, the set of closed
supports iterated from the previous step's). A wheel load changes it only locally, so
each wheel position is solved on a window of ``2 half + 1`` sleepers centred on the
sleeper under the wheel, for the change from the rest state, held at zero one sleeper
beyond the window (the change at 6 m from a wheel is below 0.1 % for a characteristic
length of 0.8 m, ``e^(-x/L_c)``). Each wheel position is a banded system of the
window's deflections and rotations at its ``2 half + 1`` sleepers, solved for one set of
closed supports at a time (closed where the rail reaches the ballast, open elsewhere)
until the set no longer changes, starting from the set the same row had in its latest
solve (the ballast changes little between solves); all positions are solved in one
compiled loop, `LANES` of them side by side in the vector lanes (`trackdyn.lanewise`).
The section is extended beyond its ends by copies of its end sleepers, as the track goes
on beyond a section.

References
----------
Nielsen, J.C.O., Li, X. (2018). Railway track geometry degradation due to differential
settlement of ballast/subgrade - Numerical prediction by an iterative procedure. Journal
of Sound and Vibration 412, 441-456.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from trackdyn.beam.elements import solve_band, stiffness_band
from trackdyn.errors import TrackdynInputError
from trackdyn.lanewise import FASTMATH, LANES, lanewise, load, store, vectorised

WINDOW_HALF = 10
"""Sleepers each side of a wheel in the rail-seat windows [-]: the change of deflection at
``WINDOW_HALF`` spacings (6 m at 0.6 m) from a wheel is below 0.1 % for a characteristic
length of 0.8 m, ``e^(-x/L_c)``."""

MAX_SWEEPS = 60
"""Active-set iterations allowed (rest state, and each batch of wheel positions)."""


@dataclass(frozen=True)
class RailBeam:
    """One rail on its sleepers: what does not change with settlement.

    Parameters
    ----------
    position : ndarray
        Sleeper positions, strictly increasing [m].
    stiffness : ndarray
        Support stiffness per sleeper, the spring behind the gap [N/m].
    weight : ndarray
        Self-weight carried at each sleeper: rail over the sleeper spacing and the
        sleeper's share per rail seat [N].
    EI : float
        Rail bending stiffness [N m^2].
    half : int
        Sleepers each side of the wheel in a window [-].
    """

    position: np.ndarray
    stiffness: np.ndarray
    weight: np.ndarray
    EI: float
    half: int = WINDOW_HALF

    def padded(self, values):
        """``values`` per sleeper extended by ``half + 1`` copies of the end values."""
        v, p = np.asarray(values, dtype=float), self.half + 1
        return np.concatenate([np.full(p, v[0]), v, np.full(p, v[-1])])

    @cached_property
    def band(self):
        """The rail's stiffness over its sleepers in LAPACK upper banded form
        (`trackdyn.beam.elements.stiffness_band`), formed once: every rest state needs it."""
        return stiffness_band(self.position, self.EI)

    @property
    def padded_position(self):
        """Sleeper positions extended with the end spacings [m]."""
        x, p = self.position, self.half + 1
        return np.r_[x[0] - (x[1] - x[0]) * np.arange(p, 0, -1), x,
                     x[-1] + (x[-1] - x[-2]) * np.arange(1, p + 1)]  # fmt: skip


@dataclass(frozen=True)
class RailRest:
    """One rail at rest on its ballast under self-weight alone (no wheel).

    Parameters
    ----------
    gap : ndarray
        Gap between each sleeper and its ballast at zero rail deflection, >= 0 [m].
    deflection : ndarray
        Rail deflection at each sleeper [m].
    force : ndarray
        Support force at each sleeper [N].
    closed : ndarray of bool
        Sleepers that bear (the rail has closed their gap).
    """

    gap: np.ndarray
    deflection: np.ndarray
    force: np.ndarray
    closed: np.ndarray


def rest_state(beam: RailBeam, gap, closed=None) -> RailRest:
    """The rail at rest under self-weight: banded solve over the closed gaps.

    The rail is discretised with one node per sleeper (the self-weight is lumped there, so
    the nodal results are exact). For a set of closed supports the equilibrium is linear
    (beam plus the closed springs, banded); the set is updated to the sleepers the rail
    reaches and solved again until it no longer changes (a primal-dual active-set
    iteration), starting from ``closed``, the previous step's set (all closed when None).

    Parameters
    ----------
    beam : RailBeam
        The rail and its supports.
    gap : ndarray
        Gap between each sleeper and its ballast at zero rail deflection, >= 0 [m].
    closed : ndarray of bool, optional
        Starting guess of the bearing sleepers.
    """
    gap = np.asarray(gap, dtype=float)
    n, k = gap.size, beam.stiffness
    band, w = beam.band, 2 * np.arange(n)
    closed = np.ones(n, bool) if closed is None else np.array(closed, dtype=bool)
    y = np.zeros(n)
    for _ in range(MAX_SWEEPS):
        if np.count_nonzero(closed) < 2:  # the rail rests on the two nearest ballast tops
            closed[np.argsort(gap - y)[:2]] = True
        kc = k * closed
        A = band.copy()
        A[3, w] += kc
        rhs = np.zeros(2 * n)
        rhs[w] = beam.weight + kc * gap
        y = solve_band(A, rhs)[w]
        now = y > gap
        if np.array_equal(now, closed):
            return RailRest(gap, y, k * np.maximum(y - gap, 0.0), closed)
        closed = now
    raise TrackdynInputError(
        f"rail at rest: the bearing sleepers did not settle in {MAX_SWEEPS} iterations"
    )


@dataclass(frozen=True)
class WindowLoads:
    """Wheel loads placed on the beam windows, one row per wheel position
    (`Windows.load_vector`); they do not depend on the ballast state, so that they are placed
    once and solved on every rest state (`Windows.solve`).

    Parameters
    ----------
    centre : ndarray, shape (B,)
        Window (sleeper index) of each row.
    force : ndarray, shape (B, 2 W)
        Consistent nodal forces of the loads on the window's free nodes, (deflection,
        rotation) per node [N, N m].
    closed : ndarray of bool, shape (B, W)
        Each row's closed supports in its latest solve (all closed before the first),
        where the next solve starts: the ballast changes little between solves, so that
        the set is mostly right at once.
    """

    centre: np.ndarray
    force: np.ndarray
    closed: np.ndarray


class Windows:
    """Beam stiffness of the window around every sleeper of a `RailBeam`.

    Parameters
    ----------
    beam : RailBeam
        The rail and its supports.
    """

    def __init__(self, beam: RailBeam):
        h, n = beam.half, beam.position.size
        self.beam, self.width = beam, 2 * h + 1
        xp = beam.padded_position
        # window of sleeper i: padded nodes i .. i + 2h + 2; the two outer nodes are held
        nodes = np.arange(n)[:, None] + np.arange(2 * h + 3)[None, :]
        self.x = xp[nodes]  # (n, W + 2) node positions [m]
        # windows of the same element lengths to 1e-12 m (evenly spaced sleepers, up to the
        # round-off of their positions) share one stiffness
        lengths = np.diff(self.x, axis=1)
        _, first, same = np.unique(np.round(lengths, 12), axis=0, return_index=True,
                                   return_inverse=True)  # fmt: skip
        self.band = np.array([_window_band(self.x[i], beam.EI) for i in first])
        self.kind = same.ravel()  # the stiffness of each sleeper's window, (n,)
        self.index = np.arange(n)[:, None] + np.arange(self.width)[None, :] + 1  # padded
        self._rest: RailRest | None = None  # the rest state of `_padded`
        self._padded: tuple = ()  # the rest state's values per sleeper, padded
        self._stiffness = beam.padded(beam.stiffness)  # per sleeper, padded [N/m]

    def load_vector(self, centre, position, load, closed=None) -> WindowLoads:
        """Point loads placed on the windows: their consistent nodal forces.

        Parameters
        ----------
        centre : ndarray, shape (B,)
            Window (sleeper index) of each row.
        position, load : ndarray, shape (B, L)
            Load positions [m] and loads [N]; loads outside the window are dropped.
        closed : ndarray of bool, shape (B, W), optional
            Where the first solve starts (`WindowLoads.closed`): the closed supports of
            similar loads on the same rows (all closed when not given).
        """
        centre = np.asarray(centre)
        force = _nodal_loads(self.x, centre, position, load)
        start = np.ones((centre.size, self.width), np.bool_) if closed is None else np.array(closed)
        return WindowLoads(centre, force, start)

    def solve(self, rest: RailRest, loads: WindowLoads):
        """Support forces [N] of each row with its loads added to the rest state.

        Each row is solved on its window for the change from the rest state, with the
        supports of a trial set closed (a banded solve of the window's deflections and
        rotations), and the set is iterated to convergence, starting from the row's set
        in its latest solve (``loads.closed``, updated).

        Parameters
        ----------
        rest : RailRest
            The rail at rest.
        loads : WindowLoads
            The wheel loads placed on the windows (`load_vector`).

        Returns
        -------
        index : ndarray, shape (B, W)
            Sleeper of each column (``-1`` .. ``n``: beyond the section, the copies of the
            end sleepers); formed here, not kept with the loads (half as large as their
            forces).
        support_force : ndarray, shape (B, W)
            Total support force, rest state included [N].
        deflection : ndarray, shape (B, W)
            Total rail deflection [m].
        """
        support, y, _ = self._solved(rest, loads, 1, True)
        return self.index[loads.centre] - (self.beam.half + 1), support, y

    def deflection(self, rest: RailRest, loads: WindowLoads) -> np.ndarray:
        """`solve`'s total rail deflection alone, (B, W) [m] (the beam's secant stiffness
        needs no more)."""
        return self._solved(rest, loads, 1, True)[1]

    def peaks(self, rest: RailRest, loads: WindowLoads, wheels: int):
        """Largest support force of each sleeper over the rows of each wheel, (wheels, n)
        [N]: row ``b`` is wheel ``b % wheels``'s (0 where no row reaches a sleeper); as
        `solve`, without its arrays per row.

        Parameters
        ----------
        rest : RailRest
            The rail at rest.
        loads : WindowLoads
            The wheel loads placed on the windows (`load_vector`), the rows of ``wheels``
            wheels in turn.
        wheels : int
            Wheels [-].
        """
        return self._solved(rest, loads, wheels, False)[2]

    def _solved(self, rest: RailRest, loads: WindowLoads, wheels: int, rows: bool):
        """`_window_solve` on ``rest``: support forces and deflections per row (when
        ``rows``, else empty) and the peaks per wheel and sleeper."""
        if self._rest is not rest:
            b = self.beam
            self._rest = rest
            self._padded = (self._stiffness, b.padded(rest.gap), b.padded(rest.deflection))
        k, g, u0 = self._padded
        rows_in = (loads.centre, loads.force, loads.closed)
        with vectorised():
            out = _window_solve(self.band, self.kind, *rows_in, k, g, u0, MAX_SWEEPS,
                                self.beam.half, wheels, rows)  # fmt: skip
        if out[3]:
            raise TrackdynInputError(
                f"rail-seat forces: the contact of {out[3]} wheel positions did not settle "
                f"in {MAX_SWEEPS} iterations"
            )
        return out[:3]


def _window_band(x, EI):
    """Stiffness of one window's free nodes (``x`` its nodes, the two outer ones held) in
    lower band form, ``band[j, o] = K[j + o, j]`` (0 beyond the matrix), shape (2 W, 4)."""
    upper = stiffness_band(x, EI)[:, 2:-2]  # upper[3 + i - j, j] = K[i, j]; outer nodes out
    size = upper.shape[1]
    band = np.zeros((size, 4))
    for o in range(4):
        band[: size - o, o] = upper[3 - o, o:]
    return band


@njit(cache=True, nogil=True)
def _nodal_loads(x, centre, position, load):
    """Consistent nodal forces of point loads on each row's free nodes, (B, 2 W), the
    deflection and rotation of each node in turn [N, N m] (`trackdyn.beam.elements.hermite`
    on the two nodes of each load's element; the held end nodes and loads outside the
    window are dropped)."""
    B, L = position.shape
    W = x.shape[1] - 2
    out = np.zeros((B, 2 * W))
    for b in range(B):
        xb = x[centre[b]]
        for a in range(L):
            p = position[b, a]
            if not (xb[0] <= p <= xb[W + 1]):
                continue
            e = 0
            while e < W and xb[e + 1] <= p:
                e += 1
            length = xb[e + 1] - xb[e]
            s = (p - xb[e]) / length
            s2, q = s * s, load[b, a]
            w = ((1 - 3 * s2 + 2 * s2 * s) * q, (3 * s2 - 2 * s2 * s) * q)
            t = (length * (s - 2 * s2 + s2 * s) * q, length * (s2 * s - s2) * q)
            for side in range(2):
                node = e + side  # 1 .. W are the window's free nodes
                if 1 <= node <= W:
                    out[b, 2 * node - 2] += w[side]
                    out[b, 2 * node - 1] += t[side]
    return out


_product = lanewise("a * b")
_minus_three = lanewise("a - b * c - d * e - f * g")
_minus_two = lanewise("a - b * c - d * e")
_minus_one = lanewise("a - b * c")
_reciprocal = lanewise("1.0 / a")
_with_support = lanewise("a + k * c")
_load_change = lanewise("f - k * (c - z) * (u - g)")
_bears = lanewise("1.0 if u + v > g else 0.0")
_count_changes = lanewise("m + (1 if n != c else 0)")
"""Operations of `_window_solve` on the tuples of its lanes (`trackdyn.lanewise`)."""


@njit(cache=True, inline="always")
def _fill_lanes(b0, band, kind, centre, force, start, k, g, u0, lanes, kinds):
    """Put rows ``b0`` onwards of `_window_solve` into the lanes' values ``lanes`` = (band
    of K, forces, and per sleeper its stiffness, gap, rest deflection, rest and trial sets);
    the band only where a lane's window stiffness (``kinds``) changes; past the last row,
    the last row again."""
    a, f, kb, gb, ub, c0, cl = lanes
    B, size = force.shape
    W = size // 2
    for lane in range(LANES):
        b = min(b0 + lane, B - 1)
        if kinds[lane] != kind[centre[b]]:
            kinds[lane] = kind[centre[b]]
            kw = band[kinds[lane]]
            for j in range(size):
                for o in range(4):
                    a[(4 * j + o) * LANES + lane] = kw[j, o]
        for j in range(size):
            f[j * LANES + lane] = force[b, j]
        first = centre[b] + 1
        for j in range(W):
            q = j * LANES + lane
            kb[q], gb[q], ub[q] = k[first + j], g[first + j], u0[first + j]
            c0[q] = 1.0 if ub[q] > gb[q] else 0.0
            cl[q] = 1.0 if start[b, j] else 0.0


@njit(cache=True, inline="always")
def _solve_lanes(lanes, low, vb, none):
    """One solve of the lanes' rows on their trial sets of closed supports: ``L D Lᵀ``
    factored a column at a time from the three before it with the forward solve in the same
    pass (into ``low``), then one pass back; the change of each sleeper's deflection into
    ``vb``."""
    a, f, kb, gb, ub, c0, cl = lanes
    size = f.size // LANES
    zero = load(none, 0)
    # columns j - 1, j - 2, j - 3 (last digit): L below the diagonal (m1, m2, m3, those
    # reaching row j onwards), D (d), z (y)
    m11 = m21 = m31 = d1 = m22 = m32 = d2 = m33 = d3 = zero
    y1 = y2 = y3 = zero
    for j in range(size):
        if j % 2 == 0:  # a deflection: its support, when closed
            kj, cj = load(kb, j // 2), load(cl, j // 2)
            diagonal = _with_support(load(a, 4 * j), cj, kj)
            r = _load_change(cj, load(f, j), load(gb, j // 2), kj, load(ub, j // 2),
                             load(c0, j // 2))  # fmt: skip
        else:
            diagonal, r = load(a, 4 * j), load(f, j)
        e1, e2, e3 = _product(m11, d1), _product(m22, d2), _product(m33, d3)
        d = _minus_three(diagonal, m11, e1, m22, e2, m33, e3)
        q = _reciprocal(d)
        n1 = _product(_minus_two(load(a, 4 * j + 1), m21, e1, m32, e2), q)
        n2 = _product(_minus_one(load(a, 4 * j + 2), m31, e1), q)
        n3 = _product(load(a, 4 * j + 3), q)
        y = _minus_three(r, m11, y1, m22, y2, m33, y3)
        store(low, 4 * j, n1)
        store(low, 4 * j + 1, n2)
        store(low, 4 * j + 2, n3)
        store(low, 4 * j + 3, _product(y, q))
        m33, d3 = m32, d2
        m22, m32, d2 = m21, m31, d1
        m11, m21, m31, d1 = n1, n2, n3, d
        y3, y2, y1 = y2, y1, y
    v1 = v2 = v3 = zero
    for j in range(size - 1, -1, -1):
        v = _minus_three(load(low, 4 * j + 3), load(low, 4 * j), v1,
                         load(low, 4 * j + 1), v2, load(low, 4 * j + 2), v3)  # fmt: skip
        if j % 2 == 0:
            store(vb, j // 2, v)
        v3, v2, v1 = v2, v1, v


@njit(cache=True, inline="always")
def _finish_rows(b0, lanes, vb, start, centre, half, wheels, rows, force_b, out):
    """The solved rows ``b0`` onwards of the lanes: each row's closed set into ``start``,
    its support forces and deflections into ``out`` = (support, deflection, peak) (rows
    only when ``rows``), and its forces into each sleeper's peak of its wheel."""
    a, f, kb, gb, ub, c0, cl = lanes
    support, deflection, peak = out
    B, W = start.shape
    n = peak.shape[1]
    for lane in range(min(LANES, B - b0)):
        b = b0 + lane
        for j in range(W):
            q = j * LANES + lane
            start[b, j] = cl[q] > 0.5
            force_b[j] = kb[q] * max(ub[q] + vb[q] - gb[q], 0.0)
        if rows:
            for j in range(W):
                deflection[b, j] = ub[j * LANES + lane] + vb[j * LANES + lane]
                support[b, j] = force_b[j]
        # the peaks in the section, from the forces formed above: a loop over two slices
        # vectorises (LLVM checks that they do not overlap)
        lo, hi = max(0, half - centre[b]), min(W, n + half - centre[b])
        pk = peak[b % wheels, centre[b] - half + lo : centre[b] - half + hi]
        fb = force_b[lo:hi]
        for j in range(hi - lo):
            pk[j] = max(pk[j], fb[j])


@njit(cache=True, nogil=True, fastmath=FASTMATH, error_model="numpy")
def _window_solve(band, kind, centre, force, start, k, g, u0, max_sweeps, half, wheels,
                  rows):  # fmt: skip
    """Support force and rail deflection of each row's window, its supports iterated from
    ``start`` (B, W), each row's starting set of closed supports, overwritten with its
    solution's; and the largest support force of each sleeper over the rows of each of
    ``wheels`` wheels (row ``b`` is wheel ``b % wheels``'s; column ``j`` of row ``b`` is
    sleeper ``centre[b] + j - half``; sleepers beyond the section dropped).

    Row ``b`` solves ``(K + diag(k closed)) v = force[b] - k (closed - closed0) (u0 - g)``
    on window ``centre[b]`` for the change ``v`` of its deflections and rotations from the
    rest state: ``K = band[kind[centre[b]]]``, the supports on the deflections (padded
    sleepers ``centre[b] + 1`` onwards of ``k``, ``g``, ``u0``), whose closed ones at rest
    ``closed0 = u0 > g`` balance ``k closed0 (u0 - g)``. The set ``closed`` (first
    ``start[b]``, then ``u0 + v > g``) is iterated until it no longer changes. The matrix is
    symmetric positive definite (the window's ends are held) with 3 off-diagonals, factored
    ``L D Lᵀ`` a column at a time from the three before it and solved in the same pass
    (forward) and one back. `LANES` rows are solved side by side, one in each vector lane,
    until each of them has settled (a settled row solved again gives the same answer, to
    the bit); the last group repeats its last row in the lanes left over.

    Returns
    -------
    support_force : ndarray, shape (B, W)
        Total support force, rest state included [N] (no rows unless ``rows``).
    deflection : ndarray, shape (B, W)
        Total rail deflection ``u0 + v`` [m] (no rows unless ``rows``).
    peak : ndarray, shape (wheels, n)
        Largest support force of each sleeper per wheel (0 where no row reaches it) [N].
    unsettled : int
        Rows whose set of closed supports still changed after ``max_sweeps`` solves.

    References
    ----------
    Golub, G.H., Van Loan, C.F. (2013). Matrix Computations, 4th edition. Johns Hopkins
    University Press, Baltimore (section 4.3, band ``L D Lᵀ``).
    """
    B, size = force.shape
    W = size // 2
    n = k.size - 2 * (half + 1)
    support, deflection = np.empty((B if rows else 0, W)), np.empty((B if rows else 0, W))
    peak = np.zeros((wheels, n))
    # the lanes' values, a row of LANES per entry: the band of K (4 per column), the forces,
    # and per sleeper its stiffness, gap, rest deflection, rest and trial sets, deflection
    a = np.empty(size * 4 * LANES)
    f = np.empty(size * LANES)
    kb, gb, ub = np.empty(W * LANES), np.empty(W * LANES), np.empty(W * LANES)
    c0, cl, vb = np.empty(W * LANES), np.empty(W * LANES), np.empty(W * LANES)
    low = np.empty(size * 4 * LANES)  # per column j: L[j+1, j], L[j+2, j], L[j+3, j], z_j / D_j
    lanes = (a, f, kb, gb, ub, c0, cl)
    none, nothing = np.zeros(LANES), np.zeros(LANES, np.int64)
    moved = np.empty(LANES, np.int64)
    kinds = np.full(LANES, -1)  # the window stiffness in each lane's band
    force_b = np.empty(W)
    unsettled = 0
    for b0 in range(0, B, LANES):
        _fill_lanes(b0, band, kind, centre, force, start, k, g, u0, lanes, kinds)
        for sweep in range(max_sweeps):
            _solve_lanes(lanes, low, vb, none)
            changes = load(nothing, 0)
            for i in range(W):
                now = _bears(load(gb, i), load(ub, i), load(vb, i))
                changes = _count_changes(load(cl, i), changes, now)
                store(cl, i, now)
            store(moved, 0, changes)
            if moved.max() == 0:
                break
            if sweep == max_sweeps - 1:
                for lane in range(min(LANES, B - b0)):
                    unsettled += moved[lane] > 0
        _finish_rows(b0, lanes, vb, start, centre, half, wheels, rows, force_b,
                     (support, deflection, peak))  # fmt: skip
    return support, deflection, peak, unsettled
