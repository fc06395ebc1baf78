"""Settlement laws: closed forms, their integration over steps, parameter files."""

import re

import numpy as np
import pytest

from trackdyn.deterioration.accumulation import memory
from trackdyn.deterioration.law_files import law_bounds, load_law, zone_kinds
from trackdyn.deterioration.loop import step_size
from trackdyn.deterioration.settlement import LAWS, PowerLaw, SatoLaw, ShentonLaw, harmonic
from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_toml

COMMON = {"Q_ref": 50e3, "load_exponent": 2.0, "k_ref": 100e6, "stiffness_exponent": -1.0}
# Arbitrary but typical values (the shipped file's orders of magnitude), SI units.
LAWS_UNDER_TEST = [
    PowerLaw(K_s=0.5e-3, beta=0.2, **COMMON),
    ShentonLaw(k1=0.5e-3, k2=3e-10, **COMMON),
    SatoLaw(gamma=3e-3, alpha=2e-6, beta=1e-9, **COMMON),
]


def closed_form(law, Q, k2, N):
    """The laws as published (Shenton 1985, Sato 1995; the power law with Shenton's
    exponent), times the load and stiffness factor, for N >= 1 cycle."""
    scale = (Q / law.Q_ref) ** law.load_exponent * (k2 / law.k_ref) ** law.stiffness_exponent
    if isinstance(law, PowerLaw):
        return law.K_s * scale * N**law.beta
    if isinstance(law, ShentonLaw):
        return scale * (law.k1 * N**0.2 + law.k2 * N)
    return scale * (law.gamma * (1 - np.exp(-law.alpha * N)) + law.beta * N)


def accumulate(law, loads, per_mgt, steps, k2=100e6, sleepers=3):
    """Settlement of ``sleepers`` left-rail seats after ``steps`` [MGT], each wheel ``j``
    with rail-seat load ``loads[j]`` [N] (per sleeper or one for all) and ``per_mgt[j]``
    cycles per MGT, through the accumulator the loop uses."""
    acc = memory(law, (2, sleepers), len(loads))
    e = np.zeros(sleepers)
    for dm in steps:
        seats = (sleepers,)
        cycles = [(j, 0, n, np.broadcast_to(np.asarray(q, float), seats), np.full(seats, k2))
                  for j, (q, n) in enumerate(zip(loads, per_mgt, strict=True))]  # fmt: skip
        inc = acc.prepare(cycles)(dm)
        e += inc[0]
        np.testing.assert_allclose(
            acc.advance(dm).sum(axis=0)[0], inc[0], rtol=1e-12, atol=1e-18
        )  # the vehicles' parts add up to the increment
    return e


@pytest.mark.parametrize("law", LAWS_UNDER_TEST, ids=lambda law: type(law).__name__)
def test_accumulation_reproduces_closed_form_for_any_steps(law):
    """Under a constant load the increments telescope: e = f g(N_end) whatever the steps."""
    rng = np.random.default_rng(7)
    Q = np.array([30e3, 50e3, 65e3])  # rail-seat loads around Q_ref [N]
    k2 = np.array([60e6, 100e6, 150e6])  # track stiffness per wheel [N/m]
    for n_steps in (1, 3, 40):
        steps = rng.lognormal(0.0, 2.0, n_steps)  # steps spanning orders of magnitude
        steps *= 50.0 / steps.sum()  # 50 MGT of 64 000 cycles: 3.2e6 cycles
        acc = memory(law, (2, 3), 1)
        e = np.zeros(3)
        for dm in steps:
            e += acc.prepare([(0, 0, 64e3, Q, k2)])(dm)[0]
            acc.advance(dm)
        np.testing.assert_allclose(e, closed_form(law, Q, k2, 3.2e6), rtol=1e-10)


