"""The solvers through simulate(): stored steps, block size, Newton and non-finite failures,
the nonlinear track's static state."""

import re

import numpy as np
import pytest
import xarray as xr

from trackdyn.errors import Failure, TrackdynInputError
from trackdyn.options import RunOptions
from trackdyn.simulation import OUTPUT_STEP, simulate, simulate_batch
from trackdyn.track.inputs import ContactInput
from trackdyn.track.support import SupportCurve
from trackdyn.track.track import Geometry, Supports, Track
from trackdyn.vehicle.models import build_model
from trackdyn.vehicle.parameters import load_vehicle

V = load_vehicle("loaded")


def test_store_every_keeps_the_same_steps(lin):
    full = simulate(V, lin, RunOptions(speed_kmh=72.0, store_every=1))
    every = simulate(V, lin, RunOptions(speed_kmh=72.0, store_every=7))
    # the stored steps are the same steps of the same computation
    np.testing.assert_array_equal(every.wheel_load, full.wheel_load[::7])
    auto = simulate(V, lin, RunOptions(speed_kmh=72.0, store_every=None))
    step = float(auto.time[1] - auto.time[0])
    assert step == pytest.approx(OUTPUT_STEP, rel=0.5)


def test_newton_failure_names_time_and_position(lin):
    # one Newton pass allowed: the first change of any wedge between stick and slip fails
    with pytest.raises(
        TrackdynInputError,
        match=r"did not converge at t = .* s, vehicle "
        r"centre at .* m",
    ):
        simulate(V, lin, RunOptions(speed_kmh=72.0), newton_max_iter=1)


@pytest.mark.parametrize("solver", ["central", "reference"])
def test_nonlinear_track_with_a_pure_seating_gap(solver):
    # Zero load up to 1 mm, then 100 kN/mm: the static state sits 1 mm + Ps/k down and a
    # uniform level track gives no dynamic load (seed §5.4.1).
    x = np.arange(0, 30.01, 0.25)
    sleepers = np.arange(0.3, 30, 0.6)
    loads = np.linspace(0, 300e3, 13)
    curve = SupportCurve(loads, 1e-3 + loads / 100e6)
    trk = Track(
        Geometry(x, 0 * x, 0 * x),
        Supports(sleepers, (curve,) * sleepers.size, (curve,) * sleepers.size),
    )
    options = RunOptions(model="2dof", speed_kmh=72.0, nonlinear=True, solver=solver)
    ds = simulate(V, trk, options)
    assert float(np.abs(ds.wheel_load - V.static_wheel_load).max()) < 1e-6 * V.static_wheel_load
    wheel = float(ds.displacement.sel(dof="wheel_bounce")[0])
    assert wheel == pytest.approx(1e-3 + V.static_wheel_load / 100e6, rel=1e-3)


def test_results_do_not_depend_on_the_block_size(lin, monkeypatch):
    # The loop advances blocks of steps while the next block's input is sampled in a
    # thread; the state carried from block to block is all there is, so blocks of 997
    # steps (odd against store_every = 3) give the default's results to the bit, and a run
    # whose Newton iteration fails in one block stays stopped in the next ones.
    from trackdyn.solver import central

    vehicles = [V, load_vehicle("loaded", C_slope=1.0)]
    options = [RunOptions(speed_kmh=72.0, store_every=3), RunOptions(speed_kmh=90.0, store_every=3)]
    default = simulate_batch(vehicles, lin, options, newton_max_iter=1)
    monkeypatch.setattr(central, "CHUNK_STEPS", 997)
    small = simulate_batch(vehicles, lin, options, newton_max_iter=1)
    assert isinstance(default[0], Failure)
    assert str(small[0]) == str(default[0])
    assert default[1].time.size * 3 > 2 * 997  # the run spans several small blocks
    xr.testing.assert_identical(small[1], default[1])


@pytest.mark.parametrize("model", ["11dof", "full"])
def test_stored_wheel_load_and_secondary_displacement(lin, model):
    # the loop stores them at its store step; here they follow, by numpy, from the stored
    # displacement, velocity, stiffness and input of the linear contacts
    ds = simulate(V, lin, RunOptions(model=model, speed_kmh=72.0, store_every=3))
    m = build_model(model, V)
    q, v = ds.displacement.values, ds.velocity.values
    axles = np.array([len(a) for a in m.contact_axles])
    force = ds.track_stiffness.values * (q @ m.Dc.T - ds.wheel_input.values)
    load = V.static_wheel_load + (force + m.contact_damping * (v @ m.Dc.T)) / axles
    np.testing.assert_allclose(ds.wheel_load, load, rtol=1e-12, atol=0)
    sec = ds.secondary_displacement.values
    np.testing.assert_allclose(sec, q @ m.Ds.T, rtol=1e-12, atol=1e-12 * np.abs(sec).max())


def test_non_finite_run_names_time_and_position(lin, monkeypatch):
    # a track input that turns NaN from 40 m on ends the run there
    sample = ContactInput.__call__

    def broken(self, centre):
        k, r, table = sample(self, centre)
        r[centre >= 40.0] = np.nan
        return k, r, table

    monkeypatch.setattr(ContactInput, "__call__", broken)
    with pytest.raises(TrackdynInputError, match="non-finite displacements") as err:
        simulate(V, lin, RunOptions(speed_kmh=72.0, store_every=1))
    centre = float(re.search(r"centre at ([\d.]+) m", str(err.value)).group(1))
    assert 40.0 <= centre <= 40.01
