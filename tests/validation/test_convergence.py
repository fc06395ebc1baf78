"""Observed order of accuracy of the central-difference scheme (5.15-5.18), friction off.

Central differences for displacement and velocity are second-order accurate, so halving
the step should divide the error by 4: ``order = log2(e(dt) / e(dt/2)) = 2``. The error of
the wheel load at dt, dt/2 and dt/4 is measured against a run at dt/32, whose own error
is 1/1024 of e(dt) and shifts the observed order by less than 0.01.

The friction is switched off (mu = 0: the slip forces of 5.30 vanish, so F = 0), because
the stick/slip switching is not smooth and would limit the order. The input is smooth for
the same reason: a sine on both rails (phase-shifted on the right to excite roll) with the
same stiffness at every sleeper. Linear interpolation of the geometry and of per-sleeper
stiffness puts kinks into the input; at each kink the third derivative of the response
jumps and the scheme's local error there depends on where the kink falls inside a step,
which makes the observed order wander. Here the geometry is sampled 800 times per
wavelength (chord error 8e-6 of the amplitude) and k2 is constant, so the kinks are
negligible.
"""

import numpy as np
import pytest

from trackdyn.options import RunOptions
from trackdyn.simulation import simulate
from trackdyn.track.track import Geometry, Supports, Track
from trackdyn.vehicle.parameters import load_vehicle

SPEED = 20.0  # [m/s]
WAVELENGTH = 8.0  # [m]: 2.5 Hz at 20 m/s, near the body modes, so the response is large
AMPLITUDE = 2.0e-3  # [m]
SPACING = 0.01  # [m] geometry sampling: 800 points per wavelength
TRAVEL = 30.0  # [m] run length, 1.5 s
K_TRACK = 100e6  # [N/m] per sleeper and rail, uniform
DT = 5e-4  # [s] coarsest step: a 35th of the shortest natural period (57 Hz for the
# 11-DOF model on this track, 58 Hz for the full model, 46 Hz for the 2/4/7-DOF), inside
# the asymptotic range (ω dt ≤ 0.18) and far inside the stability limit ω dt < 2
REFINE = 32  # reference step DT / 32
ORDER, ORDER_TOL = 2.0, 0.2  # central differences are second order; brief: 2 ± 0.2


@pytest.fixture(scope="module")
def track():
    v = load_vehicle("loaded")
    length = TRAVEL + 2 * (v.b_cc + v.a) + 1.0
    x = np.arange(0.0, length + SPACING / 2, SPACING)
    left = AMPLITUDE * np.sin(2 * np.pi * x / WAVELENGTH)
    right = AMPLITUDE * np.sin(2 * np.pi * x / WAVELENGTH + 1.0)
    sleepers = np.arange(0.0, length + 0.3, 0.6)
    return Track(Geometry(x, left, right), Supports.linear(sleepers, K_TRACK, K_TRACK))


@pytest.mark.parametrize("model", ["2dof", "4dof", "7dof", "11dof", "full"])
def test_second_order_convergence(track, model):
    v = load_vehicle("loaded").replace(mu=0.0)
    lin = track.linearise(v.static_wheel_load)

    def run(refine):
        # store_every = refine keeps the stored times the same for every step size.
        return simulate(
            v,
            lin,
            RunOptions(model=model, speed_kmh=SPEED * 3.6, dt_s=DT / refine, store_every=refine),
        )

    ref = run(REFINE)
    runs = [run(2**i) for i in range(3)]
    n = min(r.time.size for r in [ref, *runs])
    reference = ref.wheel_load.values[:n]
    errors = []
    for r in runs:
        np.testing.assert_allclose(r.time.values[:n], ref.time.values[:n], rtol=1e-12)
        # RMS over time of the wheel-load error, worst contact [N]
        errors.append(np.sqrt(np.mean((r.wheel_load.values[:n] - reference) ** 2, axis=0)).max())
    errors = np.array(errors)
    orders = np.log2(errors[:-1] / errors[1:])

    # The errors measured are real, not round-off: the dynamic load is several kN and
    # e(dt/4) is far above the ~1e-9 N round-off of loads of order 1e5 N.
    dynamic = np.sqrt(np.mean((reference - v.static_wheel_load) ** 2, axis=0)).max()
    assert dynamic > 500.0
    assert errors[-1] > 1e-4
    np.testing.assert_allclose(orders, ORDER, atol=ORDER_TOL, err_msg=f"errors {errors} N")
