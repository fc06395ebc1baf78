"""Chord (versine) measurements: the forward transform against its closed form, and the
profile recovered from a versine against the profile it was made from."""

import numpy as np
import pytest

from trackdyn.errors import TrackdynInputError
from trackdyn.track.chord import Chord, profile_from_versine
from trackdyn.track.quality import longitudinal_level
from trackdyn.track.spectra import generate_profile

X = np.arange(0.0, 2000.0, 0.25)  # a recording car's 0.25 m samples over 2 km


@pytest.mark.parametrize("chord", [Chord.symmetric(10.0), Chord(2.5, 7.5)])
@pytest.mark.parametrize("wavelength", [4.0, 7.3, 10.0, 23.0])
def test_the_versine_of_a_harmonic_is_the_harmonic_times_the_chord_gain(chord, wavelength):
    # closed form: z = cos(k x) gives v = Re(H(k) e^(i k x)), H from the chord's definition
    k = 2 * np.pi / wavelength
    v = chord.versine(X, np.cos(k * X))
    expected = np.real(chord.gain(wavelength) * np.exp(1j * k * X))
    inside = np.isfinite(v)
    assert inside.sum() == X.size - 40  # 10 m of chord: 40 samples without both ends
    np.testing.assert_allclose(v[inside], expected[inside], atol=2e-3)  # linear interp.


def test_a_symmetric_chord_loses_half_its_length_and_the_long_waves():
    # H = 1 - cos(k L / 2): zero at L / 2 = 5 m for a 10 m chord, gain 2 at 10 m;
    # |H| < 0.2 where cos(k L / 2) > 0.8, i.e. within acos(0.8) of a zero
    chord = Chord.symmetric(10.0)
    assert abs(chord.gain(5.0)) < 1e-12 and abs(chord.gain(10.0)) == pytest.approx(2.0)
    half = np.arccos(0.8)
    short = (10 * np.pi / (2 * np.pi + half), 10 * np.pi / (2 * np.pi - half))
    long = 10 * np.pi / half
    (a, b), (c, d) = chord.lost_band()
    assert (a, b) == pytest.approx(short, rel=2e-3) and c == pytest.approx(long, rel=2e-3)
    assert d == 70.0  # to the end of the D1 and D2 bands
    assert Chord(2.5, 7.5).lost_band(band=(3.0, 25.0)) == []  # passes the whole D1 band


def test_a_sum_of_sines_comes_back_from_its_versine():
    # wavelengths away from the 10 m chord's lost bands, whole periods in the record
    waves = [(6.25, 1.0e-3), (12.5, 2.0e-3), (20.0, 1.5e-3)]
    z = sum(a * np.sin(2 * np.pi * X / w) for w, a in waves)
    chord = Chord.symmetric(10.0)
    v = chord.versine(X, z)
    inside = np.isfinite(v)
    back = profile_from_versine(X[inside], v[inside], chord)
    middle = (X[inside] > 200) & (X[inside] < 1800)  # the ends ring (0.014 mm measured)
    np.testing.assert_allclose(back[middle], z[inside][middle], atol=0.02e-3)


@pytest.mark.parametrize("spectrum", ["german_high", "fra5"])  # D1 SD 1.5 mm and 3.3 mm
@pytest.mark.parametrize("chord", [Chord(2.5, 7.5), Chord.symmetric(10.0)])
def test_a_random_profile_comes_back_in_the_d1_band_with_noise(spectrum, chord):
    # the check: correlation above 0.98 and D1 SD within 3 % with 0.2 mm of noise
    z = generate_profile(X, spectrum, seed=1, wavelength_range=(1.0, 200.0))
    v = chord.versine(X, z)
    inside = np.isfinite(v)
    noise = np.random.default_rng(2).normal(0.0, 0.2e-3, inside.sum())
    back = profile_from_versine(X[inside], v[inside] + noise, chord)
    true, got = longitudinal_level(X[inside], z[inside]), longitudinal_level(X[inside], back)
    middle = (X[inside] > 100) & (X[inside] < 1900)  # a longest D2 wave from the ends
    assert 1.0e-3 < true[middle].std() < 3.5e-3
    assert np.corrcoef(true[middle], got[middle])[0, 1] > 0.98
    assert got[middle].std() == pytest.approx(true[middle].std(), rel=0.03)


def test_refusals_name_the_source():
    with pytest.raises(TrackdynInputError, match="chord_m must be finite and > 0"):
        Chord.symmetric(-10.0)
    uneven = np.concatenate([np.arange(0, 100, 0.25), np.arange(100.5, 200, 0.5)])
    with pytest.raises(TrackdynInputError, match="^car.csv: a versine needs uniformly spaced"):
        profile_from_versine(uneven, np.zeros(uneven.size), Chord(2.5, 7.5), where="car.csv")
    with pytest.raises(TrackdynInputError, match="recovered band"):
        profile_from_versine(X, np.zeros(X.size), Chord(2.5, 7.5), band=(0.4, 70.0))
