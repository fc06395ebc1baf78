"""Runs side by side in the vector lanes give, to the bit, what each run gives alone.

A run alone goes through the per-run loop (`kernel.advance`), each full group of `LANES`
runs of one model through the lanes (`lanes.advance_lanes`), and the runs left over
either in a group with idle lanes (`lanes.MIN_LANE_RUNS` or more) or one by one: the
same scheme, the same sums in the same order, so the stored arrays must be equal bit for
bit (not merely close).
"""

import copy
from contextlib import contextmanager

import numpy as np
import pytest

from trackdyn import simulation
from trackdyn.errors import Failure
from trackdyn.options import RunOptions
from trackdyn.simulation import run_batch
from trackdyn.solver import central, lanes
from trackdyn.track.inputs import ContactInput
from trackdyn.track.synthetic import synthetic_track
from trackdyn.vehicle.models import MODELS
from trackdyn.vehicle.parameters import load_vehicle

V = load_vehicle("loaded")
SOFT = load_vehicle("loaded", kp=0.7 * V.kp, mu=1.3 * V.mu)
EMPTY = load_vehicle("empty")
# one Newton pass allowed: wedges with a tiny C_slope never leave the stick state and need
# no second pass, the default wedges fail at their first stick/slip change
STICKY = load_vehicle("loaded", C_slope=1.0)


def assert_alone(batch, vehicles, tracks, options, newton_max_iter=50):
    """Each run of ``batch`` is what `run_batch` gives for that run alone, to the bit (or
    the same error)."""
    for r, v, trk, o in zip(batch, vehicles, tracks, options, strict=True):
        (alone,) = run_batch([v], [trk], [o], newton_max_iter=newton_max_iter)
        if isinstance(alone, Failure):
            assert isinstance(r, Failure)
            assert str(r) == str(alone)
            continue
        assert alone.out.keys() == r.out.keys()
        for name, a in alone.out.items():
            np.testing.assert_array_equal(r.out[name], a, err_msg=name)


def varied(model, n, **options):
    """``n`` runs of ``model``: different vehicles, speeds (so different step counts and
    time steps) and storage."""
    vehicles = [(V, SOFT, EMPTY)[i % 3] for i in range(n)]
    every = (1, 3, None)
    runs = [
        RunOptions(model=model, speed_kmh=50.0 + 5.0 * i, store_every=every[i % 3], **options)
        for i in range(n)
    ]
    return vehicles, runs


@pytest.mark.parametrize("model", MODELS)
def test_lanes_give_each_run_alone(lin, model):
    vehicles, options = varied(model, central.LANES + 1)
    batch = run_batch(vehicles, lin, options)
    assert not any(isinstance(r, Failure) for r in batch)
    assert_alone(batch, vehicles, [lin] * len(batch), options)


@pytest.mark.parametrize("model", ["2dof", "full"])
def test_lanes_on_the_nonlinear_track(lin, model):
    vehicles, options = varied(model, central.LANES + 1, nonlinear=True)
    batch = run_batch(vehicles, lin, options)
    assert_alone(batch, vehicles, [lin] * len(batch), options)


@pytest.mark.parametrize("model", ["2dof", "11dof"])
def test_runs_on_one_track_share_its_input(model):
    # runs given the track itself, differing in the wedge friction (one static wheel
    # load): one linearisation and one contact input, sampled once where the path is the
    # same (all lanes then hold one sample); the empty wagon (another static load) and a
    # run at another speed (another path) among them: each run is still what it is alone
    track = synthetic_track(60.0, spectrum="fra4", seed=5)
    vehicles = [load_vehicle("loaded", mu=V.mu * (0.8 + 0.05 * i)) for i in range(7)]
    vehicles.insert(3, EMPTY)
    options = [RunOptions(model=model, store_every=1)] * len(vehicles)
    options[5] = RunOptions(model=model, store_every=1, speed_kmh=70.0)
    batch = run_batch(vehicles, track, options)
    assert not any(isinstance(r, Failure) for r in batch)
    inputs = [r.problem.inputs for r in batch]
    assert all(x is inputs[0] for i, x in enumerate(inputs) if i != 3)
    assert inputs[3] is not inputs[0]
    assert_alone(batch, vehicles, [track] * len(batch), options)


def test_two_groups_of_lanes(lin):
    vehicles, options = varied("2dof", 2 * central.LANES + 1)
    batch = run_batch(vehicles, lin, options)
    assert_alone(batch, vehicles, [lin] * len(batch), options)


