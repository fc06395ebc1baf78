"""The record of one section's deterioration loop, from which its Dataset is made
(`trackdyn.deterioration.results.make_dataset`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from trackdyn.deterioration.options import LoopOptions
from trackdyn.deterioration.settlement import LawParameters
from trackdyn.errors import TrackdynInputError
from trackdyn.limits import MAX_TOTAL_MGT, require_memory
from trackdyn.track.track import Geometry, Track

BYTES_PER_STORED_STEP = 1.2e3
"""Memory of the loop per stored step of each vehicle's run [bytes] (the runs' wheel
loads and the rail-seat loads taken from them): measured peaks of 10 km sections through
0.5 MGT, 0.76 GB with one vehicle and 1.33 GB with two, 1.13 kB per stored step (a step
every 0.02 m, ``output_spacing_m``) of each vehicle; with a margin."""


def snapshots(total: float, every: float, extra: int = 0) -> int:
    """Snapshots of a loop through ``total`` [MGT], one every ``every`` [MGT] and ``extra``
    more, the initial and the final state included."""
    return math.ceil(total / every) + extra + 1


def require_loop_memory(track: Track, vehicles: int, o: LoopOptions, total: float) -> None:
    """Refuse, before it starts, a loop through ``total`` [MGT] beyond `MAX_TOTAL_MGT` or
    estimated to need more memory than `trackdyn.limits.memory_budget`: the runs of its
    ``vehicles`` (`BYTES_PER_STORED_STEP`) and its snapshots (settlement, gap and
    geometry, kept and in the Dataset)."""
    if not total <= MAX_TOTAL_MGT:
        raise TrackdynInputError(
            f"total_mgt = {total:g} MGT is outside the plausible 0 to {MAX_TOTAL_MGT:g} MGT "
            "(40 years of the heaviest heavy-haul traffic)"
        )
    start, end = track.extent
    stored = vehicles * (end - start) / o.output_spacing
    count = snapshots(total, o.snapshot_every_mgt, len(o.snapshot_mgt))
    each = 8.0 * (6 * 2 * track.supports.position.size + 5 * track.geometry.distance.size)
    require_memory(
        BYTES_PER_STORED_STEP * stored + each * count,
        f"a loop over {end - start:.4g} m with {vehicles} vehicle(s) and {count:.3g} "
        f"snapshots (total_mgt = {total:g}, snapshot_every_mgt = {o.snapshot_every_mgt:g})",
    )


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
    void_factor : ndarray, optional
        Settlement-rate factor of ballast under a void (rail, sleeper) [-], with the
        loop's ``voids`` option (`trackdyn.deterioration.voids`).
    """

    mgt: float
    settlement: np.ndarray
    geometry: Geometry
    hanging_gap: np.ndarray
    void_factor: np.ndarray | None = None


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
    void_settlement : ndarray, optional
        The part of the settlement due to voids (rail, sleeper) [m], with the loop's
        ``voids`` option.
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
    void_settlement: np.ndarray | None = None
