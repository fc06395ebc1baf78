"""Tamping over a track's life: when and where the loop tamps, and what tamping does.

The deterioration loop (`trackdyn.deterioration.loop`) goes on to its horizon; at the end
of every step the policy looks at the D1 standard deviation of each segment and tamps
those that are due:

- ``policy = "threshold"``: a segment whose D1 SD reaches the loop's
  ``threshold_sd_mm`` on either rail, at least ``min_interval_mgt`` after its last
  tamping; ``neighbours`` segments each side are tamped with it (the stretch around it),
  and so are the adjacent segments past the alert limit (``alert_fraction`` of the
  threshold);
- ``policy = "fixed"``: every segment every ``interval_mgt``;
- ``policy = "planned"``: the stretches a plan gives (``planned``, each ``(tonnage,
  start, end)``; `trackdyn.deterioration.planning`), each at the first step end at or
  after its tonnage; set by a scenario's ``[plan]``, never in ``[maintenance]``.

A segment tamped ``max_tampings`` times gets its ballast renewed at the next
intervention instead (the damage of the tampings is undone; the geometry is restored as
by a tamping). A section with no traffic is never tamped.

What a tamping does, over the tamped stretch (whole segments, the machine running in and
out over ``run_out_m`` beyond them, so the joints with untamped segments are tamped too and
stay smooth; the track beyond the run-out is not touched):

1. **Geometry.** The D1 band of each rail (EN 13848-1, 3-25 m) is replaced by
   ``D1' = ρ k D1 + sqrt(1 - ρ²) σ' ε``: the part of the old shape the track keeps
   (correlation ``ρ = kept_correlation`` with the old shape; ``k = σ'/σ``) and new
   irregularity from the tamping itself (``ε`` a D1-band random profile of unit standard
   deviation), so that the standard deviation after tamping is
   ``σ' = recovery_offset_mm + recovery_slope σ``, the linear form of the recovery
   relations reviewed by Audley & Andrews (2013): bad track improves a lot, good track
   little, and very good track may come out worse. The longer waves stay.
2. **Lift.** The rail is lifted to the new profile plus a general lift
   (``general_lift_mm``) and the ballast packed under every sleeper: no sleeper hangs
   after tamping (`Ballast.tamp`).
3. **Settlement after tamping.** The settlement law's memory at the tamped sleepers
   (its equivalent cycles, consolidation or load history,
   `trackdyn.deterioration.accumulation`) is set to that of new ballast after
   ``consolidated_mgt`` of the current traffic: the early, fast phase comes again, the
   same after every tamping, so that without ballast damage the cycles repeat. The lifted
   ballast is loose: its
   settlement rate is multiplied by ``1 + (lift / lift_reference_mm) exp(-ΔM /
   loosening_mgt)`` (``ΔM`` the tonnage since the tamping), so the track settles back
   more where it was lifted more, towards its old shape (Nakamura et al., 2025).
4. **Ballast damage.** Each tamping multiplies the settlement rate of the tamped sleepers
   by ``1 + damage_per_tamping`` (broken and rounded stones, fines): the intervals between
   tampings shrink (Abadi et al., 2016).

Every default is illustrative (set so that the built-in example shows a life of a few
tampings per segment, not from measurement): a railway sets its own from its records.

References
----------
Audley, M., Andrews, J.D. (2013). The effects of tamping on railway track geometry
degradation. Proceedings of the IMechE, Part F: Journal of Rail and Rapid Transit 227(4),
376-391.

Nakamura, T. et al. (2025). Journal of JSCE, Intelligence, Informatics and Infrastructure
4(1), 79-84 (geometry returns towards its pre-tamping shape, with more settlement where
the lift was larger).

Abadi, T., Le Pen, L., Zervos, A., Powrie, W. (2016). Effect of sleeper interventions on
railway track performance. Procedia Engineering 143, 999-1006 (tamping damages ballast).

EN 13848-5:2017. Railway applications - Track - Track geometry quality - Part 5:
Geometric quality levels - Plain line, switches and crossings. CEN, Brussels (alert and
intervention limits).

EN 13848-1:2019. Railway applications - Track - Track geometry quality - Part 1:
Characterisation of track geometry. CEN, Brussels.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydantic import ConfigDict, Field, field_validator, model_serializer, model_validator
from scipy.optimize import brentq

from trackdyn.deterioration.quality import D1Assessment
from trackdyn.limits import MAX_TOTAL_MGT
from trackdyn.options import Strict
from trackdyn.track.quality import longitudinal_level
from trackdyn.track.track import RAILS

DUE_MARGIN = 0.005
"""Fraction under the threshold at which a segment counts as due at a step end [-]: the
step ends where the D1 SD is predicted to reach the threshold (`Maintenance.until_due`),
and the rail-seat load updates within the step move it a little."""


class MaintenanceOptions(Strict):
    """The ``[maintenance]`` table: policy and tamping model (units in the names).

    Each value has a plausible range (its field's bounds, wide: beyond them a typing error
    or a wrong unit), numbers are numbers (not text), ``inf`` and ``nan`` are refused.

    Parameters
    ----------
    policy : str
        A key of `POLICIES`: ``"threshold"``, tamp a segment when its D1 SD reaches the
        loop's threshold; ``"fixed"``, tamp every segment every ``interval_mgt``.
    interval_mgt : float, optional
        Tonnage between tampings of the fixed policy [MGT].
    min_interval_mgt : float
        Shortest time between two tampings of a segment [MGT]; default 5, illustrative.
    neighbours : int
        Segments each side tamped with a segment that is due [-]; default 0.
    alert_fraction : float
        When a segment is due, the segments next to it whose D1 SD has passed this
        fraction of the threshold (the alert limit; the threshold is the intervention
        limit, EN 13848-5) are tamped with it, and theirs next to them [-]; default 0.9,
        illustrative (1: only the segments due).
    max_tampings : int
        Tampings of a segment before its ballast is renewed [-]; default 6, illustrative.
    recovery_offset_mm, recovery_slope : float
        D1 SD after tamping ``offset + slope × before`` [mm]; default 0.6 mm and 0.3,
        illustrative (the linear form reviewed by Audley & Andrews, 2013).
    kept_correlation : float
        Correlation of the D1 profile after tamping with the one before [-]; default 0.5,
        illustrative.
    run_out_m : float
        Length over which the machine runs in and out beyond each end of the tamped
        stretch [m]; default 10, illustrative (a run-out inside the stretch leaves the
        segment joints untamped, and over many cycles they run away).
    general_lift_mm : float
        Lift of the lowest point of the stretch [mm]; default 10, illustrative.
    consolidated_mgt : float
        Tonnage of the current traffic after which new ballast has the memory the law has
        right after tamping [MGT]; default 10, illustrative (0: the law starts again as on
        new track, and the shipped laws, which settle a third of their 50 MGT settlement in
        the first MGT, then re-create most of the unevenness within the minimum interval).
    lift_reference_mm : float
        Lift that doubles the settlement rate just after tamping [mm]; default 40,
        illustrative.
    loosening_mgt : float
        Tonnage over which the loosening of the lifted ballast decays by ``1/e`` [MGT];
        default 3, illustrative.
    damage_per_tamping : float
        Rise of the settlement rate per tamping [-]; default 0.1, illustrative.
    seed : int
        Seed of the irregularity each tamping leaves.
    planned : tuple of (float, float, float)
        The ``"planned"`` policy's stretches: tonnage [MGT], start and end [m] (the
        segments whose middle lies within are tamped); left out of the options' record
        when empty.
    """

    model_config = ConfigDict(strict=True)  # "5" is no number

    policy: str = "threshold"
    interval_mgt: float | None = Field(None, ge=0.1, le=MAX_TOTAL_MGT)
    min_interval_mgt: float = Field(5.0, ge=0.0, le=MAX_TOTAL_MGT)
    neighbours: int = Field(0, ge=0, le=100)
    alert_fraction: float = Field(0.9, gt=0.0, le=1.0)
    max_tampings: int = Field(6, ge=1, le=1000)
    recovery_offset_mm: float = Field(0.6, ge=0.0, le=5.0)
    recovery_slope: float = Field(0.3, ge=0.0, le=1.0)
    kept_correlation: float = Field(0.5, ge=0.0, le=1.0)
    run_out_m: float = Field(10.0, ge=0.0, le=100.0)
    general_lift_mm: float = Field(10.0, ge=0.0, le=200.0)
    consolidated_mgt: float = Field(10.0, ge=0.0, le=1000.0)
    lift_reference_mm: float = Field(40.0, ge=1.0, le=1000.0)
    loosening_mgt: float = Field(3.0, gt=0.0, le=1000.0)
    damage_per_tamping: float = Field(0.1, ge=0.0, le=1.0)
    seed: int = Field(0, ge=0)
    planned: tuple[tuple[float, float, float], ...] = ()

    @model_serializer(mode="wrap")
    def _without_plan(self, handler):
        # options without a plan record what they recorded before the policy existed
        data = handler(self)
        if not self.planned:
            data.pop("planned", None)
        return data

    @field_validator("policy")
    @classmethod
    def _known_policy(cls, value):
        if value not in POLICIES:
            raise ValueError(f"unknown maintenance policy {value!r}; known: {', '.join(POLICIES)}")
        return value

    @model_validator(mode="after")
    def _interval(self):
        if self.policy == "fixed" and self.interval_mgt is None:
            raise ValueError("maintenance policy 'fixed' needs interval_mgt")
        if (self.policy == "planned") != bool(self.planned):
            raise ValueError("maintenance policy 'planned' and its stretches come from a "
                             "scenario's [plan] table")  # fmt: skip
        return self


@dataclasses.dataclass
class Intervention:
    """One tamping (or renewal) of one segment.

    Parameters
    ----------
    mgt : float
        Tonnage [MGT].
    segment : int
        Segment index.
    kind : str
        ``"tamping"`` or ``"renewal"``.
    sd_before, sd_after : ndarray
        D1 SD of each rail before and after [mm].
    lift : float
        Mean lift of the segment's sleepers [m].
    """

    mgt: float
    segment: int
    kind: str
    sd_before: np.ndarray
    sd_after: np.ndarray
    lift: float


class Maintenance:
    """The maintenance state of a section and the tampings it gets.

    Parameters
    ----------
    options : MaintenanceOptions
        Policy and tamping model.
    position : ndarray
        Sleeper positions [m].
    starts, ends : ndarray
        Segment bounds [m] (`trackdyn.deterioration.quality.d1_sd`).
    threshold : float
        D1 SD that makes a segment due [mm].
    """

    def __init__(self, options: MaintenanceOptions, position, starts, ends, threshold: float):
        self.o, self.position, self.threshold = options, position, threshold
        self.policy = POLICIES[options.policy]()
        self.starts, self.ends = np.asarray(starts), np.asarray(ends)
        n = self.starts.size
        self.last = np.full(n, -np.inf)  # tonnage of the last tamping [MGT]
        self.count = np.zeros(n, dtype=int)  # tampings since the last renewal
        shape = (len(RAILS), position.size)
        self.damage = np.ones(shape)  # rate factor of the tampings' ballast damage [-]
        self.lift = np.zeros(shape)  # lift of the last tamping [m]
        self.since = np.full(shape, np.inf)  # tonnage since it [MGT]
        self._decay: tuple = (None, None)  # (since, its loosening's decay) of the last factor
        self.done: list[Intervention] = []
        self.expected: set[int] = set()  # segments a step was cut for (`until_due`)
        self._assess: D1Assessment | None = None  # the D1 SD's set-up of the latest call

    def d1_sd(self, geometry, extent, segment_length: float) -> np.ndarray:
        """D1 SD of ``geometry`` (rail, segment) [mm] (`trackdyn.deterioration.quality.d1_sd`),
        its filter and segments set up once for every geometry on the same distances."""
        a = self._assess
        if a is None or (a.extent, a.segment_length) != (tuple(extent), segment_length):
            a = self._assess = D1Assessment(tuple(extent), segment_length)
        return a(geometry)[0]

    def next_due(self, mgt: float) -> float:
        """Next tonnage after ``mgt`` at which the policy tamps whatever the track [MGT]
        (inf: none), so that a step ends there (`Policy.next_due`)."""
        return self.policy.next_due(self, mgt)

    def due(self, mgt: float, sd) -> np.ndarray:
        """Segments to tamp at ``mgt`` given the D1 SD (rail, segment) [mm]
        (`Policy.due`)."""
        return self.policy.due(self, mgt, sd)

    def until_due(self, mgt: float, settle, geometry, extent, segment_length: float,
                  cap: float) -> float:  # fmt: skip
        """Traffic until the policy may next tamp [MGT], at most ``cap``
        (`Policy.until_due`)."""
        return self.policy.until_due(self, mgt, settle, geometry, extent, segment_length, cap)

    def factor(self, dm: float) -> np.ndarray:
        """Settlement-rate factor of ballast damage and loosening over a step of ``dm``
        [MGT] (the loosening averaged over the step), per rail and sleeper [-]."""
        tau = self.o.loosening_mgt
        with np.errstate(invalid="ignore"):
            if self._decay[0] is not self.since:  # a step's trial tonnages share it
                self._decay = (self.since, np.exp(-self.since / tau))
            decay = self._decay[1]
            mean = decay if dm <= 0 else decay * -np.expm1(-dm / tau) * tau / dm
        loose = self.lift / (self.o.lift_reference_mm * 1e-3) * np.nan_to_num(mean)
        return self.damage * (1.0 + loose)

    def advance(self, dm: float) -> None:
        """Traffic of ``dm`` [MGT] has passed."""
        self.since = self.since + dm

    def sleepers(self, segments) -> np.ndarray:
        """Which sleepers the ``segments`` hold, (2, n) bool."""
        x = self.position
        held = np.zeros(x.size, dtype=bool)
        for i in segments:
            held |= (x >= self.starts[i]) & (x <= self.ends[i])
        return np.broadcast_to(held, (len(RAILS), x.size))

    def tamp(self, mgt, segments, geometry, extent, segment_length):
        """Tamp ``segments``: the new geometry, the tamped sleepers and the lift.

        Parameters
        ----------
        mgt : float
            Tonnage [MGT].
        segments : ndarray
            Segments due.
        geometry : Geometry
            Unloaded space curve before tamping.
        extent : tuple of float
            Part of the track assessed [m].
        segment_length : float
            Segment length of the D1 SD [m].

        Returns
        -------
        geometry : Geometry
            Unloaded space curve after tamping.
        held : ndarray
            Tamped sleepers, (2, n) bool.
        """
        before = self.d1_sd(geometry, extent, segment_length)
        profiles, lift = {}, np.zeros((len(RAILS), self.position.size))
        rng = np.random.default_rng((self.o.seed, len(self.done)))
        x = geometry.distance
        runs = _contiguous(segments)
        weights, at_sleepers = (self._weights(runs, where) for where in (x, self.position))
        for r, rail in enumerate(RAILS):
            z = geometry.profile(rail).copy()
            d1 = longitudinal_level(x, z, "D1")
            noise = longitudinal_level(x, rng.standard_normal(x.size), "D1")
            for run, w, ws in zip(runs, weights, at_sleepers, strict=True):
                inside = w >= 1.0
                sd = float(np.sqrt(np.mean(before[r, run] ** 2))) * 1e-3
                new_sd = self.o.recovery_offset_mm * 1e-3 + self.o.recovery_slope * sd
                rho = self.o.kept_correlation
                eps = noise / np.std(noise[inside])
                kept = rho * (new_sd / sd if sd > 0 else 0.0) * d1
                target = kept + np.sqrt(1 - rho * rho) * new_sd * eps
                z = z + w * (target - d1)
                # lift [m], up: the general lift where the machine is fully in, the
                # correction relative to its lowest point there
                up = ws * np.interp(self.position, x, d1 - target)
                low = up[ws >= 1.0].min()
                lift[r] = np.maximum(lift[r], ws * (self.o.general_lift_mm * 1e-3 - low) + up)
            profiles[rail] = z
        new = dataclasses.replace(geometry, **profiles)
        after = self.d1_sd(new, extent, segment_length)
        held = np.broadcast_to(sum(at_sleepers, np.zeros(self.position.size)) > 0, lift.shape)
        renew = np.isin(np.arange(self.starts.size), segments) & (self.count >= self.o.max_tampings)
        renewed = self._weights(_contiguous(np.flatnonzero(renew)), self.position)
        fresh = np.broadcast_to(sum(renewed, np.zeros(self.position.size)) > 0, lift.shape)
        worn = self.damage * (1.0 + self.o.damage_per_tamping)
        self.damage = np.where(fresh, 1.0, np.where(held, worn, self.damage))
        self.lift = np.where(held, lift, self.lift)
        self.since = np.where(held, 0.0, self.since)
        for i in segments:
            kind = "renewal" if renew[i] else "tamping"
            self.count[i] = 0 if renew[i] else self.count[i]
            self.count[i] += 1
            self.last[i] = mgt
            mean_lift = float(lift[self.sleepers([i])].mean())
            self.done.append(Intervention(mgt, int(i), kind, before[:, i], after[:, i], mean_lift))
        return new, held

    def _weights(self, runs, x) -> list[np.ndarray]:
        """Weight of each run's tamped profile at ``x`` (`_run_in_out`); where the ramps of
        two runs overlap they share, so the weights add up to 1 at most [-]."""
        weights = [_run_in_out(x, self.starts[run[0]], self.ends[run[-1]], self.o.run_out_m)
                   for run in runs]  # fmt: skip
        total = np.maximum(sum(weights, np.zeros(np.shape(x))), 1.0)
        return [w / total for w in weights]


class Policy:
    """When a maintenance policy tamps: the base, which tamps nothing; a policy is a
    subclass registered in `POLICIES` (its name the ``[maintenance] policy`` key).

    Each method gets the section's `Maintenance` (its options, threshold, segments and
    the tonnage of each segment's last tamping, ``last``).
    """

    def next_due(self, m: Maintenance, mgt: float) -> float:
        """Next tonnage after ``mgt`` [MGT] at which it tamps whatever the track (a step
        ends there); inf: none."""
        return np.inf

    def due(self, m: Maintenance, mgt: float, sd) -> np.ndarray:
        """Segments to tamp at the step end ``mgt`` [MGT] given the D1 SD (rail,
        segment) [mm]."""
        return np.array([], dtype=int)

    def until_due(self, m: Maintenance, mgt: float, settle, geometry, extent,
                  segment_length: float, cap: float) -> float:  # fmt: skip
        """Longest step from ``mgt`` [MGT], at most ``cap``, before a segment may be due (the
        step ends there, so that the tamping comes at its tonnage); ``settle(dm)`` is the
        step's settlement increment [m] against its tonnage [MGT]."""
        return cap


