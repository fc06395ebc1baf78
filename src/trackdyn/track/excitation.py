"""The four excitation cases of §5.4.1: transformations of a linearised track's input.

(i) the unloaded space curve on infinitely stiff track; (ii) the space curve with the mean
stiffness everywhere; (iii) level rails with the measured stiffness; (iv) the track as
measured. A new kind of track input (a dipped joint, a measured stiffness trace) is
another function from a `LinearisedTrack` to a `LinearisedTrack`.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.4.1.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from trackdyn.errors import unknown
from trackdyn.track.track import Geometry, LinearisedTrack

RIGID_STIFFNESS = 1e11
"""Track stiffness per wheel standing in for infinitely stiff track in case (i) [N/m]:
about 1000 times real track, so the wheel follows the geometry within 0.1 %."""

CASES = {
    "i": "space curve, infinitely stiff track",
    "ii": "space curve, constant stiffness",
    "iii": "varying stiffness, level track",
    "iv": "space curve and varying stiffness",
}


def excitation_case(lin: LinearisedTrack, case: str) -> LinearisedTrack:
    """The linearised track as one of the excitation cases of §5.4.1 (keys of `CASES`).

    (i) the unloaded space curve on infinitely stiff track (`RIGID_STIFFNESS`, no static
    deflection); (ii) the space curve with the mean k2 and ys everywhere; (iii) level rails
    with the measured k2 and ys; (iv) the track as measured.

    Parameters
    ----------
    lin : LinearisedTrack
        The track as measured, linearised.
    case : str
        ``i``, ``ii``, ``iii`` or ``iv``.
    """
    if case not in CASES:
        raise unknown("excitation case", case, CASES)
    if case == "iv":
        return lin
    if case == "iii":
        g = lin.track.geometry
        level = Geometry(g.distance, np.zeros_like(g.left), np.zeros_like(g.right), g.where)
        return dataclasses.replace(lin, track=dataclasses.replace(lin.track, geometry=level))
    if case == "ii":
        return dataclasses.replace(
            lin, k2=np.full_like(lin.k2, lin.k2.mean()), ys=np.full_like(lin.ys, lin.ys.mean())
        )
    return dataclasses.replace(
        lin, k2=np.full_like(lin.k2, RIGID_STIFFNESS), ys=np.zeros_like(lin.ys)
    )