def test_power_law_at_reference_is_K_s_times_N_beta():
    law = LAWS_UNDER_TEST[0]
    # At Q = Q_ref, k2 = k_ref the factor is 1; one cycle gives K_s, 1e5 cycles 10 K_s.
    assert law.load_factor(50e3, 100e6) == 1.0
    assert law.load_factor(100e3, 50e6) == pytest.approx(2.0**2 * 0.5**-1)  # α = 2, γ = -1
    assert law.cycles(1.0) == pytest.approx(0.5e-3, rel=1e-15)
    assert law.cycles(1e5) == pytest.approx(5e-3, rel=1e-12)


@pytest.mark.parametrize("name", list(LAWS))
def test_no_law_settles_for_a_fraction_of_a_cycle_more_than_that_fraction(name):
    """Counting starts at whole cycles: 0.08 of a cycle settles 0.08 of the first cycle's
    settlement (before, the power law gave 0.08^0.2 = 0.60 of it)."""
    law = load_law(name)
    one, part = (accumulate(law, [law.Q_ref if name != "varandas" else law.F0], [n], [1.0])[0]
                 for n in (1.0, 0.08))  # fmt: skip
    assert part == pytest.approx(0.08 * one, rel=1e-9)


def test_power_law_mixed_traffic_is_the_equivalent_cycle_closed_form():
    """Cycles of Q count as N (Q/Q_ref)^(α/β) cycles of Q_ref (the strain-hardening rule of
    Stewart 1986 for a power law), so mixed traffic in any steps settles
    K_s (Σ_j n_j M (Q_j/Q_ref)^(α/β))^β (uniform stiffness k_ref)."""
    law = LAWS_UNDER_TEST[0]
    rng = np.random.default_rng(3)
    for _ in range(5):
        k = rng.integers(2, 6)
        loads, per_mgt = rng.uniform(10e3, 90e3, k), rng.uniform(1e3, 6e4, k)
        steps = rng.lognormal(0.0, 1.5, 7)
        total = steps.sum()
        expected = law.K_s * (np.sum(per_mgt * total * (loads / law.Q_ref) ** (2.0 / 0.2))) ** 0.2
        e = accumulate(law, loads, per_mgt, steps)
        np.testing.assert_allclose(e, expected, rtol=1e-10)


@pytest.mark.parametrize("name", list(LAWS))
def test_adding_a_vehicle_never_lowers_settlement(name):
    """Random mixes of 2-5 wheels' load levels (rail-seat loads of 5-35 t axles, about
    12-90 kN) and passages, then one more: no sleeper settles less, for every law. The
    old rule (cycle-weighted mean load factor times the curve of all cycles) fails this:
    adding the empties of the example traffic lowered the power-law settlement 6.58 ->
    3.97 mm on a 300 m section over 10 MGT."""
    law = load_law(name)
    rng = np.random.default_rng(11)
    for _ in range(20):
        k = rng.integers(2, 6)
        loads = rng.uniform(12e3, 90e3, (k, 4))  # per wheel, four sleepers
        per_mgt = rng.uniform(100.0, 3e4, k)
        steps = rng.lognormal(-1.0, 1.0, 4)
        base = accumulate(law, list(loads[:-1]), per_mgt[:-1], steps, sleepers=4)
        more = accumulate(law, list(loads), per_mgt, steps, sleepers=4)
        assert np.all(more >= base * (1 - 1e-12))
        assert np.all(more > base)  # the added cycles settle something


def test_step_size_meets_the_limit_exactly():
    """Power law: the largest step solves f K_s ((N + n dM)^β - N^β) = limit in closed form."""
    law = LAWS_UNDER_TEST[0]
    factor = np.array([[0.8, 1.2], [1.0, 1.1]])
    N = np.full((2, 2), 1e4)
    n = 64520.0  # cycles per MGT: 8 wheels x 8065 passages
    limit = 0.5e-3
    expected = (((limit / (factor.max() * law.K_s) + N[0, 1] ** 0.2) ** 5) - N[0, 1]) / n

    def increment(dm):
        return factor * law.K_s * ((N + n * dm) ** law.beta - N**law.beta)

    dm = step_size(increment, cap=100.0, limit=limit)
    assert dm == pytest.approx(expected, rel=1e-8)
    assert step_size(increment, cap=0.1 * expected, limit=limit) == 0.1 * expected


