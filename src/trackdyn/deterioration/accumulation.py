"""Settlement accumulated over tonnage steps, per rail and sleeper, with the law's memory.

A step's load cycles are the wheels of the traffic: each with its rail-seat load at every
sleeper of its rail [N] and its cycles per MGT [-]. `prepare` takes them and returns the
settlement increment as a function of the step length ``ΔM`` [MGT], in closed form for
loads held over the step (so the loop can choose the step); `advance` then applies the
step to the law's memory.

- `TimeHardening` (power, Shenton, Sato laws): the memory is the cycle count ``N``;
  ``Δe = Σ_j (n_j / Σ n) f(Q_j, k2) (g(N + ΔN) - g(N))``, the cycle-weighted mean load
  factor times the advance on the cycle curve (for one load level, the time-hardening
  rule).
- `LoadHistory` (Varandas law): the memory is ``h(F)``, the cycles whose peak reached ``F``,
  on a load grid of `LOAD_GRID` cells. Over a step the wheels interleave, so ``h`` grows
  at ``r(F) = Σ_j n_j [Q_j >= F]`` per MGT and the settlement is
  ``(gamma / M) Σ_cells w_k (S(h_k + r_k ΔM) - S(h_k))``, with ``w_k`` the integral of
  ``F^alpha`` over cell ``k`` and ``S`` the harmonic sum: the per-cycle law summed exactly
  for loads on the grid points (a load inside a cell counts that cell's fraction).
"""

from __future__ import annotations

import numpy as np

from trackdyn.deterioration.settlement import VarandasLaw, harmonic, time_hardening_increment

LOAD_GRID = 500.0
"""Cell width of the load histogram of `LoadHistory` [N]."""


class TimeHardening:
    """Memory of the ``f(Q, k2) g(N)`` laws: the cycles applied per rail and sleeper.

    Parameters
    ----------
    law : SettlementLaw
        The law.
    shape : tuple
        (2 rails, sleepers).
    """

    def __init__(self, law, shape):
        self.law, self.N = law, np.zeros(shape)
        self._cycles = np.zeros(shape)

    def prepare(self, cycles):
        """Increment [m] as a function of the step [MGT] for ``cycles``.

        Parameters
        ----------
        cycles : list of (int, float, ndarray, ndarray)
            Per wheel: rail index, cycles per MGT [-], rail-seat load per sleeper [N] and
            track stiffness per sleeper [N/m].
        """
        shape = self.N.shape
        weighted, per_mgt = np.zeros(shape), np.zeros(shape)
        for r, w, q, k2 in cycles:
            weighted[r] += w * self.law.load_factor(q, k2)
            per_mgt[r] += w
        factor = np.divide(weighted, per_mgt, out=np.zeros(shape), where=per_mgt > 0)
        self._cycles = per_mgt
        N = self.N
        return lambda dm: time_hardening_increment(self.law, factor, N, per_mgt * dm)

    def advance(self, dm: float):
        """Apply a step of ``dm`` [MGT] with the cycles last prepared."""
        self.N = self.N + self._cycles * dm


class LoadHistory(TimeHardening):
    """Memory of the Varandas law: the load histogram ``h(F)`` per rail and sleeper.

    Parameters
    ----------
    law : VarandasLaw
        The law.
    shape : tuple
        (2 rails, sleepers).
    """

    def __init__(self, law: VarandasLaw, shape):
        super().__init__(law, shape)
        self.h = np.zeros((*shape, 0))
        self._rate = self.h

    def prepare(self, cycles):
        law, shape = self.law, self.N.shape
        top = max((float(np.max(q)) for _, _, q, _ in cycles), default=0.0)
        cells = max(int(np.ceil(top / LOAD_GRID)), self.h.shape[-1])
        self.h = np.pad(self.h, ((0, 0), (0, 0), (0, cells - self.h.shape[-1])))
        edges = np.arange(cells + 1) * LOAD_GRID
        rate, per_mgt = np.zeros((*shape, cells)), np.zeros(shape)
        for r, w, q, _ in cycles:
            rate[r] += w * np.clip((q[:, None] - edges[:-1]) / LOAD_GRID, 0.0, 1.0)
            per_mgt[r] += w
        self._rate, self._cycles = rate, per_mgt
        a = law.alpha + 1
        weight = np.diff(edges**a) / a
        on = np.nonzero(rate > 0)
        h, rk, wk = self.h[on], rate[on], weight[on[-1]]
        flat = np.ravel_multi_index(on[:2], shape)
        base = harmonic(h, law.beta)
        scale = law.gamma / law.M

        def increment(dm):
            each = wk * (harmonic(h + rk * dm, law.beta) - base)
            return scale * np.bincount(flat, each, minlength=self.N.size).reshape(shape)

        return increment

    def advance(self, dm: float):
        super().advance(dm)
        self.h = self.h + self._rate * dm


def memory(law, shape) -> TimeHardening:
    """The accumulator for ``law``: `LoadHistory` for the Varandas law, else `TimeHardening`."""
    return LoadHistory(law, shape) if isinstance(law, VarandasLaw) else TimeHardening(law, shape)