class FixedPolicy(Policy):
    """``policy = "fixed"``: every segment every ``interval_mgt``."""

    def next_due(self, m: Maintenance, mgt: float) -> float:
        """See `Policy.next_due`: the next multiple of ``interval_mgt``."""
        step = m.o.interval_mgt
        assert step is not None  # required by the "fixed" policy (the model's check)
        return (np.floor(mgt / step + 1e-9) + 1) * step

    def due(self, m: Maintenance, mgt: float, sd) -> np.ndarray:
        """See `Policy.due`: every segment at a multiple of ``interval_mgt``."""
        step = m.o.interval_mgt
        assert step is not None  # required by the "fixed" policy (the model's check)
        hit = np.isclose(mgt, np.round(mgt / step) * step)
        return np.arange(m.starts.size) if hit and mgt > 0 else np.array([], int)


class ThresholdPolicy(Policy):
    """``policy = "threshold"``: a segment whose D1 SD reaches the threshold on either
    rail, ``min_interval_mgt`` after its last tamping, with its ``neighbours`` and the
    adjacent segments past the alert limit."""

    def due(self, m: Maintenance, mgt: float, sd) -> np.ndarray:
        """See `Policy.due`."""
        ready = mgt - m.last >= m.o.min_interval_mgt
        worst = np.max(sd, axis=0)
        over = np.flatnonzero((worst >= m.threshold * (1 - DUE_MARGIN)) & ready)
        over = np.union1d(over, sorted(m.expected)).astype(int)
        m.expected = set()
        # the machine is there: the segments next to the stretch that are past the alert
        # limit go with it, and theirs next to them
        alert = (worst >= m.o.alert_fraction * m.threshold) & ready
        chosen = np.isin(np.arange(worst.size), over)
        for order in (slice(None), slice(None, None, -1)):  # grow right, then left
            grown, run = chosen[order].copy(), False
            for i, (c, a) in enumerate(zip(chosen[order], alert[order], strict=True)):
                run = c or (run and a)
                grown[i] = run
            chosen[order] = grown
        over = np.flatnonzero(chosen)
        k = m.o.neighbours
        near = {j for i in over for j in range(i - k, i + k + 1) if 0 <= j < m.starts.size}
        return np.array(sorted(near), dtype=int)

    def until_due(self, m: Maintenance, mgt: float, settle, geometry, extent,
                  segment_length: float, cap: float) -> float:  # fmt: skip
        """Traffic until a segment that may be tamped reaches the threshold [MGT], at most
        ``cap`` and at most until the next segment may be tamped again (its minimum
        interval passes).

        The rail is taken to follow the settlement increment ``settle(dm)`` [m] at the
        sleepers; the step ends where the D1 SD so predicted reaches the threshold, so that
        the tamping comes at its tonnage and not up to a step late. The segment that
        reaches it is then due at the step end (`due`), whatever the rail-seat load updates
        within the step did to its D1 SD.
        """
        wait = m.last + m.o.min_interval_mgt - mgt  # until each segment may be tamped
        cap = min(cap, float(wait[wait > 0].min(initial=np.inf)))
        ready = wait <= 0
        if not ready.any():
            return cap
        x, target = geometry.distance, m.threshold

        def worst(dm):  # the predicted D1 SD of the segments ready, worst rail [mm]
            e = settle(dm)
            moved = {r: geometry.profile(r) + np.interp(x, m.position, e[k])
                     for k, r in enumerate(RAILS)}  # fmt: skip
            sd = m.d1_sd(dataclasses.replace(geometry, **moved), extent, segment_length)
            return np.where(ready, sd.max(axis=0), -np.inf)

        def excess(dm):
            return float(worst(dm).max()) - target

        if excess(cap) <= 0 or excess(0.0) >= 0:
            return cap
        dm = brentq(excess, 0.0, cap, xtol=1e-9 * cap, rtol=1e-6)
        m.expected = {int(np.argmax(worst(dm)))}
        return dm


