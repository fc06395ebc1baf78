"""Settlement laws: permanent sleeper settlement against load cycles, and their parameters.

The power, Shenton and Sato laws split into a load factor ``f(Q, k2)`` [-] and a cycle
function ``g(N)`` [m], so that under a constant rail-seat load ``Q`` the settlement after
``N`` cycles is ``e = f(Q, k2) g(N)``. ``g`` is a sum of terms
(`trackdyn.deterioration.hardening`), each with the rule by which mixed traffic adds up on
it (strain hardening: equivalent cycles for a power term), exact for a constant load and
any step sizes. Counting starts at whole cycles: no law settles more for a fraction of a
cycle than that fraction of the first cycle's settlement.

Their load factor: ``f = (Q / Q_ref)^load_exponent (k2 / k_ref)^stiffness_exponent``, with
``k2`` the linearised track stiffness per wheel under the sleeper (``stiffness_exponent =
0`` switches the stiffness scaling off; a negative value lets softer support settle more).
The Varandas law has no stiffness dependence (as published): stiffness acts on it only
through the rail-seat loads; a zone's own parameters (`trackdyn.deterioration.zones`) carry
what a structure or an approach does to it.

============  =========================================  ===========================
law           ``g(N)``                                   own parameters
============  =========================================  ===========================
``power``     ``K_s N^beta``                             ``K_s`` [m], ``beta`` [-]
``shenton``   ``k1 N^0.2 + k2 N``                        ``k1`` [m], ``k2`` [m/cycle]
``sato``      ``gamma (1 - exp(-alpha N)) + beta N``     ``gamma`` [m], ``alpha``
                                                         [1/cycle], ``beta`` [m/cycle]
============  =========================================  ===========================

(Shenton's ``k2`` is his settlement rate per cycle, not the track stiffness.) Parameter
files give ``value``, ``unit`` and ``source`` for each parameter, one table per law; the
shipped ``settlement.toml`` holds illustrative values that are not calibrated. A parameter
may also give ``min`` and ``max`` (in its ``unit``): the range `trackdyn calibrate` may fit
it in; the model itself does not use them. Reading parameter files:
`trackdyn.deterioration.law_files`.

References
----------
Shenton, M.J. (1985). Ballast deformation and track deterioration. In: Track
Technology, Thomas Telford, London, 253-265.

Sato, Y. (1995). Japanese studies on deterioration of ballasted track. Vehicle System
Dynamics 24 (suppl.), 197-208.

Varandas, J.N., Hölscher, P., Silva, M.A.G. (2014). Settlement of ballasted track under
traffic loading: application to transition zones. Proc. IMechE Part F 228(3), 242-259.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np
from numba import njit

from trackdyn.deterioration.hardening import Consolidation, Power
from trackdyn.errors import TrackdynInputError

COMMON = {"Q_ref": "N", "load_exponent": "-", "k_ref": "N/m", "stiffness_exponent": "-"}
"""Parameters of the load and stiffness factor, shared by all laws, and their SI units."""


@dataclass(frozen=True, kw_only=True)
class LawParameters:
    """Base of all laws: checks that every parameter is a finite number in range."""

    units: ClassVar[dict[str, str]] = {}
    """The law's own parameters and their SI units."""
    common: ClassVar[dict[str, str]] = {}
    """Parameters shared with other laws and their SI units."""
    positive: ClassVar[tuple[str, ...]] = ()
    non_negative: ClassVar[tuple[str, ...]] = ()

    @property
    def load_sensitivity(self) -> float:
        """``d ln e / d ln Q`` for a load on fresh ballast [-]: how strongly settlement
        follows the rail-seat load (sets the loop's stable step, `trackdyn.deterioration.loop`)."""
        raise NotImplementedError

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise TrackdynInputError(f"settlement parameter {f.name} must be a number")
            if not math.isfinite(value):
                raise TrackdynInputError(f"settlement parameter {f.name} must be finite")
        for name in self.positive:
            if getattr(self, name) <= 0:
                raise TrackdynInputError(f"settlement parameter {name} must be > 0")
        for name in self.non_negative:
            if getattr(self, name) < 0:
                raise TrackdynInputError(f"settlement parameter {name} must be >= 0")


