"""The deterioration loop: dynamic loads -> rail-seat loads -> ballast settlement -> track.

One tonnage step: every vehicle of the traffic runs over the current track (unloaded
profile and linearisation re-derived from the rail beam on the current ballast,
`trackdyn.deterioration.ballast`); each wheel's loads, placed on the rail beam with the
current gaps, give the rail-seat load cycles of every sleeper
(`trackdyn.deterioration.loads`); the settlement law turns them into ballast settlement
under each rail seat (`trackdyn.deterioration.accumulation`), times the sleeper's
settlement-rate factor; the ballast level drops by it, the rail comes to rest on the new
ballast (hanging where it cannot reach), and the next step starts from there.

Mixed traffic: in a step of ``ΔM`` MGT each wheel of each vehicle applies its passages per
MGT times ``ΔM`` cycles at every sleeper of its rail, with the load it had there at the
step start; see `trackdyn.deterioration.accumulation` for how each law sums them (every
cycle adds settlement; each vehicle's part is recorded). Zones
(`trackdyn.deterioration.zones`) give parts of the track their own law and rate field.

Two step sizes. A step (a vehicle run) is as long as ``max_step_settlement`` allows: with
the loads of the step start, the increment is known in closed form for any ``ΔM``, so the
step is the largest one whose change of the track's shape stays within the limit at
every sleeper (found by root finding). The shape is what the vehicle feels: the
increment less its moving mean over `SHAPE_WAVELENGTH` (a track that settles evenly over
a wavelength longer than the D1 band's loads the wheels as before; the rail beam still
redistributes the rail-seat loads within the step). The step is cut to land on
``total_mgt``, on maintenance and on the tonnages of ``snapshot_mgt`` (the surveys a
calibration compares with: their comparison stays at a step end, as measured before;
seed 8 of `tests/calibration/test_rate_field_fit.py` predicts its check survey to 0.049
mm so, to 0.051 mm without); a snapshot of ``snapshot_every_mgt`` within a step is the
track at its tonnage from the step's closed form, so asking for more of them changes no
step (cut at each of the life's 30 snapshots, a 1 km section's 300 MGT took 89 steps
instead of 73, 17 % more time). The first step, and the first after each tamping, is
at least one train (``min_step_passages`` passages of the traffic mix): the law's first
cycles settle fast, and a step shorter than a train would follow them with vehicle runs
where the rail-seat load updates do. Within a step, the dynamic wheel loads of
the run stay and the rail beam redistributes them as the ballast settles: the rail-seat
loads are updated as often as each sleeper's stable step (`stable_settlement`) needs.
A law that follows the load steeply, a soft spot or the first train after tamping then
costs beam solves, not vehicle runs. A vehicle that causes next to none of a step's
settlement (`MIN_SHARE`) keeps its latest run and load cycles into the next step.

The stable step. A sleeper whose ballast sinks ``δ`` more than its neighbours' sheds load
``kd δ`` to them (the rail, far stiffer against a sleeper-to-sleeper pattern than the
support ``kd``, does not follow). With settlement ``e ∝ Q^s`` (``s`` the law's
`load_sensitivity`), the next step's increment there falls by ``g δ`` with
``g = s kd e / Q``: for ``g > 1`` the explicit step overshoots and settlement alternates
from sleeper to sleeper, for ``g > 2`` the alternation grows. Each sleeper's increment is
kept to ``e <= STABLE_GAIN Q / (s kd)`` between load updates (measured on the built-in
example before the updates within a step: a 1 mm limit reached ``g`` = 1.9 and gave the
settlement of a 0.25 mm limit; a 2 mm limit reached ``g`` = 3.5 and doubled the largest
sleeper-to-sleeper step of the settlement at 20 MGT).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria.

Nielsen, J.C.O., Li, X. (2018). Railway track geometry degradation due to differential
settlement of ballast/subgrade - Numerical prediction by an iterative procedure. Journal
of Sound and Vibration 412, 441-456.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.optimize import brentq

from trackdyn.deterioration.accumulation import Zoned
from trackdyn.deterioration.ballast import Ballast, rate_field
from trackdyn.deterioration.loads import (
    TrafficRun,
    rail_seat_loads,
    step_together,
    vehicle_runs,
)
from trackdyn.deterioration.maintenance import Maintenance
from trackdyn.deterioration.options import LoopOptions
from trackdyn.deterioration.quality import d1_sd
from trackdyn.deterioration.record import LoopRecord, StepRecord, Timing, TrackState
from trackdyn.deterioration.results import make_dataset
from trackdyn.deterioration.starts import STARTS, surveyed_geometry, tamped_geometry
from trackdyn.deterioration.zones import check_zones
from trackdyn.errors import TrackdynInputError, require_positive, shown
from trackdyn.progress import progress_bar
from trackdyn.track.rails import rail_section
from trackdyn.track.track import RAILS, Track

STABLE_GAIN = 1.0
"""Largest ``g = s kd e / Q`` a step may reach at any sleeper (no overshoot)."""


def stable_settlement(peak, stiffness, sensitivity: float) -> np.ndarray:
    """Largest stable settlement increment of each sleeper in a step [m].

    Parameters
    ----------
    peak : ndarray
        Largest rail-seat load of the step's traffic per rail and sleeper [N].
    stiffness : ndarray
        Support stiffness per rail seat [N/m].
    sensitivity : float
        ``d ln e / d ln Q`` of the settlement law [-].

    Returns
    -------
    ndarray
        ``STABLE_GAIN Q / (s kd)``; infinite where no load bears or settlement does not
        follow the load.
    """
    gain = sensitivity * np.asarray(stiffness, dtype=float)
    return np.divide(STABLE_GAIN * peak, gain, out=np.full(np.shape(peak), np.inf),
                     where=(gain > 0) & (peak > 0))  # fmt: skip


SHAPE_WAVELENGTH = 25.0
"""Length of the moving mean taken off a step's settlement before the step limit [m]: the
longest wavelength of the D1 band (EN 13848-1), which sets the dynamic wheel loads."""


def shape_sleepers(position) -> int:
    """Sleepers in `SHAPE_WAVELENGTH` at the median spacing of ``position`` [m], odd."""
    spacing = float(np.median(np.diff(position)))
    return max(1, int(round(SHAPE_WAVELENGTH / spacing)) | 1)


def shape_change(increment, sleepers: int) -> np.ndarray:
    """The settlement increment (rail, sleeper) [m] less its moving mean over ``sleepers``
    (`shape_sleepers`), in absolute value [m]."""
    return np.abs(increment - uniform_filter1d(increment, sleepers, axis=-1, mode="nearest"))


MIN_SHARE = 0.01
"""A vehicle whose part of a step's settlement at every rail seat is below this share of the
step's largest settlement is not run again in the next step (unless a tamping came
between), nor its rail-seat loads solved again: its latest load cycles stand (the
example's empty wagons cause 0.07 % of its settlement). Held load cycles 10 % off move
that part by about ``α`` times 10 % (``α`` the law's load exponent, 2 in the shipped power
law: 1.1² = 1.21), 0.21 % of the step's largest settlement, within the step limit's
accuracy."""

RUNAWAY_STEPS = 10
"""Steps in a row, each shorter than one passage of the traffic, after which the loop
refuses to go on: every passage settling a sleeper by the step limit is runaway
settlement (a law far outside its range), not deterioration."""

MAX_LOAD_UPDATES = 2000
"""Rail-seat load updates allowed within one step (each a beam solve) before giving up."""

NO_TRAFFIC_LOAD = 100e3
"""Static wheel load the beam is set up for when no vehicle runs [N] (nothing settles)."""


def step_size(increment, cap: float, limit) -> float:
    """Largest tonnage step up to ``cap`` [MGT] in which no sleeper settles over ``limit``.

    Parameters
    ----------
    increment : callable
        Settlement increment per rail and sleeper [m] as a function of the step [MGT].
    cap : float
        Longest step allowed [MGT].
    limit : float or ndarray
        Largest settlement in the step [m], for all sleepers or per rail and sleeper.
    """

    def excess(dm):
        return np.max(increment(dm) - limit)

    if excess(cap) <= 0:
        return cap
    return brentq(excess, 0.0, cap, xtol=1e-14 * cap, rtol=1e-12)


def predict(track: Track, traffic, law, options=None, *, zones=(), progress=False):
    """Predict settlement and geometry of a track section over accumulated tonnage.

    Parameters as `predicting`, which this runs on its own (`step_together`).

    Returns
    -------
    xarray.Dataset
        See `trackdyn.deterioration.results.make_dataset`.
    """
    (result,) = step_together([predicting(track, traffic, law, options, zones=zones,
                                          progress=progress)])  # fmt: skip
    if isinstance(result, Exception):
        raise result
    return result


def predicting(track: Track, traffic, law, options=None, *, zones=(), progress=False):
    """`predict` as a generator, to be stepped together with other sections'
    (`step_together`): it yields each step's vehicle runs (`vehicle_runs`).

    Parameters
    ----------
    track : Track
        Measured track section (initial geometry and support curves).
    traffic : sequence of Traffic
        The traffic mix; an empty mix causes no settlement.
    law : LawParameters
        Settlement law with its parameters (`trackdyn.deterioration.settlement.LAWS`).
    options : LoopOptions, optional
        Loop options; default `LoopOptions()`.
    zones : sequence of Zone
        Parts of the track with their own law and rate field
        (`trackdyn.deterioration.zones`); the rest is open track with ``law``.
    progress : bool
        Show a progress bar over the tonnage.

    Returns
    -------
    xarray.Dataset
        See `trackdyn.deterioration.results.make_dataset`.
    """
    t0 = time.perf_counter()
    o = options or LoopOptions()
    total = float(require_positive("total_mgt", o.total_mgt))
    require_positive("max_step_settlement_mm", o.max_step_settlement_mm)
    limit = o.max_step_settlement
    every = float(require_positive("snapshot_every_mgt", o.snapshot_every_mgt))
    require_positive("min_step_passages", o.min_step_passages)
    length = track.extent[1] - track.extent[0]
    if o.segment_length > length:
        raise TrackdynInputError(
            f"segment_length_m = {o.segment_length:g} m is longer than the track "
            f"({length:g} m); the D1 SD needs at least one whole segment"
        )
    _, seg_start, seg_end = d1_sd(track.geometry, track.extent, o.segment_length)
    if o.start not in STARTS:
        raise TrackdynInputError(f"start must be one of {', '.join(STARTS)}; got {o.start!r}")
    seated = o.start == "tamped"
    if seated:
        tamped = tamped_geometry(track.geometry, track.extent, o.segment_length)
        track = dataclasses.replace(track, geometry=tamped)
    elif o.start == "as surveyed":
        track = dataclasses.replace(track, geometry=surveyed_geometry(track.geometry))
    pos = track.supports.position
    shape = (len(RAILS), pos.size)
    check_zones(zones, (float(pos[0]), float(pos[-1])))
    spacing = float(np.median(np.diff(pos)))
    mean_over = shape_sleepers(pos)
    rate = rate_field(pos.size, spacing, o.rate_cov, o.rate_correlation_length, o.seed,
                      o.rate_factor)  # fmt: skip
    for z in zones:
        if z.rate is not None:
            own = rate_field(pos.size, spacing, z.rate.cov, z.rate.correlation_length,
                             z.rate.seed)  # fmt: skip
            rate = np.where(z.holds(pos), own, rate)
    if o.rate_scale is not None:
        if len(o.rate_scale) != pos.size:
            raise TrackdynInputError(f"rate_scale has {len(o.rate_scale)} values for "
                                     f"{pos.size} sleepers")  # fmt: skip
        rate = rate * np.asarray(o.rate_scale)
    laws = _zone_laws(law, zones, pos)
    sensitivity = sum(m * lw.load_sensitivity for m, lw in laws)
    runs, lins = _runs(track, traffic, o)
    per_mgt = sum(t.passages_per_mgt for t in traffic)
    shortest = o.min_step_passages / per_mgt if per_mgt > 0 else 0.0
    base = (
        lins[max(lins)]
        if lins
        else track.linearise(NO_TRAFFIC_LOAD, o.run.delta, extrapolate=o.run.extrapolate)
    )
    timing = {"vehicle": 0.0, "beam": 0.0, "others": 0.0}  # others: other sections' time
    clock = time.perf_counter()
    ballast = Ballast(base, rail_section(o.rail), o.sleeper_mass, seated=seated)
    state = ballast.initial
    timing["beam"] += time.perf_counter() - clock
    acc = Zoned(laws, shape, len(traffic))
    maint = (
        None
        if o.maintenance is None or per_mgt == 0
        else Maintenance(o.maintenance, pos, seg_start, seg_end, o.threshold_sd_mm)
    )
    wear = maint.factor if maint is not None else (lambda dm: 1.0)
    reference, fresh = track.geometry, 0.0  # tonnage of the last (re)start [MGT]
    by_vehicle = np.zeros((len(traffic), *shape))
    extra = [float(m) for m in o.snapshot_mgt if 0.0 < m < total]
    snap_at = np.unique(np.concatenate([np.arange(0.0, total, every), extra, [total]]))
    ends = np.unique(np.concatenate([extra, [total]]))  # where a step must end [MGT]
    level, mgt, geometry = np.zeros(shape), 0.0, track.geometry
    history: dict[str, list] = {"mgt": [0.0], "settlement": [level], "geometry": [geometry],
               "hanging_gap": [state.hanging_gap]}  # fmt: skip
    steps: dict[str, list[float]] = {
        "start": [],
        "end": [],
        "peak_load": [],
        "max_settlement": [],
        "load_updates": [],
        "vehicle_runs": [],
    }
    with progress_bar(progress, total, "tonnage [MGT]") as bar:
        while mgt < total:
            if len(steps["start"]) >= o.max_steps:
                raise TrackdynInputError(
                    f"more than max_steps = {o.max_steps} steps needed to reach {total:g} MGT "
                    f"(at {mgt:.3g} MGT); raise max_step_settlement_mm or max_steps, or check "
                    "the settlement law's parameters"
                )
            lengths = np.diff(np.array(steps["start"][-RUNAWAY_STEPS:] + [mgt]))
            if per_mgt > 0 and lengths.size == RUNAWAY_STEPS and np.all(lengths * per_mgt < 1):
                raise TrackdynInputError(
                    f"settlement runs away at {mgt:.3g} MGT: {RUNAWAY_STEPS} steps in a row "
                    f"shorter than one passage each changed the shape by max_step_settlement_mm; "
                    "check the settlement law's parameters"
                )
            clock = time.perf_counter()
            current = {p: ballast.linearised(lin, state, geometry) for p, lin in lins.items()}
            timing["beam"] += time.perf_counter() - clock
            step_lins = [current[run.lin.static_load] for run in runs]
            ran = sum(not run.keeps for run in runs)
            solved = yield from vehicle_runs(runs, step_lins, timing, ballast, state)
            target = ends[np.searchsorted(ends, mgt, side="right")]
            if maint is not None:
                target = min(target, maint.next_due(mgt))
            start_level, span, moved, updates = level, None, 0.0, 0
            step_parts = np.zeros_like(by_vehicle)
            while span is None or span - moved > 1e-12 * span:
                if updates >= MAX_LOAD_UPDATES:
                    raise TrackdynInputError(
                        f"more than {MAX_LOAD_UPDATES} load updates needed in one step at "
                        f"{mgt:.3g} MGT: the settlement law follows the load too steeply for a "
                        "stable step; check its load exponent"
                    )
                loads = rail_seat_loads(runs, solved, ballast, state, timing)
                cycles, peak = _cycles(runs, step_lins, loads, shape)
                settle = _scaled(rate, acc.prepare(cycles), wear)
                if span is None:  # the accuracy limit, and at least one train
                    span = step_size(lambda dm, f=settle: shape_change(f(dm), mean_over),
                                     target - mgt, limit)  # fmt: skip
                    train = min(shortest, target - mgt)
                    if mgt == fresh:
                        span = max(span, train)
                    if maint is not None:
                        span = maint.until_due(mgt, settle, geometry, track.extent,
                                               o.segment_length, span)  # fmt: skip
                    step_peak = peak
                stable = stable_settlement(peak, ballast.stiffness, sensitivity)
                dm = step_size(settle, span - moved, stable)
                here = mgt + moved
                for m in snap_at[(snap_at > here) & (snap_at <= here + dm)]:  # snapshots within
                    clock = time.perf_counter()
                    inner = level + settle(m - here)
                    at = ballast.state(inner, state)
                    _record(history, m, inner, at, ballast.geometry(reference, at))
                    timing["beam"] += time.perf_counter() - clock
                level = level + settle(dm)
                step_parts += rate * wear(dm) * acc.advance(dm)
                if maint is not None:
                    maint.advance(dm)
                moved, updates = moved + dm, updates + 1
                clock = time.perf_counter()
                state = ballast.state(level, state)
                timing["beam"] += time.perf_counter() - clock
            by_vehicle += step_parts
            for run in runs:
                run.held = _largest_share(step_parts, run.vehicle) < MIN_SHARE
            clock = time.perf_counter()
            geometry = ballast.geometry(reference, state)
            timing["beam"] += time.perf_counter() - clock
            steps["start"].append(mgt)
            mgt = target if target - (mgt + span) <= 1e-12 * total else mgt + span
            steps["end"].append(mgt)
            steps["peak_load"].append(step_peak)
            steps["max_settlement"].append(float((level - start_level).max()))
            steps["load_updates"].append(updates)
            steps["vehicle_runs"].append(ran)
            if mgt - history["mgt"][-1] > 1e-12 * total:  # not a snapshot just recorded
                _record(history, mgt, level, state, geometry)
            if maint is not None and mgt < total:
                due = maint.due(mgt, maint.d1_sd(geometry, track.extent, o.segment_length))
                if due.size:
                    clock = time.perf_counter()
                    tamped, held = maint.tamp(mgt, due, geometry, track.extent,
                                              o.segment_length)  # fmt: skip
                    change = [np.interp(pos, geometry.distance, tamped.profile(r) -
                                        geometry.profile(r)) for r in RAILS]  # fmt: skip
                    ballast.tamp(level, state, held, np.array(change))
                    geometry = tamped
                    acc.restart(held, maint.o.consolidated_mgt)
                    for run in runs:  # a new shape: every vehicle runs again
                        run.held = False
                    state = ballast.state(level, state)
                    reference = ballast.geometry(geometry, state, sign=-1.0)
                    fresh = mgt
                    timing["beam"] += time.perf_counter() - clock
            bar.update(mgt)
    timing["total"] = time.perf_counter() - t0 - timing["others"]
    states = [TrackState(*v) for v in zip(*(history[k] for k in history), strict=True)]
    done = [StepRecord(*v) for v in zip(*(steps[k] for k in steps), strict=True)]
    record = LoopRecord(track, tuple(traffic), law, o, states, done, snap_at, acc.N, rate,
                        by_vehicle, _kinds(zones, pos), maint.done if maint else [],
                        Timing(timing["vehicle"], timing["beam"], timing["total"]))  # fmt: skip
    return make_dataset(record)


def _largest_share(parts, vehicle: int) -> float:
    """The largest part of ``vehicle`` in the settlement of any rail seat over the largest
    settlement of any rail seat [-] (``parts``: each vehicle's settlement, (vehicles,
    rail, sleeper) [m]; 1 when nothing settled)."""
    largest = float(parts.sum(axis=0).max())
    return float(parts[vehicle].max()) / largest if largest > 0 else 1.0


def _record(history, mgt, level, state, geometry) -> None:
    """Append the track at ``mgt`` [MGT] to the loop's ``history``."""
    for key, value in (("mgt", mgt), ("settlement", level), ("geometry", geometry),
                       ("hanging_gap", state.hanging_gap)):  # fmt: skip
        history[key].append(value)


