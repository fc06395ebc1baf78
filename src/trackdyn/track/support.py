"""Measured track stiffness: load-deflection curves and their linearisation (seed §5.2).

A support curve is the wheel load on the rail above one sleeper against the rail
deflection there (positive downward), as a track loading vehicle measures it. Eqs 5.9-5.11
turn it into an effective linearised loaded stiffness ``k2`` and a static deflection ``ys``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline, PchipInterpolator

from trackdyn.errors import TrackdynInputError

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
        if load.ndim != 1 or load.shape != defl.shape or load.size < 2:
            raise TrackdynInputError(f"{self.where}: needs at least two (load, deflection) points")
        if not (np.all(np.isfinite(load)) and np.all(np.isfinite(defl))):
            raise TrackdynInputError(f"{self.where}: NaN or infinite load or deflection")
        if load[0] < 0:
            raise TrackdynInputError(f"{self.where}: negative load {load[0]:g} N")
        if np.any(np.diff(load) <= 0) or np.any(np.diff(defl) <= 0):
            raise TrackdynInputError(
                f"{self.where}: load-deflection curve is not monotonic "
                "(load and deflection must both increase; zero or negative stiffness)"
            )

    @classmethod
    def linear(cls, stiffness: float, where: str = "linear support") -> SupportCurve:
        """A linear support of the given stiffness [N/m], from zero load up to 2 MN."""
        if not np.isfinite(stiffness) or stiffness <= 0:
            raise TrackdynInputError(f"{where}: stiffness must be > 0, got {stiffness!r} N/m")
        load = np.array([0.0, LINEAR_CURVE_MAX_LOAD])
        return cls(load, load / stiffness, where)

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
        lo, hi = self.load[0], self.load[-1]
        outside = (p < lo) | (p > hi)
        if np.any(outside) and not extrapolate:
            bad = p[outside].flat[0]
            raise TrackdynInputError(
                f"{self.where}: load {bad / 1e3:.1f} kN is outside the measured curve "
                f"({lo / 1e3:.1f}-{hi / 1e3:.1f} kN); extend the curve or allow extrapolation"
            )
        if method == "cubic":
            spline = CubicSpline(self.load, self.deflection, bc_type="not-a-knot")
        elif method == "pchip":
            spline = PchipInterpolator(self.load, self.deflection)
        else:
            raise TrackdynInputError(f"unknown interpolation method {method!r}; use cubic or pchip")
        inside = np.clip(p, lo, hi)
        y = spline(inside)
        slope_lo, slope_hi = spline(lo, 1), spline(hi, 1)
        return np.where(
            p < lo, y + (p - lo) * slope_lo, np.where(p > hi, y + (p - hi) * slope_hi, y)
        )


def secant_linearisation(
    curve: SupportCurve,
    static_load: float,
    delta: float = 0.3,
    *,
    method: str = "cubic",
    extrapolate: bool = False,
    printed_5_10: bool = False,
) -> tuple[float, float]:
    """Effective linearised loaded stiffness and static deflection (eqs 5.9-5.11).

    ``ΔP = δ Ps`` (5.9); ``ys1, ys2`` are the deflections at ``Ps ∓ ΔP``;
    ``k2 = 2ΔP / (ys2 - ys1)`` (5.10, secant form: the default, because it is the slope of
    the line through the two points, equal to ``k`` for a linear support);
    ``ys = (ys1 + ys2) / 2`` (5.11).

    Parameters
    ----------
    curve : SupportCurve
        Measured curve of the sleeper.
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
    k2 : float
        Effective linearised loaded track stiffness [N/m].
    ys : float
        Static track deflection [m].
    """
    if not np.isfinite(static_load) or static_load <= 0:
        raise TrackdynInputError(f"static wheel load must be > 0, got {static_load!r} N")
    if not np.isfinite(delta) or not 0 < delta < 1:
        raise TrackdynInputError(f"dynamic increment delta must be in (0, 1), got {delta!r}")
    dp = delta * static_load
    ys1, ys2 = curve.deflection_at(
        [static_load - dp, static_load + dp], method=method, extrapolate=extrapolate
    )
    if ys2 <= ys1:
        raise TrackdynInputError(
            f"{curve.where}: interpolated curve is not increasing over Ps ± ΔP; "
            "use method='pchip' for noisy curves"
        )
    numerator = static_load if printed_5_10 else 2.0 * dp
    return numerator / (ys2 - ys1), 0.5 * (ys1 + ys2)
