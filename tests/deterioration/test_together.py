"""Sections stepped together (`run_group`) give, to the bit, what each gives alone.

Their vehicle runs share batches of the solver, so that runs of different sections go
side by side in the vector lanes (`trackdyn.solver.lanes.lane_groups`); a run's result
does not depend on the other runs of its batch, so each section's Dataset must be
identical to the one it gives alone (`run_section`), and a section that fails stops
alone.
"""

import dataclasses

import numpy as np
import pytest
import xarray as xr

from trackdyn.deterioration import LoopOptions, Traffic, load_law
from trackdyn.deterioration.runs import Section, SectionTask, run_group, run_section
from trackdyn.errors import Failure, Status, TrackdynNumericalError
from trackdyn.io import write_geometry, write_supports
from trackdyn.options import RunOptions
from trackdyn.parallel import groups, run_tasks
from trackdyn.solver import central, lanes
from trackdyn.track.synthetic import SoftSpot, synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

PASSAGES = 8065.0  # 1e6 t / (104 t + 20 t), the example's coal traffic [per MGT]
TRAFFIC = (
    Traffic(load_vehicle("loaded"), 60.0, PASSAGES, "loaded"),
    Traffic(load_vehicle("empty"), 60.0, PASSAGES, "empty"),
)


@pytest.fixture(scope="module")
def tasks(tmp_path_factory):
    """Three 100 m sections (different geometry, one with a soft spot), 11-DOF, both
    wagons, 10 MGT: 3 to 6 runs a round, in a group of the lanes with idle lanes."""
    path = tmp_path_factory.mktemp("together")
    out = []
    for i in range(3):
        features = (SoftSpot(50.0, 6.0),) if i == 1 else ()
        trk = synthetic_track(100.0, spectrum="fra5", seed=10 + i, features=features)
        geometry, supports = path / f"s{i}_geometry.csv", path / f"s{i}_supports.csv"
        write_geometry(trk.geometry, geometry)
        write_supports(trk.supports, supports)
        options = LoopOptions(run=RunOptions(model="11dof"), total_mgt=10.0,
                              snapshot_every_mgt=5.0, segment_length_m=50.0, seed=i)  # fmt: skip
        section = Section(f"s{i}", str(geometry), str(supports))
        out.append(SectionTask(section, TRAFFIC, load_law("power"), options))
    return out


def without_times(ds):
    ds.attrs = {k: v for k, v in ds.attrs.items() if not k.startswith("time_")}
    return ds


def test_sections_stepped_together_give_what_each_gives_alone(tasks, monkeypatch):
    batches = []
    solve = central.solve

    def counted(problems, *args, **kwargs):
        batches.append(len(problems))
        return solve(problems, *args, **kwargs)

    monkeypatch.setattr(central, "solve", counted)
    together = run_group(tasks)
    in_lanes = [b for b in batches if b >= lanes.MIN_LANE_RUNS]
    assert in_lanes, batches  # the lanes were used
    for result, task in zip(together, tasks, strict=True):
        alone = run_section(task)
        assert result.attrs["section"] == alone.attrs["section"] == task.section.name
        xr.testing.assert_identical(without_times(result), without_times(alone))
    first = together[0].settlement.isel(mgt=-1).values
    assert not np.allclose(first, together[1].settlement.isel(mgt=-1).values)


def test_a_section_that_fails_stops_alone(tasks):
    # the second section may take only one step: it stops with its error after the first
    # round of runs, the others go on to what they give alone
    short = tasks[1].options.model_copy(update={"max_steps": 1})
    broken = [tasks[0], dataclasses.replace(tasks[1], options=short), tasks[2]]
    results = run_group(broken)
    assert isinstance(results[1], Failure) and results[1].status is Status.INPUT_REFUSED
    assert results[1].message.startswith("section s1: more than max_steps = 1 steps")
    for i in (0, 2):
        xr.testing.assert_identical(without_times(results[i]),
                                    without_times(run_section(tasks[i])))  # fmt: skip


