"""Rail-seat forces from the rail beam, against independent solves of `solve_beam`."""

import numpy as np
import pytest

from trackdyn.beam.railseat import RailBeam, Windows, _ldl_solve, _spd_inverses, rest_state
from trackdyn.beam.static import linear_supports, solve_beam
from trackdyn.deterioration.ballast import Ballast
from trackdyn.track.rails import rail_section
from trackdyn.track.synthetic import VoidedSleepers, synthetic_track

RAIL = rail_section("60E1")
SLEEPER_MASS = 125.5  # kg per rail seat, Zhai et al. (2004), as the loop's default
WHEELS = np.array([0.0, 1.83])  # a bogie's two wheels [m], Barber bogie wheelbase
LOADS = np.array([120e3, 110e3])  # wheel loads [N], about a 104 t wagon's static load


def ballast(void=None):
    """60 m of level track, linear supports of 100 kN/mm per wheel, optionally one void."""
    features = () if void is None else (VoidedSleepers(30.0, 1, void, "both"),)
    trk = synthetic_track(60.0, spectrum=None, stiffness_cov=0.0, gap=0.0, seed=1,
                          features=features)  # fmt: skip
    return Ballast(trk.linearise(120e3, 0.3), RAIL, SLEEPER_MASS)


def independent(b, state, r, at, loads):
    """Support forces of the whole section by `solve_beam`: self-weight and wheels."""
    beam, gap = b.beams[r], state.rails[r].gap
    base = gap.min()  # solve_beam starts from zero deflection: drop the rail onto the ballast
    supports = linear_supports(beam.position, beam.stiffness, gap - base)
    sol = solve_beam(supports, beam.EI, np.r_[beam.position, at], np.r_[beam.weight, loads],
                     max_element=1e3, max_iter=400)  # fmt: skip
    return sol.support_force


def wheel_forces(b, state, r, i, shift=0.0):
    """Rail-seat forces with the bogie's first wheel ``shift`` beyond sleeper ``i``: index,
    force."""
    at = b.position[i] + shift + WHEELS
    index, force, _ = b.wheel_solve(r, state, np.array([i]), at[None, :], LOADS[None, :])
    return index[0], force[0]


def test_rest_state_matches_an_independent_fe_solve():
    b = ballast()
    gap = np.random.default_rng(5).uniform(0.0, 1.5e-3, b.position.size)  # rough ballast
    rest = rest_state(b.beams[0], gap)
    beam = b.beams[0]
    sol = solve_beam(linear_supports(beam.position, beam.stiffness, gap - gap.min()), beam.EI,
                     beam.position, beam.weight, max_element=1e3, max_iter=400)  # fmt: skip
    np.testing.assert_allclose(rest.force, sol.support_force, atol=1e-3)  # N
    assert rest.force.sum() == pytest.approx(beam.weight.sum(), rel=1e-12)  # equilibrium
    assert 0 < np.count_nonzero(rest.closed) < gap.size  # some sleepers hang


@pytest.mark.parametrize("shift", [0.0, 0.27])  # over a sleeper, and between two
@pytest.mark.parametrize("void", [0.0, 1.0e-3])
def test_wheel_forces_match_an_independent_fe_solve_and_sum_to_the_loads(void, shift):
    """Windows of ±10 sleepers against the whole section; within 5 sleepers of the wheels
    the window's held ends change the forces by < 50 N (of 40-60 kN). The forces of the
    window sum to the wheel loads plus the self-weight carried there (rail over a sleeper
    spacing plus the sleeper, per sleeper) to within the held ends' share, < 0.5 %."""
    b = ballast(None if void == 0.0 else void)
    state = b.initial
    i = int(np.argmin(np.abs(b.position - 30.0))) - 1  # the wheel over the void's neighbour
    index, force = wheel_forces(b, state, 0, i, shift)
    full = independent(b, state, 0, b.position[i] + shift + WHEELS, LOADS)
    near = np.abs(index - i) <= 5
    np.testing.assert_allclose(force[near], full[index[near]], atol=50.0)
    total = LOADS.sum() + b.beams[0].weight[index].sum()
    assert force.sum() == pytest.approx(total, rel=5e-3)


