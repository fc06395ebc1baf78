"""Rail-seat forces from the rail as a beam on tensionless supports with seating gaps.

The rail of one side is an Euler-Bernoulli beam on one linear, tensionless spring per
sleeper that only bears once the rail has closed that sleeper's gap (a hanging sleeper).
Its rest state (rail and sleeper self-weight, no wheel) is solved once per step over the
whole section (`rest_state`: a banded solve over the closed supports, the set of closed
supports iterated from the previous step's). A wheel load changes it only locally, so
each wheel position is solved on a window of ``2 half + 1`` sleepers centred on the
sleeper under the wheel, for the change from the rest state, held at zero one sleeper
beyond the window (the change at 6 m from a wheel is below 0.1 % for a characteristic
length of 0.8 m, ``e^(-x/L_c)``). The rail rotations of the window are condensed out once
per window, so that each wheel position is a dense system of ``2 half + 1`` unknowns (the
deflections at the sleepers); all positions are solved in one compiled loop, and the set
of closed supports of each is iterated to convergence (closed where the rail reaches the
ballast, open elsewhere), starting from the set the same row had in its latest solve
(the ballast changes little between solves). The section is extended beyond
its ends by copies of its end sleepers, as the track goes on beyond a section.

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

from trackdyn.beam.elements import element_stiffness, solve_band, stiffness_band
from trackdyn.errors import TrackdynInputError

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
    half: int = 8

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
    force : ndarray, shape (B, W)
        Condensed nodal forces of the loads [N].
    closed : ndarray of bool, shape (B, W)
        Each row's closed supports in its latest solve (all closed before the first),
        where the next solve starts: the ballast changes little between solves, so that
        the set is mostly right at once.
    base : ndarray, shape (B, W)
        Each row's ``A^-1 force`` with its window's inverse (`Windows`) [m], kept while
        that inverse stays as it is (most windows, from one rest state to the next).
    seen : ndarray of int, shape (B,)
        The version of its window's inverse that ``base`` was formed with (0: none yet).
    """

    centre: np.ndarray
    force: np.ndarray
    closed: np.ndarray
    base: np.ndarray
    seen: np.ndarray


