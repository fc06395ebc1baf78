"""Rail-seat loads of one passage: dynamic wheel loads on the rail beam with its gaps.

For each wheel of the vehicle model and each sleeper, the vehicle is placed with that
wheel over the sleeper; every wheel of the vehicle on that rail carries the load its
contact had at that moment of the run (a bogie contact reports the mean load of its
leading and trailing wheel, 5.4.3), and the rail-seat forces follow from the rail beam
on the current ballast (`trackdyn.deterioration.ballast`, quasi-static). A wheel's load
cycle at a sleeper is the largest force that sleeper carries over all positions of that
wheel (self-weight included), so a hanging sleeper's share shows at its neighbours.
Positions the run did not reach (near the ends of the section) take the loads of the
nearest point it reached.

With ``[run] track = "discrete"`` the vehicles run on the discretely supported track
(`trackdyn.track.discrete`) built on the ballast as it stands (its rail-seat stiffness and
gaps), and a wheel's load cycle at a sleeper is the largest sleeper-ballast force of that
sleeper while the wheel was the nearest on its rail (`discrete_passage_loads`): the
dynamic response of rail, pads, sleepers and gaps, in place of the quasi-static beam.
Within a tonnage step the ballast settles under the run's loads; as the quasi-static loop,
the discrete loop follows the redistribution this causes through the rail beam: a load
cycle is the discrete run's plus the change of the beam's (`passage_loads`, the same wheel
loads) since the ballast state the run was made on (`StepLoads`). Without it a sleeper
that sheds load keeps shedding it through a whole step: a 1 mm void under one sleeper
closed within the first train and its sleeper came out about 1 mm proud, carrying 38 % more
than the far sleepers.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from trackdyn.deterioration.ballast import BallastState
from trackdyn.errors import TrackdynInputError
from trackdyn.simulation import Run, time_step
from trackdyn.solver.discrete import stable_step
from trackdyn.track.discrete import DiscreteParameters, discrete_track
from trackdyn.track.track import RAILS, LinearisedTrack
from trackdyn.vehicle.models import build_model

RUN_STEPS_PER_PERIOD = 25
"""Time steps per period of the highest natural frequency in the loop's vehicle runs
(unless ``[run] dt_s`` is given), half of `simulate`'s `STEPS_PER_PERIOD`: the loop needs
the load cycles, not the last 0.1 % of the wheel load. Measured on the built-in example
(11-DOF, 60 km/h) against steps of a quarter of this: the wheel loads within 0.32 %
(loaded) and 0.86 % (empty wagon) of the static wheel load (RMS 0.008 and 0.021 %), the
50 MGT D1 SD of every segment within 0.003 %, at half the vehicle runs' cost."""


KEPT = ("wl",)
"""What the loop's runs on the Winkler track store: the wheel loads (`wheel_forces`), not
the displacements, velocities and forces of every stored step."""


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
    4-DOF model carries only the front bogie), its wheels stand for the vehicle's axles per
    rail (``model.axles_per_rail``) in proportion.

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
    return np.array([model.axles_per_rail / per_rail[r] for _, _, r in wheels(model)])


def wheel_forces(run, ballast, model, previous=None) -> list:
    """The wheel loads of one passage placed on each rail's beam windows, for
    `passage_loads`: for each wheel over each sleeper, every wheel of the vehicle on that
    rail with the load its contact had at that moment of the run.

    Parameters
    ----------
    run : trackdyn.simulation.Run
        The solved run (its vehicle centre positions and wheel loads).
    ballast : Ballast
        The section's rails and ballast.
    model : trackdyn.vehicle.assembly.Model
        The model of the run (its contacts' axles).
    previous : list of tuple, optional
        The same vehicle's loads of an earlier run, placed: the first solve starts from
        their latest closed supports (`trackdyn.beam.railseat.WindowLoads`).

    Returns
    -------
    list of tuple
        Per rail: the indices in `wheels` of its wheels and the rows placed on the beam
        windows (`Ballast.wheel_forces`), one row per wheel over each sleeper (sleeper after
        sleeper, each of those wheels over it in turn). They do not change as the ballast
        settles.
    """
    pos = ballast.position
    n = pos.size
    centre = run.centre
    placed = []
    for r, rail in enumerate(RAILS):
        mine = [(j, c, x) for j, (c, x, rl) in enumerate(wheels(model)) if rl == rail]
        offsets = np.array([x for _, _, x in mine])
        # rows sleeper after sleeper, each wheel over it in turn
        sleeper = np.repeat(np.arange(n), len(mine))
        at = (pos[:, None] - offsets[None, :]).ravel()  # vehicle centre of each row [m]
        contacts = np.array([c for _, c, _ in mine])
        row_load = _row_loads(at, centre[0], centre[1] - centre[0], run.wheel_load, contacts)
        closed = None if previous is None else previous[r][1].closed
        rows = ballast.wheel_forces(r, sleeper, at[:, None] + offsets[None, :], row_load, closed)
        placed.append(([j for j, _, _ in mine], rows))
    return placed