@dataclass(frozen=True, kw_only=True)
class SettlementLaw(LawParameters):
    """Base of the laws ``e = f(Q, k2) g(N)``: the load and stiffness factor; subclasses
    add ``g(N)``.

    Parameters
    ----------
    Q_ref : float
        Reference rail-seat load [N].
    load_exponent : float
        Exponent of the load ratio ``Q / Q_ref`` [-].
    k_ref : float
        Reference track stiffness per wheel [N/m].
    stiffness_exponent : float
        Exponent of the stiffness ratio ``k2 / k_ref`` [-].
    """

    Q_ref: float
    load_exponent: float
    k_ref: float
    stiffness_exponent: float

    common: ClassVar[dict[str, str]] = COMMON

    def __post_init__(self):
        super().__post_init__()
        for name in ("Q_ref", "k_ref"):
            if getattr(self, name) <= 0:
                raise TrackdynInputError(f"settlement parameter {name} must be > 0")

    @property
    def load_sensitivity(self) -> float:
        """See `LawParameters.load_sensitivity`: ``load_exponent``."""
        return self.load_exponent

    def load_factor(self, Q, k2):
        """``f(Q, k2) = (Q/Q_ref)^load_exponent (k2/k_ref)^stiffness_exponent`` [-].

        Parameters
        ----------
        Q : array_like
            Rail-seat (sleeper-ballast) load [N]; negative values count as zero.
        k2 : array_like
            Track stiffness per wheel over the sleeper [N/m].
        """
        q = np.maximum(np.asarray(Q, dtype=float), 0.0) / self.Q_ref
        k = np.asarray(k2, dtype=float) / self.k_ref
        return q**self.load_exponent * k**self.stiffness_exponent

    @property
    def terms(self) -> tuple:
        """The terms of ``g(N)`` (`trackdyn.deterioration.hardening`), which also say how
        mixed traffic adds up on them."""
        raise NotImplementedError

    def cycles(self, N):
        """Settlement at the reference load and stiffness after ``N`` cycles, ``g(N)`` [m].

        Increasing, with ``g(0) = 0``; counted from whole cycles (linear over the first).

        Parameters
        ----------
        N : array_like
            Cumulative number of load cycles [-].
        """
        return sum(term.curve(N) for term in self.terms)


@dataclass(frozen=True, kw_only=True)
class PowerLaw(SettlementLaw):
    """``e = K_s (Q/Q_ref)^α (k2/k_ref)^γ N^β`` (α = load_exponent, γ = stiffness_exponent).

    Parameters
    ----------
    K_s : float
        Settlement after one cycle at the reference load and stiffness [m].
    beta : float
        Exponent of the number of cycles, 0 < beta <= 1 [-].
    """

    K_s: float
    beta: float
    units: ClassVar[dict[str, str]] = {"K_s": "m", "beta": "-"}
    positive: ClassVar[tuple[str, ...]] = ("K_s", "beta")

    def __post_init__(self):
        super().__post_init__()
        if self.beta > 1:
            raise TrackdynInputError("settlement parameter beta must be <= 1")

    @property
    def terms(self):
        """See `SettlementLaw.terms`: ``K_s N^beta``."""
        return (Power(self.K_s, self.beta),)


@dataclass(frozen=True, kw_only=True)
class ShentonLaw(SettlementLaw):
    """Shenton: ``e = (k1 N^0.2 + k2 N) (Q/Q_ref)^α (k2_track/k_ref)^γ``.

    ``Q_ref``, ``load_exponent`` (α), ``k_ref`` and ``stiffness_exponent`` (γ) as in
    `SettlementLaw`.

    Parameters
    ----------
    k1 : float
        Coefficient of ``N^0.2`` [m].
    k2 : float
        Settlement rate per cycle of the linear term [m/cycle].
    """

    k1: float
    k2: float
    units: ClassVar[dict[str, str]] = {"k1": "m", "k2": "m/cycle"}
    positive: ClassVar[tuple[str, ...]] = ("k1",)
    non_negative: ClassVar[tuple[str, ...]] = ("k2",)

    @property
    def terms(self):
        """See `SettlementLaw.terms`: ``k1 N^0.2`` and ``k2 N``."""
        return (Power(self.k1, 0.2), Power(self.k2, 1.0))


@dataclass(frozen=True, kw_only=True)
class SatoLaw(SettlementLaw):
    """Sato: ``e = (gamma (1 - exp(-alpha N)) + beta N) (Q/Q_ref)^α_Q (k2/k_ref)^γ_k``.

    ``Q_ref``, ``load_exponent`` (α_Q), ``k_ref`` and ``stiffness_exponent`` (γ_k) as in
    `SettlementLaw`.

    Parameters
    ----------
    gamma : float
        Initial (consolidation) settlement [m].
    alpha : float
        Rate of the initial settlement per cycle [1/cycle].
    beta : float
        Settlement rate per cycle of the linear term [m/cycle].
    """

    gamma: float
    alpha: float
    beta: float
    units: ClassVar[dict[str, str]] = {"gamma": "m", "alpha": "1/cycle", "beta": "m/cycle"}
    positive: ClassVar[tuple[str, ...]] = ("gamma", "alpha")
    non_negative: ClassVar[tuple[str, ...]] = ("beta",)

    @property
    def terms(self):
        """See `SettlementLaw.terms`: ``gamma (1 - exp(-alpha N))`` and ``beta N``."""
        return (Consolidation(self.gamma, self.alpha), Power(self.beta, 1.0))


