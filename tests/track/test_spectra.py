"""Track irregularity spectra: values, synthetic profiles and their recovered PSD."""

import numpy as np
import pytest
from scipy import integrate

from trackdyn.errors import TrackdynInputError
from trackdyn.track.spectra import SPECTRA, estimate_psd, generate_profile, psd

DX = 0.25  # sampling interval [m]
X_10KM = np.arange(0.0, 10_000.0, DX)


def test_psd_values_at_cutoff():
    oc = 0.8245
    # FRA: k A_v Oc^2 / (Oc^2 (2 Oc^2)) with A_v = 0.5376 cm^2 rad/m = 0.5376e-4 m^2 rad/m
    assert psd("fra4", oc) == pytest.approx(0.25 * 0.5376e-4 / (2 * oc**2), rel=1e-12)
    og, orr = 0.8246, 0.0206
    expected = 1.080e-6 * og**2 / ((og**2 + orr**2) * 2 * og**2)
    assert psd("german_high", og) == pytest.approx(expected, rel=1e-12)


def test_spectra_ordering_and_shape():
    w = np.array([0.05, 0.5, 3.0])
    classes = np.array([psd(f"fra{i}", w) for i in range(1, 7)])
    assert np.all(np.diff(classes, axis=0) < 0)  # class 1 (worst) ... class 6 (best)
    ratio = psd("german_high", w) / psd("german_low", w)
    np.testing.assert_allclose(ratio, 1.080e-6 / 4.032e-7, rtol=1e-12)
    # FRA falls as Omega^-2 well below Oc and as Omega^-4 well above it
    assert psd("fra4", 0.001) / psd("fra4", 0.002) == pytest.approx(4.0, rel=1e-5)
    assert psd("fra4", 100.0) / psd("fra4", 200.0) == pytest.approx(16.0, rel=1e-3)
    assert psd("FRA4", 1.0) == psd("fra4", 1.0)
    assert set(SPECTRA) == {"german_low", "german_high", *(f"fra{i}" for i in range(1, 7))}


@pytest.mark.parametrize("name", ["fra4", "german_high"])
def test_welch_recovers_target_psd(name):
    """Welch estimate of a 10 km profile matches the target over 3-70 m wavelengths.

    Welch with 1024-sample (256 m) Hann segments, 50 % overlap, gives K ~ 77 overlapping
    segments, roughly 40-70 independent ones: per-bin relative scatter ~ 1/sqrt(K) ~ 15 %.
    The mean of log10 over the ~80 bins of the band scatters by ~0.005 (0.004 measured over
    20 seeds), so +-0.05 (about +-12 %) catches any factor error (2, 2 pi) with a wide
    margin. An octave band averages >= 4 bins (<= ~8 % scatter; worst over 20 seeds and
    both spectra measured 13 %), so 30 % is a > 3 sigma bound.
    """
    z = generate_profile(X_10KM, name, seed=7)
    w, s = estimate_psd(X_10KM, z, nperseg=1024)
    band = (w >= 2 * np.pi / 70.0) & (w <= 2 * np.pi / 3.0)
    assert band.sum() > 70
    log_err = np.log10(s[band] / psd(name, w[band]))
    assert abs(log_err.mean()) < 0.05
    edges = 2 * np.pi / 70.0 * 2.0 ** np.arange(6)
    edges[-1] = 2 * np.pi / 3.0
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        m = (w >= lo) & (w < hi)
        ratio = s[m].mean() / psd(name, w[m]).mean()
        assert abs(ratio - 1) < 0.30, f"octave {2 * np.pi / hi:.1f}-{2 * np.pi / lo:.1f} m"


@pytest.mark.parametrize("name", ["fra4", "german_high"])
def test_variance_equals_integral_of_psd(name):
    """Parseval: profile variance = integral of S over the generated band.

    The variance is dominated by the longest (~300 m) wavelengths, so a finite profile
    scatters: measured SD of the ratio 3.5 % for 10 km, 1.0 % for 50 km (40 seeds), hence a
    50 km profile (at 0.5 m to keep it fast) and a 5 % tolerance.
    """
    x = np.arange(0.0, 50_000.0, 0.5)
    z = generate_profile(x, name, seed=11)
    target, _ = integrate.quad(SPECTRA[name], 2 * np.pi / 304.8, 2 * np.pi / 1.524, limit=200)
    assert np.var(z) == pytest.approx(target, rel=0.05)


def test_seed_reproducibility():
    x = np.arange(0.0, 1000.0, DX)
    a = generate_profile(x, "fra4", seed=3)
    np.testing.assert_array_equal(a, generate_profile(x, "fra4", seed=3))
    b = generate_profile(x, "fra4", seed=4)
    assert not np.allclose(a, b)
    assert a.shape == x.shape


def test_profile_depends_on_position_not_grid():
    """The uniform-grid fast path and the general path give the same profile."""
    x = np.arange(0.0, 1000.0, DX)
    z = generate_profile(x, "german_low", seed=5)
    keep = np.sort(np.random.default_rng(0).choice(x.size, 1500, replace=False))
    z_sub = generate_profile(x[keep], "german_low", seed=5)
    np.testing.assert_allclose(z_sub, z[keep], rtol=0, atol=1e-9 * np.std(z))


def test_estimate_psd_units_with_white_noise():
    """White noise of variance s2 sampled at dx has S(Omega) = s2 dx / pi per rad/m."""
    rng = np.random.default_rng(1)
    z = rng.normal(0.0, 1e-3, X_10KM.size)
    w, s = estimate_psd(X_10KM, z)
    assert w[0] > 0
    assert w[-1] == pytest.approx(np.pi / DX)
    assert np.median(s) == pytest.approx(1e-6 * DX / np.pi, rel=0.05)
    assert np.trapezoid(s, w) == pytest.approx(np.var(z), rel=0.05)


def test_bad_inputs():
    x = np.arange(0.0, 100.0, DX)
    with pytest.raises(TrackdynInputError, match="unknown spectrum 'fra9'.*fra4"):
        psd("fra9", 1.0)
    with pytest.raises(TrackdynInputError, match="unknown spectrum"):
        generate_profile(x, "ore", seed=1)
    with pytest.raises(TrackdynInputError, match="omega"):
        psd("fra4", [0.0, 1.0])
    bad = x.copy()
    bad[3] = bad[2]
    with pytest.raises(TrackdynInputError, match="strictly increasing at row 3"):
        generate_profile(bad, "fra4")
    bad = x[::-1]
    with pytest.raises(TrackdynInputError, match="strictly increasing at row 1"):
        generate_profile(bad, "fra4")
    bad = x.copy()
    bad[5] = np.nan
    with pytest.raises(TrackdynInputError, match="distance is NaN or infinite at row 5"):
        generate_profile(bad, "fra4")
    with pytest.raises(TrackdynInputError, match="wavelength_range"):
        generate_profile(x, "fra4", wavelength_range=(10.0, 1.0))
    with pytest.raises(TrackdynInputError, match="n_harmonics"):
        generate_profile(x, "fra4", n_harmonics=0)
    z = np.zeros_like(x)
    z[9] = np.inf
    with pytest.raises(TrackdynInputError, match="profile is NaN or infinite at row 9"):
        estimate_psd(x, z)
    with pytest.raises(TrackdynInputError, match="nperseg"):
        estimate_psd(x, np.zeros_like(x), nperseg=10 * x.size)
    with pytest.raises(TrackdynInputError, match="shape"):
        estimate_psd(x, np.zeros(x.size - 1))