def test_a_hanging_sleepers_load_goes_to_its_neighbours():
    """A 1 mm void under one sleeper (rail at rest leaves it hanging): with the wheel over
    either neighbour that neighbour carries more than on level ballast, by > 10 %, and the
    voided sleeper less (independent FE solves agree, see the test above)."""
    level, voided = ballast(), ballast(1.0e-3)
    v = int(np.argmin(np.abs(voided.position - 30.0)))
    assert voided.initial.hanging_gap[0, v] > 0.5e-3  # it hangs at rest
    for i in (v - 1, v + 1):
        index, f_void = wheel_forces(voided, voided.initial, 0, i)
        _, f_level = wheel_forces(level, level.initial, 0, i)
        at = index == i
        assert f_void[at][0] > 1.1 * f_level[at][0]
        assert f_void[index == v][0] < 0.8 * f_level[index == v][0]


def test_forces_do_not_depend_on_the_rest_states_solved_before():
    """The window inverses follow the rest states by rank-one changes where their closed
    supports changed (`_flip_supports`): solving on a rough rest state after the level one
    gives what a fresh beam gives on the rough one alone, to round-off (measured 7e-13 of
    the value; the rough state leaves sleepers hanging, so some windows do change)."""
    used, fresh = ballast(), ballast()
    level = np.zeros((2, used.position.size))
    rough = np.random.default_rng(7).uniform(0.0, 1.5e-3, level.shape)
    centre = np.arange(used.position.size)
    at = used.position[:, None] + WHEELS
    loads = np.tile(LOADS, (centre.size, 1))
    used.wheel_solve(0, used.state(level), centre, at, loads)
    state_used, state_fresh = used.state(rough), fresh.state(rough)
    assert np.any(state_used.hanging_gap[0] > 0)
    for a, b in zip(used.wheel_solve(0, state_used, centre, at, loads),
                    fresh.wheel_solve(0, state_fresh, centre, at, loads), strict=True):  # fmt: skip
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12 * np.abs(b).max())


def test_peaks_are_the_largest_force_of_each_sleeper_per_wheel():
    """`Windows.peaks` (row ``b`` is wheel ``b % wheels``'s), against numpy's unbuffered
    ``maximum.at`` over the rows of the full solve, to the bit: a bogie's two wheels over
    sleepers 20-40 of 100, on ballast with a 1 mm void; the columns beyond the section are
    dropped and a sleeper no row reaches gets 0."""
    b = ballast(1.0e-3)
    n = b.position.size
    centre = np.repeat(np.arange(20, 41), 2)  # each wheel over each sleeper in turn
    at = b.position[centre][:, None] + WHEELS[None, :] - np.tile([0.0, WHEELS[1]], 21)[:, None]
    loads = np.tile(LOADS, (centre.size, 1))
    index, force, _ = b.wheel_solve(0, b.initial, centre, at, loads)
    peaks = b.peak_forces(0, b.initial, b.wheel_forces(0, centre, at, loads), 2)
    for wheel in range(2):
        expected = np.zeros(n)
        rows = slice(wheel, None, 2)
        inside = (index[rows] >= 0) & (index[rows] < n)
        np.maximum.at(expected, index[rows][inside], force[rows][inside])
        np.testing.assert_array_equal(peaks[wheel], expected)
    assert np.all(peaks[:, :5] == 0.0) and np.all(peaks[:, 60:] == 0.0)
    assert np.all(peaks[:, 25:36] > 0.0)


def test_window_inverses_follow_supports_that_open_and_close():
    """Each rest state changes the window inverses by rank-one updates for the supports
    that opened or closed (`_flip_supports`): after a sequence of rough ballast states
    (random gaps up to 1.5 mm: about 47 of the 100 supports change each time, so that
    windows pass `MAX_FLIPS` and are formed again) they equal the inverses formed in full
    from the last state's closed supports to 1e-12 of their largest entry (measured 3e-14:
    double-precision round-off through a few dozen updates of matrices of condition about
    40)."""
    from trackdyn.beam.railseat import MAX_FLIPS, Windows

    b = ballast()
    win = Windows(b.beams[0])
    rng = np.random.default_rng(3)
    for _ in range(3 * MAX_FLIPS):
        rest = rest_state(b.beams[0], rng.uniform(0.0, 1.5e-3, b.position.size))
        updated = win._inverses(rest).copy()
    fresh = Windows(b.beams[0])._inverses(rest)
    assert np.abs(updated - fresh).max() < 1e-12 * np.abs(fresh).max()
    assert win._flips.max() <= MAX_FLIPS


