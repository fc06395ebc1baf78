"""The deterioration loop: dynamic loads -> sleeper settlement -> new geometry -> loads.

One tonnage step: every vehicle of the traffic runs over the current geometry
(`trackdyn.simulation.simulate` on the track linearised once per vehicle: the stiffness stays
as measured, only the space curve changes); its wheel loads become rail-seat loads
(`trackdyn.deterioration.loads`); the settlement law turns them into settlement of each
sleeper and rail; the settlement is added (positive down) to the unloaded space curve of
its rail, interpolated linearly between sleepers onto the geometry grid.

Mixed traffic (the rule used here): in a step of ``ΔM`` MGT, sleeper ``i`` of rail ``r``
receives ``ΔN = ΔM Σ_j n_j`` cycles, ``n_j`` the cycles per MGT of load level ``j`` (each
contact of each vehicle: passages per MGT times the wheels it stands for). The cycles of
each level advance the common cycle count in proportion, so the time-hardening increment
is ``Δe = Σ_j (n_j / Σ n) f(Q_j) (g(N + ΔN) - g(N))``: the cycle-weighted mean load factor
times the advance on the cycle curve. For one load level it is the time-hardening rule.

The step adapts so that no sleeper settles more than ``max_step_settlement`` in it: with
the loads of the step start, the increment is known in closed form for any ``ΔM``, so the
step is the largest one within the limit (found by root finding), cut to land on the
snapshot tonnages and on ``total_mgt``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from trackdyn.deterioration.loads import TrafficRun, step_loads
from trackdyn.deterioration.results import d1_sd, make_dataset
from trackdyn.deterioration.settlement import SettlementLaw, time_hardening_increment
from trackdyn.errors import TrackdynInputError, require_positive
from trackdyn.options import RunOptions
from trackdyn.progress import progress_bar
from trackdyn.track.rails import rail_section
from trackdyn.track.track import RAILS, Geometry, Track
from trackdyn.vehicle.parameters import Vehicle


@dataclass(frozen=True)
class Traffic:
    """One kind of vehicle in the traffic mix.

    Parameters
    ----------
    vehicle : Vehicle
        Vehicle parameter set.
    speed : float
        Running speed [m/s].
    passages_per_mgt : float
        Passages of this vehicle per million gross tonnes of traffic [-].
    label : str
        Name used in outputs.
    """

    vehicle: Vehicle
    speed: float
    passages_per_mgt: float
    label: str = ""

    @property
    def gross_mass(self) -> float:
        """Gross mass of the vehicle, ``m1 + 2 m2 + 2 mw`` [kg]."""
        v = self.vehicle
        return v.m1 + 2 * v.m2 + 2 * v.mw


@dataclass(frozen=True)
class LoopOptions:
    """Options of the deterioration loop.

    Parameters
    ----------
    total_mgt : float
        Traffic to predict over [MGT].
    max_step_settlement : float
        Largest settlement of any sleeper in one step [m].
    snapshot_every_mgt : float
        Tonnage between stored geometry snapshots [MGT].
    threshold_sd_mm : float
        D1 standard deviation that triggers maintenance [mm].
    segment_length : float
        Segment length of the D1 standard deviation [m].
    max_steps : int
        Steps allowed before giving up.
    scatter_cov : float
        Coefficient of variation of a lognormal factor on each sleeper's settlement [-].
    seed : int or tuple of int
        Seed of that scatter.
    run : RunOptions
        Model (with wheels on both rails), linearisation increment, time step and solver
        of the vehicle runs; each vehicle's speed comes from its `Traffic`.
    rail : str
        Rail section, for the bending stiffness EI of the load distribution.
    output_spacing : float
        Travel between stored simulation samples [m] (sets ``store_every``).
    """

    total_mgt: float = 50.0
    max_step_settlement: float = 0.5e-3
    snapshot_every_mgt: float = 10.0
    threshold_sd_mm: float = 2.0
    segment_length: float = 200.0
    max_steps: int = 1000
    scatter_cov: float = 0.0
    seed: int | tuple[int, ...] = 0
    run: RunOptions = RunOptions()
    rail: str = "60E1"
    output_spacing: float = 0.02


def step_size(law, factor, N, cycles_per_mgt, cap: float, limit: float) -> float:
    """Largest tonnage step up to ``cap`` [MGT] in which no sleeper settles over ``limit``.

    Parameters
    ----------
    law : SettlementLaw
        Settlement law.
    factor : ndarray
        Load factor of each sleeper for the step [-].
    N : ndarray
        Cycles applied so far [-].
    cycles_per_mgt : ndarray
        Cycles per MGT [-].
    cap : float
        Longest step allowed [MGT].
    limit : float
        Largest settlement in the step [m].
    """

    def excess(dm):
        return np.max(time_hardening_increment(law, factor, N, cycles_per_mgt * dm)) - limit

    if excess(cap) <= 0:
        return cap
    return brentq(excess, 0.0, cap, xtol=1e-14 * cap, rtol=1e-12)


def settled_geometry(geometry: Geometry, position, settlement) -> Geometry:
    """Unloaded space curve plus the settlement of each rail, interpolated between sleepers.

    Parameters
    ----------
    geometry : Geometry
        Initial unloaded space curve.
    position : ndarray
        Sleeper positions [m].
    settlement : ndarray
        Settlement per rail and sleeper, positive down [m].
    """
    g = geometry
    left, right = (np.interp(g.distance, position, s) for s in settlement)
    return Geometry(g.distance, g.left + left, g.right + right, g.where)


def predict(track: Track, traffic, law: SettlementLaw, options=None, *, progress=False):
    """Predict settlement and geometry of a track section over accumulated tonnage.

    Parameters
    ----------
    track : Track
        Measured track section (initial geometry and support curves).
    traffic : sequence of Traffic
        The traffic mix; an empty mix causes no settlement.
    law : SettlementLaw
        Settlement law with its parameters.
    options : LoopOptions, optional
        Loop options; default `LoopOptions()`.
    progress : bool
        Show a progress bar over the tonnage.

    Returns
    -------
    xarray.Dataset
        See `trackdyn.deterioration.results.make_dataset`.
    """
    o = options or LoopOptions()
    total = float(require_positive("total_mgt", o.total_mgt))
    limit = float(require_positive("max_step_settlement", o.max_step_settlement))
    every = float(require_positive("snapshot_every_mgt", o.snapshot_every_mgt))
    if not 0 <= o.scatter_cov < np.inf:
        raise TrackdynInputError(f"scatter_cov must be >= 0, got {o.scatter_cov!r}")
    d1_sd(track.geometry, track.extent, o.segment_length)  # refuses too short a section now
    runs = _runs(track, traffic, o)
    pos = track.supports.position
    shape = (len(RAILS), pos.size)
    sigma = np.sqrt(np.log1p(o.scatter_cov**2))
    scatter = np.exp(sigma * np.random.default_rng(o.seed).standard_normal(shape) - sigma**2 / 2)
    snap_at = np.append(np.arange(0.0, total, every), total)
    e, N, mgt = np.zeros(shape), np.zeros(shape), 0.0
    history = {"mgt": [0.0], "settlement": [e], "geometry": [track.geometry]}
    steps = {"start": [], "end": [], "peak_load": [], "max_settlement": []}
    with progress_bar(progress, total, "tonnage [MGT]") as bar:
        while mgt < total:
            if len(steps["start"]) >= o.max_steps:
                raise TrackdynInputError(
                    f"more than max_steps = {o.max_steps} steps needed to reach {total:g} MGT "
                    f"(at {mgt:.3g} MGT); raise max_step_settlement or max_steps"
                )
            factor, cycles, peak = step_loads(runs, history["geometry"][-1], law, shape)
            factor = factor * scatter
            target = snap_at[np.searchsorted(snap_at, mgt, side="right")]
            dm = step_size(law, factor, N, cycles, target - mgt, limit)
            de = time_hardening_increment(law, factor, N, cycles * dm)
            e, N = e + de, N + cycles * dm
            steps["start"].append(mgt)
            mgt = target if target - (mgt + dm) <= 1e-12 * total else mgt + dm
            steps["end"].append(mgt)
            steps["peak_load"].append(peak)
            steps["max_settlement"].append(float(de.max()))
            history["mgt"].append(mgt)
            history["settlement"].append(e)
            history["geometry"].append(settled_geometry(track.geometry, pos, e))
            bar.update(mgt)
    return make_dataset(track, history, steps, snap_at, N, traffic, law, o)


def _runs(track: Track, traffic, o: LoopOptions) -> list[TrafficRun]:
    """One `TrafficRun` per vehicle with traffic; the track is linearised once per static load."""
    EI = rail_section(o.rail).EI
    lins, runs = {}, []
    for t in traffic:
        if not 0 <= t.passages_per_mgt < np.inf:
            raise TrackdynInputError(f"passages_per_mgt must be >= 0, got {t.passages_per_mgt!r}")
        require_positive("speed", t.speed)
        if t.passages_per_mgt > 0:
            load = t.vehicle.static_wheel_load
            if load not in lins:
                lins[load] = track.linearise(load, o.run.delta, extrapolate=o.run.extrapolate)
            runs.append(TrafficRun(t, lins[load], o, EI))
    return runs
