"""The record of one section's deterioration loop, from which its Dataset is made
(`trackdyn.deterioration.results.make_dataset`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from trackdyn.deterioration.options import LoopOptions
from trackdyn.deterioration.settlement import LawParameters
from trackdyn.track.track import Geometry, Track


@dataclass(frozen=True)
class TrackState:
    """The track at one tonnage.

    Parameters
    ----------
    mgt : float
        Tonnage [MGT].
    settlement : ndarray
        Ballast settlement under each rail seat (rail, sleeper) [m], positive down.
    geometry : Geometry
        The unloaded space curve.
    hanging_gap : ndarray
        Gap under each sleeper with the rail at rest (rail, sleeper) [m].
    """

    mgt: float
    settlement: np.ndarray
    geometry: Geometry
    hanging_gap: np.ndarray


@dataclass(frozen=True)
class StepRecord:
    """One tonnage step of the loop.

    Parameters
    ----------
    start, end : float
        Its tonnages [MGT].
    peak_load : ndarray
        Largest rail-seat load at its start (rail, sleeper) [N].
    max_settlement : float
        Largest settlement of any rail seat in it [m].
    load_updates : int
        Rail-seat load updates (beam solves) in it.
    vehicle_runs : int
        Vehicles run for it (the others held their latest run).
    """

    start: float
    end: float
    peak_load: np.ndarray
    max_settlement: float
    load_updates: int
    vehicle_runs: int


@dataclass
class Timing:
    """Seconds a section's loop spent, by part [s].

    Parameters
    ----------
    vehicle : float
        Its share of the vehicle runs' batches.
    beam : float
        Rail-beam solves (rail-seat loads, ballast states, geometry).
    total : float
        Its whole loop, without the time it waited for other sections.
    """

    vehicle: float = 0.0
    beam: float = 0.0
    total: float = 0.0


@dataclass(frozen=True)
class LoopRecord:
    """What one section's loop recorded.

    Parameters
    ----------
    track : Track
        The section at the start of the loop (its start state, `LoopOptions.start`).
    traffic : tuple of Traffic
        The traffic mix.
    law : LawParameters
        The settlement law of the open track.
    options : LoopOptions
        The loop options.
    states : list of TrackState
        The track after each step and at each snapshot, initial first, by tonnage.
    steps : list of StepRecord
        The steps.
    snap_at : ndarray
        Snapshot tonnages, each one of the states' [MGT].
    cycles : ndarray
        Load cycles applied per rail and sleeper [-].
    rate : ndarray
        Settlement-rate factor per rail and sleeper [-].
    by_vehicle : ndarray
        Each vehicle's part of the settlement (vehicle, rail, sleeper) [m].
    kind : ndarray
        The zone kind of each sleeper.
    interventions : list of Intervention
        The maintenance's tampings and renewals.
    timing : Timing
        Seconds spent, by part.
    """

    track: Track
    traffic: tuple
    law: LawParameters
    options: LoopOptions
    states: list[TrackState]
    steps: list[StepRecord]
    snap_at: np.ndarray
    cycles: np.ndarray
    rate: np.ndarray
    by_vehicle: np.ndarray
    kind: np.ndarray
    interventions: list = field(default_factory=list)
    timing: Timing = field(default_factory=Timing)
