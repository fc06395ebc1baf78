"""Measured track stiffness: load-deflection curves and their linearisation (seed §5.2).

A support curve is the wheel load on the rail above one sleeper against the rail
deflection there (positive downward), as a track loading vehicle measures it. Eqs 5.9-5.11
turn it into an effective linearised loaded stiffness ``k2`` and a static deflection ``ys``,
for all sleepers of a track in one array pass.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria.
"""

from __future__ import annotations

import operator
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from trackdyn.errors import TrackdynInputError
from trackdyn.limits import SUPPORT_STIFFNESS, check_within
from trackdyn.track.interpolation import METHODS, evaluate, knot_slopes

LINEAR_CURVE_MAX_LOAD = 2.0e6
"""Top of the curve built for a linear support [N]; far above any wheel load."""


@dataclass(frozen=True)
class SupportCurve:
    """Load-deflection curve of the track at one sleeper.

    Parameters
    ----------
    load : ndarray
        Wheel load points, strictly increasing, >= 0 [N].
    deflection : ndarray
        Rail deflection at those loads, strictly increasing [m].
    where : str
        Where the curve came from (file, row, sleeper), used in error messages.
    """

    load: np.ndarray
    deflection: np.ndarray
    where: str = "support curve"

    def __post_init__(self):
        load = np.asarray(self.load, dtype=float)
        defl = np.asarray(self.deflection, dtype=float)
        object.__setattr__(self, "load", load)
        object.__setattr__(self, "deflection", defl)
        if load.ndim != 1 or load.shape != defl.shape:
            raise TrackdynInputError(f"{self.where}: needs at least two (load, deflection) points")
        check_curves(load, defl, np.array([0, load.size]), lambda _: self.where)

    @classmethod
    def linear(cls, stiffness: float, where: str = "linear support") -> SupportCurve:
        """A linear support of the given stiffness [N/m], from zero load up to 2 MN."""
        return Curves.linear([stiffness], lambda _: where)[0]

    def deflection_at(self, load, *, method: str = "cubic", extrapolate: bool = False):
        """Deflection [m] at the given wheel load(s) [N] by cubic interpolation.

        Parameters
        ----------
        load : array_like
            Wheel load [N].
        method : {"cubic", "pchip"}
            ``"cubic"``: a not-a-knot cubic spline, the seed's cubic-polynomial
            interpolation (exact for a cubic curve); ``"pchip"``: monotone cubic Hermite,
            for noisy measurements that would make the spline overshoot.
        extrapolate : bool
            Allow loads outside the measured range (linearly, with the end slope). Off by
            default: a load outside the curve is refused.
        """
        p = np.asarray(load, dtype=float)
        if not extrapolate:
            self.check_covers(p)
        return Curves.of((self,)).deflection_at(p.reshape(1, -1), method).reshape(p.shape)

    def check_covers(self, load: np.ndarray) -> None:
        """Refuse wheel loads [N] outside the measured curve."""
        lo, hi = self.load[0], self.load[-1]
        outside = (load < lo) | (load > hi)
        if np.any(outside):
            bad = load[outside].flat[0]
            raise TrackdynInputError(
                f"{self.where}: load {bad / 1e3:.1f} kN is outside the measured curve "
                f"({lo / 1e3:.1f}-{hi / 1e3:.1f} kN); extend the curve or allow extrapolation"
            )


def check_curves(load: np.ndarray, deflection: np.ndarray, start: np.ndarray, where) -> None:
    """Refuse the first curve, in order, that is short, not finite, negative or not monotonic.

    Parameters
    ----------
    load, deflection : ndarray
        Points of all curves, one curve after another [N], [m].
    start : ndarray
        Index of each curve's first point, then the total number of points.
    where : callable
        ``where(i)``: where curve ``i`` came from, for the message.
    """
    sizes = np.diff(start)
    curve = np.repeat(np.arange(sizes.size), sizes)  # curve of each point
    first = start[:-1]
    negative = np.zeros(sizes.size, dtype=bool)
    negative[sizes > 0] = load[first[sizes > 0]] < 0
    finite = np.isfinite(load) & np.isfinite(deflection)
    step = (load[1:] > load[:-1]) & (deflection[1:] > deflection[:-1])
    across = start[1:-1] - 1  # from one curve's last point to the next curve's first
    step[across[(across >= 0) & (across < step.size)]] = True
    checks = (
        (sizes < 2, lambda i: "needs at least two (load, deflection) points"),
        (
            np.bincount(curve[~finite], minlength=sizes.size) > 0,
            lambda i: "NaN or infinite load or deflection",
        ),
        (negative, lambda i: f"negative load {load[first[i]]:g} N"),
        (
            np.bincount(curve[:-1][~step], minlength=sizes.size) > 0,
            lambda i: (
                "load-deflection curve is not monotonic "
                "(load and deflection must both increase; zero or negative stiffness)"
            ),
        ),
    )
    bad = np.zeros(sizes.size, dtype=bool)
    for flags, _ in checks:
        bad |= flags
    if bad.any():
        i = int(np.argmax(bad))
        message = next(text(i) for flags, text in checks if flags[i])
        raise TrackdynInputError(f"{where(i)}: {message}")


