"""Fixtures shared by test modules."""

import pytest

from trackdyn.track.synthetic import synthetic_track
from trackdyn.vehicle.parameters import load_vehicle


@pytest.fixture(scope="module")
def lin():
    """An 80 m synthetic track linearised about the loaded wagon's static wheel load."""
    return synthetic_track(80.0, spectrum="fra4", seed=4).linearise(
        load_vehicle("loaded").static_wheel_load
    )
