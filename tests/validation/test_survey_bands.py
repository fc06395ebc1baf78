"""What a filtered longitudinal level lacks as a profile: the dynamic wheel load on the
example's profile filtered to D1 (3-25 m) against the load on the profile itself, the
figures `docs/file-formats.md` states per model and speed."""

import numpy as np
import pytest

from trackdyn import RunOptions, load_track, load_vehicle, simulate
from trackdyn.track.quality import WAVEBANDS, longitudinal_level
from trackdyn.track.track import Geometry, Track

STATED = {("2dof", 60): 7.1, ("11dof", 60): 63.2}
"""RMS difference of the dynamic wheel load, % of its RMS on the true profile, 100-900 m,
the loaded wagon (docs/file-formats.md, measured when written)."""


@pytest.mark.parametrize(("model", "speed"), list(STATED))
def test_a_d1_profile_changes_the_loads_as_the_docs_say(model, speed):
    example = load_track()
    g = example.geometry
    d1 = [
        longitudinal_level(g.distance, g.profile(rail), WAVEBANDS["D1"])
        for rail in ("left", "right")
    ]
    filtered = Track(Geometry(g.distance, *d1, "d1"), example.supports)
    options = RunOptions(model=model, speed_kmh=speed, start_m=100, end_m=900)
    vehicle = load_vehicle("loaded")
    true, d1run = (simulate(vehicle, t, options).wheel_load for t in (example, filtered))
    dyn_true, dyn_d1 = (w - w.mean("time") for w in (true, d1run))
    error = float(np.sqrt(((dyn_d1 - dyn_true) ** 2).mean() / (dyn_true**2).mean())) * 100
    # the 2-DOF wheelset sees the short waves D1 keeps; the 11-DOF body the long ones it drops
    assert error == pytest.approx(STATED[model, speed], abs=0.5)