class Curves(Sequence):
    """Support curves packed one after another in flat arrays, checked on construction.

    Holds a track's thousands of curves in a few arrays (16 bytes a point, 8 a curve) and
    interpolates them all in one array pass per number of points; indexing gives a
    `SupportCurve`, made when asked for.

    Parameters
    ----------
    load, deflection : ndarray
        Points of all curves, one curve after another [N], [m].
    start : ndarray
        Index of each curve's first point, then the total number of points.
    where : callable
        ``where(i)``: where curve ``i`` came from (file, rail, position, lines), for
        messages; picklable (a bound method or `functools.partial`) for parallel runs.
    """

    def __init__(self, load, deflection, start, where):
        self.load = np.asarray(load, dtype=float)
        self.deflection = np.asarray(deflection, dtype=float)
        self.start = np.asarray(start, dtype=np.intp)
        self.where = where
        check_curves(self.load, self.deflection, self.start, where)

    @classmethod
    def of(cls, curves) -> Curves:
        """Pack a sequence of `SupportCurve` (a `Curves` is returned as it is)."""
        if isinstance(curves, Curves):
            return curves
        curves = tuple(curves)
        sizes = [c.load.size for c in curves]
        return cls(
            np.concatenate([c.load for c in curves]) if curves else np.empty(0),
            np.concatenate([c.deflection for c in curves]) if curves else np.empty(0),
            np.r_[0, np.cumsum(sizes, dtype=np.intp)],
            tuple(c.where for c in curves).__getitem__,
        )

    @classmethod
    def linear(cls, stiffness, where) -> Curves:
        """Linear supports of the given stiffnesses [N/m], from zero load up to 2 MN.

        Parameters
        ----------
        stiffness : array_like
            One stiffness per curve [N/m].
        where : callable
            ``where(i)``: where curve ``i`` came from, for messages.
        """
        k = np.asarray(stiffness, dtype=float).reshape(-1)
        bad = ~((k >= SUPPORT_STIFFNESS[0]) & (k <= SUPPORT_STIFFNESS[1]))
        if bad.any():
            i = int(np.argmax(bad))
            check_within(k[i], *SUPPORT_STIFFNESS, f"{where(i)}: stiffness", "kN/mm", 1e6)
        load = np.tile([0.0, LINEAR_CURVE_MAX_LOAD], k.size)
        return cls(load, load / np.repeat(k, 2), np.arange(0, 2 * k.size + 1, 2), where)

    def __len__(self) -> int:
        return self.start.size - 1

    # integer indices only (a slice raises TypeError), narrower than Sequence's
    def __getitem__(self, i: int) -> SupportCurve:  # type: ignore[override]
        i = range(len(self))[operator.index(i)]
        part = slice(self.start[i], self.start[i + 1])
        return SupportCurve(self.load[part].copy(), self.deflection[part].copy(), self.where(i))

    @property
    def lo(self) -> np.ndarray:
        """First measured load of each curve [N]."""
        return self.load[self.start[:-1]]

    @property
    def hi(self) -> np.ndarray:
        """Last measured load of each curve [N]."""
        return self.load[self.start[1:] - 1]

    def deflection_at(self, load: np.ndarray, method: str = "cubic") -> np.ndarray:
        """Deflection [m] of each curve at its own wheel loads, linear beyond the curve.

        Parameters
        ----------
        load : ndarray
            Wheel loads [N], shape (curves, k).
        method : {"cubic", "pchip"}
            Interpolation, see `SupportCurve.deflection_at`.
        """
        if method not in METHODS:
            raise TrackdynInputError(f"unknown interpolation method {method!r}; use cubic or pchip")
        out = np.empty(load.shape)
        sizes = np.diff(self.start)
        for n in np.unique(sizes):  # curves with n points as 2-D arrays, a row a curve
            rows = np.flatnonzero(sizes == n)
            points = self.start[rows, None] + np.arange(n)
            x, y = self.load[points], self.deflection[points]
            out[rows] = evaluate(x, y, knot_slopes(x, y, method), load[rows])
        return out


