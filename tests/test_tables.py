"""The statistics tables (run summary, study table) against closed-form values.

A pure sine of amplitude A sampled over a whole number of periods has standard deviation
A/√2 (the mean of sin² over a period is 1/2), extremes ±A when a sample falls on the
crests, and a spectrum whose only peak is at its frequency when that frequency lies on the
FFT grid (f T an integer).
"""

import numpy as np
import pytest
import xarray as xr

from trackdyn.errors import Failure, Status
from trackdyn.results import summary
from trackdyn.studies.runner import SPECTRUM_FREQUENCY, Statistics, gather

PS = 127.5e3  # static wheel load [N]
DT = 1e-3  # [s]
T = 8.0  # [s], 8000 samples
AMPLITUDES = {"FL": 20e3, "FR": 5e3}  # [N]
FREQUENCY = {"FL": 2.0, "FR": 7.5}  # [Hz]: f T = 16 and 60 periods; 1/(4f) a whole number of dt
SECONDARY = 3e-3  # [m], amplitude of the secondary displacement
BOUNCE_ACC = 0.4  # [m/s^2], amplitude of the body bounce acceleration


def sine_run() -> xr.Dataset:
    t = np.arange(0.0, T, DT)
    load = np.column_stack(
        [PS + AMPLITUDES[c] * np.sin(2 * np.pi * FREQUENCY[c] * t) for c in AMPLITUDES]
    )
    acc = np.column_stack([BOUNCE_ACC * np.cos(2 * np.pi * 1.5 * t), np.zeros_like(t)])
    return xr.Dataset(
        {
            "wheel_load": (("time", "contact"), load),
            "secondary_displacement": (("time", "suspension"), SECONDARY * np.sin(t)[:, None]),
            "acceleration": (("time", "dof"), acc),
        },
        coords={
            "time": t,
            "contact": list(AMPLITUDES),
            "suspension": ["FL"],
            "dof": ["body_bounce", "wheel_bounce"],
        },
        attrs={"static_wheel_load_N": PS},
    )


def test_summary_of_a_pure_sine():
    table = summary(sine_run()).set_index("contact")
    for c, amp in AMPLITUDES.items():
        assert table.loc[c, "dyn_load_sd_kN"] == pytest.approx(amp / np.sqrt(2) / 1e3, rel=1e-12)
        assert table.loc[c, "dyn_load_max_kN"] == pytest.approx(amp / 1e3, rel=1e-12)
        assert table.loc[c, "dyn_load_min_kN"] == pytest.approx(-amp / 1e3, rel=1e-12)
        assert table.loc[c, "dominant_frequency_Hz"] == FREQUENCY[c]
    # |sin t| over 0-8 s peaks at t = π/2 + nπ; the largest sample is within 1e-6 of 1
    assert table["secondary_max_mm"].iloc[0] == pytest.approx(SECONDARY * 1e3, rel=1e-6)
    # RMS of a cosine over 12 whole periods (1.5 Hz, 8 s) is its amplitude / √2
    rms = table["body_bounce_acc_rms_m_per_s2"].iloc[0]
    assert rms == pytest.approx(BOUNCE_ACC / np.sqrt(2), rel=1e-12)


def test_study_table_keeps_each_run_and_its_failure():
    psd = np.linspace(1.0, 2.0, SPECTRUM_FREQUENCY.size)
    results = [
        ({"speed_kmh": 40.0}, Statistics({"dyn_load_sd_kN": 10.0}, psd)),
        ({"speed_kmh": 80.0}, Failure(Status.INPUT_REFUSED, "vehicle parameter k1 must be > 0")),
    ]
    table, ds = gather(results)
    assert list(table["speed_kmh"]) == [40.0, 80.0]
    assert table["dyn_load_sd_kN"].iloc[0] == 10.0 and np.isnan(table["dyn_load_sd_kN"].iloc[1])
    assert list(table["error"]) == ["", "vehicle parameter k1 must be > 0"]
    np.testing.assert_array_equal(ds.wheel_load_psd.isel(run=0), psd)
    assert np.isnan(ds.wheel_load_psd.isel(run=1)).all()
    assert ds.dyn_load_sd_kN.attrs["units"] == "kN" and ds.frequency.attrs["units"] == "Hz"


def test_figure_envelope_keeps_every_peak():
    from trackdyn.plots import envelope

    # 60 000 samples of a 1 kHz run thinned for a full-length panel: the extremes of every
    # stretch of 30 samples survive, so no peak of the wheel load disappears from the plot
    t = np.arange(60_000) * DT
    y = np.sin(2 * np.pi * 3.0 * t) + 0.1 * np.sin(2 * np.pi * 170.0 * t)
    x, e = envelope(t, y, points=4000)
    assert x.size == e.size == 4000
    assert e.max() == y.max() and e.min() == y.min()
    np.testing.assert_array_equal(e[1::2], y.reshape(2000, 30).max(axis=1))