def test_forces_do_not_depend_on_where_the_supports_iteration_starts():
    """Each row's closed supports are iterated from its set in the latest solve
    (`WindowLoads.closed`, the warm start); the tensionless beam has one solution, and the
    Woodbury solve depends only on the final set, so rows started from all supports
    closed, from every other support open, or from the answer itself give the same forces
    to the bit. On rough ballast (gaps up to 1.5 mm) the final sets differ from the rest
    state's (so the Woodbury part is exercised) and from each start; a solve that took the
    start for the rest state's set (whose forces balance at rest) would be wrong by the
    rest forces of the changed supports."""
    b = ballast()
    state = b.state(np.random.default_rng(11).uniform(0.0, 1.5e-3, (2, b.position.size)))
    centre = np.arange(b.position.size)
    at, loads = b.position[:, None] + WHEELS, np.tile(LOADS, (centre.size, 1))
    placed = b.wheel_forces(0, centre, at, loads)
    assert placed.closed.all()  # starts from all closed
    first = b.force_solve(0, state, placed)
    answer = placed.closed.copy()  # the solution's closed supports, kept for the next solve
    rest = state.rails[0].closed[(b.windows[0].index - 1).clip(0, centre.size - 1)]
    assert np.count_nonzero(answer != rest) > centre.size  # the sets differ from the rest state's
    alternate = np.zeros_like(answer)
    alternate[:, ::2] = True
    assert np.count_nonzero(answer != alternate) > centre.size
    for start in (alternate, answer):
        again = b.wheel_forces(0, centre, at, loads, closed=start)
        for x, y in zip(b.force_solve(0, state, again), first, strict=True):
            np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(again.closed, answer)


@pytest.mark.parametrize("spacing", ["random", "two"])
def test_unevenly_spaced_sleepers_match_an_independent_fe_solve(spacing):
    """Windows of the same element lengths are condensed once: on sleepers spaced 0.55 to
    0.65 m at random (stiffness 40-120 kN/mm, no gaps) every window is its own; spaced 0.6 m
    and then 0.65 m, the windows of either spacing are shared and those across the change
    are their own. The forces within 5 sleepers of the wheels match the independent FE
    solve of the whole rail (`solve_beam`) as on even spacing, < 50 N of 40-60 kN
    (measured 16 N over 60 wheel positions; a window given its neighbour's lengths is off
    by over 1 kN)."""
    rng = np.random.default_rng(4)
    steps = rng.uniform(0.55, 0.65, 100) if spacing == "random" else np.repeat([0.6, 0.65], 50)
    x = np.cumsum(steps)
    k = rng.uniform(40e6, 120e6, x.size)
    beam = RailBeam(x, k, np.full(x.size, 1.2e3), RAIL.EI, half=10)
    win, rest = Windows(beam), rest_state(beam, np.zeros(x.size))
    assert win.T.shape[0] == (x.size if spacing == "random" else 2 + 2 * beam.half + 1)
    supports = linear_supports(x, k, 0.0)
    for i in range(20, 80, 7):
        at = x[i] + WHEELS
        placed = win.load_vector(np.array([i]), at[None, :], LOADS[None, :])
        index, force, _ = win.solve(rest, placed)
        full = solve_beam(supports, beam.EI, np.r_[x, at], np.r_[beam.weight, LOADS],
                          max_element=1e3, max_iter=400).support_force  # fmt: skip
        near = np.abs(index[0] - i) <= 5
        np.testing.assert_allclose(force[0][near], full[index[0][near]], atol=50.0)


