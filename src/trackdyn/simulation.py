"""`simulate`: a vehicle model running over a track at constant speed.

Builds the model, linearises the track (5.9-5.11), picks a stable time step, starts the
vehicle on the static path and hands the run to a solver (`trackdyn.solver`).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria,
§5.2-5.4.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import xarray as xr

from trackdyn.errors import Failure, TrackdynInputError
from trackdyn.limits import MAX_STEPS, require_memory
from trackdyn.options import RunOptions
from trackdyn.progress import progress_bar
from trackdyn.results import make_dataset
from trackdyn.solver import OUTPUTS, Problem, discrete, solve
from trackdyn.solver.matrices import STEPS_PER_PERIOD, highest_frequency
from trackdyn.solver.statics import widths
from trackdyn.track.discrete import DiscreteTrack, discrete_track
from trackdyn.track.inputs import ContactInput
from trackdyn.track.track import RAILS, LinearisedTrack, Track
from trackdyn.vehicle.models import build_model
from trackdyn.vehicle.parameters import Vehicle

OUTPUT_STEP = 1e-3
"""Output interval when ``store_every`` is None [s]: 1 kHz, well above the wheel-load
frequencies of interest (body modes of 1-8 Hz, wheelset on track of 40-60 Hz)."""


RUN_MEMORY_FACTOR = 2.5
"""Memory of a run per byte of the arrays it stores [-]: the arrays, the Dataset made from
them and what is written from it. Measured peaks of 11-DOF runs (`trackdyn run`) over 1,
10 and 40 km: 0.90-1.02 kB per stored step beyond the 0.4 GB of a short run, 2.0-2.2 times
its 456 B of arrays; 2.5 with a margin."""


def time_step(
    model, lin: LinearisedTrack, speed: float, steps_per_period: float = STEPS_PER_PERIOD
) -> tuple[float, float, float]:
    """Default time step, stability limit [s] and highest natural frequency [rad/s].

    The frequency is that of the model on the stiffest track along the path; the default
    step gives ``steps_per_period`` (`STEPS_PER_PERIOD` unless a caller needs less)
    steps per its period and moves the vehicle no more than half a geometry sample
    interval; the explicit scheme is stable below ``2 / ω_max``.
    """
    k_max = np.array(
        [
            lin.k2[0 if r == "left" else 1].max() * len(a)
            for r, a in zip(model.contact_rails, model.contact_axles, strict=True)
        ]
    )
    omega = highest_frequency(model.M, model.K + model.Dc.T @ (k_max[:, None] * model.Dc))
    spacing = float(np.min(np.diff(lin.track.geometry.distance)))
    dt = min(2 * np.pi / omega / steps_per_period, 0.5 * spacing / speed)
    return dt, 2.0 / omega, omega


def _shared(made: dict, key: tuple, make):
    """``make()``, made once per ``key`` in ``made``: what the runs of a batch with equal
    inputs share (a key names its objects by ``id``; ``made`` lives no longer than they)."""
    if key not in made:
        made[key] = make()
    return made[key]


def _problem(vehicle, track, o: RunOptions, keep=OUTPUTS, made: dict | None = None) -> Problem:
    """The solver's view of one run: model, track input, path, time step and storage.

    With ``o.track == "discrete"`` the input is a `DiscreteTrack` (given, or built from the
    linearised track) and the default step is also kept within the track's own stable step.
    A run whose stored arrays (``keep``, `trackdyn.solver.OUTPUTS`; every one on the discrete
    track) would not fit in memory is refused before it starts (`RUN_MEMORY_FACTOR`).
    Runs given the same ``made`` (`_shared`) share the linearisation of a track about the
    same static wheel load [N] and the `ContactInput` of a linearised track under the same
    contacts: one object, made once, as each run alone would make it.
    """
    made = {} if made is None else made
    speed = o.speed
    m = build_model(o.model, vehicle)
    given = track if isinstance(track, DiscreteTrack) else None
    if given is not None:
        track = given.lin
    lin = (
        track
        if isinstance(track, LinearisedTrack)
        else _shared(
            made,
            ("linearised", id(track), vehicle.static_wheel_load, o.delta, o.extrapolate),
            lambda: track.linearise(vehicle.static_wheel_load, o.delta, extrapolate=o.extrapolate),
        )
    )
    lo, hi = lin.track.extent
    for key, value in (("start_m", o.start_m), ("end_m", o.end_m)):
        if value is not None and not lo <= value <= hi:
            raise TrackdynInputError(
                f"{key} = {value:g} m is outside the track, {lo:g} to {hi:g} m"
            )
    rear, front = m.reach
    start = lo if o.start_m is None else o.start_m
    end = hi if o.end_m is None else o.end_m
    c0, c1 = start - rear, end - front
    if c1 <= c0:
        raise TrackdynInputError(
            f"track {start:.1f}-{end:.1f} m is shorter than the vehicle's path: the axles span "
            f"{front - rear:.2f} m"
        )
    default_dt, limit, omega = time_step(m, lin, speed)
    contacts = ("contacts", id(lin), m.contact_rails, m.contact_axles, o.nonlinear)
    inputs: ContactInput | DiscreteTrack = _shared(
        made, contacts, lambda: ContactInput(m, lin, o.nonlinear)
    )
    if o.track == "discrete":
        inputs = given or discrete_track(lin)
        default_dt = min(default_dt, discrete.stable_step(inputs, m.static_wheel_load))
        track_limit, track_omega = discrete.stability_limit(inputs, m.static_wheel_load)
        if track_limit < limit:
            limit, omega = track_limit, track_omega
    dt = default_dt if o.dt_s is None else o.dt_s
    if dt >= limit:
        raise TrackdynInputError(
            f"time step dt_s = {dt:.3g} s is beyond the stability limit {limit:.3g} s of the "
            f"explicit scheme (highest natural frequency {omega / 2 / np.pi:.1f} Hz)"
        )
    n_steps = int(np.floor((c1 - c0) / (speed * dt))) + 1
    if n_steps > MAX_STEPS:
        raise TrackdynInputError(
            f"time step dt_s = {dt:.3g} s gives {n_steps:.3g} steps over {c1 - c0:.1f} m at "
            f"{o.speed_kmh:g} km/h, more than the plausible {MAX_STEPS:.0e}"
        )
    if o.store_every is not None and o.store_every >= n_steps:
        raise TrackdynInputError(
            f"store_every = {o.store_every} is not less than the run's {n_steps} steps: the "
            "results would hold its first step only"
        )
    store_every = o.store_every or max(1, round(OUTPUT_STEP / dt))
    problem = Problem(m, inputs, c0, speed, dt, n_steps, store_every)
    columns = widths(m)
    kept = columns if o.track == "discrete" else {k: columns[k] for k in keep}
    require_memory(
        RUN_MEMORY_FACTOR * 8.0 * problem.n_store * sum(kept.values()),
        f"a run over {c1 - c0:.4g} m ({problem.n_store:.3g} stored steps of {o.model})",
    )
    return problem


@dataclass(frozen=True)
class Run:
    """One solved run as the solver leaves it: its problem and stored arrays.

    Parameters
    ----------
    problem : Problem
        The run (model, track input, path, time step, storage).
    out : dict
        The solver's stored arrays (`trackdyn.solver.statics.OUTPUTS`).
    """

    problem: Problem
    out: dict

    @functools.cached_property
    def time(self) -> np.ndarray:
        """Time of each stored step [s], ``i * store_every * dt``, made once (one array:
        the integers ``i * store_every`` are exact in floating point)."""
        p = self.problem
        time = np.arange(p.n_store, dtype=float)
        time *= p.store_every
        time *= p.dt
        return time

    @functools.cached_property
    def centre(self) -> np.ndarray:
        """Vehicle centre position at each stored step, ``centre0 + speed * time`` [m]."""
        centre = self.problem.speed * self.time
        centre += self.problem.centre0
        return centre

    @property
    def wheel_load(self) -> np.ndarray:
        """Wheel load of each contact at each stored step, (steps, contacts) [N]."""
        return self.out["wl"]


def run_batch(vehicles: list[Vehicle], tracks, options: list[RunOptions], *,
              progress: bool = False, newton_max_iter: int = 50,
              keep=OUTPUTS) -> list:  # fmt: skip
    """Run several vehicles over a track side by side; the solver's arrays of each.

    What `simulate_batch` does without building Datasets, for callers that need only a few
    arrays (the deterioration loop). Parameters as for `simulate_batch`; ``keep``: the
    `trackdyn.solver.OUTPUTS` a run on the Winkler track stores and returns (a run on the
    discrete track returns all of its own).

    Returns
    -------
    list
        Per run, a `Run` or the `trackdyn.errors.Failure` it gave.
    """
    if not isinstance(tracks, list | tuple):
        tracks = [tracks] * len(vehicles)
    _check_types(vehicles, tracks, options)
    if not len(vehicles) == len(tracks) == len(options):
        raise TrackdynInputError(
            f"simulate_batch: {len(vehicles)} vehicles, {len(tracks)} tracks and "
            f"{len(options)} run options; give one of each per run"
        )
    made: list = []
    shared: dict = {}
    for v, trk, o in zip(vehicles, tracks, options, strict=True):
        try:
            made.append(_problem(v, trk, o, keep, shared))
        except TrackdynInputError as exc:
            made.append(exc)
    results: list = list(made)
    todo = [i for i, p in enumerate(made) if isinstance(p, Problem)]
    total = sum(made[i].n_steps for i in todo)
    label = f"{options[0].model} at {options[0].speed_kmh:.0f} km/h [steps]"
    if len(vehicles) > 1:
        label = f"{len(vehicles)} runs [steps]"
    with progress_bar(progress, total, label) as bar:
        for solver in dict.fromkeys(options[i].integrator for i in todo):
            index = [i for i in todo if options[i].integrator == solver]
            batch = [made[i] for i in index]
            solved = solve(batch, solver, newton_max_iter=newton_max_iter, advanced=bar.advance,
                           keep=keep)  # fmt: skip
            for i, out in zip(index, solved, strict=True):
                results[i] = out if isinstance(out, Exception) else Run(made[i], out)
    return [Failure.of(r) if isinstance(r, Exception) else r for r in results]


def simulate_batch(
    vehicles: list[Vehicle],
    tracks,
    options: list[RunOptions],
    *,
    progress: bool = False,
    newton_max_iter: int = 50,
) -> list:
    """Run several vehicles over a track side by side; the results of `simulate` each.

    Runs of the same model and solver go through the solver together (one compiled call
    per block of steps, the runs side by side in the vector lanes,
    `trackdyn.solver.lanes.advance_lanes`); each run's results are those it gives alone,
    to the bit. A run that cannot be made or fails (bad time step, Newton) comes
    back as its `trackdyn.errors.Failure` and does not stop the others.

    Parameters
    ----------
    vehicles : list of Vehicle
        One vehicle per run.
    tracks : Track, LinearisedTrack, DiscreteTrack or list of them
        The track, or one per run (e.g. linearised about each vehicle's static load). A
        `trackdyn.track.discrete.DiscreteTrack` is the discrete track itself (for
        ``track = "discrete"``; with the Winkler track, its linearised track is used).
    options : list of RunOptions
        One per run: model, speed, time step, storage, track law, solver.
    progress, newton_max_iter
        As for `simulate`.

    Returns
    -------
    list
        Per run, an `xarray.Dataset` (see `simulate`) or a `trackdyn.errors.Failure`.
    """
    runs = run_batch(vehicles, tracks, options, progress=progress,
                     newton_max_iter=newton_max_iter)  # fmt: skip
    return [r if isinstance(r, Failure) else _dataset(r, v, o)
            for r, v, o in zip(runs, vehicles, options, strict=True)]  # fmt: skip


def _check_types(vehicles, tracks, options) -> None:
    """Refuse arguments of the wrong kind with a message naming the argument."""
    kinds = (
        ("vehicle", vehicles, Vehicle, "a Vehicle (trackdyn.load_vehicle)"),
        ("track", tracks, Track | LinearisedTrack | DiscreteTrack, "a Track (trackdyn.load_track)"),
        ("options", options, RunOptions, "RunOptions (trackdyn.RunOptions)"),
    )
    for name, values, kind, expected in kinds:
        for v in values:
            if not isinstance(v, kind):
                raise TrackdynInputError(
                    f"simulate: {name} must be {expected}, got {type(v).__name__} {v!r:.40}"
                )


def _dataset(run: Run, vehicle, o: RunOptions) -> xr.Dataset:
    """The run's Dataset; a discrete-track run adds ``ballast_force_peak`` (rail, sleeper)."""
    p = run.problem
    flags = dict(dt=p.dt, speed=p.speed, nonlinear=o.nonlinear)
    ds = make_dataset(p.model, vehicle, run.time, run.centre, run.out, **flags)
    ds.attrs["track_model"] = o.track
    if o.track == "discrete":
        assert isinstance(p.inputs, DiscreteTrack)
        ds = ds.assign_coords(
            rail=list(RAILS), sleeper_position=("sleeper", p.inputs.lin.track.supports.position)
        )
        ds["ballast_force_peak"] = (
            ("rail", "sleeper"),
            run.out["ballast_peak"],
            {"units": "N", "long_name": "largest sleeper-ballast contact force of the run "
             "(self-weight included)"},
        )  # fmt: skip
    return ds


def simulate(
    vehicle: Vehicle,
    track: Track | LinearisedTrack,
    options: RunOptions | None = None,
    *,
    progress: bool = False,
    newton_max_iter: int = 50,
) -> xr.Dataset:
    """Run a vehicle model over a track at constant speed.

    The vehicle starts with its rearmost axle at the options' ``start_m`` (default: the
    start of the track) in the static equilibrium of that position, moving with the track
    (its velocity is that of the static equilibrium carried along the track), and runs
    until its foremost axle reaches ``end_m`` (default: the end of the track).

    Parameters
    ----------
    vehicle : Vehicle
        Vehicle parameter set.
    track : Track, LinearisedTrack or DiscreteTrack
        The track; a `Track` is linearised about the vehicle's static wheel load with the
        options' ``delta`` and ``extrapolate``; with ``track = "discrete"`` the discrete
        track is built from that linearisation (`trackdyn.track.discrete.discrete_track`)
        unless given.
    options : RunOptions, optional
        Model, speed, time step, storage, linearisation and track law
        (`trackdyn.options.RunOptions`; default: the 11-DOF model at 60 km/h). The default
        time step gives ``STEPS_PER_PERIOD`` steps per period of the highest natural
        frequency with the stiffest track on the path, and no more than half a geometry
        sample interval of travel per step; a step beyond the stability limit
        ``2 / ω_max`` of the explicit scheme is refused. Without ``store_every`` one step
        is kept about every `OUTPUT_STEP` seconds.
    progress : bool
        Show a progress bar.
    newton_max_iter : int
        Newton iterations allowed per step.

    Returns
    -------
    xarray.Dataset
        See `trackdyn.results.make_dataset`; a run on the discrete track also holds
        ``ballast_force_peak`` (rail, sleeper) [N], the largest sleeper-ballast contact
        force of each sleeper over the run.
    """
    o = RunOptions() if options is None else options
    if isinstance(vehicle, list | tuple):
        raise TrackdynInputError("simulate: vehicle must be one Vehicle; for many, simulate_batch")
    (result,) = simulate_batch(
        [vehicle], [track], [o], progress=progress, newton_max_iter=newton_max_iter
    )
    if isinstance(result, Failure):
        raise result.error()
    return result
