"""Longitudinal level (EN 13848 wavebands) and segment standard deviation."""

import numpy as np
import pytest
from scipy import signal

from trackdyn.errors import TrackdynInputError
from trackdyn.track.quality import WAVEBANDS, longitudinal_level, segment_sd

DX = 0.25  # sampling interval [m]
X = np.arange(0.0, 1000.0, DX)
MIDDLE = (X >= 200.0) & (X <= 800.0)  # > 2 x 70 m from both ends: end transients decayed
A = 0.002  # sine amplitude [m]


def sine(x, wavelength):
    return A * np.sin(2 * np.pi * x / wavelength)


def expected_gain(band, wavelength, dx=DX, order=4):
    """|H|^2 of the Butterworth band-pass at 1/wavelength: filtfilt squares the magnitude."""
    lo, hi = WAVEBANDS[band]
    sos = signal.butter(order, [1 / hi, 1 / lo], btype="bandpass", fs=1 / dx, output="sos")
    _, h = signal.sosfreqz(sos, worN=[1.0 / wavelength], fs=1 / dx)
    return abs(h[0]) ** 2


def gain(x_mask, z, y):
    """Amplitude ratio of output to input (projection onto the input) in the masked part."""
    return np.dot(y[x_mask], z[x_mask]) / np.dot(z[x_mask], z[x_mask])


def test_wavebands():
    assert WAVEBANDS == {"D1": (3.0, 25.0), "D2": (25.0, 70.0), "D3": (70.0, 150.0)}


@pytest.mark.parametrize(
    ("band", "wavelength"), [("D1", 10.0), ("D1", 5.0), ("D2", 40.0), ("D3", 100.0)]
)
def test_passband(band, wavelength):
    x = np.arange(0.0, 2000.0, DX) if band == "D3" else X
    middle = (x >= 400.0) & (x <= 1600.0) if band == "D3" else MIDDLE
    z = sine(x, wavelength)
    y = longitudinal_level(x, z, band)
    r = gain(middle, z, y)
    assert 0.97 <= r <= 1.03
    assert r == pytest.approx(expected_gain(band, wavelength), rel=0.01)
    assert np.std(y[middle]) / np.std(z[middle]) == pytest.approx(r, rel=0.01)


@pytest.mark.parametrize(("band", "wavelength"), [("D1", 60.0), ("D2", 10.0), ("D2", 150.0)])
def test_stopband(band, wavelength):
    z = sine(X, wavelength)
    y = longitudinal_level(X, z, band)
    assert np.std(y[MIDDLE]) / np.std(z[MIDDLE]) < 0.02


def test_zero_phase():
    z = sine(X, 10.0)
    y = longitudinal_level(X, z, "D1")
    peaks_in, _ = signal.find_peaks(z)
    peaks_out, _ = signal.find_peaks(y)
    keep_in = peaks_in[MIDDLE[peaks_in]]
    keep_out = peaks_out[MIDDLE[peaks_out]]
    assert keep_in.size == keep_out.size == 60
    assert np.max(np.abs(keep_out - keep_in)) <= 1


@pytest.mark.parametrize("length", [1000.0, 50.0])  # 50 m: the shortest D1 allows
def test_equals_scipys_zero_phase_filter(length):
    """The filter keeps each band's steady state (`_bandpass`) and filters forward and
    backward itself; the result is what ``scipy.signal.sosfiltfilt`` gives on the same
    design, padding and profile, to the bit."""
    x = np.arange(0.0, length + DX / 2, DX)
    z = np.random.default_rng(2).standard_normal(x.size).cumsum() * 1e-4
    lo, hi = WAVEBANDS["D1"]
    sos = signal.butter(4, [1 / hi, 1 / lo], btype="bandpass", fs=1 / DX, output="sos")
    pad = min(x.size - 1, int(np.ceil(hi / DX)))
    expected = signal.sosfiltfilt(sos, z, padtype="constant", padlen=pad)
    for _ in range(2):  # the design is kept after the first call
        np.testing.assert_array_equal(longitudinal_level(x, z, "D1"), expected)


