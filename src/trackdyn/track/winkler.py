"""Winkler beam on a continuous elastic foundation (seed §5.1, eqs 5.1-5.8).

All functions take and return SI units. Eq 5.6 is used in its corrected form
``L_c = (4 EI / u)^(1/4)`` (the printed ``k`` is a misprint: only ``u`` makes 5.5, 5.7 and
5.8 consistent, since then ``k = P / y(0) = 2 u L_c``).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading
and spatially varying track stiffness. PhD thesis, University of Pretoria, §5.1, eqs 5.1-5.8.

Hetényi, M. (1946). Beams on Elastic Foundation. University of Michigan Press, Ann Arbor.
"""

from __future__ import annotations

import numpy as np

from trackdyn.errors import require_positive as _positive


def characteristic_length(EI, u):
    """Characteristic length of the beam on elastic foundation (eq 5.6, corrected).

    Parameters
    ----------
    EI : float
        Bending stiffness of one rail [N m^2].
    u : float
        Track modulus, support force per unit rail length per unit deflection [N/m^2].

    Returns
    -------
    float
        ``L_c = (4 EI / u)^(1/4)`` [m].
    """
    return (4.0 * _positive("EI", EI) / _positive("track modulus u", u)) ** 0.25


def stiffness_from_modulus(u, EI):
    """Track stiffness under a point load from the track modulus (eq 5.8).

    Parameters
    ----------
    u : float
        Track modulus [N/m^2].
    EI : float
        Rail bending stiffness [N m^2].

    Returns
    -------
    float
        ``k = 2 u / (u / 4EI)^(1/4) = 2 u L_c`` [N/m].
    """
    return 2.0 * _positive("track modulus u", u) * characteristic_length(EI, u)


def modulus_from_stiffness(k, EI):
    """Track modulus from the track stiffness under a point load (eq 5.7).

    Parameters
    ----------
    k : float
        Track stiffness ``P / y(0)`` [N/m].
    EI : float
        Rail bending stiffness [N m^2].

    Returns
    -------
    float
        ``u = k^(4/3) / (64 EI)^(1/3)`` [N/m^2].
    """
    return _positive("track stiffness k", k) ** (4.0 / 3.0) / (64.0 * _positive("EI", EI)) ** (
        1.0 / 3.0
    )


def deflection(x, P, EI, u):
    """Rail deflection at distance ``x`` from a point load (eq 5.5), positive downward.

    Parameters
    ----------
    x : array_like
        Distance from the load [m]; the basin is symmetric in ``x``.
    P : float
        Point load [N].
    EI : float
        Rail bending stiffness [N m^2].
    u : float
        Track modulus [N/m^2].

    Returns
    -------
    ndarray
        Deflection [m].
    """
    lc = characteristic_length(EI, u)
    s = np.abs(np.asarray(x, dtype=float)) / lc
    return P / (2.0 * u * lc) * np.exp(-s) * (np.cos(s) + np.sin(s))


def bending_moment(x, P, EI, u):
    """Rail bending moment at distance ``x`` from a point load, sagging positive.

    ``M = P L_c / 4 e^(-x/L_c) (cos(x/L_c) - sin(x/L_c))`` (Hetényi, 1946).

    Parameters
    ----------
    x : array_like
        Distance from the load [m].
    P : float
        Point load [N].
    EI : float
        Rail bending stiffness [N m^2].
    u : float
        Track modulus [N/m^2].

    Returns
    -------
    ndarray
        Bending moment [N m].
    """
    lc = characteristic_length(EI, u)
    s = np.abs(np.asarray(x, dtype=float)) / lc
    return P * lc / 4.0 * np.exp(-s) * (np.cos(s) - np.sin(s))


def sleeper_load(x, P, EI, u, spacing):
    """Load carried by a sleeper at distance ``x`` from a point load.

    The foundation force over one sleeper bay, ``u * spacing * y(x)``; under the load it is
    ``P spacing / (2 L_c)``.

    Parameters
    ----------
    x : array_like
        Distance from the load to the sleeper [m].
    P : float
        Point load [N].
    EI : float
        Rail bending stiffness [N m^2].
    u : float
        Track modulus [N/m^2].
    spacing : float
        Sleeper spacing [m].

    Returns
    -------
    ndarray
        Sleeper (rail seat) load [N].
    """
    return u * _positive("sleeper spacing", spacing) * deflection(x, P, EI, u)
