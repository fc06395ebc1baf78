"""Ballast under a void: a hanging sleeper that strikes its ballast settles faster.

An option of the deterioration loop (`LoopOptions.voids`, the ``[settlement] voids`` key;
off by default, and then nothing here runs). Its parameters are the ``[voids]`` table of
the settlement parameter file (`load_voids`), every one illustrative, not calibrated.

The rule. A sleeper that hangs from the rail at rest by ``g`` [m] (the gap under it,
`BallastState.hanging_gap`) and that a passage presses onto its ballast (its rail-seat
load in the passage above zero: the loaded rail closes the gap) strikes the ballast once
per wheel; its settlement per cycle is the law's (with its own, smaller rail-seat load)
times the impact factor

    F(g) = 1 + a (g / g_ref)^n          for g <= g_ref,
    F(g) = 1 + a (g_max - g) / (g_max - g_ref)   for g_ref < g < g_max,   1 beyond,

``a`` = ``amplification`` [-], ``g_ref`` = ``gap_ref`` [m], ``n`` = ``exponent`` [-],
``g_max`` = ``max_depth`` [m]. Why this form: the sleeper meets the ballast when the rail,
coming down ahead of the wheel, has closed the gap, with the velocity of the rail there;
the rail's deflection line ahead of a wheel falls exponentially (``e^(-x/L_c)``), so the
sleeper's velocity at contact grows with the gap it closes and the impact's energy, which
does the extra work on the ballast, about with its square; a small gap is closed far
ahead of the wheel, slowly, hence the steeper shipped ``n = 4``, which leaves voids below
about 1 mm to close as the load-driven law closes them (with ``n = 2`` the sub-millimetre
gaps of a settlement-rate field grew too). A sleeper that a passage does not press down
(the gap larger than the loaded rail can close) does not strike: its load is zero, and so
is its settlement whatever the factor. Voids grow through the impact when the gap closes
(Sysyn et al. 2021, abstract); the voided sleeper sheds load to its neighbours (about +70
% on the adjacent sleeper for a 1 mm void, Lundqvist & Dahlberg 2005, abstract).

Bounds (why it cannot run away; an earlier parameter-free attempt dug a 240 mm hole):

1. the factor is capped: ``F <= 1 + a`` for any gap, looseness included (21 with the
   shipped values);
2. the void's growth saturates: beyond ``g_ref`` the factor falls, to 1 at ``g_max``, and
   the voided sleeper's load falls as its gap grows (the rail beam carries the wheel on
   its neighbours); the void grows while ``F(g) (Q_v / Q_n)^α`` exceeds 1 (``Q_v``, ``Q_n``
   the voided sleeper's and its neighbours' loads, ``α`` the law's load exponent) and
   shrinks beyond, so that it tends to a depth below ``g_max`` (on 100 kN/mm track under a
   127.5 kN wheel the rail beam gives ``Q_v / Q_n`` = 0.44 at 1 mm and 0.23 at 1.5 mm, so
   ``(1 / 0.23)^2`` = 19.6 ≈ ``1 + a`` holds a void of about ``g_ref`` = 1.5 mm, the depth
   at which an iterative vehicle-track study finds voids "stable", abstract in the
   project's reference notes); no gap grows past ``g_max`` by the impact (3 mm shipped);
3. a load update within a step moves no sleeper by more than `VOID_GAIN` times
   ``F / |dF/dg|``, so the factor held over it is within half of its value at the end.

What is not bounded by the rule: a persistent void's neighbours carry more and settle
more, so a void spreads along the track (measured on 120 m of level track from one 1.5 mm
void, 4-DOF model, the example's loaded wagon: 9 sleepers hanging at 10 MGT, 11 at 50
MGT, the settlement there 21.0 mm against 8.7 mm of open track), as the load-driven law
makes any soft spot spread.

Tamping and voids. A tamping packs the ballast under the sleepers it lifts, so their
voids close (`Ballast.tamp`), but the ballast under a sleeper that hung keeps a part,
``memory`` [-], of its looseness: the tamped sleeper's factor is ``1 + memory (F - 1)``
(``F`` its factor when tamped), decaying with the traffic as ``e^(-ΔM/looseness_mgt)``,
so that a group of hanging sleepers, tamped, settles faster than its neighbours again and
hangs again sooner than open track (a group of hanging sleepers was not effectively
rectified by tamping: Le Pen et al., field monitoring at a level crossing).

Closed form (`void_depth`): with the neighbours held and the loads held, a void deepens by
``dg = F(g) de`` for the law's settlement ``de`` of the sleeper: below ``g_ref`` the
settlement to deepen it is ``∫ dg / F`` (`rising_settlement`, a hypergeometric function;
``(g_ref/√a) arctan(√a g/g_ref)`` for ``n = 2``), on the falling flank ``g_max - g``
decays exponentially to 0, and beyond ``g_max`` the void deepens as the sleeper settles.

References
----------
Sysyn, M. et al. (2021). Sustainability 13, 7740.

Lundqvist, A., Dahlberg, T. (2005). Load impact on railway track due to unsupported
sleepers. Proc. IMechE Part F 219(2), 67-77.
"""

