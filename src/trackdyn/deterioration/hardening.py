"""Cycle terms of the settlement laws and how mixed traffic adds up on them.

A law ``e = f(Q, k2) g(N)`` has a cycle curve ``g`` that is a sum of terms. Each term says
how the cycles of mixed traffic add up on it, so that adding a vehicle at any load never
lowers settlement (where the cycle-weighted mean load factor times the curve of the total
cycle count let light vehicles dilute heavy ones):

========================  ===========================================================
term                      cycles ``n_j`` [per MGT] of load factor ``f_j``
========================  ===========================================================
`Power` ``c N^b``         equivalent cycles: cycles of ``Q`` count as ``N (Q/Q_ref)^(α/b)``
                          cycles of ``Q_ref`` (α the load exponent), so held loads settle
                          ``c (Σ_j N_j f_j^(1/b))^b``. Over steps: time hardening on the
                          cycles of all vehicles ``N = Σ N_j`` with the factor of the mix
                          ``f = (Σ_j p_j f_j^(1/b))^b``, ``p_j`` the shares of the cycles
                          (the same closed form for held loads, and an increment that
                          follows the load as ``Q^α``, so the loop's stable step holds).
                          ``b = 1`` is a linear term, ``e = c Σ_j N_j f_j``.
`Consolidation`           strain hardening: ``de/dN = a (f γ - e)`` for each load while
``γ (1 - exp(-a N))``     ``e < f γ``: a load consolidates the ballast towards its own
                          asymptote ``f γ`` and no further; piecewise exponential in
                          closed form, exact for held loads.
========================  ===========================================================

Counting starts at whole cycles: below one (equivalent) cycle a power term grows linearly
to its first cycle's settlement, so a fraction ``x`` of a cycle settles ``x c``, not
``x^b c`` (which for ``b = 0.2`` makes 0.08 of a cycle settle 0.6 of a whole one).

References
----------
Stewart, H.E. (1986). Permanent strains from cyclic variable-amplitude loadings. Journal of
Geotechnical Engineering 112(6), 646-660 (superposition of cyclic permanent strain under
loads of different amplitude, tested on ballast: the equivalent-cycle idea).

Li, D., Selig, E.T. (1996). Cumulative plastic deformation for fine-grained subgrade
soils. Journal of Geotechnical Engineering 122(12), 1006-1013 (power laws in ``N`` with a
stress exponent, and equivalent cycles for mixed traffic).

Shenton, M.J. (1985). Ballast deformation and track deterioration. In: Track Technology,
Thomas Telford, London, 253-265.

Sato, Y. (1995). Japanese studies on deterioration of ballasted track. Vehicle System
Dynamics 24 (suppl.), 197-208.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def whole_cycles(N, b: float):
    """``N^b`` for ``N >= 1``, ``N`` below one cycle (linear up to the first cycle) [-].

    Parameters
    ----------
    N : array_like
        Cycles, >= 0 [-].
    b : float
        Exponent, 0 < b <= 1 [-].
    """
    n = np.asarray(N, dtype=float)
    return np.where(n < 1.0, n, np.maximum(n, 1.0) ** b)


@dataclass(frozen=True)
class Power:
    """The term ``c N^b`` (``b = 1``: linear), counted from whole cycles (`whole_cycles`).

    Parameters
    ----------
    c : float
        Settlement of the first cycle at the reference load [m].
    b : float
        Exponent, 0 < b <= 1 [-].
    """

    c: float
    b: float

    def curve(self, N):
        """``c N^b`` [m] of ``N`` cycles at the reference load."""
        return self.c * whole_cycles(N, self.b)

    def start(self, shape):
        """The state before any traffic: cycles of all vehicles, zero."""
        return np.zeros(shape)

    def prepare(self, state, classes):
        """Increment [m] against the step [MGT], and each class's share of it.

        Parameters
        ----------
        state : ndarray
            Cycles so far, per rail and sleeper [-].
        classes : list of (ndarray, ndarray)
            Per load class: cycles per MGT [-] and load factor [-], per rail and sleeper.

        Returns
        -------
        increment : callable
            ``dm`` [MGT] -> (increment [m], new state).
        shares : list of ndarray
            Each class's fraction of the increment [-].
        """
        shape = np.shape(state)
        # f^(1/b) where the class has cycles only (a wheel loads one rail): n * f^(1/b) is 0
        # elsewhere all the same
        each = [n * np.power(np.asarray(f, dtype=float), 1.0 / self.b, out=np.zeros(shape),
                             where=np.asarray(n) != 0) for n, f in classes]  # fmt: skip
        equivalent = sum(each, np.zeros(shape))
        rate = sum((n for n, _ in classes), np.zeros(shape))
        mix = np.divide(equivalent, rate, out=np.zeros(shape), where=rate > 0) ** self.b
        base = self.curve(state)

        def increment(dm):
            new = state + rate * dm
            return mix * (self.curve(new) - base), new

        return increment, _fractions(each, equivalent)


@dataclass(frozen=True)
class Consolidation:
    """The term ``γ (1 - exp(-a N))``: consolidation towards ``f γ`` under load factor ``f``.

    Parameters
    ----------
    gamma : float
        Consolidation settlement at the reference load [m].
    a : float
        Rate per cycle [1/cycle].
    """

    gamma: float
    a: float

    def curve(self, N):
        """``γ (1 - exp(-a N))`` [m] of ``N`` cycles at the reference load."""
        return -self.gamma * np.expm1(-self.a * np.asarray(N, dtype=float))

    def start(self, shape):
        """The state before any traffic: the term's settlement, zero [m]."""
        return np.zeros(shape)

    def prepare(self, state, classes):
        """As `Power.prepare`, with the term's settlement so far [m] as the state.

        Each load class ``j`` (target ``t_j = f_j γ``, ``n_j`` cycles per MGT) drives the
        settlement at ``a n_j (t_j - e)`` per MGT while ``e < t_j``. With the classes
        sorted by target, the active ones are the top ``k``: ``e`` relaxes to their
        weighted mean target at rate ``a Σ n``, until it reaches the ``k``-th target,
        which then drops out.
        """
        shape = np.shape(state)
        if not classes:
            return (lambda dm: (np.zeros(shape), state)), []
        n = np.array([np.broadcast_to(c[0], shape) for c in classes], dtype=float)
        t = self.gamma * np.array([np.broadcast_to(c[1], shape) for c in classes], dtype=float)
        order = np.argsort(-t, axis=0)
        t, n = np.take_along_axis(t, order, 0), np.take_along_axis(n, order, 0)
        weight = np.cumsum(n, axis=0)  # active classes' cycles per MGT, top k
        mean = np.divide(np.cumsum(n * t, axis=0), weight, out=t.copy(), where=weight > 0)
        each = [c[0] * np.maximum(self.gamma * c[1] - state, 0.0) for c in classes]

        def increment(dm):
            e, left = np.array(state, dtype=float), np.full(shape, float(dm))
            for k in range(len(classes) - 1, -1, -1):  # from all classes active down to one
                active = (e < t[k]) & (left > 0)
                lam = self.a * weight[k]
                target = mean[k]
                floor = t[k + 1] if k + 1 < len(classes) else np.full(shape, -np.inf)
                on = active & (e >= floor) & (lam > 0)
                # time to reach t[k] (then class k drops out), infinite when t[k] = mean
                gap = np.where(on, target - e, 1.0)
                rest = np.where(on, target - t[k], 0.0)
                tau = np.full(shape, np.inf)
                reach = on & (rest > 0) & (gap > rest)
                tau[reach] = np.log(gap[reach] / rest[reach]) / lam[reach]
                run = np.where(on, np.minimum(tau, left), 0.0)
                e = np.where(on, target - (target - e) * np.exp(-lam * run), e)
                e = np.where(on & (tau <= left), t[k], e)
                left = left - run
            return e - state, e

        return increment, _fractions(each, sum(each, np.zeros(shape)))


def _fractions(each, total) -> list:
    """Each part's fraction of ``total`` (0 where the total is 0)."""
    return [np.divide(p, total, out=np.zeros(np.shape(total)), where=total > 0) for p in each]
