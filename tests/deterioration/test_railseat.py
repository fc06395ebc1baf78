"""Rail-seat forces from the rail beam, against independent solves of `solve_beam`."""

import numpy as np
import pytest

from trackdyn.beam.elements import element_stiffness, hermite
from trackdyn.beam.railseat import RailBeam, Windows, rest_state
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
    """A beam keeps nothing of the rest states it solved on but each row's closed supports
    (where its next solve starts): solving on a rough rest state after the level one gives
    what a fresh beam gives on the rough one alone, to the bit (the rough state leaves
    sleepers hanging, so that the rows' sets change between the two states)."""
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
        np.testing.assert_array_equal(a, b)


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


def test_forces_do_not_depend_on_where_the_supports_iteration_starts():
    """Each row's closed supports are iterated from its set in the latest solve
    (`WindowLoads.closed`, the warm start); the tensionless beam has one solution, and the
    banded solve depends only on the final set, so rows started from all supports
    closed, from every other support open, or from the answer itself give the same forces
    to the bit. On rough ballast (gaps up to 1.5 mm) the final sets differ from the rest
    state's and from each start; a solve that took the
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
    """Windows of the same element lengths share one stiffness: on sleepers spaced 0.55 to
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
    assert win.band.shape[0] == (x.size if spacing == "random" else 2 + 2 * beam.half + 1)
    supports = linear_supports(x, k, 0.0)
    for i in range(20, 80, 7):
        at = x[i] + WHEELS
        placed = win.load_vector(np.array([i]), at[None, :], LOADS[None, :])
        index, force, _ = win.solve(rest, placed)
        full = solve_beam(supports, beam.EI, np.r_[x, at], np.r_[beam.weight, LOADS],
                          max_element=1e3, max_iter=400).support_force  # fmt: skip
        near = np.abs(index[0] - i) <= 5
        np.testing.assert_allclose(force[0][near], full[index[0][near]], atol=50.0)


def dense_window(win, i):
    """Stiffness of window ``i``'s free nodes, assembled element by element from
    `element_stiffness` (the two outer nodes held), dense."""
    ke = element_stiffness(np.diff(win.x[i]), win.beam.EI)
    K = np.zeros((2 * win.x.shape[1], 2 * win.x.shape[1]))
    for e in range(ke.shape[0]):
        K[2 * e : 2 * e + 4, 2 * e : 2 * e + 4] += ke[e]
    return K[2:-2, 2:-2]


def test_window_solve_is_the_dense_solve_of_its_final_set():
    """Each row's deflection is the solution of its window's equations with the closed
    supports it ends with, solved dense by numpy from the element stiffness and the Hermite
    nodal forces of the wheels (`hermite`), to 1e-12 of the largest deflection
    (double-precision round-off at the windows' condition); that set is the one its
    deflection gives (closed where the rail reaches the ballast) by construction. On rough
    ballast (gaps up to 1.5 mm), where the sets differ from the rest state's in most rows:
    a solve that dropped the rest forces of the changed supports would be off by them."""
    b = ballast()
    state = b.state(np.random.default_rng(12).uniform(0.0, 1.5e-3, (2, b.position.size)))
    win, rest, beam = b.windows[0], state.rails[0], b.beams[0]
    centre = np.arange(5, b.position.size - 5, 3)
    at = b.position[centre][:, None] + WHEELS
    loads = np.tile(LOADS, (centre.size, 1))
    index, _, y = b.wheel_solve(0, state, centre, at, loads)
    padded = index + beam.half + 1
    k, g, u0 = (beam.padded(v)[padded] for v in (beam.stiffness, rest.gap, rest.deflection))
    closed, closed0 = y > g, u0 > g
    assert np.count_nonzero(np.any(closed != closed0, axis=1)) > 0.8 * centre.size
    for row, i in enumerate(centre):
        x = win.x[i]
        force = np.zeros(2 * x.size)
        for p, q in zip(at[row], loads[row], strict=True):
            e = np.searchsorted(x, p, side="right") - 1
            length = x[e + 1] - x[e]
            force[2 * e : 2 * e + 4] += q * hermite((p - x[e]) / length, length)
        A, rhs = dense_window(win, i), force[2:-2]
        A[0::2, 0::2] += np.diag(k[row] * closed[row])
        rhs[0::2] -= k[row] * (closed[row] * 1.0 - closed0[row]) * (u0[row] - g[row])
        v = np.linalg.solve(A, rhs)[0::2]
        np.testing.assert_allclose(y[row], u0[row] + v, rtol=0, atol=1e-12 * np.abs(y).max())