@pytest.mark.parametrize("m", [1, 2, 5, 9])
def test_ldl_solve_of_a_quasi_definite_matrix_matches_numpy(m):
    """The Woodbury capacitance ``D^-1 + U^T A^-1 U`` of supports closed (d > 0) and opened
    (d < 0) in mixed order, its lower triangle only, against ``numpy.linalg.solve`` on the
    full matrix: to 1e-12 of the solution (double-precision round-off at condition < 1e3)."""
    rng = np.random.default_rng(m)
    q = rng.standard_normal((12, 12))
    inv = np.linalg.inv(q @ q.T + 12 * np.eye(12))  # a window inverse: symmetric, definite
    pick = rng.choice(12, m, replace=False)
    M = inv[np.ix_(pick, pick)]
    # opened supports: k below 1 / M_jj, so that the window stays definite
    opened = rng.random(m) < 0.5
    d = np.where(opened, -0.5 / np.linalg.eigvalsh(M).max(), rng.uniform(1.0, 10.0, m))
    full = M + np.diag(1.0 / d)
    rhs = rng.standard_normal(m)
    c, z = np.tril(full) + np.triu(rng.standard_normal((m, m)), 1), rhs.copy()  # upper: junk
    _ldl_solve(c, z, m)
    expected = np.linalg.solve(full, rhs)
    np.testing.assert_allclose(z, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_window_inverses_match_numpy_and_are_symmetric():
    """`_spd_inverses` (Cholesky) against ``numpy.linalg.inv`` on the windows of a rough rest
    state (gaps up to 1.5 mm, some supports open): equal to 1e-13 of the largest entry
    (measured 2e-14: round-off at the windows' condition, up to 2700), and each inverse
    exactly symmetric, as `_window_solve` reads its rows as columns."""
    b = ballast()
    win = Windows(b.beams[0])
    rest = rest_state(b.beams[0], np.random.default_rng(4).uniform(0.0, 1.5e-3, b.position.size))
    k, g, u0 = (b.beams[0].padded(v)[win.index] for v in (b.beams[0].stiffness, rest.gap,
                                                          rest.deflection))  # fmt: skip
    assert 0 < np.count_nonzero(u0 <= g)  # some supports open
    A = win.S[win.kind] + k[:, :, None] * np.eye(win.width) * (u0 > g)[:, :, None]
    inverse = _spd_inverses(A)
    expected = np.linalg.inv(A)
    assert np.abs(inverse - expected).max() < 1e-13 * np.abs(expected).max()
    np.testing.assert_array_equal(inverse, np.transpose(inverse, (0, 2, 1)))


def test_loads_placed_once_give_on_each_state_what_fresh_ones_give():
    """A run's loads are placed once and solved on every rest state of its step; each row
    keeps ``A^-1 force`` while its window's inverse stays (`WindowLoads.base`). Solved on
    a sequence of rest states (settlement growing by up to 0.05 mm a state at random, so
    that some windows' supports open or close and others do not: 0 to 57 of 100 windows
    changed), they give what loads placed afresh on each state give, to the bit; a row
    that kept its product through a change of its window's inverse would be off by that
    change."""
    b = ballast()
    centre = np.repeat(np.arange(b.position.size), 2)
    at = (
        b.position[centre][:, None]
        + WHEELS[None, :]
        - np.tile([0.0, WHEELS[1]], b.position.size)[:, None]
    )
    loads = np.tile(LOADS, (centre.size, 1))
    kept = b.wheel_forces(0, centre, at, loads)
    rng, level = np.random.default_rng(9), np.zeros((2, b.position.size))
    changed = []
    for _ in range(6):
        level = level + rng.uniform(0.0, 0.05e-3, level.shape)
        state = b.state(level)
        before = b.windows[0]._version.copy()
        fresh = b.wheel_forces(0, centre, at, loads, closed=kept.closed)
        for x, y in zip(b.force_solve(0, state, kept), b.force_solve(0, state, fresh), strict=True):
            np.testing.assert_array_equal(x, y)
        changed.append(np.count_nonzero(b.windows[0]._version != before))
    assert changed[0] == b.position.size  # formed at the first state
    assert any(0 < c < b.position.size for c in changed[1:])  # then some kept, some not