def test_shipped_file_gives_value_unit_source_and_is_labelled_illustrative():
    from trackdyn.deterioration.law_files import DEFAULT_FILE

    data = read_toml(DEFAULT_FILE)
    assert set(data) == set(LAWS) | {"voids"}  # voids: tests/deterioration/test_voids.py
    data.pop("voids")
    for name, table in data.items():
        assert zone_kinds(name) == ["open", "structure", "approach"]
        kinds = [table.pop(k) for k in ("structure", "approach")]
        entries = [e for k in kinds for e in k.items()] + list(table.items())
        for key, entry in entries:
            if key != "description":
                assert (
                    {"value", "unit", "source"}
                    <= set(entry)
                    <= {"value", "unit", "source", "min", "max"}
                )
                assert "illustrative" in entry["source"], (name, key)
    law = load_law("power")
    # settlement.toml: K_s = 0.5 mm, Q_ref = 50 kN, k_ref = 100 kN/mm, converted to SI
    assert (law.K_s, law.Q_ref, law.k_ref) == pytest.approx((0.5e-3, 50e3, 100e6))
    assert load_law("power", K_s=1e-3).K_s == 1e-3  # overrides in SI units
    assert isinstance(load_law("sato"), SatoLaw) and isinstance(load_law("shenton"), ShentonLaw)
    # [power.structure] K_s = 0.15 mm, [power.approach] 1 mm; the rest as open track
    assert load_law("power", kind="structure").K_s == pytest.approx(0.15e-3)
    assert load_law("power", kind="approach").K_s == pytest.approx(1e-3)
    assert load_law("power", kind="approach").Q_ref == law.Q_ref
    with pytest.raises(TrackdynInputError, match=r"unknown zone kind .*'tunnel'; known: open"):
        load_law("power", kind="tunnel")
    # settlement.toml: K_s between 0.01 and 10 mm, stiffness_exponent between -3 and 1
    bounds = law_bounds("power")
    assert bounds["K_s"] == pytest.approx((1e-5, 1e-2))
    assert bounds["stiffness_exponent"] == (-3.0, 1.0)
    assert "Q_ref" not in bounds  # a reference scale, not for fitting


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ('{ value = 1, unit = "mm", min = 0.1, source = "x" }', "gives min but not both"),
        ('{ value = 1, unit = "mm", min = 2, max = 0.1, source = "x" }', "needs min < max"),
        ('{ value = 1, unit = "mm", min = "a", max = 2, source = "x" }', "K_s min is not a number"),
    ],
)
def test_bad_bounds_are_refused(tmp_path, entry, message):
    path = tmp_path / "law.toml"
    path.write_text(f"[power]\nK_s = {entry}\n")
    with pytest.raises(TrackdynInputError, match=message):
        law_bounds("power", path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[power]\nK_s = { value = 1, unit = "furlong", source = "x" }', "unit 'furlong' of K_s"),
        ('[power]\nK_s = { value = 1, unit = "mm" }', "K_s needs value, unit and source"),
        ('[power]\nK_z = { value = 1, unit = "mm", source = "x" }', "unknown parameter 'K_z'"),
        ('[power]\nK_s = { value = 1, unit = "mm", source = "x" }', "missing parameter Q_ref"),
        ('[sato]\ngamma = { value = 1, unit = "mm", source = "x" }', "no table [power]"),
    ],
)
def test_bad_parameter_files(tmp_path, text, message):
    path = tmp_path / "law.toml"
    path.write_text(text)
    with pytest.raises(TrackdynInputError, match=re.escape(message)):
        load_law("power", path)


