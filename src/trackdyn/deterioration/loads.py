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

import numpy as np
from numba import njit

from trackdyn.errors import TrackdynInputError
from trackdyn.simulation import run_batch, time_step
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


class TrafficRun:
    """One vehicle of the traffic, run over the track as it stands at each step.

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
        self.traffic, self.lin, self.options, self.vehicle = traffic, lin, options, vehicle
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
        self.state = None  # the ballast state of its latest run on the discrete track
        self.step: StepLoads | None = None
        self.placed: tuple | None = None  # (solved run, its `wheel_forces`)
        self.solved = None  # its latest run
        self.loads: np.ndarray | None = None  # its latest load cycles (wheels, sleepers)
        self.held = False  # keep its latest run and load cycles (the loop decides)

    @property
    def keeps(self) -> bool:
        """Held, with a latest run to keep (its run and load cycles stand this step)."""
        return self.held and self.solved is not None


def vehicle_runs(runs, lins: list[LinearisedTrack], timing: dict, ballast=None,
                 state=None):  # fmt: skip
    """Run every vehicle of the traffic once over the track as it stands; a vehicle
    ``held`` keeps its latest run. A generator (``yield from`` it): it yields the runs to
    make and is sent their results (`step_together`).

    The vehicles run side by side in one batch (`trackdyn.simulation.run_batch`), with
    those of the other sections stepped together, each over its own linearisation of the
    track, or on the discrete track of the ballast's rail-seat stiffness and ``state``'s
    gaps; only the solver's arrays come back, no Datasets. Adds this section's share of
    the batch's seconds to ``timing["vehicle"]`` and the rest of the time it waited (the
    other sections' runs and steps) to ``timing["others"]``.

    Parameters
    ----------
    runs : list of TrafficRun
        The traffic.
    lins : list of LinearisedTrack
        The current track linearised about each run's static wheel load.
    timing : dict
        Seconds spent so far, by part.
    ballast : Ballast, optional
        The ballast model of the section (needed for runs on the discrete track).
    state : BallastState, optional
        Its current state (each run records it, for `StepLoads`).

    Yields
    ------
    tuple of list
        Vehicles, tracks and run options of the runs to make; sent back: their results
        (a `trackdyn.simulation.Run` or an exception each) and the seconds they took.

    Returns
    -------
    list of trackdyn.simulation.Run
        One solved run per vehicle.
    """
    fresh = [(run, lin) for run, lin in zip(runs, lins, strict=True) if not run.keeps]
    if fresh:
        vehicles = [run.traffic.vehicle for run, _ in fresh]
        tracks = [
            discrete_track(lin, run.discrete, stiffness=ballast.stiffness, gap=state.gap)
            if run.run.track == "discrete"
            else lin
            for run, lin in fresh
        ]
        for run, _ in fresh:
            run.state = state
        clock = time.perf_counter()
        solved, seconds = yield vehicles, tracks, [run.run for run, _ in fresh]
        timing["vehicle"] += seconds
        timing["others"] += time.perf_counter() - clock - seconds
        for (run, _), result in zip(fresh, solved, strict=True):
            if isinstance(result, Exception):
                raise result
            run.solved = result
    return [run.solved for run in runs]


def step_together(loops: list) -> list:
    """Drive the deterioration loops of several sections in step (`predicting`): at each
    round, the vehicle runs every loop asks for (`vehicle_runs`) go in one batch
    (`trackdyn.simulation.run_batch`, which groups them by model; storing only the wheel
    loads, `KEPT`), so that the runs of different sections share the solver's vector
    lanes. A run's result does not depend on the others in its batch, so each loop gives
    what it gives alone.

    Parameters
    ----------
    loops : list of generator
        The loops, not started.

    Returns
    -------
    list
        Per loop, what it returns, or the exception that stopped it (the others go on).
    """
    results: list = [None] * len(loops)
    asked: dict[int, tuple] = {}

    def resume(i, sent):
        try:
            asked[i] = loops[i].send(sent)
        except StopIteration as done:
            results[i] = done.value
        except Exception as exc:  # noqa: BLE001 - this section's failure, the others go on
            results[i] = exc

    for i in range(len(loops)):
        resume(i, None)
    while asked:
        rounds, asked = asked, {}
        pairs = [(i, j) for i, r in rounds.items() for j in range(len(r[0]))]
        clock = time.perf_counter()
        solved = run_batch(*([rounds[i][part][j] for i, j in pairs] for part in range(3)),
                           keep=KEPT)  # fmt: skip
        share = (time.perf_counter() - clock) / len(pairs)  # split evenly between the runs
        answers: dict[int, list] = {i: [] for i in rounds}
        for (i, _), result in zip(pairs, solved, strict=True):
            answers[i].append(result)
        for i in rounds:
            resume(i, (answers[i], share * len(answers[i])))
    return results


def rail_seat_loads(runs, solved, ballast, state, timing: dict) -> list:
    """Load cycles of one passage of each vehicle, (wheels, sleepers) [N] per run.

    The wheel loads of each run go onto the rail beam on ``state`` (`passage_loads`; they are
    placed on the beam windows once per run, `wheel_forces`, and solved on each state); a run
    on the discrete track gives them itself, redistributed by the rail beam as the ballast
    has settled since the run (`StepLoads`); a run ``held`` keeps its latest load cycles.
    Adds the seconds spent to ``timing["beam"]``.

    Parameters
    ----------
    runs : list of TrafficRun
        The traffic.
    solved : list of trackdyn.simulation.Run
        Their solved runs (`vehicle_runs`).
    ballast : Ballast
        The ballast model of the section.
    state : BallastState
        Its current state (gaps, rest deflection).
    timing : dict
        Seconds spent so far, by part.
    """
    clock = time.perf_counter()
    for run, done in zip(runs, solved, strict=True):
        if run.keeps:
            continue  # its latest load cycles stand
        if run.run.track != "discrete":
            if run.placed is None or run.placed[0] is not done:
                previous = None if run.placed is None else run.placed[1]
                run.placed = (done, wheel_forces(done, ballast, run.model, previous))
            run.loads = passage_loads(run.placed[1], ballast, state)
            continue
        if run.step is None or run.step.run is not done:
            run.step = StepLoads(done, run.model, ballast, run.state)
        run.loads = run.step.at(state)
    timing["beam"] += time.perf_counter() - clock
    return [run.loads for run in runs]
