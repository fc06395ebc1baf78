"""The deterioration loop: dynamic loads -> rail-seat loads -> ballast settlement -> track.

One tonnage step: every vehicle of the traffic runs over the current track (unloaded
profile and linearisation re-derived from the rail beam on the current ballast,
`trackdyn.deterioration.ballast`); each wheel's loads, placed on the rail beam with the
current gaps, give the rail-seat load cycles of every sleeper
(`trackdyn.deterioration.loads`); the settlement law turns them into ballast settlement
under each rail seat (`trackdyn.deterioration.accumulation`), times the sleeper's
settlement-rate factor; the ballast level drops by it, the rail comes to rest on the new
ballast (hanging where it cannot reach), and the next step starts from there.
With the ``voids`` option a hanging sleeper that a passage presses onto its ballast settles
faster (`trackdyn.deterioration.voids`); off, nothing of it runs.

Mixed traffic: in a step of ``ΔM`` MGT each wheel of each vehicle applies its passages per
MGT times ``ΔM`` cycles at every sleeper of its rail, with the load it had there at the
step start; see `trackdyn.deterioration.accumulation` for how each law sums them (every
cycle adds settlement; each vehicle's part is recorded). Zones
(`trackdyn.deterioration.zones`) give parts of the track their own law and rate field.

Two step sizes. A step (a vehicle run) is as long as ``max_step_settlement_mm`` allows: with
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
from trackdyn.deterioration.driver import RunReply, RunRequest, step_together
from trackdyn.deterioration.loads import TrafficRun, rail_seat_loads
from trackdyn.deterioration.maintenance import Maintenance
from trackdyn.deterioration.options import LoopOptions
from trackdyn.deterioration.quality import d1_sd
from trackdyn.deterioration.record import (
    LoopRecord,
    StepRecord,
    Timing,
    TrackState,
    require_loop_memory,
)
from trackdyn.deterioration.results import make_dataset
from trackdyn.deterioration.starts import STARTS, surveyed_geometry, tamped_geometry
from trackdyn.deterioration.voids import Voids
from trackdyn.deterioration.zones import check_zones
from trackdyn.errors import (
    Failure,
    Status,
    TrackdynInputError,
    TrackdynNumericalError,
    require_positive,
    shown,
)
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
    section = SectionLoop(track, traffic, law, options, zones=zones)
    (result,) = step_together([section], progress=progress)
    if isinstance(result, Failure):
        raise result.error()
    return make_dataset(result)


class SectionLoop:
    """The deterioration loop of one section, phase by phase.

    Made, it has started (checks, start state, rate field, ballast, maintenance); then,
    step after step until `done`: `runs_wanted` gives the vehicle runs the step needs (a
    `RunRequest`, empty when every vehicle holds its latest run), `take_runs` takes their
    `RunReply`, `settle_step` settles the ballast over the step (the rail-seat loads from
    the runs, `loads_from_runs`, updated at each sleeper's stable step; a `snapshot` of
    each tonnage asked for), and `maintain` tamps what is due at its end; `record` gives
    the `LoopRecord`. `trackdyn.deterioration.driver.step_together` drives one section
    (`predict`) or several side by side, their runs in one batch.

    Parameters
    ----------
    track, traffic, law, options, zones
        As `predict`.
    """

    def __init__(self, track: Track, traffic, law, options=None, *, zones=()):
        t0 = time.perf_counter()
        o = self.o = options or LoopOptions()
        self.total = float(require_positive("total_mgt", o.total_mgt))
        require_positive("max_step_settlement_mm", o.max_step_settlement_mm)
        self.limit = o.max_step_settlement
        every = float(require_positive("snapshot_every_mgt", o.snapshot_every_mgt))
        require_positive("min_step_passages", o.min_step_passages)
        require_loop_memory(track, len(traffic), o, self.total)
        track, seg_start, seg_end = _start_state(track, o)
        self.track = track
        pos = self.position = track.supports.position
        self.shape = (len(RAILS), pos.size)
        check_zones(zones, (float(pos[0]), float(pos[-1])))
        self.mean_over = shape_sleepers(pos)
        self.rate = _rate(o, zones, pos)
        self.traffic, self.law, self.kind = tuple(traffic), law, _kinds(zones, pos)
        laws = _zone_laws(law, zones, pos)
        self.sensitivity = sum(m * lw.load_sensitivity for m, lw in laws)
        self.runs, self.lins = _runs(track, traffic, o)
        per_mgt = self.per_mgt = sum(t.passages_per_mgt for t in traffic)
        self.shortest = o.min_step_passages / per_mgt if per_mgt > 0 else 0.0
        base = (
            self.lins[max(self.lins)]
            if self.lins
            else track.linearise(NO_TRAFFIC_LOAD, o.run.delta, extrapolate=o.run.extrapolate)
        )
        self.timing = Timing()
        clock = time.perf_counter()
        self.ballast = Ballast(base, rail_section(o.rail), o.sleeper_mass,
                               seated=o.start == "tamped")  # fmt: skip
        self.state = self.ballast.initial
        self.timing.beam += time.perf_counter() - clock
        self.acc = Zoned(laws, self.shape, len(traffic))
        self.maint = (
            None
            if o.maintenance is None or per_mgt == 0
            else Maintenance(o.maintenance, pos, seg_start, seg_end, o.threshold_sd_mm)
        )
        self.wear = self.maint.factor if self.maint is not None else (lambda dm: 1.0)
        self.voids = None if o.voids is None else Voids(o.voids, self.shape)
        self.by_void = np.zeros(self.shape)  # the part of the settlement due to voids [m]
        self.reference, self.fresh = track.geometry, 0.0  # tonnage of the last (re)start [MGT]
        self.by_vehicle = np.zeros((len(traffic), *self.shape))
        extra = [float(m) for m in o.snapshot_mgt if 0.0 < m < self.total]
        self.snap_at = np.unique(np.concatenate([np.arange(0.0, self.total, every), extra,
                                                 [self.total]]))  # fmt: skip
        self.ends = np.unique(np.concatenate([extra, [self.total]]))  # a step must end [MGT]
        self.level, self.mgt, self.geometry = np.zeros(self.shape), 0.0, track.geometry
        self.states: list[TrackState] = []
        self.snapshot(0.0, self.level, self.state, self.geometry)
        self.steps: list[StepRecord] = []
        self.step_lins: list = []  # the step's linearisations, one per run
        self.fresh_runs: list[TrafficRun] = []  # the runs of the step's request
        self.timing.total += time.perf_counter() - t0

    @property
    def done(self) -> bool:
        """The loop has reached ``total_mgt``."""
        return self.mgt >= self.total

    def runs_wanted(self) -> RunRequest:
        """The vehicle runs of the next step over the track as it stands: each vehicle not
        held, over the current track linearised about its static wheel load (or the
        discrete track on the current ballast). Refuses to go on after ``max_steps``
        steps, or when settlement runs away (`RUNAWAY_STEPS`)."""
        self._check_progress()
        clock = time.perf_counter()
        current = {p: self.ballast.linearised(lin, self.state, self.geometry)
                   for p, lin in self.lins.items()}  # fmt: skip
        self.timing.beam += time.perf_counter() - clock
        self.step_lins = [current[run.lin.static_load] for run in self.runs]
        fresh = [(run, lin) for run, lin in zip(self.runs, self.step_lins, strict=True)
                 if not run.keeps]  # fmt: skip
        self.fresh_runs = [run for run, _ in fresh]
        return RunRequest(
            tuple(run.traffic.vehicle for run, _ in fresh),
            tuple(run.track(lin, self.ballast, self.state) for run, lin in fresh),
            tuple(run.run for run, _ in fresh),
        )

    def _check_progress(self) -> None:
        """Refuse a step beyond ``max_steps``, or after `RUNAWAY_STEPS` runaway steps."""
        o, mgt = self.o, self.mgt
        if len(self.steps) >= o.max_steps:
            raise TrackdynInputError(
                f"more than max_steps = {o.max_steps} steps needed to reach {self.total:g} MGT "
                f"(at {mgt:.3g} MGT); raise max_step_settlement_mm or max_steps, or check "
                "the settlement law's parameters"
            )
        lengths = np.diff(np.array([s.start for s in self.steps[-RUNAWAY_STEPS:]] + [mgt]))
        if (
            self.per_mgt > 0
            and lengths.size == RUNAWAY_STEPS
            and np.all(lengths * self.per_mgt < 1)
        ):
            raise TrackdynNumericalError(
                f"settlement runs away at {mgt:.3g} MGT: {RUNAWAY_STEPS} steps in a row "
                f"shorter than one passage each changed the shape by max_step_settlement_mm; "
                "check the settlement law's parameters",
                Status.SETTLEMENT_RAN_AWAY,
            )

    def take_runs(self, reply: RunReply) -> None:
        """Take the runs of `runs_wanted`'s request (a `Failure` among them is raised)."""
        self.timing.vehicle += reply.seconds
        self.timing.total += reply.seconds
        for run, result in zip(self.fresh_runs, reply.results, strict=True):
            if isinstance(result, Failure):
                raise result.error()
            run.ran(result, self.state)

    def loads_from_runs(self) -> tuple[list, np.ndarray]:
        """The load cycles of the runs on the current ballast, for `Zoned.prepare`, and the
        largest rail-seat load per rail and sleeper [N]."""
        loads = rail_seat_loads(self.runs, self.ballast, self.state, self.timing)
        return _cycles(self.runs, self.step_lins, loads, self.shape)

    def settle_step(self) -> None:
        """Settle the ballast over one step: as long as the step limit allows (at least a
        train after a (re)start; to the next end, tamping or survey), the rail-seat loads
        updated at each sleeper's stable step; record the step and the track at its end."""
        o, mgt, maint = self.o, self.mgt, self.maint
        target = self.ends[np.searchsorted(self.ends, mgt, side="right")]
        if maint is not None:
            target = min(target, maint.next_due(mgt))
        start_level, span, moved, updates = self.level, None, 0.0, 0
        step_parts = np.zeros_like(self.by_vehicle)
        while span is None or span - moved > 1e-12 * span:
            if updates >= MAX_LOAD_UPDATES:
                raise TrackdynNumericalError(
                    f"more than {MAX_LOAD_UPDATES} load updates needed in one step at "
                    f"{mgt:.3g} MGT: the settlement law follows the load too steeply for a "
                    "stable step; check its load exponent",
                    Status.SETTLEMENT_RAN_AWAY,
                )
            cycles, peak = self.loads_from_runs()
            wear = self._wear(peak)
            settle = _scaled(self.rate, self.acc.prepare(cycles), wear)
            if span is None:  # the accuracy limit, and at least one train
                span = step_size(lambda dm, f=settle: shape_change(f(dm), self.mean_over),
                                 target - mgt, self.limit)  # fmt: skip
                train = min(self.shortest, target - mgt)
                if mgt == self.fresh:
                    span = max(span, train)
                if maint is not None:
                    span = maint.until_due(mgt, settle, self.geometry, self.track.extent,
                                           o.segment_length, span)  # fmt: skip
                step_peak = peak
            stable = stable_settlement(peak, self.ballast.stiffness, self.sensitivity)
            if self.voids is not None:
                stable = np.minimum(stable, self.voids.limit(self.state.hanging_gap, peak))
            dm = step_size(settle, span - moved, stable)
            here = mgt + moved
            for m in self.snap_at[(self.snap_at > here) & (self.snap_at <= here + dm)]:
                clock = time.perf_counter()  # the snapshots within the step
                inner = self.level + settle(m - here)
                at = self.ballast.state(inner, self.state)
                self.snapshot(m, inner, at, self.ballast.geometry(self.reference, at))
                self.timing.beam += time.perf_counter() - clock
            self.level = self.level + settle(dm)
            split = self.acc.advance(dm)
            step_parts += self.rate * wear(dm) * split
            if self.voids is not None:
                extra = self.voids.factor(dm) - 1.0
                self.by_void += self.rate * self.wear(dm) * extra * split.sum(axis=0)
                self.voids.advance(dm)
            if maint is not None:
                maint.advance(dm)
            moved, updates = moved + dm, updates + 1
            clock = time.perf_counter()
            self.state = self.ballast.state(self.level, self.state)
            self.timing.beam += time.perf_counter() - clock
        self._end_step(target, span, step_parts, step_peak, start_level, updates)

    def _wear(self, peak):
        """The settlement-rate factor against the step [MGT] of the maintenance's wear
        and, with the ``voids`` option, of ballast under a void on the current ballast
        under the loads ``peak`` [N] (`trackdyn.deterioration.voids`)."""
        voids, wear = self.voids, self.wear
        if voids is None:
            return wear
        voids.update(self.state.hanging_gap, peak)
        return lambda dm: wear(dm) * voids.factor(dm)

    def _end_step(self, target, span, step_parts, peak, start_level, updates) -> None:
        """Record the step that `settle_step` made, and the track at its end."""
        self.by_vehicle += step_parts
        for run in self.runs:
            run.held = _largest_share(step_parts, run.vehicle) < MIN_SHARE
        clock = time.perf_counter()
        self.geometry = self.ballast.geometry(self.reference, self.state)
        self.timing.beam += time.perf_counter() - clock
        start, total = self.mgt, self.total
        self.mgt = target if target - (start + span) <= 1e-12 * total else start + span
        self.steps.append(StepRecord(start, self.mgt, peak,
                                     float((self.level - start_level).max()), updates,
                                     len(self.fresh_runs)))  # fmt: skip
        if self.mgt - self.states[-1].mgt > 1e-12 * total:  # not a snapshot just recorded
            self.snapshot(self.mgt, self.level, self.state, self.geometry)

    def snapshot(self, mgt: float, level, state, geometry) -> None:
        """Store the track at ``mgt`` [MGT]: settlement ``level`` [m], the ballast
        ``state`` and the ``geometry``."""
        voids = None if self.voids is None else self.voids.factor(0.0)
        self.states.append(TrackState(mgt, level, geometry, state.hanging_gap, voids))

    def maintain(self) -> None:
        """Tamp the segments due at the step's end (`trackdyn.deterioration.maintenance`):
        the geometry and the ballast lifted, the hardening restarted, every vehicle run
        again on the new shape."""
        maint, o, mgt = self.maint, self.o, self.mgt
        if maint is None or mgt >= self.total:
            return
        extent = self.track.extent
        due = maint.due(mgt, maint.d1_sd(self.geometry, extent, o.segment_length))
        if not due.size:
            return
        clock = time.perf_counter()
        geometry = self.geometry
        tamped, held = maint.tamp(mgt, due, geometry, extent, o.segment_length)
        change = [np.interp(self.position, geometry.distance, tamped.profile(r) -
                            geometry.profile(r)) for r in RAILS]  # fmt: skip
        if self.voids is not None:
            self.voids.tamp(held)
        self.ballast.tamp(self.level, self.state, held, np.array(change))
        self.geometry = tamped
        self.acc.restart(held, maint.o.consolidated_mgt)
        for run in self.runs:  # a new shape: every vehicle runs again
            run.held = False
        self.state = self.ballast.state(self.level, self.state)
        self.reference = self.ballast.geometry(self.geometry, self.state, sign=-1.0)
        self.fresh = mgt
        self.timing.beam += time.perf_counter() - clock

    def record(self) -> LoopRecord:
        """What the loop recorded, for `trackdyn.deterioration.results.make_dataset`."""
        return LoopRecord(self.track, self.traffic, self.law, self.o, self.states, self.steps,
                          self.snap_at, self.acc.N, self.rate, self.by_vehicle, self.kind,
                          self.maint.done if self.maint else [], self.timing,
                          None if self.voids is None else self.by_void)  # fmt: skip