DELTA = 0.3
"""Dynamic wheel load increment δ of the linearisation (5.9) unless one is given [-]: the
estimate the thesis gives where no measured value is available (Fröhling 1997, after eq 5.9)."""


def linearise_curves(
    curves,
    static_load: float,
    delta: float = DELTA,
    *,
    method: str = "cubic",
    extrapolate: bool = False,
    printed_5_10: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Effective linearised loaded stiffness and static deflection (eqs 5.9-5.11).

    ``ΔP = δ Ps`` (5.9); ``ys1, ys2`` are the deflections at ``Ps ∓ ΔP``;
    ``k2 = 2ΔP / (ys2 - ys1)`` (5.10, secant form: the default, because it is the slope of
    the line through the two points, equal to ``k`` for a linear support);
    ``ys = (ys1 + ys2) / 2`` (5.11). All curves in one array pass; a bad curve is reported
    as it would be curve by curve, the first one in ``curves``.

    Parameters
    ----------
    curves : Curves or sequence of SupportCurve
        Measured curves, one per sleeper.
    static_load : float
        Static wheel load Ps [N].
    delta : float
        Dynamic wheel load increment δ [-]; the seed's estimate is 0.3.
    method : {"cubic", "pchip"}
        Interpolation of the measured curve, see `SupportCurve.deflection_at`.
    extrapolate : bool
        Allow ``Ps ± ΔP`` outside the measured curve.
    printed_5_10 : bool
        Use eq 5.10 as printed, ``k2 = Ps / (ys2 - ys1)``, which is ``1/(2δ)`` times the
        secant; only to reproduce the printed numbers.

    Returns
    -------
    k2 : ndarray
        Effective linearised loaded track stiffness per curve [N/m].
    ys : ndarray
        Static track deflection per curve [m].
    """
    if not np.isfinite(static_load) or static_load <= 0:
        raise TrackdynInputError(f"static wheel load must be > 0, got {float(static_load):g} N")
    if not np.isfinite(delta) or not 0 < delta < 1:
        raise TrackdynInputError(f"dynamic increment delta must be in (0, 1), got {float(delta):g}")
    stack = Curves.of(curves)
    dp = delta * static_load
    p = np.array([static_load - dp, static_load + dp])
    ys1, ys2 = stack.deflection_at(np.broadcast_to(p, (len(stack), 2)), method).T
    bad = ys2 <= ys1
    if not extrapolate:
        bad |= (p[0] < stack.lo) | (p[1] > stack.hi)
    if np.any(bad):
        curve = stack[int(np.argmax(bad))]
        if not extrapolate:
            curve.check_covers(p)
        raise TrackdynInputError(
            f"{curve.where}: interpolated curve is not increasing over Ps ± ΔP; "
            "use method='pchip' for noisy curves"
        )
    numerator = static_load if printed_5_10 else 2.0 * dp
    return numerator / (ys2 - ys1), 0.5 * (ys1 + ys2)


def secant_linearisation(
    curve: SupportCurve, static_load: float, delta: float = DELTA, **options
) -> tuple[float, float]:
    """`linearise_curves` for one curve: ``k2`` [N/m] and ``ys`` [m] as floats.

    Parameters
    ----------
    curve : SupportCurve
        Measured curve of the sleeper.
    static_load : float
        Static wheel load Ps [N].
    delta : float
        Dynamic wheel load increment δ [-].
    **options
        ``method``, ``extrapolate``, ``printed_5_10`` of `linearise_curves`.
    """
    k2, ys = linearise_curves((curve,), static_load, delta, **options)
    return float(k2[0]), float(ys[0])