from __future__ import annotations

import numpy as np
from pydantic import ConfigDict, Field, model_validator
from scipy.optimize import brentq
from scipy.special import hyp2f1

from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_toml
from trackdyn.strict import Strict
from trackdyn.units import si_value

TABLE = "voids"
"""The table of the settlement parameter file that holds the parameters."""

UNITS = {
    "amplification": "-",
    "gap_ref": "m",
    "exponent": "-",
    "max_depth": "m",
    "memory": "-",
    "looseness_mgt": "MGT",
}
"""The parameters and the units they are read in."""

VOID_GAIN = 0.5
"""Largest ``Δg (dF/dg) / F`` of a load update at a voided sleeper [-] (bound 3)."""


class VoidParameters(Strict):
    """The parameters of ballast under a void (SI units; `load_voids` reads them).

    Parameters
    ----------
    amplification : float
        ``a``: the impact factor's rise at and beyond ``gap_ref`` [-].
    gap_ref : float
        ``g_ref``: the gap closed per passage at which the factor reaches ``1 + a`` [m].
    memory : float
        Part of the looseness ``F - 1`` the ballast keeps through a tamping [-].
    exponent : float
        ``n``: the factor's rise with the gap, ``(g / g_ref)^n`` below ``g_ref``, >= 1 [-].
    max_depth : float
        ``g_max``: the gap beyond which a sleeper no longer strikes harder than seated
        ballast settles (the factor falls from ``1 + a`` at ``g_ref`` to 1 there), > ``g_ref``
        [m].
    looseness_mgt : float
        Traffic over which the kept looseness decays by ``1/e`` [MGT].
    """

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    amplification: float = Field(ge=0.0)
    gap_ref: float = Field(gt=0.0)
    exponent: float = Field(ge=1.0)
    max_depth: float
    memory: float = Field(ge=0.0, le=1.0)
    looseness_mgt: float = Field(gt=0.0)

    @model_validator(mode="after")
    def _deeper(self):
        if not self.max_depth > self.gap_ref:
            raise ValueError("max_depth must be larger than gap_ref")
        return self


def load_voids(path=None) -> VoidParameters:
    """The ``[voids]`` table of a settlement parameter file, each parameter within its
    ``min`` and ``max``.

    Parameters
    ----------
    path : path, optional
        The file; default the shipped illustrative one.
    """
    from trackdyn.deterioration.law_files import DEFAULT_FILE

    where = str(path) if path is not None else "settlement.toml (shipped)"
    table = read_toml(path if path is not None else DEFAULT_FILE).get(TABLE)
    if not isinstance(table, dict):
        raise TrackdynInputError(f"{where}: no table [{TABLE}] for voids = true")
    unknown = sorted(set(table) - set(UNITS) - {"description"})
    if unknown:
        raise TrackdynInputError(f"{where}: [{TABLE}] unknown parameter {unknown[0]!r}")
    values = {}
    for key, unit in UNITS.items():
        entry = table.get(key)
        if not isinstance(entry, dict) or not {"min", "max"} <= set(entry):
            raise TrackdynInputError(f"{where}: [{TABLE}] {key} needs value, unit, min, "
                                     "max and source")  # fmt: skip
        base = {k: v for k, v in entry.items() if k not in ("min", "max")}
        value, lo, hi = (si_value({**base, "value": entry[b]}, key, unit, where)
                         for b in ("value", "min", "max"))  # fmt: skip
        if not lo <= value <= hi:
            bounds = f"min {entry['min']} and max {entry['max']}"
            raise TrackdynInputError(
                f"{where}: [{TABLE}] {key} = {entry['value']} is outside its {bounds}"
            )
        values[key] = value
    try:
        return VoidParameters(**values)
    except ValueError as exc:
        raise TrackdynInputError(f"{where}: [{TABLE}] {str(exc).splitlines()[-1]}") from None


def impact_factor(gap, p: VoidParameters) -> np.ndarray:
    """The impact factor ``F(g)`` of the gap ``g`` closed per passage [m] (module
    docstring) [-]."""
    g = np.asarray(gap, dtype=float)
    rising = (np.minimum(g, p.gap_ref) / p.gap_ref) ** p.exponent
    falling = np.clip((p.max_depth - g) / (p.max_depth - p.gap_ref), 0.0, 1.0)
    return 1.0 + p.amplification * np.where(g <= p.gap_ref, rising, falling)


def impact_slope(gap, p: VoidParameters) -> np.ndarray:
    """``dF/dg`` of `impact_factor` [1/m]."""
    g = np.asarray(gap, dtype=float)
    n = p.exponent
    rising = n * p.amplification * (np.minimum(g, p.gap_ref) / p.gap_ref) ** (n - 1) / p.gap_ref
    falling = -p.amplification / (p.max_depth - p.gap_ref)
    return np.where(g <= p.gap_ref, rising, np.where(g < p.max_depth, falling, 0.0))