def _cycles(runs, lins, loads, shape):
    """The step's load cycles for `Zoned.prepare`, and the largest load per rail seat [N]."""
    cycles, peak = [], np.zeros(shape)
    for run, lin, per_wheel in zip(runs, lins, loads, strict=True):
        for q, r, w in zip(per_wheel, run.rails, run.weights, strict=True):
            cycles.append((run.vehicle, r, w, q, lin.k2[r]))
            peak[r] = np.maximum(peak[r], q)
    return cycles, peak


def _scaled(rate, increment, wear):
    """The settlement increment [m] against the step [MGT], times the rate field and the
    ballast's wear by tamping (`Maintenance.factor`)."""
    return lambda dm: rate * wear(dm) * increment(dm)


def _zone_laws(law, zones, position) -> list:
    """(sleepers, law) of the open track and of each zone."""
    held = [z.holds(position) for z in zones]
    rest = ~np.any(held, axis=0) if held else np.ones(position.size, dtype=bool)
    return [(rest, law)] + [(h, z.law) for h, z in zip(held, zones, strict=True)]


def _kinds(zones, position) -> np.ndarray:
    """The zone kind of each sleeper (``open`` outside every zone)."""
    kind = np.full(position.size, "open", dtype=object)
    for z in zones:
        kind[z.holds(position)] = z.kind
    return kind.astype(str)


def _runs(track: Track, traffic, o: LoopOptions):
    """One `TrafficRun` per vehicle with traffic, and the measured track linearised once
    per static wheel load ({load [N]: LinearisedTrack})."""
    lins, runs = {}, []
    for i, t in enumerate(traffic):
        if not 0 <= t.passages_per_mgt < np.inf:
            raise TrackdynInputError(
                f"passages_per_mgt must be >= 0, got {shown(t.passages_per_mgt)}"
            )
        require_positive("speed_kmh", t.speed_kmh)
        if t.passages_per_mgt > 0:
            load = t.vehicle.static_wheel_load
            if load not in lins:
                lins[load] = track.linearise(load, o.run.delta, extrapolate=o.run.extrapolate)
            runs.append(TrafficRun(t, lins[load], o, vehicle=i))
    return runs, lins
