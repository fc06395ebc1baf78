"""Track input (§5.2): loaded profile, sampling under a wheel, synthetic and example tracks."""

import numpy as np
import pytest

from trackdyn.data import EXAMPLE_GEOMETRY, EXAMPLE_SUPPORTS, example_path, load_track
from trackdyn.errors import TrackdynInputError
from trackdyn.track.synthetic import SoftSpot, Transition, VoidedSleepers, synthetic_track
from trackdyn.track.track import Geometry, Supports, Track

PS = 127.53e3  # loaded wagon static wheel load, g (m1/8 + m2/4 + mw/4)


def small_track(k_left=80e6, k_right=100e6):
    x = np.linspace(0, 30, 121)
    geo = Geometry(x, 1e-3 * np.sin(2 * np.pi * x / 10), np.zeros_like(x))
    return Track(geo, Supports.linear(np.arange(0.3, 30, 0.6), k_left, k_right))


def test_loaded_profile_is_unloaded_plus_static_deflection():
    lin = small_track().linearise(PS)
    # linear supports: ys = Ps / k (5.11 on a straight line through the origin)
    np.testing.assert_allclose(lin.ys[0], PS / 80e6)
    np.testing.assert_allclose(lin.ys[1], PS / 100e6)
    x = np.array([2.5, 7.25, 12.0])  # on geometry grid points: no interpolation error
    k, loaded = lin.sample("left", x)
    np.testing.assert_allclose(k, 80e6)
    np.testing.assert_allclose(loaded, 1e-3 * np.sin(2 * np.pi * x / 10) + PS / 80e6)


def test_sampling_interpolates_between_sleepers():
    pos = np.arange(0.3, 30, 0.6)
    k = np.where(np.arange(pos.size) % 2 == 0, 60e6, 120e6)
    x = np.linspace(0, 30, 61)
    lin = Track(Geometry(x, 0 * x, 0 * x), Supports.linear(pos, k, k)).linearise(PS)
    # midway between a 60 and a 120 kN/mm sleeper: the mean, 90 kN/mm (linear interpolation)
    kk, _ = lin.sample("right", np.array([0.6]))
    assert kk[0] == pytest.approx(90e6)
    with pytest.raises(TrackdynInputError, match="outside the track"):
        lin.sample("left", np.array([31.0]))


def test_features_show_in_k2_and_ys():
    features = (
        SoftSpot(100.0, 10.0, factor=0.5, gap=1e-3),
        VoidedSleepers(200.0, count=2, gap=3e-3, rail="left"),
        Transition(300.0, 20.0, factor=3.0),
    )
    trk = synthetic_track(400.0, spectrum=None, stiffness_cov=0.0, features=features, seed=1)
    lin = trk.linearise(PS)
    pos = trk.supports.position
    plain = np.abs(pos - 50) < 5
    soft = np.abs(pos - 100) < 3
    # stiffness x 0.5 on the soft spot; x 3 on the structure (uniform field, cov = 0)
    assert lin.k2[:, soft].mean() / lin.k2[:, plain].mean() == pytest.approx(0.5, rel=0.02)
    bridge = (pos > 302) & (pos < 318)
    assert lin.k2[:, bridge].mean() / lin.k2[:, plain].mean() == pytest.approx(3.0, rel=0.02)
    voided = np.argmin(np.abs(pos - 200))
    # the void adds its 3 mm gap (less the 0.5 mm base gap) to ys on the left rail only
    assert lin.ys[0, voided] - lin.ys[0, plain].mean() == pytest.approx(2.5e-3, rel=0.02)
    assert lin.ys[1, voided] == pytest.approx(lin.ys[1, plain].mean(), rel=1e-6)


def test_synthetic_track_is_reproducible():
    a = synthetic_track(100.0, seed=5)
    b = synthetic_track(100.0, seed=5)
    c = synthetic_track(100.0, seed=6)
    np.testing.assert_array_equal(a.geometry.left, b.geometry.left)
    assert not np.allclose(a.geometry.left, c.geometry.left)


def test_shipped_example_files_match_the_generator():
    from trackdyn.track.synthetic import example_track

    shipped = load_track()
    made = example_track()
    # files hold 6 significant digits
    np.testing.assert_allclose(shipped.geometry.left, made.geometry.left, rtol=1e-5, atol=1e-8)
    i = shipped.supports.position.size // 2
    np.testing.assert_allclose(
        shipped.supports.right[i].deflection, made.supports.right[i].deflection, rtol=1e-5
    )
    assert example_path(EXAMPLE_GEOMETRY).is_file() and example_path(EXAMPLE_SUPPORTS).is_file()


def test_track_needs_overlap():
    x = np.linspace(0, 10, 11)
    trk = Track(Geometry(x, 0 * x, 0 * x), Supports.linear(np.arange(20.3, 30, 0.6), 1e8, 1e8))
    with pytest.raises(TrackdynInputError, match="do not overlap"):
        _ = trk.extent


def test_curve_picks_name_each_sleeper_once_with_every_criterion_it_meets():
    from trackdyn.track.analysis import curve_picks

    # 2 rails x 3 sleepers: left 1 is the softest and has the largest ys; right 2 is the
    # stiffest; sorted k2 is 50, 80, 90, 100, 120, 300, so the median (index 3) is 100
    k2 = np.array([[80e6, 50e6, 120e6], [100e6, 90e6, 300e6]])
    ys = np.array([[2e-3, 5e-3, 1e-3], [1e-3, 2e-3, 0.5e-3]])
    picks = curve_picks(k2, ys, np.array([0.3, 0.9, 1.5]), lambda r, i: (r, i))
    assert [(p.label, p.rail, p.position, p.curve) for p in picks] == [
        ("softest and largest ys", "left", 0.9, (0, 1)),
        ("stiffest", "right", 1.5, (1, 2)),
        ("median", "right", 0.3, (1, 0)),
    ]