class Windows:
    """Condensed beam stiffness of the window around every sleeper of a `RailBeam`.

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
        # round-off of their positions) are condensed once
        lengths = np.diff(self.x, axis=1)
        _, first, same = np.unique(np.round(lengths, 12), axis=0, return_index=True,
                                   return_inverse=True)  # fmt: skip
        ke = element_stiffness(lengths[first], beam.EI)  # (windows, W + 1, 4, 4)
        ndof = 2 * (self.width + 2)
        K = np.zeros((first.size, ndof, ndof))
        for e in range(ke.shape[1]):
            K[:, 2 * e : 2 * e + 4, 2 * e : 2 * e + 4] += ke[:, e]
        inner = np.arange(2, ndof - 2)
        K = K[:, inner][:, :, inner]
        w, t = np.arange(0, 2 * self.width, 2), np.arange(1, 2 * self.width, 2)
        Ktt = K[:, t][:, :, t]
        self.T = np.linalg.solve(Ktt, K[:, t][:, :, w])  # Ktt^-1 Ktw, (windows, W, W)
        self.S = K[:, w][:, :, w] - K[:, w][:, :, t] @ self.T  # condensed stiffness
        self.kind = same.ravel()  # the condensed window of each sleeper's window, (n,)
        self.index = np.arange(n)[:, None] + np.arange(self.width)[None, :] + 1  # padded
        self._rest: RailRest | None = None  # the rest state the inverses below belong to
        self._flips = np.zeros(n, np.int64)  # rank-one changes since formed in full
        self._version = np.zeros(n, np.int64)  # changes of each window's inverse
        self._closed: np.ndarray | None = None  # its closed supports per window
        self._inverse: np.ndarray = np.empty((0, self.width, self.width))  # sized at first use
        self._padded: tuple = ()  # the rest state's values per sleeper, padded
        self._stiffness = beam.padded(beam.stiffness)  # per sleeper, padded [N/m]
        self._window_stiffness = self._stiffness[self.index]  # per window and column

    def load_vector(self, centre, position, load, closed=None) -> WindowLoads:
        """Point loads placed on the windows: their condensed nodal forces.

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
        force = _condensed_loads(self.x, self.T, self.kind, centre, position, load)
        start = np.ones(force.shape, np.bool_) if closed is None else np.array(closed)
        return WindowLoads(centre, force, start, np.empty(force.shape),
                           np.zeros(centre.size, np.int64))  # fmt: skip

    def _inverses(self, rest: RailRest) -> np.ndarray:
        """Inverse window matrices with the rest state's closed supports, (n, W, W) [m/N].

        Formed in full at the first rest state; after that, each support that opened or
        closed since the last rest state is a rank-one change of the windows that hold it
        (`_flip_supports`, Sherman-Morrison), and a window is formed in full again after
        `MAX_FLIPS` of them (round-off). Each window's version counts its changes
        (`WindowLoads.base`). Keeps the rest state's stiffness, gap and rest deflection per
        sleeper, padded (`RailBeam.padded`), for `solve`.
        """
        if self._rest is not rest:
            b = self.beam
            self._padded = (self._stiffness, b.padded(rest.gap), b.padded(rest.deflection))
            k, closed = self._window_stiffness, _bearing(*self._padded[1:], self.width)
            if self._rest is None:
                A = self.S[self.kind]
                A[:, np.arange(self.width), np.arange(self.width)] += k * closed
                self._inverse = _spd_inverses(A)
                self._version += 1
            else:
                redo = _flip_supports(self._inverse, self._closed, closed, k, self._flips,
                                      self._version, MAX_FLIPS)  # fmt: skip
                if redo.size:
                    A = self.S[self.kind[redo]]
                    A[:, np.arange(self.width), np.arange(self.width)] += (k * closed)[redo]
                    self._inverse[redo] = _spd_inverses(A)
                    self._version[redo] += 1
            self._rest, self._closed = rest, closed
        return self._inverse

    def solve(self, rest: RailRest, loads: WindowLoads):
        """Support forces [N] of each row with its loads added to the rest state.

        The inverse of each window's matrix with the supports closed at rest is formed once
        per rest state; a row whose set of closed supports differs from the rest state's
        in ``m`` supports is solved from it by the Woodbury identity (an ``m x m`` system),
        and the sets are iterated to convergence, starting from the row's set in its
        latest solve (``loads.closed``, updated).

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
            end sleepers); formed here, not kept with the loads (as large as their forces).
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
        inverse = self._inverses(rest)
        k, g, u0 = self._padded
        rows_in = (loads.centre, loads.force, loads.closed, loads.base, loads.seen)
        out = _window_solve(inverse, self._version, *rows_in, k, g, u0, MAX_SWEEPS,
                            self.beam.half, wheels, rows)  # fmt: skip
        if out[3]:
            raise TrackdynInputError(
                f"rail-seat forces: the contact of {out[3]} wheel positions did not settle "
                f"in {MAX_SWEEPS} iterations"
            )
        return out[:3]


@njit(cache=True, nogil=True)
def _condensed_loads(x, coupling, kind, centre, position, load):
    """Condensed nodal forces ``f_w - Tᵀ f_t`` of point loads on each row's window, (B, W)
    [N]: each load's consistent nodal forces (`trackdyn.beam.elements.hermite`) on the two
    nodes of its element, the held end nodes dropped, and the rotations' part carried onto
    the deflections by ``T = Ktt⁻¹ Ktw`` (``coupling[kind[i]]`` for window ``i``); loads outside the
    window are dropped."""
    B, L = position.shape
    W = x.shape[1] - 2
    out = np.zeros((B, W))
    for b in range(B):
        xb, tb = x[centre[b]], coupling[kind[centre[b]]]
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
                if node < 1 or node > W:
                    continue
                out[b, node - 1] += w[side]
                for i in range(W):
                    out[b, i] -= tb[node - 1, i] * t[side]
    return out


MAX_FLIPS = 32
"""Rank-one changes of a window's inverse (`_flip_supports`) before it is formed again."""


@njit(cache=True, nogil=True)
def _flip_supports(inverse, before, after, k, flips, version, max_flips):
    """Update each window's inverse for the supports that opened or closed, in place.

    Closing support ``j`` of stiffness ``k`` adds ``d = k`` at ``(j, j)``, opening it
    ``d = -k``: ``A'^-1 = A^-1 - d c cᵀ / (1 + d c_j)``, ``c`` the column ``j`` of the
    symmetric ``A^-1`` (Sherman-Morrison; ``1 + d c_j > 0`` as the window stays positive
    definite with its ends held). Returns the windows with more than ``max_flips``
    changes since they were last formed in full (``flips`` counts them), left for the
    caller to form again; ``version`` counts each window changed.
    """
    n, W = before.shape
    col = np.empty(W)
    again = np.zeros(n, np.bool_)
    for w in range(n):
        for j in range(W):
            if before[w, j] == after[w, j]:
                continue
            flips[w] += 1
            if flips[w] > max_flips:
                again[w] = True
                break
            version[w] += 1
            inv = inverse[w]
            d = k[w, j] if after[w, j] else -k[w, j]
            for i in range(W):
                col[i] = inv[i, j]
            f = d / (1.0 + d * col[j])
            for a in range(W):
                ca = f * col[a]
                for b in range(W):
                    inv[a, b] -= ca * col[b]
    redo = np.flatnonzero(again)
    for w in redo:
        flips[w] = 0
    return redo