def harmonic(h, beta: float):
    """``S(h) = sum_{n=1}^{h} n^(-beta)``, continued to real ``h >= 0`` [-].

    ``S(h) = zeta(beta) - zeta(beta, h + 1)`` with the Hurwitz zeta function, from its
    Euler-Maclaurin expansion after shifting the argument to 9 or more (error below 1e-9
    relative for ``0 < beta < 1``); below one cycle ``S(h) = h``, linear up to the first
    cycle (counting starts at whole cycles). Compiled: the Varandas law's increment
    evaluates it on every cell of every rail seat's load histogram at each trial step.

    Parameters
    ----------
    h : array_like
        Number of cycles, >= 0 [-].
    beta : float
        Exponent, 0 < beta < 1 [-].
    """
    h = np.asarray(h, dtype=float)
    return _harmonic(h.ravel(), float(beta)).reshape(h.shape)


@njit(cache=True, nogil=True)
def _harmonic(h, beta):
    """`harmonic` of a flat array."""
    zeta = hurwitz_zeta(beta, 1.0)
    out = np.empty(h.size)
    for i in range(h.size):
        out[i] = harmonic_one(h[i], beta, zeta)
    return out


@njit(cache=True, nogil=True)
def harmonic_one(h: float, beta: float, zeta: float) -> float:
    """`harmonic` of one ``h``, compiled; ``zeta`` is ``hurwitz_zeta(beta, 1)`` [-]."""
    return h if h < 1.0 else zeta - hurwitz_zeta(beta, h + 1.0)


@njit(cache=True, nogil=True)
def hurwitz_zeta(s: float, a: float) -> float:
    """Hurwitz zeta ``zeta(s, a)`` for 0 < s < 1, a >= 1, by analytic continuation
    (compiled; see `harmonic`)."""
    shift = 0.0
    if a < 9.0:
        for _ in range(9):
            shift += a**-s
            a += 1.0
    inv2 = a**-2.0
    tail = a**-s * (a / (s - 1) + 0.5 + (s / 12) / a * (1 - inv2 * ((s + 1) * (s + 2) / 60
                    - inv2 * (s + 1) * (s + 2) * (s + 3) * (s + 4) / 2520)))  # fmt: skip
    return tail + shift


@dataclass(frozen=True, kw_only=True)
class VarandasLaw(LawParameters):
    """Varandas et al. (2014): settlement per cycle driven by loads above those seen.

    The settlement of cycle ``n`` with peak load ``F_n`` is
    ``du = (gamma / M) int_0^F_n F^alpha (1 / (h(F) + 1))^beta dF`` with ``h(F)`` the
    number of earlier cycles whose peak reached ``F``, and
    ``M = F0^(alpha + 1) / (alpha + 1) S(N0)``, ``S`` the `harmonic` sum; so ``N0`` cycles
    of ``F0`` settle ``gamma``, and ``N`` cycles of a constant ``F`` settle
    ``gamma (F/F0)^(alpha + 1) S(N) / S(N0)``. A load below all earlier ones adds little,
    one above them adds as on fresh ballast. Integrated over tonnage steps by
    `trackdyn.deterioration.accumulation.LoadHistory`.

    Parameters
    ----------
    alpha : float
        Load exponent of the integrand [-].
    beta : float
        Cycle exponent, 0 < beta < 1 [-].
    gamma : float
        Settlement after ``N0`` cycles of ``F0`` [m].
    F0 : float
        Reference load [N].
    N0 : float
        Reference number of cycles [-].

    References
    ----------
    Varandas, J.N., Hölscher, P., Silva, M.A.G. (2014). Settlement of ballasted track under
    traffic loading: application to transition zones. Proceedings of the Institution of
    Mechanical Engineers, Part F: Journal of Rail and Rapid Transit 228(3), 242-259.
    """

    alpha: float
    beta: float
    gamma: float
    F0: float
    N0: float
    units: ClassVar[dict[str, str]] = {"alpha": "-", "beta": "-", "gamma": "m", "F0": "N",
                                       "N0": "-"}  # fmt: skip
    positive: ClassVar[tuple[str, ...]] = ("beta", "gamma", "F0", "N0")
    non_negative: ClassVar[tuple[str, ...]] = ("alpha",)

    @property
    def load_sensitivity(self) -> float:
        """See `LawParameters.load_sensitivity`: ``alpha + 1`` (settlement of ``N`` equal
        cycles goes as ``F^(alpha + 1)``)."""
        return self.alpha + 1.0

    def __post_init__(self):
        super().__post_init__()
        if self.beta >= 1:
            raise TrackdynInputError("settlement parameter beta must be < 1")

    @property
    def M(self) -> float:
        """Normalising constant ``F0^(alpha + 1) / (alpha + 1) S(N0)`` [N^(alpha + 1)]."""
        a = self.alpha + 1
        return float(self.F0**a / a * harmonic(self.N0, self.beta))


LAWS: dict[str, type[LawParameters]] = {
    "power": PowerLaw,
    "shenton": ShentonLaw,
    "sato": SatoLaw,
    "varandas": VarandasLaw,
}
"""Registry of settlement laws by name; add an entry to plug in another law."""
