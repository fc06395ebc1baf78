"""The deterioration loop on short synthetic tracks (7-DOF model for speed)."""

import numpy as np
import pytest

from trackdyn.deterioration import LoopOptions, Traffic, load_law, predict
from trackdyn.errors import TrackdynInputError
from trackdyn.options import RunOptions
from trackdyn.track.synthetic import SoftSpot, synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

PASSAGES = 8065.0  # 1e6 t / (104 t + 20 t), the coal traffic [per MGT]
LAW = load_law("power")  # the shipped illustrative parameters
LOADED = Traffic(load_vehicle("loaded"), 60 / 3.6, PASSAGES, "loaded")
EMPTY = Traffic(load_vehicle("empty"), 60 / 3.6, PASSAGES, "empty")


def options(**kw):
    base = {
        "run": RunOptions(model="7dof"),
        "rate_cov": 0.0,  # uniform ballast unless a test asks for the rate field
        "total_mgt": 5.0,
        "snapshot_every_mgt": 2.5,
        "segment_length": 60.0,
    }
    return LoopOptions(**{**base, **kw})


@pytest.fixture(scope="module")
def uniform():
    """120 m of level track on uniform supports."""
    return synthetic_track(120.0, spectrum=None, stiffness_cov=0.0, seed=1)


def test_no_traffic_no_settlement(uniform):
    for traffic in ([], [Traffic(LOADED.vehicle, LOADED.speed, 0.0)]):
        ds = predict(uniform, traffic, LAW, options())
        assert np.all(ds.settlement.values == 0.0)
        np.testing.assert_array_equal(ds.profile.isel(snapshot=-1), ds.profile.isel(snapshot=0))
        assert list(ds.mgt.values) == [0.0, 2.5, 5.0]  # one step per snapshot interval


@pytest.mark.parametrize("traffic", [[LOADED], [LOADED, EMPTY]], ids=["loaded", "mixed"])
def test_uniform_level_track_stays_level(uniform, traffic):
    """Level track on uniform supports and uniform ballast: every sleeper away from the
    section ends carries the same loads, so the ballast settles evenly and the rail stays
    level. Within 6 m of the ends the bogie's other axle is off the section (the run does
    not reach there), which changes the loads by up to 0.5 % (measured)."""
    ds = predict(uniform, traffic, LAW, options())
    e = ds.settlement.isel(mgt=-1)
    x = ds.sleeper_distance
    inner = e.where((x > 6.0) & (x < 114.0), drop=True).values
    assert (inner.max() - inner.min()) / inner.mean() < 1e-3
    assert float(ds.d1_sd.max()) < 0.01  # mm, the criterion
    assert int(ds.hanging_sleepers.max()) == 0


def test_soft_spot_settles_more_and_its_segment_deteriorates():
    spot = SoftSpot(centre=30.0, length=6.0, factor=0.45, gap=1.5e-3)
    trk = synthetic_track(120.0, spectrum=None, stiffness_cov=0.0, seed=1, features=(spot,))
    ds = predict(trk, [LOADED], LAW, options())
    e = ds.settlement.isel(mgt=-1)
    x = ds.sleeper_distance
    at_spot = float(e.where(abs(x - 30.0) < 1.0).mean())
    away = float(e.where(abs(x - 90.0) < 1.0).mean())
    # Quasi-static estimate from the shipped law: f ∝ Q^2 / k2 with Q ∝ k2^(1/3) (Winkler)
    # gives 0.45^(-1/3) = 1.30 times the settlement; 1.2 leaves room for dynamics.
    assert at_spot > 1.2 * away
    sd = ds.d1_sd.isel(rail=0)  # segments 0-60 m (soft spot) and 60-120 m
    growth = sd.isel(mgt=-1) - sd.isel(mgt=0)
    assert float(growth[0]) > 0.1  # mm; the spot alone sets about 0.27 mm
    assert float(growth[0]) > 10 * float(growth[1])


def test_halving_the_step_limit_changes_50_mgt_settlement_by_less_than_2_percent():
    spot = SoftSpot(centre=60.0, length=6.0, factor=0.45, gap=1.5e-3)
    trk = synthetic_track(120.0, spectrum="fra5", seed=3, features=(spot,))
    runs = [
        predict(trk, [LOADED, EMPTY], LAW, options(total_mgt=50.0, snapshot_every_mgt=25.0,
                                                    max_step_settlement=limit))
        for limit in (0.5e-3, 0.25e-3)
    ]  # fmt: skip
    coarse, fine = (r.settlement.isel(mgt=-1).values for r in runs)
    assert runs[1].attrs["steps"] > runs[0].attrs["steps"]
    assert np.max(np.abs(coarse - fine) / fine) < 0.02
    assert runs[0].step_max_settlement.max() <= 0.5e-3 * (1 + 1e-9)


def test_rate_field_is_seeded_lognormal(uniform):
    runs = [predict(uniform, [LOADED], LAW, options(rate_cov=0.3, seed=s)) for s in (1, 1, 2)]
    np.testing.assert_array_equal(runs[0].rate_factor, runs[1].rate_factor)
    assert not np.allclose(runs[0].rate_factor, runs[2].rate_factor)
    f = runs[0].rate_factor.values
    # lognormal with mean 1: every factor positive; 400 correlated samples (3 m correlation,
    # about 40 independent ones per rail): the sample mean within 0.3 / sqrt(40) * 3
    assert f.min() > 0 and abs(f.mean() - 1.0) < 0.15
    e = [r.settlement.isel(mgt=-1).values for r in runs]
    np.testing.assert_array_equal(e[0], e[1])
    assert not np.allclose(e[0], e[2])


def test_bad_options(uniform):
    with pytest.raises(TrackdynInputError, match="total_mgt must be finite and > 0"):
        predict(uniform, [LOADED], LAW, options(total_mgt=-5.0))
    with pytest.raises(TrackdynInputError, match="passages_per_mgt must be >= 0"):
        predict(uniform, [Traffic(LOADED.vehicle, 10.0, -1.0)], LAW, options())
    with pytest.raises(TrackdynInputError, match="no contact on the right rail"):
        predict(uniform, [LOADED], LAW, options(run=RunOptions(model="2dof")))
    with pytest.raises(TrackdynInputError, match="max_steps = 3"):
        predict(uniform, [LOADED], LAW, options(max_steps=3))
