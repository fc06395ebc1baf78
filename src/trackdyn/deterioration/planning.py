"""A maintenance plan for a section or a line: which stretches to tamp in which year.

The plan is made from a forecast of when each segment needs tamping (`Needs`: the
deterministic run's tampings, or the share of an ensemble's members that tamp it in each
year), year by year over the planning years:

1. **Due.** The segments due in the year (deterministic: the run tamps them in it; with
   an ensemble: at least ``min_probability`` of the members do), and those a cap deferred
   from the year before.
2. **Stretches.** Runs of due segments closer than ``bridge_gap_m`` are joined (the machine
   tamps the gap with them); a stretch shorter than ``min_stretch_m`` grows by the
   adjacent segment more likely to need tamping (the one with the earlier forecast on a
   tie) until it is long enough or holds its whole section, and stretches that then touch
   are joined.
3. **Cap.** With a yearly cap of metres tamped (``cap_m_per_year``) or of budget
   (``budget_per_year``: each stretch costs its length at ``tamping_per_m`` and one
   possession), the stretches are taken most likely first (earlier forecast first on a
   tie); the first that does not fit is cut to the part around its most likely segment
   that fits (if that part is at least ``min_stretch_m``), and it and every stretch after
   it are deferred: what is deferred is never more likely to need tamping than what is
   done. A deferred stretch's due segments are due the next year.

A year's stretches are tamped at the year's start, ``(year - 1) annual_mgt``, before the
forecast reaches the threshold in it; the first year's at `FIRST_YEAR_LEAD` of its
traffic (the loop tamps at the end of a step, and its first step is at least a train). The
plan is made once, from the forecast of the policy that made it, and followed as it is
(the maintenance policy ``"planned"``, `trackdyn.deterioration.maintenance`): a segment
tamped earlier than the forecast's policy would have tamped it may reach the threshold
again sooner than the plan says.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FIRST_YEAR_LEAD = 0.01
"""Share of the first year's traffic after which its planned stretches are tamped [-]."""


@dataclass(frozen=True)
class Rules:
    """How a plan is made (the ``[plan]`` table).

    Parameters
    ----------
    years : int
        Planning years [-].
    annual_mgt : float
        Traffic per year [MGT/year].
    min_stretch_m : float
        Shortest stretch a machine tamps [m].
    bridge_gap_m : float
        Longest gap between due stretches tamped with them [m].
    min_probability : float
        With an ensemble, the share of members that makes a segment due [-].
    cap_m_per_year : float, optional
        Most metres tamped in a year [m].
    budget_per_year : float, optional
        Most spent on tamping in a year [currency].
    tamping_per_m, per_possession : float
        Cost per metre tamped [currency/m] and per stretch [currency].
    """

    years: int
    annual_mgt: float
    min_stretch_m: float = 200.0
    bridge_gap_m: float = 0.0
    min_probability: float = 0.5
    cap_m_per_year: float | None = None
    budget_per_year: float | None = None
    tamping_per_m: float = 0.0
    per_possession: float = 0.0

    def cost(self, length: float) -> float:
        """Cost of tamping one stretch ``length`` metres long [currency]."""
        return self.tamping_per_m * length + self.per_possession


@dataclass(frozen=True)
class Needs:
    """When a section's segments need tamping, year by year.

    Parameters
    ----------
    section : str
        The section's name.
    starts, ends : ndarray
        Segment bounds [m].
    probability : ndarray
        (years, segments): the share of the forecast's members that tamp the segment in
        the year [-] (deterministic: 1 or 0).
    reach_year : ndarray
        (years, segments): when in the year the deterministic forecast tamps it [year from
        the start]; NaN: it does not.
    """

    section: str
    starts: np.ndarray
    ends: np.ndarray
    probability: np.ndarray
    reach_year: np.ndarray


