"""Runs side by side in the vector lanes give, to the bit, what each run gives alone.

A run alone goes through the per-run loop (`central.advance`), several runs of one model
through the lanes (`central.advance_lanes`): the same scheme, the same sums in the same
order, so the stored arrays must be equal bit for bit (not merely close).
"""

import copy

import numpy as np
import pytest

from trackdyn.errors import TrackdynInputError
from trackdyn.options import RunOptions
from trackdyn.simulation import run_batch
from trackdyn.solver import central
from trackdyn.track.inputs import ContactInput
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
        if isinstance(alone, Exception):
            assert isinstance(r, TrackdynInputError)
            assert str(r) == str(alone)
            continue
        assert alone.out.keys() == r.out.keys()
        for name, a in alone.out.items():
            np.testing.assert_array_equal(r.out[name], a, err_msg=name)


@pytest.mark.parametrize("model", MODELS)
def test_lanes_give_each_run_alone(lin, model):
    # different vehicles, speeds (so different step counts and time steps) and storage
    vehicles = [V, SOFT, EMPTY]
    options = [
        RunOptions(model=model, speed_kmh=72.0, store_every=1),
        RunOptions(model=model, speed_kmh=50.0, store_every=3),
        RunOptions(model=model, speed_kmh=60.0),
    ]
    batch = run_batch(vehicles, lin, options)
    assert not any(isinstance(r, Exception) for r in batch)
    assert_alone(batch, vehicles, [lin] * 3, options)


@pytest.mark.parametrize("model", ["2dof", "full"])
def test_lanes_on_the_nonlinear_track(lin, model):
    options = [
        RunOptions(model=model, speed_kmh=90.0, nonlinear=True, store_every=2),
        RunOptions(model=model, speed_kmh=70.0, nonlinear=True),
    ]
    batch = run_batch([V, SOFT], lin, options)
    assert_alone(batch, [V, SOFT], [lin] * 2, options)


def test_more_runs_than_lanes(lin):
    # LANES + 1 runs: two groups of lanes side by side
    n = central.LANES + 1
    vehicles = [load_vehicle("loaded", kp=V.kp * (0.8 + 0.4 * i / n)) for i in range(n)]
    options = [RunOptions(model="2dof", speed_kmh=50.0 + 5.0 * i) for i in range(n)]
    batch = run_batch(vehicles, lin, options)
    assert_alone(batch, vehicles, [lin] * n, options)


def test_a_lane_whose_newton_fails_stops_alone(lin):
    # the loaded wagon's wedges fail part way; the sticky ones run on to the end
    vehicles = [STICKY, V, STICKY]
    options = [RunOptions(speed_kmh=s, store_every=2) for s in (90.0, 72.0, 60.0)]
    batch = run_batch(vehicles, lin, options, newton_max_iter=1)
    assert isinstance(batch[1], TrackdynInputError)
    assert "did not converge" in str(batch[1])
    assert_alone(batch, vehicles, [lin] * 3, options, newton_max_iter=1)


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
    tracks = [lin, bad, lin]
    options = [RunOptions(speed_kmh=s, store_every=1) for s in (72.0, 60.0, 50.0)]
    batch = run_batch([V, V, SOFT], tracks, options)
    assert isinstance(batch[1], TrackdynInputError)
    assert "non-finite displacements" in str(batch[1])
    assert_alone(batch, [V, V, SOFT], tracks, options)
