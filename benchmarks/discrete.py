"""Speed of the discrete track: ns per step and s per km of the 11-DOF model, one core.

Run with ``python benchmarks/discrete.py`` (``--smoke`` for a short check in CI). The
loaded wagon at 60 km/h over the built-in example (its whole 1 km, or 100 m with
``--smoke``), end to end through `trackdyn.simulation.run_batch` (best of 3, compiled code
cached by a first run); and where the time goes: building the discrete track (rest state),
the static start, the compiled loop, and the rest (geometry sampling, storage); then the
same run on the Winkler track in the same process (best of 3), and the ratio of the two
(goal: at most 2). With
``--deteriorate``, the built-in 50 MGT deterioration example (``--mgt`` to change it, 2 MGT
with ``--smoke``) on the discrete and on the Winkler track, with ``--voids`` the ballast
under a void too: steps, wall time and its split as the loop records it.
"""

from __future__ import annotations

import argparse
import time
from unittest import mock

import numba

from trackdyn.commands.deteriorate.scenario import load_deterioration
from trackdyn.commands.deteriorate.sections import section_tasks
from trackdyn.deterioration.runs import run_section
from trackdyn.errors import Failure
from trackdyn.options import RunOptions
from trackdyn.simulation import run_batch
from trackdyn.solver import discrete
from trackdyn.track import discrete as discrete_track
from trackdyn.track.synthetic import example_track
from trackdyn.vehicle.parameters import load_vehicle


def timed(module, name, spent):
    """``module.name`` wrapped to add its seconds to ``spent[name]``."""
    func = getattr(module, name)

    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return func(*args, **kwargs)
        finally:
            spent[name] = spent.get(name, 0.0) + time.perf_counter() - t

    return mock.patch.object(module, name, wrapper)


def main(smoke: bool) -> None:
    numba.set_num_threads(1)
    vehicle = load_vehicle("loaded")
    track = example_track()
    lo, hi = track.extent
    end = lo + 100.0 if smoke else hi
    options = RunOptions(model="11dof", speed_kmh=60.0, track="discrete", end_m=end)
    run_batch([vehicle], [track], [options])  # compile (or load the cache)
    best, parts = float("inf"), {}
    for _ in range(1 if smoke else 3):
        spent = {}
        with (timed(discrete, "advance", spent), timed(discrete, "start", spent),
              timed(discrete_track, "_rest", spent)):  # fmt: skip
            t = time.perf_counter()
            (run,) = run_batch([vehicle], [track], [options])
            total = time.perf_counter() - t
        if total < best:
            best, parts, result = total, spent, run
    p = result.problem
    km = (p.n_steps - 1) * p.dt * p.speed / 1e3
    loop = parts["advance"]
    print(f"11-DOF on the discrete track, {km * 1e3:.0f} m at 60 km/h, dt = {p.dt:.3g} s, "
          f"{p.n_steps} steps")  # fmt: skip
    print(f"end to end: {best:.3f} s, {best / km:.2f} s per km, "
          f"{best / p.n_steps * 1e9:.0f} ns per step")  # fmt: skip
    print(f"compiled loop: {loop:.3f} s, {loop / p.n_steps * 1e9:.0f} ns per step")
    print(f"rest state: {parts['_rest']:.3f} s; static start: {parts['start']:.3f} s; "
          f"the rest (track build, geometry sampling, storage): "
          f"{best - loop - parts['_rest'] - parts['start']:.3f} s")  # fmt: skip
    winkler = options.model_copy(update={"track": "winkler"})
    run_batch([vehicle], [track], [winkler])
    walls = []
    for _ in range(1 if smoke else 3):
        t = time.perf_counter()
        run_batch([vehicle], [track], [winkler])
        walls.append(time.perf_counter() - t)
    print(f"the same on the Winkler track: {min(walls):.3f} s end to end; the discrete track "
          f"takes {best / min(walls):.2f} times as long (goal: at most 2)")  # fmt: skip


def deteriorate(smoke: bool, voids: bool, mgt: float | None) -> None:
    """The built-in deterioration example on the discrete track and on the Winkler track,
    optionally with ballast under a void (`trackdyn.deterioration.voids`): steps and wall
    time of each, and the hanging sleepers at the end."""
    spec, base = load_deterioration(None)
    total = 2.0 if smoke else mgt or spec.loop.total_mgt
    for track in ("winkler", "discrete"):
        case = spec.model_copy(
            update={
                "run": spec.run.model_copy(update={"track": track}),
                "loop": spec.loop.model_copy(update={"total_mgt": total}),
                "settlement": spec.settlement.model_copy(update={"voids": voids}),
            }
        )
        task = section_tasks(case, base)[0]
        t = time.perf_counter()
        result = run_section(task)
        wall = time.perf_counter() - t
        if isinstance(result, Failure):
            raise SystemExit(result.message)
        a = result.attrs
        parts = ", ".join(
            f"{label} {a[key]:.1f} s"
            for key, label in (("time_vehicle_runs_s", "vehicle runs"),
                               ("time_beam_solves_s", "rail beam"),
                               ("time_bookkeeping_s", "bookkeeping"))
        )  # fmt: skip
        hanging = int(result.hanging_sleepers.isel(mgt=-1).sum())
        print(f"example on the {track} track{' with voids' if voids else ''}, {total:g} MGT, "
              f"{a['steps']} steps: {wall:.1f} s ({parts}); "
              f"{hanging} sleeper rail seats hanging at the end")  # fmt: skip


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="a short run, for CI")
    parser.add_argument(
        "--deteriorate",
        action="store_true",
        help="the deterioration example, discrete against Winkler track",
    )
    parser.add_argument("--voids", action="store_true", help="with ballast under a void")
    parser.add_argument("--mgt", type=float, help="tonnage of --deteriorate [MGT]")
    args = parser.parse_args()
    if args.deteriorate:
        deteriorate(args.smoke, args.voids, args.mgt)
    else:
        main(args.smoke)
