"""The banded beam stiffness and its compiled Cholesky solve."""

import numpy as np
import pytest
from scipy.linalg import solveh_banded

from trackdyn.beam.elements import band_times, solve_band, stiffness_band
from trackdyn.track.rails import rail_section


@pytest.mark.parametrize("supported", [1.0, 0.3])  # every sleeper bears; 30 % of them
def test_solve_band_matches_lapack(supported):
    """`solve_band` against LAPACK's banded Cholesky (``scipy.linalg.solveh_banded``) and
    against the residual ``K y - rhs`` (`band_times`): a rail on 500 sleepers spaced 0.55 to
    0.65 m at random, 40-120 kN/mm springs at some of them, random loads; to 1e-12 of the
    solution (double-precision round-off at the condition of a rail on springs), and the
    residual to 1e-9 of the largest load (round-off of products of entries up to about
    1e9 N/m with deflections, measured 4e-15 and 5e-13)."""
    rng = np.random.default_rng(8)
    x = np.cumsum(rng.uniform(0.55, 0.65, 500))
    band = stiffness_band(x, rail_section("60E1").EI)
    bearing = rng.random(x.size) < supported
    bearing[[0, -1]] = True
    band[3, ::2] += rng.uniform(40e6, 120e6, x.size) * bearing
    rhs = rng.uniform(-1e3, 1e5, 2 * x.size)
    kept = band.copy(), rhs.copy()
    y = solve_band(band, rhs)
    expected = solveh_banded(band, rhs, check_finite=False)
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    residual = band_times(band, y) - rhs
    assert np.abs(residual).max() < 1e-9 * np.abs(rhs).max()
    np.testing.assert_array_equal(band, kept[0])  # left as they were
    np.testing.assert_array_equal(rhs, kept[1])
