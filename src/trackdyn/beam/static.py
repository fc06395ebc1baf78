"""Rail as a finite-element Euler-Bernoulli beam on discrete nonlinear supports.

One support per sleeper, each with its own piecewise-linear, tensionless load-deflection curve
(a first curve point above zero deflection is a seating gap: a voided sleeper). Hermite cubic
elements are exact for a beam loaded only at points, so nodal results carry no discretisation
error. The springs' forces never decrease, so the equilibrium is the minimum of a convex
potential; it is found by Newton-Raphson with load stepping and a line search on that
potential. Displacements are positive downward; SI units.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import LinAlgError, solveh_banded

from trackdyn.beam.elements import band_times, hermite, stiffness_band
from trackdyn.errors import TrackdynInputError, shown


def _frozen(name, value, ndim):
    arr = np.array(value, dtype=float)
    if arr.ndim != ndim:
        raise TrackdynInputError(f"{name} must be {ndim}-D, got shape {arr.shape}")
    arr.setflags(write=False)
    return arr


def _rows(bad, what, values=None):
    if np.any(bad):
        i = int(np.argmax(bad))
        got = "" if values is None else f", got {float(values[i])!r}"
        raise TrackdynInputError(f"support {i}: {what}{got}")


@dataclass(frozen=True)
class BeamSupports:
    """Per-support load-deflection curves of the sleeper/ballast springs (rail seat force).

    The force is piecewise linear between the points, continues with the last segment's
    slope beyond the last point and is zero below the first (seating gap or uplift).

    Parameters
    ----------
    position : array_like, shape (n,)
        Support positions along the rail, strictly increasing [m].
    deflection : array_like, shape (n, m)
        Curve points, ``m >= 2``, strictly increasing per row; ``deflection[:, 0] >= 0`` is
        the seating gap [m].
    force : array_like, shape (n, m)
        Force at those points, ``force[:, 0] == 0``, non-decreasing, last slope > 0 [N].
    tensionless : bool, optional
        ``False`` continues the first segment below the first point, so the spring also pulls
        (a bilateral Winkler-type support, e.g. for checks against the Winkler beam) [-].
    """

    position: np.ndarray
    deflection: np.ndarray
    force: np.ndarray
    tensionless: bool = True

    def __post_init__(self):
        pos = _frozen("BeamSupports.position", self.position, 1)
        d = _frozen("BeamSupports.deflection", self.deflection, 2)
        f = _frozen("BeamSupports.force", self.force, 2)
        if pos.size == 0 or d.shape[0] != pos.size or d.shape[1] < 2 or f.shape != d.shape:
            raise TrackdynInputError(
                f"BeamSupports: deflection and force must both have shape (n, m >= 2) with"
                f" n = {pos.size} supports, got {d.shape} and {f.shape}"
            )
        _rows(~np.isfinite(pos), "position is not finite")
        _rows(~np.isfinite(d).all(axis=1), "deflection curve is not finite")
        _rows(~np.isfinite(f).all(axis=1), "force curve is not finite")
        _rows(np.r_[False, np.diff(pos) <= 0], "position is not greater than the previous one")
        _rows((np.diff(d) <= 0).any(axis=1), "deflection points must be strictly increasing")
        _rows(d[:, 0] < 0, "first deflection point (seating gap) must be >= 0")
        _rows(f[:, 0] != 0, "force at the first deflection point must be 0")
        _rows((np.diff(f) < 0).any(axis=1), "force must be non-decreasing (no negative stiffness)")
        _rows(f[:, -1] <= f[:, -2], "last segment slope must be > 0")
        for name, arr in (("position", pos), ("deflection", d), ("force", f)):
            object.__setattr__(self, name, arr)

    def force_and_tangent(self, y):
        """Support forces and tangent stiffnesses at rail deflections ``y``.

        Parameters
        ----------
        y : array_like, shape (n,)
            Rail deflection at each support [m].

        Returns
        -------
        force : ndarray, shape (n,)
            Force carried by each support [N].
        tangent : ndarray, shape (n,)
            ``dforce/dy``, right-hand derivative at the curve points [N/m].
        """
        y = np.asarray(y, dtype=float)
        d, f, rows = self.deflection, self.force, np.arange(self.deflection.shape[0])
        seg = np.clip(np.sum(d <= y[:, None], axis=1) - 1, 0, d.shape[1] - 2)
        d0, f0 = d[rows, seg], f[rows, seg]
        slope = (f[rows, seg + 1] - f0) / (d[rows, seg + 1] - d0)
        on = (y >= d[:, 0]) | (not self.tensionless)
        return np.where(on, f0 + slope * (y - d0), 0.0), np.where(on, slope, 0.0)


def linear_supports(position, stiffness, gap=0.0, *, tensionless=True) -> BeamSupports:
    """Linear springs, one per support, with optional seating gaps.

    Parameters
    ----------
    position : array_like, shape (n,)
        Support positions, strictly increasing [m].
    stiffness : float or array_like
        Spring stiffness, scalar or one per support, > 0 [N/m].
    gap : float or array_like, optional
        Seating gap, scalar or one per support, >= 0 [m].
    tensionless : bool, optional
        See :class:`BeamSupports` [-].

    Returns
    -------
    BeamSupports
    """
    pos = _frozen("position", position, 1)
    try:
        k, g = (np.broadcast_to(np.asarray(v, dtype=float), pos.shape) for v in (stiffness, gap))
    except ValueError:
        msg = f"stiffness and gap must be scalars or of shape {pos.shape}"
        raise TrackdynInputError(msg) from None
    _rows(~(np.isfinite(k) & (k > 0)), "stiffness must be finite and > 0 N/m", k)
    _rows(~(np.isfinite(g) & (g >= 0)), "gap must be finite and >= 0 m", g)
    d = np.stack([g, g + 1e-3], axis=1)
    f = np.stack([np.zeros_like(k), k * 1e-3], axis=1)
    return BeamSupports(pos, d, f, tensionless=bool(tensionless))


@dataclass(frozen=True)
class BeamSolution:
    """Static solution of :func:`solve_beam`.

    Parameters
    ----------
    x : ndarray
        Node positions [m].
    deflection : ndarray
        Rail deflection at the nodes, positive downward [m].
    rotation : ndarray
        Rail slope ``dw/dx`` at the nodes [rad].
    support_position : ndarray
        Support positions [m].
    support_deflection : ndarray
        Rail deflection at each support [m].
    support_force : ndarray
        Force carried by each support [N].
    load_position, load : ndarray
        Wheel load positions [m] and loads [N].
    EI : float
        Rail bending stiffness [N m^2].
    """

    x: np.ndarray
    deflection: np.ndarray
    rotation: np.ndarray
    support_position: np.ndarray
    support_deflection: np.ndarray
    support_force: np.ndarray
    load_position: np.ndarray = field(repr=False)
    load: np.ndarray = field(repr=False)
    EI: float = field(repr=False)

    def deflection_at(self, x):
        """Rail deflection anywhere on the beam, exact for the beam model.

        Cubic Hermite interpolation of the nodal deflections and rotations, plus, in an
        element with a load between its nodes, that load's clamped-clamped deflection.

        Parameters
        ----------
        x : array_like
            Positions between the first and last support [m].

        Returns
        -------
        ndarray
            Deflection, positive downward [m].
        """
        xq, nodes = np.asarray(x, dtype=float), self.x
        if not np.all((xq >= nodes[0]) & (xq <= nodes[-1])):
            raise TrackdynInputError(f"x must lie within [{nodes[0]:g}, {nodes[-1]:g}] m")
        e = np.clip(np.searchsorted(nodes, xq, side="right") - 1, 0, nodes.size - 2)
        L, t = nodes[e + 1] - nodes[e], xq - nodes[e]
        dofs = (self.deflection[e], self.rotation[e], self.deflection[e + 1], self.rotation[e + 1])
        w = sum(n * v for n, v in zip(hermite(t / L, L), dofs, strict=True))
        le = np.clip(
            np.searchsorted(nodes, self.load_position, side="right") - 1, 0, nodes.size - 2
        )
        for p, el, a in zip(self.load, le, self.load_position - nodes[le], strict=True):
            b = nodes[el + 1] - nodes[el] - a
            left = t <= a
            s, a1, b1 = np.where(left, t, L - t), np.where(left, a, b), np.where(left, b, a)
            fixed = p * b1**2 * s**2 * (3 * a1 * L - (3 * a1 + b1) * s) / (6 * self.EI * L**3)
            w = w + np.where((e == el) & (a > 0) & (b > 0), fixed, 0.0)
        return w


def _check(name, value, integer=False):
    if integer:
        ok = isinstance(value, int | np.integer) and not isinstance(value, bool) and value >= 1
    else:
        ok = isinstance(value, int | float | np.number) and bool(np.isfinite(value) and value > 0)
    if not ok:
        raise TrackdynInputError(
            f"{name} must be {'an integer >= 1' if integer else 'finite and > 0'}, "
            f"got {shown(value)}"
        )


def _mesh(support_x, load_x, max_element):
    """Nodes at the supports, at loads at least ``max_element / 4`` from other nodes (closer
    ones enter as consistent nodal loads) and evenly in between, elements <= ``max_element``."""
    keys = list(support_x)
    for xp in np.sort(load_x):
        if np.min(np.abs(np.asarray(keys) - xp)) >= 0.25 * max_element:
            keys.append(xp)
    keys = np.unique(keys)
    span = np.diff(keys)
    count = np.maximum(np.ceil(span / max_element * (1 - 1e-12)), 1).astype(int)
    step = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    return np.r_[np.repeat(keys[:-1], count) + step * np.repeat(span / count, count), keys[-1]]


def solve_beam(
    supports, EI, load_position, load, *, max_element=0.15, load_steps=10, tol=1e-9, max_iter=50
) -> BeamSolution:
    """Static rail deflection under wheel loads on discrete nonlinear supports.

    The rail is weightless and free at the first and last support. Each of ``load_steps``
    equal load increments is solved by Newton-Raphson (tangent: beam stiffness plus support
    tangents) with a line search on the potential energy. A support whose penetration beyond
    its gap is below ``max penetration x relative residual`` enters the tangent with its
    stiffness scaled down in proportion, which lets long stretches of rail that barely touch
    lift off in a few iterations; if fewer than two supports bear, every support gets 1e-9 of
    the mean last-segment slope so that the rigid-body modes stay restrained. Only the tangent
    is modified: the residual, hence the converged answer, is exact.

    Notes
    -----
    With tensionless supports the unloaded rail lifts off beyond about ``3 pi L_c / 4`` from a
    load, so the peak deflection exceeds the Winkler beam's (by 9 % for 60E1 rail on dense
    supports, u = 40 MN/m^2); ``tensionless=False`` supports reproduce Winkler. A load exactly
    at an end support rests on that support alone and the lifted rail may then tip freely: its
    deflection is one of many equilibria (the support forces are unique).

    Parameters
    ----------
    supports : BeamSupports
        At least two supports.
    EI : float
        Rail bending stiffness [N m^2].
    load_position : float or array_like
        Wheel load positions, between the first and last support [m].
    load : float or array_like
        Wheel loads, > 0, broadcast against ``load_position`` [N].
    max_element : float, optional
        Longest element; sets only the output resolution [m].
    load_steps : int, optional
        Number of equal load increments [-].
    tol : float, optional
        Limit on ``|residual| / |load vector|``; a residual at the rounding level of the
        internal forces is also accepted [-].
    max_iter : int, optional
        Newton iterations allowed per load step [-].

    Returns
    -------
    BeamSolution
    """
    if not isinstance(supports, BeamSupports) or supports.position.size < 2:
        raise TrackdynInputError("supports must be a BeamSupports with at least 2 supports")
    _check("EI", EI)
    _check("max_element", max_element)
    _check("tol", tol)
    _check("load_steps", load_steps, integer=True)
    _check("max_iter", max_iter, integer=True)
    try:
        xp, p = (np.ravel(a).astype(float) for a in np.broadcast_arrays(load_position, load))
    except ValueError:
        raise TrackdynInputError("load_position and load must have matching shapes") from None
    sx = supports.position
    for i in range(p.size):
        if not (np.isfinite(p[i]) and p[i] > 0):
            raise TrackdynInputError(f"load[{i}] must be finite and > 0 N, got {float(p[i])!r}")
        if not sx[0] <= xp[i] <= sx[-1]:
            raise TrackdynInputError(
                f"load_position[{i}] = {float(xp[i])!r} m is outside the supports"
                f" [{sx[0]:g}, {sx[-1]:g}] m"
            )
    if p.size == 0:
        raise TrackdynInputError("load: at least one wheel load is needed")

    x = _mesh(sx, xp, float(max_element))
    L, ndof = np.diff(x), 2 * x.size
    band = stiffness_band(x, EI)
    abs_band = np.abs(band)
    el = np.clip(np.searchsorted(x, xp, side="right") - 1, 0, x.size - 2)
    f_total = np.zeros(ndof)
    for i, n in enumerate(hermite((xp - x[el]) / L[el], L[el])):
        np.add.at(f_total, 2 * el + i, p * n)
    w = 2 * np.searchsorted(x, sx)
    gap = supports.deflection[:, 0]
    last = np.diff(supports.force[:, -2:]) / np.diff(supports.deflection[:, -2:])
    regulariser = 1e-9 * float(np.mean(last))

    def residual(u, f):
        fs, kt = supports.force_and_tangent(u[w])
        r = f - band_times(band, u)
        r[w] -= fs
        return r, kt

    def converged(u, r, f):
        floor = 8 * np.finfo(float).eps * np.linalg.norm(band_times(abs_band, np.abs(u)))
        return np.linalg.norm(r) <= max(tol * np.linalg.norm(f), floor)

    u = np.zeros(ndof)
    for step in range(1, load_steps + 1):
        f = f_total * (step / load_steps)
        r, kt = residual(u, f)
        for _ in range(max_iter):
            if converged(u, r, f):
                break
            pen = u[w] - gap
            if supports.tensionless and np.max(pen) > 0:
                soft = np.max(pen) * min(1.0, np.linalg.norm(r) / np.linalg.norm(f))
                kt = kt * np.clip(pen / soft, 0.0, 1.0)
            if np.count_nonzero(kt > regulariser) < 2:
                kt = kt + regulariser
            tangent = band.copy()
            tangent[3, w] += kt
            try:
                du = solveh_banded(tangent, r, check_finite=False)
            except LinAlgError:
                raise TrackdynInputError(f"load step {step}: singular tangent stiffness") from None
            u, r, kt = _line_search(u, du, r, lambda v, f=f: residual(v, f))
        if not converged(u, r, f):
            raise TrackdynInputError(
                f"load step {step} of {load_steps}: Newton-Raphson did not converge in"
                f" {max_iter} iterations (relative residual"
                f" {np.linalg.norm(r) / np.linalg.norm(f):.2e}, tol {tol:g})"
            )
    fs, _ = supports.force_and_tangent(u[w])
    return BeamSolution(x, u[0::2], u[1::2], sx, u[w], fs, xp, p, float(EI))


def _line_search(u, du, r0, residual, eta=0.1, max_eval=60):
    """Step to ``u + alpha du`` where the potential's slope ``g = -r . du`` is near zero.

    The potential is convex, so ``g`` rises from ``g(0) < 0``. The Newton step is kept if
    ``|g(1)|`` is small; otherwise the root is bracketed (expanding while the step falls
    short, as when rail lifts off) and refined by the Illinois variant of regula falsi.
    """
    g0 = -float(r0 @ du)
    lo, g_lo, hi, g_hi, side, alpha = 0.0, g0, np.inf, 0.0, 0, 1.0
    for _ in range(max_eval):
        r, kt = residual(u + alpha * du)
        g = -float(r @ du)
        if not abs(g) > eta * abs(g0) or g0 >= 0:
            break
        if g > 0:
            hi, g_hi, g_lo, side = alpha, g, g_lo * (0.5 if side < 0 else 1.0), -1
        else:
            lo, g_lo, g_hi, side = alpha, g, g_hi * (0.5 if side > 0 else 1.0), 1
        if np.isinf(hi):
            alpha *= min(max(g0 / (g0 - g), 2.0), 100.0)
        else:
            alpha = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
    return u + alpha * du, r, kt