@njit(cache=True, nogil=True)
def _bearing(gap, deflection, width):
    """The closed supports ``deflection > gap`` of each window, (n, width): window ``i``
    holds the padded sleepers ``i + 1`` onwards (`Windows.index`)."""
    n = gap.size - width - 1
    out = np.empty((n, width), np.bool_)
    for i in range(n):
        for j in range(width):
            out[i, j] = deflection[i + 1 + j] > gap[i + 1 + j]
    return out


@njit(cache=True, nogil=True)
def _spd_inverses(A):
    """Inverses of the symmetric positive definite matrices ``A`` (m, W, W) from their
    Cholesky factors ``L``: ``A^-1 = L^-T L^-1``, exactly symmetric (each entry formed once
    and mirrored); twice as fast as LAPACK's general inverse for windows of 21 sleepers."""
    m, W = A.shape[0], A.shape[1]
    out = np.empty_like(A)
    L = np.empty((W, W))
    for k in range(m):
        a = A[k]
        for j in range(W):  # Cholesky, lower triangle
            s = a[j, j]
            for p in range(j):
                s -= L[j, p] * L[j, p]
            L[j, j] = np.sqrt(s)
            for i in range(j + 1, W):
                s = a[i, j]
                for p in range(j):
                    s -= L[i, p] * L[j, p]
                L[i, j] = s / L[j, j]
        for j in range(W):  # L^-1 in place, a column at a time from the left
            L[j, j] = 1.0 / L[j, j]
            for i in range(j + 1, W):
                s = 0.0
                for p in range(j, i):
                    s -= L[i, p] * L[p, j]
                L[i, j] = s / L[i, i]
        o = out[k]
        for i in range(W):
            for j in range(i, W):
                s = 0.0
                for p in range(j, W):
                    s += L[p, i] * L[p, j]
                o[i, j] = s
                o[j, i] = s
    return out


@njit(cache=True, nogil=True, inline="always")
def _ldl_solve(c, z, m):
    """Solve ``c[:m, :m] y = z[:m]`` in place (``z`` becomes ``y``) for a symmetric
    quasi-definite ``c`` (a positive definite and a negative definite diagonal block, in
    any order), of which the lower triangle is read: ``L D Lᵀ`` without pivoting, which
    such a matrix has in every order of its rows (Vanderbei 1995); no allocation. Inlined
    into `_window_solve`, which calls it for a few unknowns per sweep (3 % of its time).

    References
    ----------
    Vanderbei, R.J. (1995). Symmetric quasidefinite matrices. SIAM Journal on
    Optimization 5(1), 100-113.
    """
    for j in range(m):  # c's lower triangle becomes L (unit diagonal) and D (diagonal)
        for p in range(j):
            f = c[j, p] * c[p, p]
            for i in range(j, m):
                c[i, j] -= c[i, p] * f
        for i in range(j + 1, m):
            c[i, j] /= c[j, j]
    for i in range(m):
        for p in range(i):
            z[i] -= c[i, p] * z[p]
    for i in range(m):
        z[i] /= c[i, i]
    for i in range(m - 1, -1, -1):
        for p in range(i + 1, m):
            z[i] -= c[p, i] * z[p]


