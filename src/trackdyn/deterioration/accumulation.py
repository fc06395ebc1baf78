"""Settlement accumulated over tonnage steps, per rail and sleeper, with the law's memory.

A step's load cycles are the wheels of the traffic: each with its vehicle, its rail, its
cycles per MGT [-] and its rail-seat load at every sleeper of its rail [N]. `prepare`
takes them and returns the settlement increment as a function of the step length ``ΔM``
[MGT], in closed form for loads held over the step (so the loop can choose the step);
`advance` then applies the step to the law's memory and returns each vehicle's part of it.

- `Hardening` (power, Shenton, Sato laws): the memory is the state of each term of the
  cycle curve (`trackdyn.deterioration.hardening`): for a power term the equivalent cycles
  of the reference load, so that every cycle, at any load, adds settlement.
- `LoadHistory` (Varandas law): the memory is ``h(F)``, the cycles whose peak reached ``F``,
  on a load grid of `LOAD_GRID` cells. Over a step the wheels interleave, so ``h`` grows
  at ``r(F) = Σ_j n_j [Q_j >= F]`` per MGT and the settlement is
  ``(gamma / M) Σ_cells w_k (S(h_k + r_k ΔM) - S(h_k))``, with ``w_k`` the integral of
  ``F^alpha`` over cell ``k`` and ``S`` the harmonic sum: the per-cycle law summed exactly
  for loads on the grid points (a load inside a cell counts that cell's fraction).
- `Zoned`: one of these per zone of the track, each on its own sleepers.

Each vehicle's part of a step's settlement is its share of the rate at the step start:
of the equivalent cycles of a power term, of the consolidation drive of a consolidation
term, of the cycles reaching each load cell of the Varandas histogram.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

from trackdyn.deterioration.settlement import VarandasLaw, harmonic, harmonic_one, hurwitz_zeta

LOAD_GRID = 500.0
"""Cell width of the load histogram of `LoadHistory` [N]."""


class Hardening:
    """Memory of the ``f(Q, k2) g(N)`` laws: each term's state per rail and sleeper.

    Parameters
    ----------
    law : SettlementLaw
        The law.
    shape : tuple
        (2 rails, sleepers).
    vehicles : int
        Vehicles of the traffic (for each one's part of the settlement).
    """

    def __init__(self, law, shape, vehicles: int):
        self.law, self.vehicles = law, vehicles
        self.N = np.zeros(shape)
        self.states = [term.start(shape) for term in law.terms]
        self._parts: list[tuple] = []  # per term: (increment, shares) of `prepare`
        self._owners: list[int] = []
        self._cycles = np.zeros(shape)
        self._classes_now: list = []  # the load classes last prepared

    def _classes(self, cycles):
        """Per wheel: (cycles per MGT, load factor) per rail and sleeper; owners; per MGT."""
        shape = self.N.shape
        classes, owners, per_mgt = [], [], np.zeros(shape)
        for v, r, w, q, k2 in cycles:
            n, f = np.zeros(shape), np.zeros(shape)
            n[r], f[r] = w, self.law.load_factor(q, k2)
            classes.append((n, f))
            owners.append(v)
            per_mgt[r] += w
        return classes, owners, per_mgt

    def prepare(self, cycles):
        """Increment [m] as a function of the step [MGT] for ``cycles``.

        Parameters
        ----------
        cycles : list of (int, int, float, ndarray, ndarray)
            Per wheel: vehicle index, rail index, cycles per MGT [-], rail-seat load per
            sleeper [N] and track stiffness per sleeper [N/m].
        """
        classes, self._owners, self._cycles = self._classes(cycles)
        self._classes_now = classes
        self._parts = [t.prepare(s, classes) for t, s in zip(self.law.terms, self.states,
                                                             strict=True)]  # fmt: skip
        parts = self._parts
        return lambda dm: sum((inc(dm)[0] for inc, _ in parts), np.zeros(self.N.shape))

    def advance(self, dm: float) -> np.ndarray:
        """Apply a step of ``dm`` [MGT] with the cycles last prepared.

        Returns
        -------
        ndarray
            Each vehicle's part of the step's settlement, (vehicles, 2, sleepers) [m].
        """
        split = np.zeros((self.vehicles, *self.N.shape))
        for i, (inc, shares) in enumerate(self._parts):
            de, self.states[i] = inc(dm)
            for v, share in zip(self._owners, shares, strict=True):
                split[v] += share * de
        self.N = self.N + self._cycles * dm
        return split

    def restart(self, held, mgt: float) -> None:
        """Set the law's memory at the rail seats ``held`` (bool, per rail and sleeper) to
        that of new ballast after ``mgt`` [MGT] of the traffic last prepared (after tamping:
        the early, fast phase comes again, the same after every tamping); ``N`` still
        counts every cycle."""
        shape = self.N.shape
        fresh = [t.prepare(t.start(shape), self._classes_now)[0](mgt)[1] for t in self.law.terms]
        self.states = [np.where(held, f, s) for f, s in zip(fresh, self.states, strict=True)]


class LoadHistory(Hardening):
    """Memory of the Varandas law: the load histogram ``h(F)`` per rail and sleeper.

    Parameters
    ----------
    law : VarandasLaw
        The law.
    shape : tuple
        (2 rails, sleepers).
    vehicles : int
        Vehicles of the traffic.
    """

    def __init__(self, law: VarandasLaw, shape, vehicles: int):
        self.law, self.vehicles = law, vehicles
        self.N = np.zeros(shape)
        self.h = np.zeros((*shape, 0))
        self._rate, self._cycles = self.h, np.zeros(shape)
        self._increment: Callable[[float], np.ndarray] | None = None

    def prepare(self, cycles):
        law, shape = self.law, self.N.shape
        top = max((float(np.max(c[3])) for c in cycles), default=0.0)
        cells = max(int(np.ceil(top / LOAD_GRID)), self.h.shape[-1])
        self.h = np.pad(self.h, ((0, 0), (0, 0), (0, cells - self.h.shape[-1])))
        edges = np.arange(cells + 1) * LOAD_GRID
        rate = np.zeros((self.vehicles, *shape, cells))
        per_mgt = np.zeros(shape)
        for _, r, w, _, _ in cycles:
            per_mgt[r] += w
        if cycles:
            _cell_rates(rate, *(np.array([c[k] for c in cycles]) for k in range(4)), edges)
        total = rate.sum(axis=0)
        self._rate, self._cycles = total, per_mgt
        a = law.alpha + 1
        weight = np.diff(edges**a) / a
        # the cells with cycles, those that grow alike merged (`_merged_cells`)
        by_vehicle = rate.reshape(self.vehicles, -1)
        on, first = _merged_cells(self.h.ravel(), total.ravel(), by_vehicle, cells)
        kept = on[first]
        h, rk, parts, flat = (
            self.h.ravel()[kept],
            total.ravel()[kept],
            by_vehicle[:, kept],
            kept // cells,
        )
        wk = np.add.reduceat(weight[on % cells], first) if on.size else np.zeros(0)
        shares = parts / rk
        base = harmonic(h, law.beta)
        scale = law.gamma / law.M

        def each(dm):
            return scale * wk * (harmonic(h + rk * dm, law.beta) - base)

        def to_seats(values):
            return np.bincount(flat, values, minlength=self.N.size).reshape(shape)

        def total_increment(dm):
            seats = _seat_increment(h, rk, wk, base, flat, float(dm), law.beta, self.N.size)
            return scale * seats.reshape(shape)

        self._increment = lambda dm: np.array([to_seats(s * each(dm)) for s in shares])
        return total_increment

    def advance(self, dm: float) -> np.ndarray:
        assert self._increment is not None, "prepare comes first"
        split = self._increment(dm)
        self.N = self.N + self._cycles * dm
        self.h = self.h + self._rate * dm
        return split

    def restart(self, held, mgt: float) -> None:
        self.h = np.where(np.asarray(held)[..., None], self._rate * mgt, self.h)


def memory(law, shape, vehicles: int) -> Hardening:
    """The accumulator for ``law``: `LoadHistory` for the Varandas law, else `Hardening`."""
    kind = LoadHistory if isinstance(law, VarandasLaw) else Hardening
    return kind(law, shape, vehicles)


class Zoned:
    """One accumulator per zone, each on its own sleepers only.

    Parameters
    ----------
    laws : list of (ndarray, LawParameters)
        Per zone: which sleepers it holds (bool, per sleeper) and its law.
    shape : tuple
        (2 rails, sleepers).
    vehicles : int
        Vehicles of the traffic.
    """

    def __init__(self, laws, shape, vehicles: int):
        self.shape, self.vehicles = shape, vehicles
        held = [(np.flatnonzero(m), law) for m, law in laws]
        self.parts = [(i, memory(law, (shape[0], i.size), vehicles)) for i, law in held if i.size]
        self._whole = len(self.parts) == 1 and self.parts[0][0].size == shape[-1]  # no zones

    @property
    def N(self) -> np.ndarray:
        """Load cycles applied per rail and sleeper [-]."""
        return self._join((i, acc.N) for i, acc in self.parts)

    def _join(self, pieces, lead=()) -> np.ndarray:
        """The zones' values (``pieces``: sleepers, values) on the whole track; a single
        zone's own values when it holds every sleeper (a track without zones)."""
        if self._whole:
            ((_, values),) = pieces
            return values
        out = np.zeros((*lead, *self.shape))
        for i, values in pieces:
            out[..., i] = values
        return out

    def prepare(self, cycles):
        """See `Hardening.prepare`."""
        incs = [(i, acc.prepare([(v, r, w, q[i], k2[i]) for v, r, w, q, k2 in cycles]))
                for i, acc in self.parts]  # fmt: skip
        return lambda dm: self._join((i, inc(dm)) for i, inc in incs)

    def advance(self, dm: float) -> np.ndarray:
        """See `Hardening.advance`."""
        return self._join(((i, acc.advance(dm)) for i, acc in self.parts), (self.vehicles,))

    def restart(self, held, mgt: float) -> None:
        """See `Hardening.restart`."""
        for i, acc in self.parts:
            acc.restart(np.asarray(held)[:, i], mgt)


@njit(cache=True, nogil=True)
def _merged_cells(h, total, rate, cells):
    """The cells of `LoadHistory` with cycles (``total > 0``), as flat indices into its
    (rails, seats, cells) arrays in order, and where each run of cells that grow alike
    starts among them: a rail seat's cells in a row with the same history ``h`` and the
    same cycles per MGT of each vehicle (``rate``, (vehicles, cells of all seats)). The
    cells below every load a seat has carried, most of them, grow alike, so that a run is
    evaluated once, its cells' weights added; the increment is the cells' own to
    round-off. ``h`` and ``total`` are flat, ``cells`` per seat."""
    on, first = np.empty(total.size, np.int64), np.empty(total.size, np.int64)
    m, runs, last = 0, 0, -1
    for i in range(total.size):
        if not total[i] > 0:
            continue
        alike = last >= 0 and i // cells == last // cells and h[i] == h[last]
        for v in range(rate.shape[0]):
            alike = alike and rate[v, i] == rate[v, last]
        if not alike:
            first[runs] = m
            runs += 1
        on[m], m, last = i, m + 1, i
    return on[:m], first[:runs]


@njit(cache=True, nogil=True)
def _cell_rates(rate, vehicle, rail, weight, load, edges):
    """Add each wheel's cycles per MGT to the cells of the load grid its rail-seat load
    reaches, in place: in `LoadHistory`'s ``rate`` (vehicles, rails, seats, cells), wheel
    ``a`` adds ``weight[a]`` times the fraction of each cell of ``edges`` below its load
    ``load[a]`` (per seat) [N], clipped to [0, 1]; the cells at or above the load get
    nothing."""
    for a in range(load.shape[0]):
        v, r, w = vehicle[a], rail[a], weight[a]
        for i in range(load.shape[1]):
            q, out = load[a, i], rate[v, r, i]
            for c in range(out.size):
                if edges[c] >= q:
                    break
                out[c] += w * min((q - edges[c]) / LOAD_GRID, 1.0)


@njit(cache=True, nogil=True)
def _seat_increment(h, rate, weight, base, seat, dm, beta, size):
    """``Σ_cells w_k (S(h_k + r_k ΔM) - S(h_k))`` of each rail seat (`LoadHistory`), the
    cells' seats given by the flat index ``seat`` and ``S(h_k)`` by ``base`` [N^(α+1)]."""
    zeta = hurwitz_zeta(beta, 1.0)
    out = np.zeros(size)
    for i in range(h.size):
        out[seat[i]] += weight[i] * (harmonic_one(h[i] + rate[i] * dm, beta, zeta) - base[i])
    return out