@dataclass(frozen=True)
class Stretch:
    """One stretch of a plan: ``segments`` (contiguous indices) of section ``section`` (the
    index into the plan's `Needs`) in ``year`` [1, 2, ...]; ``due``, those of them due;
    ``probability`` [-] and ``reach_year`` [year], those of its most likely due segment
    (`urgency`)."""

    year: int
    section: int
    segments: tuple[int, ...]
    due: tuple[int, ...]
    probability: float
    reach_year: float

    def bounds(self, needs: Needs) -> tuple[float, float]:
        """Start and end [m]."""
        return float(needs.starts[self.segments[0]]), float(needs.ends[self.segments[-1]])

    def length(self, needs: Needs) -> float:
        """Length [m]."""
        start, end = self.bounds(needs)
        return end - start


def urgency(probability: float, reach_year: float) -> tuple[float, float]:
    """The key segments and stretches are taken in, largest first: the probability of
    needing tamping, then the earlier forecast (NaN: none, last)."""
    return float(probability), -float(np.nan_to_num(reach_year, nan=np.inf))


@dataclass(frozen=True)
class Due:
    """A section's segments in one year: ``due`` (bool), and each one's ``probability``
    [-] and ``reach_year`` [year] (a deferred segment keeps those of the year it was due
    in, if higher)."""

    due: np.ndarray
    probability: np.ndarray
    reach_year: np.ndarray

    def key(self, j: int) -> tuple[float, float]:
        """`urgency` of segment ``j``."""
        return urgency(self.probability[j], self.reach_year[j])

    def stretch(self, year: int, section: int, segments) -> Stretch:
        """The `Stretch` of ``segments``, its urgency its most likely due segment's."""
        due = tuple(int(j) for j in segments if self.due[j])
        top = max(due, key=self.key)
        return Stretch(year, section, tuple(int(j) for j in segments), due,
                       float(self.probability[top]), float(self.reach_year[top]))  # fmt: skip


@dataclass(frozen=True)
class Plan:
    """A plan: the stretches tamped, and those deferred (each in the year it was deferred
    from; ``deferred_to`` its next year, or None beyond the plan)."""

    stretches: list[Stretch]
    deferred: list[tuple[Stretch, int | None]]


def _runs(flags) -> list[list[int]]:
    """Runs of True in ``flags``, as index lists."""
    idx = np.flatnonzero(flags)
    if not idx.size:
        return []
    return [list(r) for r in np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)]


def stretches(needs: Needs, due: Due, rules: Rules) -> list[list[int]]:
    """The stretches of one section's due segments in a year (step 2 of the module
    docstring), as lists of segment indices."""
    n = needs.starts.size
    chosen = due.due.copy()
    while True:
        runs = _runs(chosen)
        for a, b in zip(runs, runs[1:], strict=False):  # bridge short gaps
            if needs.starts[b[0]] - needs.ends[a[-1]] <= rules.bridge_gap_m:
                chosen[a[-1] : b[0]] = True
        grown = False
        for run in _runs(chosen):
            lo, hi = run[0], run[-1]
            whole = (lo, hi) == (0, n - 1)
            while needs.ends[hi] - needs.starts[lo] < rules.min_stretch_m and not whole:
                left = due.key(lo - 1) if lo > 0 else (-np.inf, -np.inf)
                right = due.key(hi + 1) if hi < n - 1 else (-np.inf, -np.inf)
                lo, hi = (lo - 1, hi) if lo > 0 and left >= right else (lo, hi + 1)
                chosen[lo : hi + 1], grown = True, True
                whole = (lo, hi) == (0, n - 1)
        if not grown:
            return _runs(chosen)


def _fitting(stretch: Stretch, needs: Needs, due: Due, room: float) -> Stretch | None:
    """The part of ``stretch`` around its most likely due segment no longer than ``room``
    [m], grown towards the more likely side; None if none is."""
    seg = stretch.segments
    lo = hi = seg.index(max(stretch.due, key=due.key))

    def length(a, b):
        return needs.ends[seg[b]] - needs.starts[seg[a]]

    if length(lo, hi) > room:
        return None
    while True:
        options = [(due.key(seg[i]), i) for i in (lo - 1, hi + 1)
                   if 0 <= i < len(seg) and length(min(lo, i), max(hi, i)) <= room]  # fmt: skip
        if not options:
            return due.stretch(stretch.year, stretch.section, seg[lo : hi + 1])
        _, i = max(options)
        lo, hi = min(lo, i), max(hi, i)