@njit(cache=True, nogil=True)
def _window_solve(inverse, version, centre, force, start, base_rows, seen, k, g, u0,
                  max_sweeps, half, wheels, rows):  # fmt: skip
    """Support force and rail deflection of each row's window, its supports iterated from
    ``start`` (B, W), each row's starting set of closed supports, overwritten with its
    solution's; each row's ``A^-1 force[b]`` kept in ``base_rows`` (B, W) while its
    window's inverse stays at the ``version`` (per window) in ``seen`` (B,), formed again
    (and ``seen`` updated) when it changed; and the largest support force of each sleeper
    over the rows of each of ``wheels`` wheels (row ``b`` is wheel ``b % wheels``'s;
    column ``j`` of row ``b`` is sleeper ``centre[b] + j - half``; sleepers beyond the
    section dropped).

    Row ``b`` solves ``(A + diag(k closed)) v = force[b] - k closed (u0 - g)`` on window
    ``centre[b]`` (padded sleepers ``centre[b] + 1`` onwards of ``k``, ``g``, ``u0``) from
    ``base = A^-1 force[b]``, ``A^-1 = inverse[centre[b]]`` (symmetric) being the inverse
    with the rest state's closed supports ``closed0 = u0 > g`` (at rest their forces
    balance ``k closed0 (u0 - g)``). A set of closed supports (first ``start[b]``, then
    ``u0 + v > g``) that differs from ``closed0`` in ``m`` supports is solved by the
    Woodbury identity, ``U`` the unit columns of those supports and ``D`` their change of
    stiffness (``±k``): ``e = D U^T (u0 - g)``, ``x0 = base - A^-1 U e`` (needed at those
    supports only), ``(D^-1 + U^T A^-1 U) z = U^T x0``, ``v = base - A^-1 U (e + z)``;
    and again with the new set until it no longer changes. ``D^-1 + U^T A^-1 U`` is
    quasi-definite (`_ldl_solve`): its block of closed supports is positive definite, and
    that of opened ones negative definite, as the window with them opened is positive
    definite (its ends are held).

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
    """
    B, W = force.shape
    n = k.size - 2 * (half + 1)
    support, deflection = np.empty((B if rows else 0, W)), np.empty((B if rows else 0, W))
    peak = np.zeros((wheels, n))
    closed0, closed = np.empty(W, np.bool_), np.empty(W, np.bool_)
    idx = np.empty(W, np.uint64)  # unsigned: numba checks signed indices for wrapping
    kb, gb, ub, force_b = np.empty(W), np.empty(W), np.empty(W), np.empty(W)
    v, d, e, z, c = np.empty(W), np.empty(W), np.empty(W), np.empty(W), np.empty((W, W))
    unsettled = 0
    for b in range(B):
        inv, first, base = inverse[centre[b]], centre[b] + 1, base_rows[b]
        if b == 0 or centre[b] != centre[b - 1]:  # a window's rows follow each other
            for j in range(W):
                kb[j], gb[j], ub[j] = k[first + j], g[first + j], u0[first + j]
                closed0[j] = ub[j] > gb[j]
        for j in range(W):
            closed[j] = start[b, j]
        if seen[b] != version[centre[b]]:
            seen[b] = version[centre[b]]
            for i in range(W):
                base[i] = 0.0
            for j in range(W):  # A^-1 is symmetric: its rows as columns, no serial sum
                f = force[b, j]
                if f == 0.0:  # a load on a sleeper (the secant's rows) loads one node
                    continue
                row = inv[j]
                for i in range(W):
                    base[i] += row[i] * f
        for sweep in range(max_sweeps):
            m = 0
            for j in range(W):  # written always, kept when counted: no branch
                idx[m] = j
                m += closed[j] != closed0[j]
            for a in range(m):
                j = idx[a]
                d[a] = kb[j] if closed[j] else -kb[j]
                e[a] = d[a] * (ub[j] - gb[j])
            for a in range(m):  # x0 at the changed supports only; D^-1 + U^T A^-1 U
                ia = idx[a]
                row = inv[ia]
                x0 = base[ia]
                for q in range(m):
                    x0 -= inv[idx[q], ia] * e[q]
                    c[a, q] = row[idx[q]]
                c[a, a] += 1.0 / d[a]
                z[a] = x0
            _ldl_solve(c, z, m)
            for i in range(W):
                v[i] = base[i]
            for a in range(m):  # v = x0 - A^-1 U z = base - A^-1 U (e + z), one pass
                w = e[a] + z[a]
                row = inv[idx[a]]  # a row, not an index pair per element: vectorised
                for i in range(W):
                    v[i] -= row[i] * w
            changed = 0  # counted, not branched on
            for j in range(W):
                now = ub[j] + v[j] > gb[j]
                changed += now != closed[j]
                closed[j] = now
            if changed == 0:
                break
            if sweep == max_sweeps - 1:
                unsettled += 1
        for j in range(W):
            start[b, j] = closed[j]
        for j in range(W):
            force_b[j] = kb[j] * max(ub[j] + v[j] - gb[j], 0.0)
        if rows:
            for j in range(W):
                deflection[b, j], support[b, j] = ub[j] + v[j], force_b[j]
        # the peaks in the section, from the forces formed above: a loop over two slices
        # vectorises (LLVM checks that they do not overlap); reading the four arrays of the
        # force in it kept it scalar, 10 % of the solve's time
        lo, hi = max(0, half - centre[b]), min(W, n + half - centre[b])
        pk, fb = peak[b % wheels, centre[b] - half + lo : centre[b] - half + hi], force_b[lo:hi]
        for j in range(hi - lo):
            pk[j] = max(pk[j], fb[j])
    return support, deflection, peak, unsettled