def test_nonuniform_sampling():
    """Jittered sampling is resampled, filtered and interpolated back to the input points."""
    rng = np.random.default_rng(2)
    x = X + rng.uniform(-0.08, 0.08, X.size)
    z = sine(x, 10.0)
    y = longitudinal_level(x, z, "D1")
    assert y.shape == x.shape
    expected = expected_gain("D1", 10.0) * z
    # linear interpolation back from the 0.25 m grid costs up to ~1 % at 10 m wavelength
    assert np.max(np.abs(y[MIDDLE] - expected[MIDDLE])) < 0.02 * A
    # a grid with two spacings (0.2 m and 0.3 m stretches)
    x2 = np.concatenate([np.arange(0.0, 500.0, 0.2), np.arange(500.0, 1000.0, 0.3)])
    z2 = sine(x2, 40.0)
    y2 = longitudinal_level(x2, z2, "D2")
    m2 = (x2 >= 200.0) & (x2 <= 800.0)
    assert gain(m2, z2, y2) == pytest.approx(expected_gain("D2", 40.0), rel=0.01)


def test_segment_sd_of_sine():
    df = segment_sd(X, sine(X, 10.0), segment_length=200.0)
    assert list(df.columns) == ["segment_start_m", "segment_end_m", "sd_mm"]
    np.testing.assert_allclose(df["segment_start_m"], [0.0, 200.0, 400.0, 600.0, 800.0])
    # X ends at 999.75 m: the last segment is a 199.75 m partial one, ending at X[-1]
    np.testing.assert_allclose(df["segment_end_m"], [200.0, 400.0, 600.0, 800.0, 999.75])
    np.testing.assert_allclose(df["sd_mm"], A * 1e3 / np.sqrt(2), rtol=0.01)


def test_segment_sd_of_filtered_sine():
    df = segment_sd(X, longitudinal_level(X, sine(X, 10.0), "D1"))
    inner = df["sd_mm"].to_numpy()[1:-1]  # the end segments carry the filter transients
    np.testing.assert_allclose(inner, A * 1e3 / np.sqrt(2), rtol=0.01)


def test_segment_sd_partial_segment_rule():
    x = np.arange(50.0, 1149.9, DX)  # 1099.75 m: remainder 99.75 m <= 100 m, in the last
    df = segment_sd(x, sine(x, 10.0))
    assert len(df) == 5
    assert df["segment_start_m"].iloc[0] == 50.0
    assert df["segment_start_m"].iloc[-1] == 850.0
    assert df["segment_end_m"].iloc[-1] == x[-1]  # 299.75 m: every position assessed
    tail = x >= 850.0
    assert df["sd_mm"].iloc[-1] == np.std(sine(x[tail], 10.0)) * 1e3  # its samples, all
    x = np.arange(50.0, 1200.1, DX)  # 1150 m: remainder 150 m > 100 m, kept
    df = segment_sd(x, sine(x, 10.0))
    assert len(df) == 6
    assert df["segment_end_m"].iloc[-1] == pytest.approx(1200.0)
    assert df["sd_mm"].iloc[-1] == pytest.approx(A * 1e3 / np.sqrt(2), rel=0.01)
    assert len(segment_sd(x[:200], sine(x[:200], 10.0))) == 0  # 49.75 m, under half a segment


def test_bad_inputs():
    z = sine(X, 10.0)
    bad = z.copy()
    bad[7] = np.nan
    with pytest.raises(TrackdynInputError, match="profile is NaN or infinite at row 7"):
        longitudinal_level(X, bad)
    x = X.copy()
    x[11] = x[10]
    with pytest.raises(TrackdynInputError, match="strictly increasing at row 11"):
        longitudinal_level(x, z)
    with pytest.raises(TrackdynInputError, match="unknown band 'D4'.*D1, D2, D3"):
        longitudinal_level(X, z, "D4")
    with pytest.raises(TrackdynInputError, match="too short for band D2.*140 m"):
        longitudinal_level(X[:400], z[:400], "D2")
    with pytest.raises(TrackdynInputError, match="too coarse for band D1"):
        longitudinal_level(X[::8], z[::8], "D1")
    with pytest.raises(TrackdynInputError, match="order"):
        longitudinal_level(X, z, order=0)
    with pytest.raises(TrackdynInputError, match="shape"):
        longitudinal_level(X, z[:-1])
    with pytest.raises(TrackdynInputError, match="band"):
        longitudinal_level(X, z, band=(25.0, 3.0))
    with pytest.raises(TrackdynInputError, match="segment_length"):
        segment_sd(X, z, segment_length=0.0)
    with pytest.raises(TrackdynInputError, match="level is NaN or infinite at row 7"):
        segment_sd(X, bad)