def test_rows_in_the_lanes_give_what_each_row_gives_alone():
    """The rows are solved `LANES` at a time, side by side, each group until all of its
    rows have settled; a row's forces, deflections and closed supports do not depend on
    the rows beside it, to the bit: a group and a part (the last lanes repeating the last
    row) of rows on different windows with different loads, against each row alone, on
    rough ballast where the rows need different numbers of iterations."""
    from trackdyn.lanewise import LANES

    b = ballast()
    state = b.state(np.random.default_rng(13).uniform(0.0, 1.5e-3, (2, b.position.size)))
    rng = np.random.default_rng(14)
    centre = rng.choice(np.arange(3, b.position.size - 3), LANES + 5, replace=False)
    at = b.position[centre][:, None] + WHEELS - rng.uniform(0.0, 0.6, (centre.size, 1))
    loads = LOADS * rng.uniform(0.3, 1.5, (centre.size, 1))
    together = b.wheel_forces(0, centre, at, loads)
    solved = b.force_solve(0, state, together)
    for row in range(centre.size):
        one = slice(row, row + 1)
        alone = b.wheel_forces(0, centre[one], at[one], loads[one])
        for x, y in zip(b.force_solve(0, state, alone), solved, strict=True):
            np.testing.assert_array_equal(x[0], y[row])
        np.testing.assert_array_equal(alone.closed[0], together.closed[row])


def test_loads_placed_once_give_on_each_state_what_fresh_ones_give():
    """A run's loads are placed once and solved on every rest state of its step. Solved on
    a sequence of rest states (settlement growing by up to 0.05 mm a state at random, so
    that supports open and close), they give what loads placed afresh on each state give,
    to the bit: a solve leaves its loads' forces as they were."""
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
    sets = []
    for _ in range(6):
        level = level + rng.uniform(0.0, 0.05e-3, level.shape)
        state = b.state(level)
        fresh = b.wheel_forces(0, centre, at, loads, closed=kept.closed)
        for x, y in zip(b.force_solve(0, state, kept), b.force_solve(0, state, fresh), strict=True):
            np.testing.assert_array_equal(x, y)
        sets.append(state.rails[0].closed)
    opened_or_closed = [np.any(p != q) for p, q in zip(sets[:-1], sets[1:], strict=True)]
    assert any(opened_or_closed)


def test_wheel_positions_that_do_not_settle_are_refused(monkeypatch):
    """A wheel position whose closed supports still change after `MAX_SWEEPS` solves is
    refused with one line that counts them. Allowed one solve, on rough ballast, the rows
    started from their answer (found with the default allowance) settle in it and those
    started from every support closed do not (every answer has supports open, where the
    rail lifts off beyond the wheels): the count is the latter's, every third row."""
    from trackdyn.beam import railseat
    from trackdyn.errors import TrackdynInputError

    b = ballast()
    state = b.state(np.random.default_rng(15).uniform(0.0, 1.5e-3, (2, b.position.size)))
    centre = np.arange(b.position.size)
    at, loads = b.position[:, None] + WHEELS, np.tile(LOADS, (centre.size, 1))
    answer = b.wheel_forces(0, centre, at, loads)
    b.force_solve(0, state, answer)
    assert not np.any(answer.closed.all(axis=1))
    start = answer.closed.copy()
    start[::3] = True
    monkeypatch.setattr(railseat, "MAX_SWEEPS", 1)
    count = centre[::3].size
    with pytest.raises(TrackdynInputError, match=rf"^rail-seat forces: the contact of {count} "
                       r"wheel positions did not settle in 1 iterations$"):  # fmt: skip
        b.force_solve(0, state, b.wheel_forces(0, centre, at, loads, closed=start))
