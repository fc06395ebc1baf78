"""What the solvers see of the track: the input under each contact of a moving vehicle.

A solver asks a `TrackInput` for the track under the model's contacts at the vehicle-centre
positions of a block of steps, ``inputs(centre) -> (k, r, table)``:

* ``k`` (positions, contacts) [N/m]: contact stiffness (sum over the contact's axles);
* ``r`` (positions, contacts) [m]: the input the contact deflection is measured from
  (the loaded profile, mean over the axles; the unloaded space curve for tabulated
  contacts), positive down;
* ``table`` (positions, contacts, ``grid.size``) [N]: the wheel load against deflection
  from ``r`` on the deflection ``grid`` for tabulated (nonlinear) contacts; zero rows when
  the contacts are linear, ``f = k (Dc q - r)``.

`ContactInput` is the input of a `LinearisedTrack` (5.4.3: stiffness summed, loaded
profile averaged over a bogie side's axles; or the bicubic surface of 5.14). A new input
(a dipped joint, a measured stiffness trace) is another class with the same ``grid``,
``__call__`` and ``linear``; or, where it is a change of the track itself, a function from
a `LinearisedTrack` to a `LinearisedTrack` (`trackdyn.track.excitation`).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.2, §5.4.3, eq 5.14.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numba import njit

from trackdyn.errors import TrackdynInputError
from trackdyn.track.track import RAILS, LinearisedTrack, load_surface

TABLE_POINTS = 96
"""Deflection points of the per-step load table of the nonlinear contact."""


class TrackInput(Protocol):
    """The track under a model's contacts at given vehicle-centre positions.

    Attributes
    ----------
    grid : ndarray
        Deflection grid of ``table`` [m], evenly spaced; empty for linear contacts.
    """

    grid: np.ndarray

    def __call__(self, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(k [N/m], r [m], table [N])`` at the vehicle-centre positions ``centre`` [m]."""

    def linear(self, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Linear contact stiffness [N/m] and loaded profile [m] at ``centre`` [m]: the
        static state of tabulated contacts starts its Newton iteration from them."""


@njit(cache=True, inline="always")
def _interval(x, xp, j):
    """``j`` with ``xp[j] <= x < xp[j+1]`` searched from the guess ``j`` (-1 / xp.size
    outside; xp.size - 1 at the last point), as numpy's ``interp`` finds it."""
    n = xp.size
    if x < xp[0]:
        return -1
    if x > xp[n - 1]:
        return n
    if x == xp[n - 1]:
        return n - 1
    if j < 0 or j >= n - 1 or x < xp[j]:
        j = 0
    while x >= xp[j + 1]:
        j += 1
    return j


@njit(cache=True, inline="always")
def _run_end(x, xp, j):
    """The position up to which (excluded) ``x`` stays in interval ``j`` of ``xp``
    (`_interval`): the next point, ``x`` itself on the last point, none beyond it."""
    if j < 0:
        return xp[0]
    if j < xp.size - 1:
        return xp[j + 1]
    return x if j == xp.size - 1 else np.inf


@njit(cache=True, nogil=True)
def _sample(centre, axles, pos, k2, ys, knots, coef, k_out, r_out):
    """Add every axle's stiffness and weighted loaded profile into ``k_out``, ``r_out``.

    ``axles`` rows: offset ahead of the centre [m], contact, rail, weight (1 / axles of
    the contact). The profile is the cubic spline ``coef`` on ``knots`` per rail, evaluated
    as scipy's ``PPoly`` does, and the stiffness and loaded deflection are interpolated
    between the sleepers as ``numpy.interp`` does; the operations and their order are
    those of `LinearisedTrack.sample` followed by the sums of `ContactInput`, so the result
    is the same to the bit. The positions go in runs over which the sleeper interval and
    the spline's piece stay the same (a run's positions do not decrease, as a vehicle's
    do), so that the search, the slopes and the coefficients are found once a run.
    """
    n, last = centre.size, pos.size - 1
    for a in range(axles.shape[0]):
        c, rail, offset, weight = int(axles[a, 1]), int(axles[a, 2]), axles[a, 0], axles[a, 3]
        kr, yr = k2[rail], ys[rail]
        j = 0
        g = 0
        s = 0
        while s < n:
            x = centre[s] + offset
            j = _interval(x, pos, j)
            gi = _interval(x, knots, g)
            g = min(max(gi, 0), knots.size - 2)
            top = min(_run_end(x, pos, j), _run_end(x, knots, gi))
            end = s + 1  # a run: positions that do not go back, below the next point
            while end < n and centre[end] >= centre[end - 1] and centre[end] + offset < top:
                end += 1
            c3, c2, c1, c0 = coef[rail, 3, g], coef[rail, 2, g], coef[rail, 1, g], coef[rail, 0, g]
            start = knots[g]
            flat = j < 0 or j >= last  # numpy.interp: the end value
            i = 0 if j < 0 else min(j, last)
            xj, kj, yj = pos[i], kr[i], yr[i]
            sk = 0.0 if flat else (kr[i + 1] - kj) / (pos[i + 1] - xj)
            sy = 0.0 if flat else (yr[i + 1] - yj) / (pos[i + 1] - xj)
            for t in range(s, end):
                x = centre[t] + offset
                d = x - start
                spline = (((0.0 + c3) + c2 * d) + c1 * (d * d)) + c0 * (d * d * d)
                if flat or x == xj:
                    k_out[t, c] += kj
                    r_out[t, c] += (spline + yj) * weight
                else:
                    k_out[t, c] += sk * (x - xj) + kj
                    r_out[t, c] += (spline + (sy * (x - xj) + yj)) * weight
            s = end


class ContactInput:
    """The `TrackInput` of a `LinearisedTrack` for a model's contacts.

    Parameters
    ----------
    model : Model
        Vehicle model (its ``contact_rails`` and ``contact_axles``).
    lin : LinearisedTrack
        The track, linearised about the vehicle's static wheel load.
    nonlinear : bool
        Tabulated contacts from the bicubic surface of 5.14 (single-wheel contacts only).
    """

    def __init__(self, model, lin: LinearisedTrack, nonlinear: bool = False):
        self.lin, self.nonlinear = lin, nonlinear
        self.rails = model.contact_rails
        self.first_axles = [a[0] for a in model.contact_axles]
        self.axles = np.array(
            [
                [x, c, RAILS.index(rail), 1.0 / len(axles)]
                for c, (rail, axles) in enumerate(
                    zip(model.contact_rails, model.contact_axles, strict=True)
                )
                for x in axles
            ]
        )
        splines = lin.track.geometry.splines
        self.coef = np.ascontiguousarray([splines[r].c for r in RAILS])
        self.grid = np.empty(0)
        if nonlinear:
            if any(len(a) != 1 for a in model.contact_axles):
                raise TrackdynInputError(
                    f"the nonlinear track (5.14) needs a contact per wheel (models 2dof, "
                    f"2dof-wedge, full); {model.name} uses the bogie approximation and the "
                    "linearised track"
                )
            top = max(getattr(lin.track.supports, r).deflection.max() for r in RAILS)
            self.grid = np.linspace(0.0, 1.5 * top, TABLE_POINTS)
            self.surface = {r: load_surface(lin.track, r, self.grid) for r in set(self.rails)}

    def linear(self, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Contact stiffness [N/m] and loaded profile [m] of the linearised track."""
        centre = np.asarray(centre, dtype=float)
        lin = self.lin
        lo, hi = lin.track.extent
        if centre.size:
            x0, x1 = centre.min() + self.axles[:, 0].min(), centre.max() + self.axles[:, 0].max()
            if x0 < lo - 1e-9 or x1 > hi + 1e-9:
                raise TrackdynInputError(
                    f"position {x0:.2f}-{x1:.2f} m is outside the track ({lo:.2f}-{hi:.2f} m)"
                )
        k, r = np.zeros((centre.size, len(self.rails))), np.zeros((centre.size, len(self.rails)))
        knots = lin.track.geometry.distance
        # contiguous, so that every caller uses the one compiled specialisation
        k2, ys = np.ascontiguousarray(lin.k2), np.ascontiguousarray(lin.ys)
        _sample(centre, self.axles, lin.track.supports.position, k2, ys, knots, self.coef, k, r)
        return k, r

    def __call__(self, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """See `TrackInput`."""
        k, r = self.linear(centre)
        if not self.nonlinear:
            return k, r, np.zeros((0, len(self.rails), 0))
        table = np.zeros((centre.size, len(self.rails), self.grid.size))
        for c, (rail, offset) in enumerate(zip(self.rails, self.first_axles, strict=True)):
            x = centre + offset
            r[:, c] = self.lin.track.geometry.at(rail, x)
            table[:, c] = self.surface[rail](x)
        return k, r, table
