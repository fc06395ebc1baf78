"""Piecewise cubic interpolation of many curves at once, each on its own abscissae.

Every row of ``x`` and ``y`` (shape (curves, points)) is one curve. The knot slopes are
those of a not-a-knot cubic spline (de Boor 1978) or of the monotone piecewise cubic
Hermite interpolant (Fritsch & Carlson 1980, end slopes after Moler 2004), computed with
the same arithmetic as scipy's ``CubicSpline`` and ``PchipInterpolator`` but for all rows
in one array pass; beyond the ends a curve continues linearly with its end slope.

References
----------
de Boor, C. (1978). A Practical Guide to Splines. Springer, New York.

Fritsch, F.N. and Carlson, R.E. (1980). Monotone piecewise cubic interpolation. SIAM
Journal on Numerical Analysis 17(2), 238-246.

Moler, C. (2004). Numerical Computing with MATLAB, §3.6. SIAM, Philadelphia.
"""

from __future__ import annotations

import numpy as np

METHODS = ("cubic", "pchip")
"""``"cubic"``: not-a-knot cubic spline; ``"pchip"``: monotone cubic Hermite."""


def knot_slopes(x: np.ndarray, y: np.ndarray, method: str) -> np.ndarray:
    """Slope dy/dx at every knot of every curve.

    Parameters
    ----------
    x : ndarray
        Abscissae, shape (curves, points), strictly increasing along each row.
    y : ndarray
        Ordinates, same shape, strictly increasing along each row (as for a support
        curve; the pchip sign tests for falling or flat stretches are therefore omitted).
    method : {"cubic", "pchip"}
        Interpolant, see `METHODS`.
    """
    h = np.diff(x, axis=1)
    m = np.diff(y, axis=1) / h
    if x.shape[1] == 2:  # a straight line, for both methods
        return np.concatenate((m, m), axis=1)
    if method == "cubic":
        return _not_a_knot_slopes(x, h, m)
    return _pchip_slopes(h, m)


def _not_a_knot_slopes(x, h, m):
    """Slopes of the not-a-knot cubic spline from knot spacing ``h`` and secants ``m``."""
    n = x.shape[1]
    lower, diag, upper, rhs = (np.empty_like(x) for _ in range(4))
    if n == 3:  # both conditions coincide: the parabola through the three points
        diag[:, 0], upper[:, 0], rhs[:, 0] = 1.0, 1.0, 2 * m[:, 0]
        lower[:, 2], diag[:, 2], rhs[:, 2] = 1.0, 1.0, 2 * m[:, 1]
    else:
        d = x[:, 2] - x[:, 0]
        diag[:, 0], upper[:, 0] = h[:, 1], d
        rhs[:, 0] = ((h[:, 0] + 2 * d) * h[:, 1] * m[:, 0] + h[:, 0] ** 2 * m[:, 1]) / d
        d = x[:, -1] - x[:, -3]
        lower[:, -1], diag[:, -1] = d, h[:, -2]
        rhs[:, -1] = (h[:, -1] ** 2 * m[:, -2] + (2 * d + h[:, -1]) * h[:, -2] * m[:, -1]) / d
    lower[:, 1:-1] = h[:, 1:]
    diag[:, 1:-1] = 2 * (h[:, :-1] + h[:, 1:])
    upper[:, 1:-1] = h[:, :-1]
    rhs[:, 1:-1] = 3 * (h[:, 1:] * m[:, :-1] + h[:, :-1] * m[:, 1:])
    return _solve_tridiagonal(lower, diag, upper, rhs)


def _solve_tridiagonal(lower, diag, upper, rhs):
    """Solve one tridiagonal system per row (Thomas algorithm, rows in parallel).

    Row ``i`` of a system reads ``lower[i] s[i-1] + diag[i] s[i] + upper[i] s[i+1] =
    rhs[i]``; the spline systems above need no pivoting (their eliminated diagonal stays
    positive).
    """
    diag, rhs = diag.copy(), rhs.copy()
    n = diag.shape[1]
    for i in range(1, n):
        w = lower[:, i] / diag[:, i - 1]
        diag[:, i] -= w * upper[:, i - 1]
        rhs[:, i] -= w * rhs[:, i - 1]
    s = np.empty_like(rhs)
    s[:, -1] = rhs[:, -1] / diag[:, -1]
    for i in range(n - 2, -1, -1):
        s[:, i] = (rhs[:, i] - upper[:, i] * s[:, i + 1]) / diag[:, i]
    return s


def _pchip_slopes(h, m):
    """Fritsch-Carlson slopes: weighted harmonic mean inside, shape-preserving ends."""
    s = np.empty((h.shape[0], h.shape[1] + 1))
    w1 = 2 * h[:, 1:] + h[:, :-1]
    w2 = h[:, 1:] + 2 * h[:, :-1]
    s[:, 1:-1] = 1.0 / ((w1 / m[:, :-1] + w2 / m[:, 1:]) / (w1 + w2))
    s[:, 0] = _pchip_end_slope(h[:, 0], h[:, 1], m[:, 0], m[:, 1])
    s[:, -1] = _pchip_end_slope(h[:, -1], h[:, -2], m[:, -1], m[:, -2])
    return s


def _pchip_end_slope(h0, h1, m0, m1):
    """One-sided three-point slope at an end, zero where its sign would flip."""
    return np.maximum(((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1), 0.0)


def evaluate(x: np.ndarray, y: np.ndarray, s: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Values of the piecewise cubic Hermite curves at ``at``, linear beyond the ends.

    Parameters
    ----------
    x, y, s : ndarray
        Knots, values and knot slopes, shape (curves, points).
    at : ndarray
        Where to evaluate each curve, shape (curves, k).

    Returns
    -------
    ndarray
        Shape (curves, k).
    """
    lo, hi = x[:, :1], x[:, -1:]
    inside = np.clip(at, lo, hi)
    i = np.count_nonzero(x[:, None, 1:-1] <= inside[:, :, None], axis=2)
    x0, y0, s0 = (np.take_along_axis(a, i, axis=1) for a in (x, y, s))
    x1, y1, s1 = (np.take_along_axis(a, i + 1, axis=1) for a in (x, y, s))
    dx = x1 - x0
    secant = (y1 - y0) / dx
    t = (s0 + s1 - 2 * secant) / dx
    cubic, quadratic = t / dx, (secant - s0) / dx - t
    u = inside - x0
    u2 = u * u
    value = y0 + s0 * u + quadratic * u2 + cubic * (u2 * u)
    end_slope = np.where(at < lo, s[:, :1], s[:, -1:])
    return value + (at - inside) * end_slope
