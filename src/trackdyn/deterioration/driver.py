"""The driver of deterioration loops: the vehicle runs of one or more sections, step by step.

Between a section's loop (`trackdyn.deterioration.loop.SectionLoop`) and the solver, a
`RunRequest` (the vehicles, tracks and run options of a step's runs) and a `RunReply`
(their results and the seconds they took). `step_together` drives several sections in
step: at each round the runs every section asks for go in one batch
(`trackdyn.simulation.run_batch`, which groups them by model; storing only the wheel
loads, `trackdyn.deterioration.loads.KEPT`), so that the runs of different sections share
the solver's vector lanes. A run's result does not depend on the others in its batch, so
each section gives what it gives alone, to the bit.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from trackdyn.deterioration.loads import KEPT
from trackdyn.deterioration.record import LoopRecord
from trackdyn.errors import Failure
from trackdyn.progress import progress_bar
from trackdyn.simulation import run_batch


@dataclass(frozen=True)
class RunRequest:
    """The vehicle runs one step of a section needs (`trackdyn.simulation.run_batch`).

    Parameters
    ----------
    vehicles : tuple of Vehicle
        The vehicles to run.
    tracks : tuple
        The track of each run (a `LinearisedTrack` or a discrete track).
    options : tuple of RunOptions
        The run options of each.
    """

    vehicles: tuple
    tracks: tuple
    options: tuple


@dataclass(frozen=True)
class RunReply:
    """The runs of a `RunRequest`.

    Parameters
    ----------
    results : tuple
        Per run asked for, in order: a `trackdyn.simulation.Run` or a `Failure`.
    seconds : float
        The section's share of the batch's time [s].
    """

    results: tuple
    seconds: float


def step_together(loops: list, progress: bool = False) -> list[LoopRecord | Failure]:
    """Drive the deterioration loops of several sections in step, their vehicle runs of
    each round in one batch; a section that fails stops, the others go on.

    Parameters
    ----------
    loops : list of SectionLoop
        The sections' loops, started: the driver asks each for its ``runs_wanted`` and
        gives it their reply (``take_runs``) to ``settle_step`` and ``maintain``, until it
        is ``done`` (its ``record``); a step that wants no runs is made at once, so that
        each round's batch holds the runs of every section that wants any.
    progress : bool
        Show a progress bar over the tonnage: the least any section has reached (a
        section done counts as at its end).

    Returns
    -------
    list
        Per loop, its `LoopRecord`, or the `Failure` that stopped it.
    """
    results: list = [None] * len(loops)
    active = dict(enumerate(loops))
    total = max((loop.total for loop in loops), default=0.0)
    with progress_bar(progress, total, "tonnage [MGT]") as bar:
        while active:
            asked = {}
            for i in list(active):
                request = _phase(results, active, i, _next_request, active[i])
                if i in active and request is None:
                    results[i] = active.pop(i).record()
                elif i in active:
                    asked[i] = request
            for i, reply in _run(asked).items():
                _phase(results, active, i, _step, active[i], reply)
                if i in active and active[i].done:
                    results[i] = active.pop(i).record()
            reached = (loop.mgt if i in active else loop.total for i, loop in enumerate(loops))
            bar.update(min(reached))
    return results


def _next_request(loop) -> RunRequest | None:
    """The next runs ``loop`` wants; the steps that want none (every vehicle held) made on
    the way; None when it is done without."""
    while not loop.done:
        request = loop.runs_wanted()
        if request.vehicles:
            return request
        _step(loop, RunReply((), 0.0))
    return None


def _phase(results: list, active: dict, i: int, phase, *args):
    """``phase(*args)`` of loop ``i``, its seconds added to its total; a failure ends the
    loop (its `Failure` in ``results``)."""
    clock = time.perf_counter()
    try:
        return phase(*args)
    except Exception as exc:  # noqa: BLE001 - this section's failure, the others go on
        results[i] = Failure.of(exc)
        del active[i]
        return None
    finally:
        if i in active:
            active[i].timing.total += time.perf_counter() - clock


def _step(loop, reply: RunReply) -> None:
    """The rest of one step of ``loop`` after its runs: settle, maintain."""
    loop.take_runs(reply)
    loop.settle_step()
    loop.maintain()


def _run(asked: dict[int, RunRequest]) -> dict[int, RunReply]:
    """The runs of every request in one batch, as each loop's reply."""
    if not asked:
        return {}
    pairs = [(i, j) for i, r in asked.items() for j in range(len(r.vehicles))]
    clock = time.perf_counter()
    solved = run_batch([asked[i].vehicles[j] for i, j in pairs],
                       [asked[i].tracks[j] for i, j in pairs],
                       [asked[i].options[j] for i, j in pairs], keep=KEPT)  # fmt: skip
    share = (time.perf_counter() - clock) / len(pairs)  # split evenly between the runs
    answers: dict[int, list] = {i: [] for i in asked}
    for (i, _), result in zip(pairs, solved, strict=True):
        answers[i].append(result)
    return {i: RunReply(tuple(a), share * len(a)) for i, a in answers.items()}