class PlannedPolicy(Policy):
    """``policy = "planned"``: the stretches of ``planned``, each at the first step end at
    or after its tonnage (a step ends at each tonnage after the start)."""

    def __init__(self):
        self.done = 0  # the planned stretches tamped so far, in tonnage order

    @staticmethod
    def _planned(m: Maintenance) -> list:
        return sorted(m.o.planned)

    def next_due(self, m: Maintenance, mgt: float) -> float:
        """See `Policy.next_due`: the next planned tonnage after ``mgt``."""
        later = [t for t, _, _ in self._planned(m) if t > mgt * (1 + 1e-12)]
        return min(later, default=np.inf)

    def due(self, m: Maintenance, mgt: float, sd) -> np.ndarray:
        """See `Policy.due`: the segments of every planned stretch whose tonnage has come."""
        plan = self._planned(m)
        come = [p for p in plan[self.done :] if p[0] <= mgt * (1 + 1e-12)]
        self.done += len(come)
        middle = 0.5 * (m.starts + m.ends)
        held = np.zeros(m.starts.size, dtype=bool)
        for _, start, end in come:
            held |= (middle >= start) & (middle <= end)
        return np.flatnonzero(held)


POLICIES: dict[str, type[Policy]] = {
    "threshold": ThresholdPolicy,
    "fixed": FixedPolicy,
    "planned": PlannedPolicy,
}
"""Registry of maintenance policies by name; add an entry to plug in another policy."""


def _contiguous(segments) -> list[list[int]]:
    """Runs of adjacent segment indices."""
    runs: list[list[int]] = []
    for i in sorted(int(s) for s in segments):
        if runs and i == runs[-1][-1] + 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    return runs


def _run_in_out(x, a: float, b: float, length: float) -> np.ndarray:
    """Weight of the tamped profile: 1 inside ``[a, b]``, cosine ramps over ``length``
    beyond its ends, 0 further out [-]."""
    inside = (x >= a) & (x <= b)
    if length <= 0:
        return inside.astype(float)
    beyond = np.maximum(a - x, x - b)  # distance outside [a, b], negative inside
    ramp = np.clip(1.0 - beyond / length, 0.0, 1.0)
    return np.where(inside, 1.0, 0.5 - 0.5 * np.cos(np.pi * ramp))
