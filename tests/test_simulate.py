"""simulate(): options, argument and track checks, batches of runs."""

import re

import numpy as np
import pytest
import xarray as xr

from trackdyn.errors import Failure, TrackdynInputError
from trackdyn.options import RunOptions
from trackdyn.simulation import simulate, simulate_batch
from trackdyn.vehicle.parameters import load_vehicle

V = load_vehicle("loaded")


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"speed_kmh": 0.0}, "speed_kmh: Input should be greater than 0"),
        ({"speed_kmh": -5.0}, "speed_kmh: Input should be greater than 0"),
        ({"dt_s": 0.05}, "beyond the stability limit"),
        ({"store_every": 0}, "store_every: Input should be greater than 0"),
        ({"model": "3dof"}, "unknown model '3dof'; known: 2dof, 2dof-wedge, 4dof"),
        ({"modle": "2dof"}, "unknown key 'modle'"),
    ],
)
def test_bad_options(lin, options, match):
    with pytest.raises(TrackdynInputError, match=re.escape(match)):
        simulate(V, lin, RunOptions(speed_kmh=72.0).with_(**options))


def test_track_shorter_than_the_vehicle_is_refused(lin):
    with pytest.raises(TrackdynInputError, match="shorter than the vehicle's path"):
        simulate(V, lin, RunOptions(speed_kmh=72.0, start_m=70.0))


def test_load_track_refuses_non_paths():
    from trackdyn import load_track

    with pytest.raises(TrackdynInputError, match="geometry must be a file path .* got int"):
        load_track(123, 456)


def test_batch_gives_each_run_its_own_results(lin):
    # Runs side by side in one compiled call give, to the bit, what each gives alone:
    # different speeds (so different step counts), parameters and storage, a run refused
    # before it starts, and a run whose Newton iteration fails part way.
    soft = load_vehicle("loaded", kp=0.7 * V.kp, mu=1.3 * V.mu)
    # one Newton pass allowed: wedges with a tiny C_slope never leave the stick state and
    # need no second pass, the default wedges fail at their first stick/slip change
    sticky = load_vehicle("loaded", C_slope=1.0)
    vehicles = [V, soft, V, sticky, V]
    options = [
        RunOptions(speed_kmh=72.0, store_every=1),
        RunOptions(speed_kmh=50.0, store_every=3),
        RunOptions(speed_kmh=72.0, dt_s=0.05),
        RunOptions(speed_kmh=90.0),
        RunOptions(speed_kmh=60.0),
    ]
    batch = simulate_batch(vehicles[:3], lin, options[:3])
    assert isinstance(batch[2], Failure)
    for v, o, ds in zip(vehicles[:2], options[:2], batch[:2], strict=True):
        xr.testing.assert_identical(ds, simulate(v, lin, o))
    failing = simulate_batch(vehicles[3:], lin, options[3:], newton_max_iter=1)
    xr.testing.assert_identical(failing[0], simulate(sticky, lin, options[3], newton_max_iter=1))
    with pytest.raises(TrackdynInputError) as alone:
        simulate(V, lin, options[4], newton_max_iter=1)
    assert str(failing[1]) == str(alone.value)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (("loaded", "lin", None), "vehicle must be a Vehicle .* got str 'loaded'"),
        (("V", None, None), "track must be a Track .* got NoneType"),
        (("V", "lin", {"speed_kmh": 60}), "options must be RunOptions .* got dict"),
    ],
)
def test_api_arguments_of_the_wrong_kind(lin, args, match):
    given = {"V": V, "lin": lin}
    vehicle, track, options = (given.get(a, a) if isinstance(a, str) else a for a in args)
    with pytest.raises(TrackdynInputError, match=match):
        simulate(vehicle, track, options)


def test_numpy_values_are_shown_as_plain_numbers():
    # values computed with numpy reach messages as the number, not "np.float64(...)"
    with pytest.raises(
        TrackdynInputError, match=r"k1 is -5 N/m, outside the plausible 100000 to 1e\+09 N/m$"
    ):
        V.replace(k1=np.float64(-5.0))