@njit(cache=True, nogil=True)
def _row_loads(at, first, spacing, wheel_load, contacts):
    """The loads of ``contacts`` (not below zero) with the vehicle centre at each of ``at``
    [m], linear between the run's stored samples (from ``first``, every ``spacing`` [m],
    `Run.centre`; beyond them, the nearest), (rows, contacts) [N]."""
    last = wheel_load.shape[0] - 1
    out = np.empty((at.size, contacts.size))
    for b in range(at.size):
        where = min(max((at[b] - first) / spacing, 0.0), float(last))
        lo = min(int(where), last - 1)
        for a in range(contacts.size):
            x = max(wheel_load[lo, contacts[a]], 0.0)
            y = max(wheel_load[lo + 1, contacts[a]], 0.0)
            out[b, a] = x + (y - x) * (where - lo)
    return out


def passage_loads(placed, ballast, state) -> np.ndarray:
    """Load cycle of every wheel at every sleeper of its rail in one passage [N].

    Parameters
    ----------
    placed : list of tuple
        The passage's wheel loads on the beam windows (`wheel_forces`).
    ballast : Ballast
        The section's rails and ballast.
    state : BallastState
        The current rest state.

    Returns
    -------
    ndarray
        Shape (wheels, sleepers) [N], wheels in the order of `wheels`.
    """
    n = ballast.position.size
    out = np.zeros((sum(len(mine) for mine, _ in placed), n))
    for r, (mine, rows) in enumerate(placed):
        out[mine] = ballast.peak_forces(r, state, rows, len(mine))
    return out


def discrete_passage_loads(run, model) -> np.ndarray:
    """Load cycle of every wheel at every sleeper of its rail in one passage on the discrete
    track: the largest sleeper-ballast force while the wheel was the nearest on its rail [N].

    Sleepers beyond the stretch a wheel ran over take the value of the nearest sleeper it
    ran over.

    Parameters
    ----------
    run : trackdyn.simulation.Run
        The solved run on the discrete track.
    model : trackdyn.vehicle.assembly.Model
        The model of the run.

    Returns
    -------
    ndarray
        Shape (wheels, sleepers) [N], wheels in the order of `wheels`.
    """
    peak = run.out["ballast_wheel_peak"]
    pos = run.problem.inputs.lin.track.supports.position
    out = np.empty_like(peak)
    for j, (_, x, _) in enumerate(wheels(model)):
        reached = np.flatnonzero((pos >= run.centre[0] + x) & (pos <= run.centre[-1] + x))
        nearest = np.clip(np.searchsorted(pos[reached], pos), 0, reached.size - 1)
        before = np.clip(nearest - 1, 0, reached.size - 1)
        closer = np.abs(pos[reached][before] - pos) < np.abs(pos[reached][nearest] - pos)
        out[j] = peak[j, reached[np.where(closer, before, nearest)]]
    return out


class StepLoads:
    """Load cycles of one run on the discrete track as the ballast settles within a step.

    The discrete run's loads (`discrete_passage_loads`) plus the change of the rail beam's
    (`passage_loads`, with the run's wheel loads) from the ballast state the run was made
    on to the current one; not below zero.

    Parameters
    ----------
    run : trackdyn.simulation.Run
        The solved run on the discrete track.
    model : trackdyn.vehicle.assembly.Model
        The model of the run.
    ballast : Ballast
        The section's rails and ballast.
    state : BallastState
        The ballast state the run's discrete track was made from.
    """

    def __init__(self, run, model, ballast, state):
        self.run, self.ballast, self.state = run, ballast, state
        self.dynamic = discrete_passage_loads(run, model)
        self.placed = wheel_forces(run, ballast, model)
        self.start = passage_loads(self.placed, ballast, state)

    def at(self, state) -> np.ndarray:
        """Load cycles on ``state``, (wheels, sleepers) [N]."""
        if state is self.state:
            return self.dynamic
        now = passage_loads(self.placed, self.ballast, state)
        return np.maximum(self.dynamic + now - self.start, 0.0)


class PlacedLoads:
    """Load cycles of one run on the Winkler track as the ballast settles: its wheel loads
    placed on the rail beam's windows once (`wheel_forces`), solved on each ballast state
    (`passage_loads`).

    Parameters
    ----------
    run : trackdyn.simulation.Run
        The solved run.
    model : trackdyn.vehicle.assembly.Model
        The model of the run.
    ballast : Ballast
        The section's rails and ballast.
    previous : PlacedLoads, optional
        The same vehicle's loads of its run before: the first solve starts from their
        latest closed supports.
    """

    placed: list

    def __init__(self, run, model, ballast, previous: PlacedLoads | None = None):
        self.ballast = ballast
        self.placed = wheel_forces(
            run, ballast, model, None if previous is None else previous.placed
        )

    def at(self, state) -> np.ndarray:
        """Load cycles on ``state``, (wheels, sleepers) [N]."""
        return passage_loads(self.placed, self.ballast, state)


