"""Hermite cubic Euler-Bernoulli beam elements: shape functions and banded stiffness.

The elements of the rail beam (`trackdyn.beam.static`) and of the rail-seat load windows
(`trackdyn.beam.railseat`). Degrees of freedom per node: deflection ``w`` [m]
and rotation ``theta`` [rad], in the order (w1, theta1, w2, theta2).

References
----------
Przemieniecki, J.S. (1968). Theory of Matrix Structural Analysis. McGraw-Hill, New York
(the stiffness matrix of a uniform beam element).
"""

from __future__ import annotations

import numpy as np
from numba import njit


def hermite(s, length):
    """Cubic Hermite shape functions of a beam element.

    Parameters
    ----------
    s : array_like
        Local coordinate, 0 at the first node and 1 at the second [-].
    length : array_like
        Element length, broadcast against ``s`` [m].

    Returns
    -------
    ndarray, shape (4,) + broadcast shape
        Shape functions of (w1, theta1, w2, theta2): the deflection at ``s`` per unit nodal
        deflection [-] and per unit nodal rotation [m].
    """
    s2, s3 = s * s, s * s * s
    return np.stack([1 - 3 * s2 + 2 * s3, length * (s - 2 * s2 + s3), 3 * s2 - 2 * s3,
                     length * (s3 - s2)])  # fmt: skip


_KE = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], dtype=float)
_POWER = np.array([0, 1, 0, 1]) - 1.5  # K[i, j] = EI ke[i, j] L^(power[i] + power[j])


def element_stiffness(length, EI):
    """Stiffness matrices of Euler-Bernoulli (Hermite cubic) beam elements.

    Parameters
    ----------
    length : array_like
        Element lengths [m].
    EI : float
        Bending stiffness [N m^2].

    Returns
    -------
    ndarray, shape ``length.shape + (4, 4)``
        In the order (w1, theta1, w2, theta2) [N/m, N, N m].
    """
    L = np.asarray(length, dtype=float)[..., None, None]
    return EI * _KE * L ** (_POWER[:, None] + _POWER[None, :])


def stiffness_band(x, EI):
    """Beam stiffness of a rail with nodes ``x``, in LAPACK upper banded form.

    Parameters
    ----------
    x : array_like
        Node positions, strictly increasing [m].
    EI : float
        Bending stiffness [N m^2].

    Returns
    -------
    ndarray, shape (4, 2 len(x))
        ``band[3 + i - j, j] = K[i, j]`` for ``i <= j``, degrees of freedom (w, theta) per
        node (`scipy.linalg.solveh_banded`).
    """
    L = np.diff(np.asarray(x, dtype=float))
    e, ke = 2 * np.arange(L.size), element_stiffness(L, EI)
    band = np.zeros((4, 2 * L.size + 2))
    for i, j in zip(*np.triu_indices(4), strict=True):
        band[3 + i - j, e + j] += ke[:, i, j]
    return band


def band_times(band, u):
    """``K @ u`` for a symmetric matrix in LAPACK upper banded form with 3 superdiagonals."""
    out = band[3] * u
    for k in (1, 2, 3):
        out[:-k] += band[3 - k, k:] * u[k:]
        out[k:] += band[3 - k, k:] * u[:-k]
    return out


@njit(cache=True, nogil=True)
def solve_band(band, rhs):
    """Solve ``K y = rhs`` for a symmetric positive definite ``K`` in LAPACK upper banded
    form with 3 superdiagonals (`stiffness_band`, with the supports added on its diagonal):
    banded Cholesky, compiled (LAPACK's ``pbsv`` takes about twice as long at this
    bandwidth). Returns ``y``; ``band`` and ``rhs`` are left as they are. ``K`` must be
    positive definite: the rail on at least two supports.
    """
    n, p = rhs.size, 3
    low = np.empty((p + 1, n))  # low[d, j] = L[j + d, j], K = L Lᵀ
    for j in range(n):
        s = band[3, j]
        for k in range(max(0, j - p), j):
            s -= low[j - k, k] * low[j - k, k]
        low[0, j] = np.sqrt(s)
        for i in range(j + 1, min(n, j + p + 1)):
            s = band[3 + j - i, i]  # K[j, i]
            for k in range(max(0, i - p), j):
                s -= low[i - k, k] * low[j - k, k]
            low[i - j, j] = s / low[0, j]
    y = rhs.copy()
    for i in range(n):  # L z = rhs
        s = y[i]
        for k in range(max(0, i - p), i):
            s -= low[i - k, k] * y[k]
        y[i] = s / low[0, i]
    for i in range(n - 1, -1, -1):  # Lᵀ y = z
        s = y[i]
        for k in range(i + 1, min(n, i + p + 1)):
            s -= low[k - i, i] * y[k]
        y[i] = s / low[0, i]
    return y
