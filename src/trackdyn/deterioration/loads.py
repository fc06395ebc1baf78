"""Rail-seat loads of one passage: dynamic wheel loads over each sleeper, Winkler share.

For each wheel of the vehicle model, the wheel load of its contact is interpolated at the
times that wheel passes each sleeper (a bogie contact reports the mean load of its
leading and trailing wheel, 5.4.3; each of the two wheels carries it over the sleepers
at its own position, so a dip under a wheel is loaded when that wheel is over it). The
force on the sleeper under the wheel follows the beam on elastic foundation of §5.1 with
the local track modulus ``u`` from the linearised stiffness ``k2`` of that sleeper and
rail (eq 5.7): ``Q = P s / (2 L_c)`` with ``s`` the
sleeper spacing and ``L_c = (4 EI / u)^(1/4)`` (eq 5.6 corrected, `trackdyn.track.winkler`).

Assumptions: each wheel is taken alone; the overlap of the neighbouring wheels' basins is
neglected. Its relative size at the other axle of the same bogie (``2a`` = 1.83 m apart) is
``e^(-x/L_c) (cos + sin)(x/L_c)``, about +1 % for ``L_c`` = 0.8 m (100 kN/mm on 60E1), and
smaller, or negative, for axles further away. Sleepers that a wheel does not reach (near
the ends of the section) take the load of the nearest point it reached.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from trackdyn.errors import TrackdynInputError
from trackdyn.simulation import simulate, time_step
from trackdyn.track.track import RAILS, LinearisedTrack
from trackdyn.track.winkler import characteristic_length, modulus_from_stiffness
from trackdyn.vehicle.models import build_model

AXLES_PER_RAIL = 4
"""Wheels of one vehicle on each rail: two bogies of two axles, as the vehicle parameter
sets describe (`trackdyn.vehicle.parameters`)."""


def rail_seat_share(lin: LinearisedTrack, EI: float) -> np.ndarray:
    """Fraction of a wheel load carried by the sleeper under it, ``s / (2 L_c)`` [-].

    Parameters
    ----------
    lin : LinearisedTrack
        Linearised track; ``k2`` sets the local track modulus.
    EI : float
        Rail bending stiffness [N m^2].

    Returns
    -------
    ndarray
        Shape (2 rails, sleepers) [-].
    """
    spacing = np.gradient(lin.track.supports.position)
    lc = characteristic_length(EI, modulus_from_stiffness(lin.k2, EI))
    return spacing / (2.0 * lc)


def wheels(model) -> list[tuple[int, float, str]]:
    """(contact index, axle position ahead of the centre [m], rail) of every wheel."""
    return [
        (c, x, rail)
        for c, (axles, rail) in enumerate(
            zip(model.contact_axles, model.contact_rails, strict=True)
        )
        for x in axles
    ]


def cycles_per_passage(model) -> np.ndarray:
    """Load cycles each wheel of the model stands for in one passage of the vehicle [-].

    One cycle per wheel; when the model has fewer axles on a rail than the vehicle (the
    4-DOF model carries only the front bogie), its wheels stand for the vehicle's
    `AXLES_PER_RAIL` in proportion.

    Parameters
    ----------
    model : trackdyn.vehicle.assembly.Model
        The vehicle model.
    """
    per_rail = {r: sum(1 for _, _, rail in wheels(model) if rail == r) for r in RAILS}
    missing = [r for r in RAILS if per_rail[r] == 0]
    if missing:
        raise TrackdynInputError(
            f"model {model.name} has no contact on the {missing[0]} rail; deterioration needs "
            "both rails (4dof, 7dof or 11dof)"
        )
    return np.array([AXLES_PER_RAIL / per_rail[r] for _, _, r in wheels(model)])


def passage_loads(ds, lin: LinearisedTrack, share: np.ndarray, model) -> np.ndarray:
    """Rail-seat load of every wheel at every sleeper of its rail in one passage [N].

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.simulation.simulate` (``wheel_load``, ``distance``,
        ``contact_offset``, ``contact_rail``).
    lin : LinearisedTrack
        The linearised track of the run.
    share : ndarray
        `rail_seat_share` of that track, shape (2 rails, sleepers) [-].
    model : trackdyn.vehicle.assembly.Model
        The model of the run (its contacts' axles).

    Returns
    -------
    ndarray
        Shape (wheels, sleepers) [N], wheels in the order of `wheels`.
    """
    pos = lin.track.supports.position
    centre = ds.distance.values
    load = ds.wheel_load.values
    rows = [
        np.interp(pos, centre + x, load[:, c]) * share[RAILS.index(rail)]
        for c, x, rail in wheels(model)
    ]
    return np.array(rows)


class TrafficRun:
    """One vehicle of the traffic on the track linearised once about its static load.

    Parameters
    ----------
    traffic : Traffic
        The vehicle, its speed and passages per MGT.
    lin : LinearisedTrack
        The track linearised about the vehicle's static wheel load (the stiffness stays as
        measured; `loads` swaps in the current geometry).
    options : LoopOptions
        Run options (model, time step, linearisation increment) and output spacing.
    EI : float
        Rail bending stiffness [N m^2].
    """

    def __init__(self, traffic, lin: LinearisedTrack, options, EI: float):
        self.traffic, self.lin, self.options = traffic, lin, options
        self.model = build_model(options.run.model, traffic.vehicle)
        self.weights = cycles_per_passage(self.model) * traffic.passages_per_mgt
        self.rails = [RAILS.index(r) for _, _, r in wheels(self.model)]
        self.share = rail_seat_share(lin, EI)
        dt = options.run.dt_s or time_step(self.model, lin, traffic.speed)[0]
        every = max(1, int(options.output_spacing / (traffic.speed * dt)))
        self.run = options.run.with_(speed_kmh=traffic.speed * 3.6, dt_s=dt, store_every=every)

    def loads(self, geometry) -> np.ndarray:
        """Rail-seat loads of one passage over ``geometry``, (wheels, sleepers) [N]."""
        lin = dataclasses.replace(
            self.lin, track=dataclasses.replace(self.lin.track, geometry=geometry)
        )
        ds = simulate(self.traffic.vehicle, lin, self.run)
        return passage_loads(ds, lin, self.share, self.model)


def step_loads(runs, geometry, law, shape):
    """Load factor, cycles and peak load of one step, per rail and sleeper.

    Parameters
    ----------
    runs : list of TrafficRun
        The traffic.
    geometry : Geometry
        Current unloaded space curve.
    law : SettlementLaw
        Settlement law (its ``load_factor``).
    shape : tuple
        (2 rails, sleepers).

    Returns
    -------
    factor : ndarray
        Cycle-weighted mean load factor of the vehicles' wheels [-].
    cycles : ndarray
        Load cycles per MGT [-].
    peak : ndarray
        Largest rail-seat load of any wheel [N].
    """
    weighted = np.zeros(shape)
    cycles = np.zeros(shape[0])
    peak = np.zeros(shape)
    for run in runs:
        loads = run.loads(geometry)
        for q, r, w in zip(loads, run.rails, run.weights, strict=True):
            weighted[r] += w * law.load_factor(q, run.lin.k2[r])
            cycles[r] += w
            peak[r] = np.maximum(peak[r], q)
    factor = np.divide(weighted, cycles[:, None], out=np.zeros(shape), where=cycles[:, None] > 0)
    return factor, np.broadcast_to(cycles[:, None], shape), peak