def test_bad_law_name_value_and_file(tmp_path):
    with pytest.raises(TrackdynInputError, match="unknown settlement law 'linear'"):
        load_law("linear")
    with pytest.raises(TrackdynInputError, match="beta must be <= 1"):
        PowerLaw(K_s=0.5e-3, beta=1.5, **COMMON)
    # an override outside the file's min and max (settlement.toml: beta 0.05 to 1)
    with pytest.raises(TrackdynInputError, match="beta = 1.5 - is outside the plausible 0.05 to 1"):
        load_law("power", beta=1.5)
    with pytest.raises(
        TrackdynInputError, match="unknown settlement parameter of the power law 'gamma'"
    ):
        load_law("power", gamma=1.0)
    with pytest.raises(TrackdynInputError, match="missing.toml: no such file"):
        load_law("power", tmp_path / "missing.toml")


@pytest.mark.parametrize("beta", [0.2, 0.6, 0.82, 0.95])
def test_harmonic_is_the_sum_of_its_terms(beta):
    """``S(n) = sum_{k=1}^{n} k^-beta`` summed term by term, within the 1e-9 its docstring
    states, on both sides of the shift to 9 and far beyond; below one cycle ``S(h) = h``."""
    n = np.array([1, 2, 8, 9, 10, 123, 100_000])
    terms = np.cumsum(np.arange(1, n[-1] + 1, dtype=float) ** -beta)
    np.testing.assert_allclose(harmonic(n, beta), terms[n - 1], rtol=1e-9)
    np.testing.assert_array_equal(harmonic(np.array([0.0, 0.25, 0.999]), beta), [0, 0.25, 0.999])
    assert harmonic(np.ones((2, 3)), beta).shape == (2, 3)


def test_varandas_closed_forms():
    """Varandas, Hölscher & Silva (2014): N0 cycles of F0 settle gamma; a second batch of
    N cycles at F2 < F1 after N at F1 settles (gamma/M) F2^(a+1)/(a+1) (S(2N) - S(N)),
    with M = F0^(a+1)/(a+1) S(N0) and S(N) = sum n^-beta, summed here term by term."""
    law = load_law("varandas")
    S = np.cumsum(np.arange(1, 2_000_001, dtype=float) ** -law.beta)  # S(n) = S[n - 1]
    acc = memory(law, (2, 1), 1)
    total = 0.0
    for dm in (0.2, 0.3, 0.5):  # N0 cycles of F0 in three steps, 1e6 cycles per MGT
        inc = acc.prepare([(0, 0, 1e6, np.array([law.F0]), np.array([1e8]))])
        total += inc(dm)[0, 0]
        acc.advance(dm)
    assert total == pytest.approx(law.gamma, rel=1e-3)
    F2 = 25e3  # half of F0, on the load grid
    inc = acc.prepare([(0, 0, 1e6, np.array([F2]), np.array([1e8]))])
    a = law.alpha + 1
    expect = law.gamma / (law.F0**a / a * S[1_000_000 - 1]) * F2**a / a * (S[-1] - S[999_999])
    assert inc(1.0)[0, 0] == pytest.approx(expect, rel=1e-3)
    assert inc(1.0)[0, 0] < 0.1 * total  # loads below those already seen add little


def test_varandas_cells_that_grow_alike_are_evaluated_once_to_the_same_settlement():
    """The load histogram's cells of one rail seat with the same history and cycles are
    made one (their weights added) for the increment: over five steps of two vehicles at
    random loads (20-130 kN) on 2 x 4 rail seats, the increment and each vehicle's part
    of it equal the sum over every cell, ``(gamma / M) Σ w_k (S(h_k + r_k ΔM) - S(h_k))``,
    to round-off (1e-10)."""
    from trackdyn.deterioration.accumulation import LOAD_GRID

    law = load_law("varandas")
    acc, rng, a, dm = memory(law, (2, 4), 2), np.random.default_rng(12), law.alpha + 1, 0.3
    for _ in range(5):
        cycles = [(v, r, 1e5 * (v + 1), rng.uniform(20e3, 130e3, 4), np.full(4, 1e8))
                  for v in range(2) for r in range(2)]  # fmt: skip
        increment = acc.prepare(cycles)
        h, rate = acc.h, acc._rate
        w = np.diff((np.arange(h.shape[-1] + 1) * LOAD_GRID) ** a) / a
        cells = w * (harmonic(h + rate * dm, law.beta) - harmonic(h, law.beta))
        direct = law.gamma / law.M * cells.sum(-1)
        np.testing.assert_allclose(increment(dm), direct, rtol=1e-10)
        parts = acc.advance(dm)
        np.testing.assert_allclose(parts.sum(0), direct, rtol=1e-10)
        assert np.all(parts > 0)  # each vehicle's cycles reach cells the other's do not