def test_the_runs_left_over_go_in_lanes_or_one_by_one():
    m, width = lanes.MIN_LANE_RUNS, central.LANES
    assert lanes.lane_groups(m - 1).size == 0  # one by one
    take = lanes.lane_groups(width + m)  # a full group, and m runs with idle lanes
    np.testing.assert_array_equal(take[0], np.arange(width))
    np.testing.assert_array_equal(take[1], np.r_[width : width + m, [-1] * (width - m)])
    np.testing.assert_array_equal(lanes.lane_groups(width + m - 1), [np.arange(width)])


@pytest.mark.parametrize("runs", [lanes.MIN_LANE_RUNS, central.LANES + central.LANES - 1])
@pytest.mark.parametrize("model", ["2dof", "11dof"])
def test_a_group_with_idle_lanes(lin, model, runs):
    # the idle lanes hold a copy of the last run and are never advanced: the runs are
    # still what they are alone, and no idle lane writes into a run's outputs
    vehicles, options = varied(model, runs)
    batch = run_batch(vehicles, lin, options)
    assert not any(isinstance(r, Failure) for r in batch)
    assert_alone(batch, vehicles, [lin] * len(batch), options)


@pytest.mark.parametrize("model", ["2dof", "11dof"])
def test_kept_outputs_are_those_of_a_full_run(lin, model):
    # the deterioration loop keeps only the wheel loads: the solver writes no other
    # output, and the wheel loads are those of the full run, to the bit (in the lanes and
    # one by one)
    vehicles, options = varied(model, central.LANES + 1)
    full = run_batch(vehicles, lin, options)
    kept = run_batch(vehicles, lin, options, keep=("wl",))
    for a, b in zip(full, kept, strict=True):
        assert list(b.out) == ["wl"]
        np.testing.assert_array_equal(b.out["wl"], a.out["wl"])


def test_a_lane_whose_newton_fails_stops_alone(lin):
    # the loaded wagon's wedges (runs 1 and 4) fail part way, the sticky ones at some
    # speeds, later or not at all
    vehicles = [V if i in (1, 4) else STICKY for i in range(central.LANES)]
    options = [RunOptions(speed_kmh=50.0 + 5.0 * i, store_every=2) for i in range(central.LANES)]
    batch = run_batch(vehicles, lin, options, newton_max_iter=1)
    failed = [isinstance(r, Failure) for r in batch]
    assert failed[1] and failed[4] and not all(failed)
    assert "did not converge" in str(batch[1])
    assert_alone(batch, vehicles, [lin] * len(batch), options, newton_max_iter=1)


def test_a_non_finite_lane_stops_alone(lin, monkeypatch):
    # the track input of the second run turns NaN from 40 m on
    bad = copy.copy(lin)
    sample = ContactInput.__call__

    def broken(self, centre):
        k, r, table = sample(self, centre)
        if self.lin is bad:
            r[centre >= 40.0] = np.nan
        return k, r, table

    monkeypatch.setattr(ContactInput, "__call__", broken)
    vehicles, options = varied("11dof", central.LANES)
    tracks = [bad if i == 1 else lin for i in range(central.LANES)]
    batch = run_batch(vehicles, tracks, options)
    for i, r in enumerate(batch):
        assert isinstance(r, Failure) == (i == 1)
    assert "non-finite displacements" in str(batch[1])
    assert_alone(batch, vehicles, tracks, options)
    # found the same way when the displacements are not stored (in the lanes and alone)
    kept = run_batch(vehicles, tracks, options, keep=("wl",))
    assert str(kept[1]) == str(batch[1])
    (alone,) = run_batch(vehicles[1:2], tracks[1:2], options[1:2], keep=("wl",))
    assert str(alone) == str(batch[1])


@pytest.mark.parametrize("runs", [1, 3, central.LANES + 1])
def test_progress_counts_every_step(lin, monkeypatch, runs):
    # the bar gets every step of every run, in the lanes and one by one (a run alone once
    # counted none of its steps)
    seen = {}

    class Bar:
        def advance(self, n):
            seen["done"] = seen.get("done", 0) + n

    @contextmanager
    def bar(show, total, label):
        seen["total"] = total
        yield Bar()

    monkeypatch.setattr(simulation, "progress_bar", bar)
    vehicles, options = varied("2dof", runs)
    batch = run_batch(vehicles, lin, options, progress=True)
    assert seen["done"] == seen["total"] == sum(r.problem.n_steps for r in batch)