@dataclass
class Latest:
    """A vehicle's latest run and the load cycles that came of it.

    Parameters
    ----------
    run : trackdyn.simulation.Run
        The run.
    state : BallastState
        The ballast state it ran on.
    before : PlacedLoads or StepLoads, optional
        The loads of the vehicle's run before (until this run's are placed).
    source : PlacedLoads or StepLoads, optional
        This run's loads on the rail beam, placed when first needed.
    loads : ndarray, optional
        Its latest load cycles (wheels, sleepers) [N].
    """

    run: Run
    state: BallastState
    before: PlacedLoads | StepLoads | None = None
    source: PlacedLoads | StepLoads | None = None
    loads: np.ndarray | None = None


class TrafficRun:
    """One vehicle of the traffic, run over the track as it stands at each step.

    Set up once: the vehicle model, its load cycles per passage, and the run options
    (time step, stored samples); ``latest`` is its latest run (`Latest`), ``held`` whether
    the loop keeps it (and its load cycles) for the next step.

    Parameters
    ----------
    traffic : Traffic
        The vehicle, its speed and passages per MGT.
    lin : LinearisedTrack
        The measured track linearised about the vehicle's static wheel load.
    options : LoopOptions
        Model, time step, linearisation increment and output spacing.
    vehicle : int
        Index of the vehicle in the traffic mix.
    """

    def __init__(self, traffic, lin: LinearisedTrack, options, vehicle: int = 0):
        self.traffic, self.lin, self.vehicle = traffic, lin, vehicle
        self.model = build_model(options.run.model, traffic.vehicle)
        self.weights = cycles_per_passage(self.model) * traffic.passages_per_mgt
        self.rails = [RAILS.index(r) for _, _, r in wheels(self.model)]
        per_period = RUN_STEPS_PER_PERIOD
        dt = options.run.dt_s or time_step(self.model, lin, traffic.speed, per_period)[0]
        self.discrete = DiscreteParameters(rail=options.rail, sleeper_mass=options.sleeper_mass)
        if options.run.track == "discrete" and options.run.dt_s is None:
            load = traffic.vehicle.static_wheel_load
            dt = min(dt, stable_step(discrete_track(lin, self.discrete), load))
        every = max(1, int(options.output_spacing / (traffic.speed * dt)))
        self.run = options.run.with_(speed_kmh=traffic.speed_kmh, dt_s=dt, store_every=every)
        self.latest: Latest | None = None
        self.held = False

    @property
    def keeps(self) -> bool:
        """Held, with a latest run to keep (its run and load cycles stand this step)."""
        return self.held and self.latest is not None

    def track(self, lin: LinearisedTrack, ballast, state):
        """The track of its next run: ``lin``, the current track linearised about its static
        wheel load, or the discrete track on the ballast's rail-seat stiffness and
        ``state``'s gaps (``[run] track = "discrete"``)."""
        if self.run.track != "discrete":
            return lin
        return discrete_track(lin, self.discrete, stiffness=ballast.stiffness, gap=state.gap)

    def ran(self, run: Run, state) -> None:
        """Take its new ``run``, made on the ballast ``state``."""
        self.latest = Latest(run, state, None if self.latest is None else self.latest.source)

    def loads_at(self, ballast, state) -> np.ndarray:
        """Its load cycles on ``state`` (wheels, sleepers) [N]: those of its latest run,
        whose loads are placed on the rail beam when first needed; held, its latest."""
        latest = self.latest
        assert latest is not None  # the loop takes the runs before it asks for loads
        if self.keeps:
            assert latest.loads is not None
            return latest.loads
        if latest.source is None:
            if self.run.track == "discrete":
                latest.source = StepLoads(latest.run, self.model, ballast, latest.state)
            else:
                previous = latest.before
                assert previous is None or isinstance(previous, PlacedLoads)
                latest.source = PlacedLoads(latest.run, self.model, ballast, previous)
            latest.before = None
        latest.loads = latest.source.at(state)
        return latest.loads


def rail_seat_loads(runs, ballast, state, timing) -> list:
    """Load cycles of one passage of each vehicle, (wheels, sleepers) [N] per run.

    The wheel loads of each run go onto the rail beam on ``state`` (`PlacedLoads`); a run
    on the discrete track gives them itself, redistributed by the rail beam as the ballast
    has settled since the run (`StepLoads`); a run ``held`` keeps its latest load cycles.
    Adds the seconds spent to ``timing.beam``.

    Parameters
    ----------
    runs : list of TrafficRun
        The traffic, each with its latest run.
    ballast : Ballast
        The ballast model of the section.
    state : BallastState
        Its current state (gaps, rest deflection).
    timing : Timing
        Seconds spent so far, by part.
    """
    clock = time.perf_counter()
    loads = [run.loads_at(ballast, state) for run in runs]
    timing.beam += time.perf_counter() - clock
    return loads