def test_varandas_cells_get_each_wheels_fraction_of_them_below_its_load():
    """The histogram's growth per MGT of each cell is the sum over the wheels of their
    cycles per MGT times the fraction of the cell below their load, clipped to [0, 1]:
    equal, to the bit, to that formula written out in numpy, for loads on, between and
    below the grid's edges; and loads that are all zero settle nothing (no cell reached)."""
    from trackdyn.deterioration.accumulation import LOAD_GRID

    law = load_law("varandas")
    acc, rng = memory(law, (2, 6), 2), np.random.default_rng(3)
    loads = [np.r_[rng.uniform(0.0, 90e3, 4), 40e3, 0.0] for _ in range(4)]  # 40 kN: an edge
    cycles = [(v, r, 1e5 * (v + 1) + 7.0 * r, loads[2 * v + r], np.full(6, 1e8))
              for v in range(2) for r in range(2)]  # fmt: skip
    acc.prepare(cycles)
    edges = np.arange(acc.h.shape[-1] + 1) * LOAD_GRID
    want = np.zeros((2, 2, 6, edges.size - 1))
    for v, r, w, q, _ in cycles:
        want[v, r] += w * np.clip((q[:, None] - edges[:-1]) / LOAD_GRID, 0.0, 1.0)
    np.testing.assert_array_equal(acc._rate, want.sum(axis=0))
    none = memory(law, (2, 3), 1)
    increment = none.prepare([(0, r, 1e5, np.zeros(3), np.full(3, 1e8)) for r in range(2)])
    np.testing.assert_array_equal(increment(1.0), np.zeros((2, 3)))
    np.testing.assert_array_equal(none.advance(1.0), np.zeros((1, 2, 3)))


@pytest.mark.parametrize("name", list(LAWS))
def test_load_sensitivity_is_the_slope_of_settlement_against_load(name):
    # The loop's stable step rests on d ln e / d ln Q. Measured here through the
    # accumulation the loop uses: 8065 cycles on fresh ballast at 60 and 66 kN (k2 fixed).
    # Every law is a pure power of the load for one load level (Varandas: F^(alpha + 1),
    # up to its 500 N load cells), so the finite-difference slope is the exponent.
    law = load_law(name)
    e = []
    for q in (60e3, 66e3):
        acc = memory(law, (1, 3), 1)
        increment = acc.prepare([(0, 0, 8065.0, np.full(3, q), np.full(3, 100e6))])
        e.append(float(increment(1.0)[0, 1]))
    slope = np.log(e[1] / e[0]) / np.log(1.1)
    assert slope == pytest.approx(law.load_sensitivity, rel=2e-3)


def test_the_old_cycle_weighting_rule_fails_the_traffic_check():
    """The check above can fail: the rule it replaces (cycle-weighted mean load factor
    times the curve of the total cycle count) lowers the power-law settlement when empties
    (rail-seat load 12 kN) join loaded wagons (60 kN), while the equivalent cycles raise it."""
    law = LAWS_UNDER_TEST[0]

    def old_rule(loads, per_mgt, mgt):
        f = law.load_factor(np.array(loads), law.k_ref)
        n = np.array(per_mgt)
        return float(np.sum(n * f) / n.sum() * law.cycles(n.sum() * mgt))

    loaded, both = ([60e3], [32e3]), ([60e3, 12e3], [32e3, 32e3])
    assert old_rule(*both, 10.0) < 0.8 * old_rule(*loaded, 10.0)
    assert accumulate(law, *both, [10.0])[0] > accumulate(law, *loaded, [10.0])[0]