def impact_gap(hanging_gap, peak) -> np.ndarray:
    """The gap each sleeper closes per passage [m]: its gap at rest ``hanging_gap`` [m]
    where a passage presses it onto the ballast (its largest rail-seat load ``peak`` [N]
    above zero), else 0."""
    return np.where(np.asarray(peak) > 0, hanging_gap, 0.0)


def rising_settlement(g0: float, g: float, p: VoidParameters) -> float:
    """The law's settlement [m] that deepens a void from ``g0`` to ``g`` [m], both at most
    ``g_ref``, neighbours and loads held: ``∫ dg / F(g) = g_ref [x 2F1(1, 1/n; 1 + 1/n;
    -a x^n)]`` between ``x = g/g_ref`` of the two (Gauss's hypergeometric function)."""
    n, a, r = p.exponent, p.amplification, p.gap_ref

    def primitive(x):
        return x * hyp2f1(1.0, 1.0 / n, 1.0 + 1.0 / n, -a * x**n)

    return float(r * (primitive(g / r) - primitive(g0 / r)))


def void_depth(g0: float, settlement, p: VoidParameters) -> np.ndarray:
    """Void depth [m] after the law's settlement ``settlement`` [m] of the voided sleeper,
    from ``g0`` [m], the neighbours and the loads held: ``dg = F(g) de`` solved in closed
    form, piece by piece (module docstring; below ``g_ref``, `rising_settlement` inverted).
    """
    e = np.atleast_1d(np.asarray(settlement, dtype=float))
    a, r, top = p.amplification, p.gap_ref, p.max_depth
    if a == 0:
        return np.reshape(g0 + e, np.shape(settlement))
    b = a / (top - r)
    low = min(g0, r)
    to_ref = rising_settlement(low, r, p)
    rising = np.array([r if x >= to_ref else low if x <= 0 else
                       brentq(lambda g, x=x: rising_settlement(low, g, p) - x, low, r,
                              xtol=1e-16, rtol=1e-13) for x in e])  # fmt: skip
    # falling: u = top - g, du/de = -(1 + b u): u = (u0 + 1/b) e^(-b e) - 1/b down to 0
    u0 = top - max(min(g0, top), r)
    to_top = np.log1p(b * u0) / b
    e2 = np.clip(e - to_ref, 0.0, to_top)
    falling = top - ((u0 + 1 / b) * np.exp(-b * e2) - 1 / b)
    beyond = max(g0, top) + np.maximum(e - to_ref - to_top, 0.0)
    out = np.where(e < to_ref, rising, np.where(e - to_ref < to_top, falling, beyond))
    return np.reshape(out, np.shape(settlement))


class Voids:
    """The voids' state of a section: the impact factor of the latest load update and the
    looseness the tamped ballast keeps.

    Parameters
    ----------
    p : VoidParameters
        The parameters.
    shape : tuple
        (rails, sleepers).
    """

    def __init__(self, p: VoidParameters, shape):
        self.p = p
        self.impact = np.ones(shape)  # impact factor of the latest load update [-]
        self.loose = np.zeros(shape)  # looseness kept at the last tamping [-]
        self.since = np.full(shape, np.inf)  # traffic since that tamping [MGT]

    def update(self, hanging_gap, peak) -> None:
        """Take the impact factor of the ballast state's gaps ``hanging_gap`` [m] under the
        step's largest rail-seat loads ``peak`` [N]."""
        self.impact = impact_factor(impact_gap(hanging_gap, peak), self.p)

    def factor(self, dm: float) -> np.ndarray:
        """Settlement-rate factor over a step of ``dm`` [MGT] (the looseness averaged over
        it), capped at ``1 + a`` [-]."""
        tau = self.p.looseness_mgt
        decay = np.exp(-self.since / tau)
        mean = decay if dm <= 0 else decay * -np.expm1(-dm / tau) * tau / dm
        return np.minimum(self.impact + self.loose * mean, 1.0 + self.p.amplification)

    def limit(self, hanging_gap, peak) -> np.ndarray:
        """Largest settlement of each sleeper in one load update [m]: `VOID_GAIN` times
        ``F / |dF/dg|`` where the factor changes with the gap, else infinite."""
        g = impact_gap(hanging_gap, peak)
        slope = np.abs(impact_slope(g, self.p))
        return np.divide(VOID_GAIN * impact_factor(g, self.p), slope,
                         out=np.full(slope.shape, np.inf), where=slope > 0)  # fmt: skip

    def advance(self, dm: float) -> None:
        """Traffic of ``dm`` [MGT] has passed."""
        self.since = self.since + dm

    def tamp(self, held) -> None:
        """The sleepers ``held`` (2, n) bool are tamped: their ballast keeps ``memory``
        of its looseness ``F - 1``."""
        kept = self.p.memory * (self.factor(0.0) - 1.0)
        self.loose = np.where(held, kept, self.loose)
        self.since = np.where(held, 0.0, self.since)
