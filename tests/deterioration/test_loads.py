"""A vehicle model carries its axles per rail and gross mass: the load cycles of a passage
follow the vehicle, not a fixed bogie wagon."""

import numpy as np
import pytest

from trackdyn.deterioration import Traffic
from trackdyn.deterioration.loads import cycles_per_passage
from trackdyn.options import RunOptions
from trackdyn.vehicle.assembly import Assembly, Body, Contact, Spring
from trackdyn.vehicle.models import MODELS, SIDES, build_model
from trackdyn.vehicle.parameters import load_vehicle

LOADED = load_vehicle("loaded")


def two_axle(v):
    """A two-axle wagon: the body on two wheelsets, one wheel per contact."""
    asm = Assembly()
    body = asm.add(Body("body", v.m1, v.I1, v.Ip, ("bounce", "roll", "pitch")))
    for end, x in (("front", v.b_cc), ("back", -v.b_cc)):
        ws = asm.add(Body(f"{end}_wheelset", v.mw, roll_inertia=v.Iw, motions=("bounce", "roll")))
        for side, sign, rail in SIDES:
            asm.add(Spring(body.at(sign * v.b, x), ws.at(sign * v.b), v.k1))
            asm.add(Contact(end[0].upper() + side, ws.at(sign * v.l), rail, (x,), v.rho2))
    return asm.build("two-axle", v.static_wheel_load, 2, v.m1 + 2 * v.mw)


def test_a_two_axle_model_counts_one_cycle_per_wheel(monkeypatch):
    monkeypatch.setitem(MODELS, "two-axle", two_axle)
    model = build_model(RunOptions(model="two-axle").model, LOADED)
    # 2 wheels on each rail, 2 axles per rail: one cycle each (a bogie wagon's 4 axles per
    # rail would count each wheel twice)
    assert model.axles_per_rail == 2
    np.testing.assert_array_equal(cycles_per_passage(model), np.ones(4))
    traffic = Traffic(LOADED, 60.0, 100.0, "two-axle")
    assert traffic.gross_mass("two-axle") == LOADED.m1 + 2 * LOADED.mw


def test_bogie_models_stand_for_four_axles_per_rail():
    # 7-DOF: two lumped bogies per rail, two axles each; 4-DOF: the front bogie only
    np.testing.assert_array_equal(cycles_per_passage(build_model("7dof", LOADED)), np.ones(8))
    np.testing.assert_array_equal(cycles_per_passage(build_model("4dof", LOADED)), np.full(4, 2.0))
    gross = LOADED.m1 + 2 * LOADED.m2 + 2 * LOADED.mw
    assert Traffic(LOADED, 60.0, 100.0).gross_mass("11dof") == gross


@pytest.mark.parametrize(("vehicle", "tolerance"), [("loaded", 0.005), ("empty", 0.012)])
def test_the_loops_time_step_keeps_wheel_loads_within_a_percent(vehicle, tolerance):
    """The loop's vehicle runs take `RUN_STEPS_PER_PERIOD` (half of `simulate`'s steps per
    period). Over the built-in example (11-DOF, 60 km/h: stiff structure, soft spot,
    voids) their wheel loads against runs with a quarter of that step (the central
    difference's error falls as Δt², so the finer run is 16 times closer): within 0.32 %
    (loaded) and 0.86 % (empty) of the static wheel load, measured; a step twice as long
    (12.5 steps per period) gives 1.4 and 3.6 %."""
    from trackdyn.deterioration.loads import RUN_STEPS_PER_PERIOD
    from trackdyn.simulation import simulate, time_step
    from trackdyn.track.synthetic import example_track

    veh = load_vehicle(vehicle)
    lin = example_track().linearise(veh.static_wheel_load)
    dt = time_step(build_model("11dof", veh), lin, 60 / 3.6, RUN_STEPS_PER_PERIOD)[0]
    loads = [
        simulate(
            veh, lin, RunOptions(model="11dof", speed_kmh=60, dt_s=dt / f, store_every=f)
        ).wheel_load.values  # fmt: skip
        for f in (1, 4)
    ]
    error = np.abs(loads[0] - loads[1]).max() / veh.static_wheel_load
    assert 0.1 * tolerance < error < tolerance


def test_each_wheel_over_each_sleeper_carries_its_contacts_load_at_that_moment():
    """`wheel_forces` places, for each wheel over each sleeper, every wheel of the rail with
    its contact's load when the vehicle centre was there: against ``numpy.interp`` of each
    contact's stored loads (not below zero) at that centre, nearest beyond the stored
    samples, placed by `Ballast.wheel_forces` (to round-off: 1e-12 of the forces). The run
    is stored every 0.37 m from 5 m into the 60 m section, so that sleepers fall between
    samples and the first ones before them; some loads are negative (a wheel off the
    rail)."""
    from types import SimpleNamespace

    from trackdyn.deterioration.ballast import Ballast
    from trackdyn.deterioration.loads import wheel_forces, wheels
    from trackdyn.track.rails import rail_section
    from trackdyn.track.synthetic import synthetic_track
    from trackdyn.track.track import RAILS

    trk = synthetic_track(60.0, spectrum=None, stiffness_cov=0.0, gap=0.0, seed=1)
    b = Ballast(trk.linearise(120e3, 0.3), rail_section("60E1"), 125.5)
    model = build_model("11dof", LOADED)
    centre = 5.0 + 0.37 * np.arange(150)
    rng = np.random.default_rng(6)
    load = rng.uniform(-2e4, 1.5e5, (centre.size, len(model.contact_rails)))
    placed = wheel_forces(SimpleNamespace(centre=centre, wheel_load=load), b, model)
    every = wheels(model)
    for r, rail in enumerate(RAILS):
        mine = [(c, x) for c, x, rl in every if rl == rail]
        offsets = np.array([x for _, x in mine])
        sleeper = np.repeat(np.arange(b.position.size), len(mine))
        at = b.position[sleeper] - np.tile(offsets, b.position.size)
        loads = np.stack([np.interp(at, centre, np.maximum(load[:, c], 0.0)) for c, _ in mine], 1)
        expected = b.wheel_forces(r, sleeper, at[:, None] + offsets[None, :], loads).force
        got = placed[r][1]
        assert placed[r][0] == [j for j, (_, _, rl) in enumerate(every) if rl == rail]
        np.testing.assert_array_equal(got.centre, sleeper)
        np.testing.assert_allclose(got.force, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