def _room(taken_m: float, spent: float, rules: Rules) -> float:
    """Metres a stretch may still have this year under the caps [m]."""
    room = np.inf if rules.cap_m_per_year is None else rules.cap_m_per_year - taken_m
    if rules.budget_per_year is not None:
        left = rules.budget_per_year - spent - rules.per_possession
        if rules.tamping_per_m > 0:
            room = min(room, left / rules.tamping_per_m)
        elif left < 0:
            room = -np.inf
    return room


def capped(candidates: list[Stretch], lines: list[Needs], dues: list[Due], rules: Rules):
    """Step 3 of the module docstring on one year's stretches: those taken, and those
    deferred, most likely first."""
    order = sorted(candidates, key=lambda s: urgency(s.probability, s.reach_year), reverse=True)
    taken: list[Stretch] = []
    metres = spent = 0.0
    for k, s in enumerate(order):
        needs = lines[s.section]
        room = _room(metres, spent, rules)
        if s.length(needs) <= room:
            taken.append(s)
            metres += s.length(needs)
            spent += rules.cost(s.length(needs))
            continue
        part = _fitting(s, needs, dues[s.section], room) if room >= rules.min_stretch_m else None
        if part is None or part.length(needs) < min(rules.min_stretch_m, s.length(needs)):
            return taken, order[k:]
        taken.append(part)
        left = [i for i in s.segments if i not in part.segments]
        rest = [dues[s.section].stretch(s.year, s.section, r)
                for r in _runs(np.isin(np.arange(needs.starts.size), left))
                if any(dues[s.section].due[j] for j in r)]  # fmt: skip
        return taken, rest + order[k + 1 :]
    return taken, []


def make_plan(lines: list[Needs], rules: Rules) -> Plan:
    """The plan for the sections ``lines`` (see the module docstring).

    Parameters
    ----------
    lines : list of Needs
        Each section's forecast.
    rules : Rules
        The ``[plan]`` table.
    """
    carried = [Due(np.zeros(n.starts.size, bool), np.zeros(n.starts.size),
                   np.full(n.starts.size, np.nan)) for n in lines]  # fmt: skip
    plan, deferred = [], []
    for year in range(1, rules.years + 1):
        dues = []
        for needs, old in zip(lines, carried, strict=True):
            p, reach = needs.probability[year - 1], needs.reach_year[year - 1]
            keep = old.due & (old.probability >= p)
            dues.append(Due((p >= rules.min_probability) & (p > 0) | old.due,
                            np.where(keep, old.probability, p),
                            np.where(keep, old.reach_year, reach)))  # fmt: skip
        candidates = [dues[i].stretch(year, i, run) for i, needs in enumerate(lines)
                      for run in stretches(needs, dues[i], rules)]  # fmt: skip
        taken, rest = capped(candidates, lines, dues, rules)
        plan += taken
        flags = [np.zeros(n.starts.size, bool) for n in lines]
        for s in rest:
            flags[s.section][list(s.due)] = True
            deferred.append((s, year + 1 if year < rules.years else None))
        carried = [Due(f, d.probability, d.reach_year) for f, d in zip(flags, dues, strict=True)]
    return Plan(sorted(plan, key=lambda s: (s.year, s.section, s.segments[0])), deferred)


def planned_tampings(plan: Plan, lines: list[Needs], rules: Rules) -> list[tuple]:
    """Per section, the plan as the ``"planned"`` maintenance policy takes it: ``(tonnage
    [MGT], start [m], end [m])`` of each stretch, tamped at its year's start (the first
    year's at `FIRST_YEAR_LEAD` of its traffic)."""
    out: list[list] = [[] for _ in lines]
    for s in plan.stretches:
        start, end = s.bounds(lines[s.section])
        at = max(s.year - 1, FIRST_YEAR_LEAD) * rules.annual_mgt
        out[s.section].append((at, start, end))
    return [tuple(o) for o in out]