def _start_state(track: Track, o: LoopOptions):
    """The section in the start state of ``o.start`` (`trackdyn.deterioration.starts`),
    checked to hold a whole segment, and the segments' starts and ends [m]. The section is
    as long as its sleepers reach, half a spacing beyond the first and the last (a 300 m
    section's sleepers 0.6 m apart span 299.4 m)."""
    spacing = float(np.median(np.diff(track.supports.position)))
    length = track.extent[1] - track.extent[0] + spacing
    if o.segment_length > length * (1 + 1e-9):
        raise TrackdynInputError(
            f"segment_length_m = {o.segment_length:g} m is longer than the track "
            f"({length:g} m); the D1 SD needs at least one whole segment"
        )
    _, starts, ends = d1_sd(track.geometry, track.extent, o.segment_length)
    if o.start not in STARTS:
        raise TrackdynInputError(f"start must be one of {', '.join(STARTS)}; got {o.start!r}")
    if o.start == "tamped":
        tamped = tamped_geometry(track.geometry, track.extent, o.segment_length)
        track = dataclasses.replace(track, geometry=tamped)
    elif o.start == "as surveyed":
        track = dataclasses.replace(track, geometry=surveyed_geometry(track.geometry))
    return track, starts, ends


def _rate(o: LoopOptions, zones, position) -> np.ndarray:
    """The settlement-rate factor per rail and sleeper [-]: the section's field, the
    zones' own, times ``rate_scale``."""
    spacing = float(np.median(np.diff(position)))
    rate = rate_field(position.size, spacing, o.rate_cov, o.rate_correlation_length, o.seed,
                      o.rate_factor)  # fmt: skip
    for z in zones:
        if z.rate is not None:
            own = rate_field(position.size, spacing, z.rate.cov, z.rate.correlation_length,
                             z.rate.seed)  # fmt: skip
            rate = np.where(z.holds(position), own, rate)
    if o.rate_scale is not None:
        if len(o.rate_scale) != position.size:
            raise TrackdynInputError(f"rate_scale has {len(o.rate_scale)} values for "
                                     f"{position.size} sleepers")  # fmt: skip
        rate = rate * np.asarray(o.rate_scale)
    return rate


def _largest_share(parts, vehicle: int) -> float:
    """The largest part of ``vehicle`` in the settlement of any rail seat over the largest
    settlement of any rail seat [-] (``parts``: each vehicle's settlement, (vehicles,
    rail, sleeper) [m]; 1 when nothing settled)."""
    largest = float(parts.sum(axis=0).max())
    return float(parts[vehicle].max()) / largest if largest > 0 else 1.0


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
