"""Track data (geometry per rail, support curves per sleeper) and its linearisation (§5.2).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from trackdyn.errors import TrackdynInputError, check_series
from trackdyn.limits import MAX_PROFILE, MAX_SLEEPER_GAP, SUPPORT_STIFFNESS, check_within
from trackdyn.track.support import DELTA, Curves, linearise_curves
from trackdyn.track.winkler import modulus_from_stiffness

RAILS = ("left", "right")


@dataclass(frozen=True)
class Geometry:
    """Unloaded vertical space curve of both rails, positive downward.

    Parameters
    ----------
    distance : ndarray
        Position along the track, strictly increasing [m].
    left, right : ndarray
        Vertical profile of the left and right rail [m].
    where : str
        Source name for error messages.
    notes : tuple of (str, str)
        What was done to the file's columns to give this profile, and what it lacks, by
        topic (``kind``, ``gaps``, ``direction``, ``sign``; `trackdyn.track.survey`); empty
        for a profile read as it is.
    """

    distance: np.ndarray
    left: np.ndarray
    right: np.ndarray
    where: str = "geometry"
    notes: tuple = ()

    def __post_init__(self):
        d = check_series(self.distance, min_points=2, where=self.where)
        object.__setattr__(self, "distance", d)
        for rail in RAILS:
            _, v = check_series(d, getattr(self, rail), name=f"{rail} profile", where=self.where)
            what = f"{self.where}: {rail} profile"
            check_within(v, -MAX_PROFILE, MAX_PROFILE, what, "mm", 1e-3)
            object.__setattr__(self, rail, v)

    def profile(self, rail: str) -> np.ndarray:
        """Vertical profile of ``rail`` (``"left"`` or ``"right"``) [m]."""
        if rail not in RAILS:
            raise TrackdynInputError(f"unknown rail {rail!r}; use left or right")
        return getattr(self, rail)

    @functools.cached_property
    def splines(self) -> dict:
        """The cubic spline of each rail's profile through its samples (`at`), by rail,
        made once (`trackdyn.track.inputs.ContactInput` evaluates their pieces)."""
        return {r: CubicSpline(self.distance, getattr(self, r)) for r in RAILS}

    def at(self, rail: str, x) -> np.ndarray:
        """Profile of ``rail`` at positions ``x`` [m], by cubic spline between samples [m].

        A smooth space curve: its slope and curvature are continuous, so a wheel that
        follows it (as on rigid track) is not kicked at every measured point.
        """
        self.profile(rail)
        return self.splines[rail](np.asarray(x, dtype=float))


@dataclass(frozen=True)
class Supports:
    """Measured load-deflection curve per sleeper and rail.

    Parameters
    ----------
    position : ndarray
        Sleeper positions along the track, strictly increasing, neighbours at most
        `trackdyn.limits.MAX_SLEEPER_GAP` apart [m].
    left, right : Curves or sequence of SupportCurve
        One curve per sleeper for each rail, kept packed as `Curves`; ``supports.left[i]``
        is the left rail's curve at sleeper ``i``, a `SupportCurve`.
    where : str
        Source name for error messages.
    """

    position: np.ndarray
    left: Curves
    right: Curves
    where: str = "supports"

    def __post_init__(self):
        pos = check_series(self.position, min_points=2, where=self.where)
        gap = np.diff(pos)
        wide = np.flatnonzero(gap > MAX_SLEEPER_GAP)
        if wide.size:
            i = wide[0]
            raise TrackdynInputError(
                f"{self.where}: sleepers at {pos[i]:g} and {pos[i + 1]:g} m are {gap[i]:g} m "
                f"apart, more than the plausible {MAX_SLEEPER_GAP:g} m"
            )
        object.__setattr__(self, "position", pos)
        for rail in RAILS:
            curves = Curves.of(getattr(self, rail))
            if len(curves) != pos.size:
                raise TrackdynInputError(
                    f"{self.where}: {len(curves)} {rail}-rail curves for {pos.size} sleepers"
                )
            object.__setattr__(self, rail, curves)

    @classmethod
    def linear(cls, position, left_stiffness, right_stiffness, where="supports"):
        """Linear supports: one stiffness per sleeper and rail [N/m] (scalars broadcast)."""
        pos = np.asarray(position, dtype=float)
        curves = [
            Curves.linear(
                np.broadcast_to(k, pos.shape), f"{where}: {rail} rail, sleeper {{}}".format
            )
            for rail, k in zip(RAILS, (left_stiffness, right_stiffness), strict=True)
        ]
        return cls(pos, *curves, where)


@dataclass(frozen=True)
class Track:
    """A track section: unloaded geometry per rail and support curves per sleeper.

    Geometry and supports may use different grids; the section a vehicle can run on is
    where both are defined.
    """

    geometry: Geometry
    supports: Supports

    @property
    def extent(self) -> tuple[float, float]:
        """First and last position covered by both geometry and supports [m]."""
        g, s = self.geometry.distance, self.supports.position
        lo, hi = max(g[0], s[0]), min(g[-1], s[-1])
        if hi <= lo:
            raise TrackdynInputError(
                f"{self.geometry.where} and {self.supports.where} do not overlap"
            )
        return lo, hi

    def linearise(self, static_load: float, delta: float = DELTA, **options) -> LinearisedTrack:
        """Effective linearised loaded stiffness and static deflection per sleeper (5.9-5.11).

        Parameters
        ----------
        static_load : float
            Static wheel load Ps [N].
        delta : float
            Dynamic wheel load increment δ [-].
        **options
            Passed to `linearise_curves` (``method``, ``extrapolate``, ``printed_5_10``).
        """
        rails = [getattr(self.supports, rail) for rail in RAILS]
        k2, ys = np.array(
            [linearise_curves(c, static_load, delta, **options) for c in rails]
        ).transpose(1, 0, 2)
        for curves, k in zip(rails, k2, strict=True):
            bad = (k < SUPPORT_STIFFNESS[0]) | (k > SUPPORT_STIFFNESS[1])
            if bad.any():
                i = int(np.argmax(bad))
                check_within(k[i], *SUPPORT_STIFFNESS, f"{curves.where(i)}: k2", "kN/mm", 1e6)
        return LinearisedTrack(self, static_load, delta, k2, ys)


@dataclass(frozen=True)
class LinearisedTrack:
    """A track linearised about a static wheel load: what a moving wheel sees.

    Parameters
    ----------
    track : Track
        The measured track.
    static_load : float
        Static wheel load Ps [N].
    delta : float
        Dynamic wheel load increment δ [-].
    k2 : ndarray
        Effective linearised loaded stiffness, shape (2 rails, sleepers) [N/m].
    ys : ndarray
        Static deflection, shape (2 rails, sleepers) [m].
    """

    track: Track
    static_load: float
    delta: float
    k2: np.ndarray
    ys: np.ndarray

    def _check_inside(self, x: np.ndarray):
        lo, hi = self.track.extent
        if x.size and (x.min() < lo - 1e-9 or x.max() > hi + 1e-9):
            raise TrackdynInputError(
                f"position {x.min():.2f}-{x.max():.2f} m is outside the track ({lo:.2f}-{hi:.2f} m)"
            )

    def sample(self, rail: str, x) -> tuple[np.ndarray, np.ndarray]:
        """Stiffness [N/m] and loaded profile [m] of ``rail`` at positions ``x`` [m].

        Stiffness and static deflection are interpolated linearly between sleepers, the
        unloaded space curve by cubic spline (`Geometry.at`); the loaded profile is the
        unloaded space curve plus the static deflection (Fig. 5.4).
        """
        x = np.asarray(x, dtype=float)
        self._check_inside(x)
        r = RAILS.index(rail)
        pos = self.track.supports.position
        g = self.track.geometry
        k = np.interp(x, pos, self.k2[r])
        loaded = g.at(rail, x) + np.interp(x, pos, self.ys[r])
        return k, loaded

    def loaded_profile(self, rail: str) -> np.ndarray:
        """Loaded profile of ``rail`` on the geometry grid [m] (NaN outside the supports)."""
        g = self.track.geometry
        pos = self.track.supports.position
        ys = np.interp(g.distance, pos, self.ys[RAILS.index(rail)], left=np.nan, right=np.nan)
        return g.profile(rail) + ys

    def seating_gap(self) -> np.ndarray:
        """Deflection at zero load of the linearised line, ``max(ys - Ps/k2, 0)`` [m]."""
        return np.maximum(self.ys - self.static_load / self.k2, 0.0)

    def support_stiffness(self, EI: float) -> np.ndarray:
        """Discrete support stiffness per sleeper [N/m] equivalent to k2 (5.7 times spacing).

        Parameters
        ----------
        EI : float
            Rail bending stiffness [N m^2].
        """
        pos = self.track.supports.position
        spacing = np.gradient(pos)
        return modulus_from_stiffness(self.k2, EI) * spacing


def load_surface(track: Track, rail: str, deflection_grid: np.ndarray):
    """Wheel load as a bicubic surface of (position [m], deflection [m]) (eq 5.14).

    Each sleeper's measured curve is inverted to load against deflection (monotone cubic,
    zero load at and below the first deflection point), then a bicubic spline spans
    sleepers and deflections. Returns a callable ``surface(x, deflection_grid) -> load [N]``
    evaluated on the grid given here, with loads clipped at zero.
    """
    from scipy.interpolate import RectBivariateSpline

    stack = getattr(track.supports, rail)
    p = np.linspace(stack.lo, stack.hi, 200, axis=1)
    y = stack.deflection_at(p, method="pchip")
    loads = np.array(
        [np.interp(deflection_grid, yi, pi, left=0.0) for yi, pi in zip(y, p, strict=True)]
    )
    slope = (p[:, -1:] - p[:, -2:-1]) / (y[:, -1:] - y[:, -2:-1])
    beyond = deflection_grid > y[:, -1:]
    loads[beyond] = (p[:, -1:] + slope * (deflection_grid - y[:, -1:]))[beyond]
    spline = RectBivariateSpline(track.supports.position, deflection_grid, loads, kx=3, ky=3)

    def surface(x):
        return np.maximum(spline(np.asarray(x, dtype=float), deflection_grid, grid=True), 0.0)

    return surface