def test_a_section_whose_files_fail_is_reported_and_the_others_run(tasks):
    missing = dataclasses.replace(tasks[0].section, geometry="nope.csv")
    results = run_group([dataclasses.replace(tasks[0], section=missing), tasks[2]])
    assert isinstance(results[0], Failure) and "nope.csv" in results[0].message
    assert results[0].message.startswith("section s0: ")
    assert isinstance(results[1], xr.Dataset)


@pytest.mark.parametrize(
    ("n", "together", "workers", "sizes"),
    [
        # each group about a (2 workers)-th of the tasks left, at most 4: smaller at the end
        (20, 4, 2, [4, 4, 3, 3, 2, 1, 1, 1, 1]),
        (4, 4, 1, [4]),  # one worker: full groups
        (9, 4, 1, [4, 4, 1]),
        (3, 4, 4, [1, 1, 1]),
        (0, 4, 2, []),
    ],
)
def test_groups_of_tasks(n, together, workers, sizes):
    parts = groups(list(range(n)), together, workers)
    assert [len(p) for p in parts] == sizes
    assert [t for p in parts for t in p] == list(range(n))  # in order, each once


def test_groups_go_through_a_cluster_in_order():
    # a real LocalCluster of 2 workers: 7 tasks, at most 3 together, as 5 groups; each
    # group's results come back in the tasks' order
    assert [len(g) for g in groups(list(range(7)), 3, 2)] == [2, 2, 1, 1, 1]
    assert run_tasks(list(range(7)), list, workers=2, together=3) == list(range(7))


def test_a_numerical_failure_keeps_its_status_and_names_its_section(tasks, monkeypatch):
    """Load updates beyond `MAX_LOAD_UPDATES` in a step (here none allowed) are a numerical
    failure (settlement ran away), not refused input; `run_sections` raises the first
    failed section's, naming it and counting the others."""
    from trackdyn.deterioration import loop
    from trackdyn.deterioration.runs import run_sections

    monkeypatch.setattr(loop, "MAX_LOAD_UPDATES", 0)
    (failed,) = run_group([tasks[0]])
    assert isinstance(failed, Failure) and failed.status is Status.SETTLEMENT_RAN_AWAY
    assert failed.message.startswith("section s0: more than 0 load updates needed")
    with pytest.raises(TrackdynNumericalError, match=r"^section s0: more than 0 load ") as info:
        run_sections(tasks[:2], workers=1)
    assert str(info.value).endswith(" (1 more sections failed)")
    assert info.value.status is Status.SETTLEMENT_RAN_AWAY


def test_a_failed_vehicle_run_stops_its_section_with_the_run_s_status(tasks, monkeypatch):
    """A vehicle run that comes back as a `Failure` (`trackdyn.simulation.run_batch`)
    stops its section with that failure's status and message."""
    from trackdyn.deterioration import driver

    diverged = Failure(Status.NEWTON_DIVERGED, "Newton iteration did not converge")
    monkeypatch.setattr(driver, "run_batch", lambda vehicles, *_, **__: [diverged] * len(vehicles))
    (failed,) = run_group([tasks[0]])
    assert failed == diverged.named("section s0")


def test_few_short_sections_run_in_this_process_by_default(tasks, monkeypatch):
    from trackdyn import parallel
    from trackdyn.deterioration import runs

    short = [dataclasses.replace(t, options=t.options.model_copy(update={"total_mgt": 50.0}))
             for t in tasks]  # fmt: skip
    assert runs.in_process(short, None, None)  # 3 x 50 MGT: within IN_PROCESS_MGT = 200
    assert runs.in_process(short, 1, None)
    assert not runs.in_process(short, 2, None)
    assert not runs.in_process(short, None, "tcp://10.0.0.5:8786")
    assert not runs.in_process(short * 2, None, None)  # 6 x 50 MGT: more than 200
    assert not runs.in_process(short * 3, 1, "tcp://10.0.0.5:8786")  # the scheduler asked for
    monkeypatch.setattr(runs, "TOGETHER", 2)  # more than a task holds
    assert not runs.in_process(short, None, None)
    monkeypatch.setattr(runs, "TOGETHER", 8)
    token = parallel._shared.set(object())  # in a shared_cluster block: its client takes them
    try:
        assert not runs.in_process(short, None, None)
    finally:
        parallel._shared.reset(token)
    assert runs.in_process(short, None, None)
