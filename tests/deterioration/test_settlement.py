"""Settlement laws: closed forms, time-hardening integration, parameter files."""

import re

import numpy as np
import pytest

from trackdyn.deterioration.law_files import law_bounds, load_law
from trackdyn.deterioration.loop import step_size
from trackdyn.deterioration.settlement import (
    LAWS,
    PowerLaw,
    SatoLaw,
    ShentonLaw,
    time_hardening_increment,
)
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
    """The laws as printed in data.md, times the load and stiffness factor."""
    scale = (Q / law.Q_ref) ** law.load_exponent * (k2 / law.k_ref) ** law.stiffness_exponent
    if isinstance(law, PowerLaw):
        return law.K_s * scale * N**law.beta
    if isinstance(law, ShentonLaw):
        return scale * (law.k1 * N**0.2 + law.k2 * N)
    return scale * (law.gamma * (1 - np.exp(-law.alpha * N)) + law.beta * N)


@pytest.mark.parametrize("law", LAWS_UNDER_TEST, ids=lambda law: type(law).__name__)
def test_time_hardening_reproduces_closed_form_for_any_steps(law):
    """Under a constant load the increments telescope: e = f g(N_end) whatever the steps."""
    rng = np.random.default_rng(7)
    Q = np.array([30e3, 50e3, 65e3])  # rail-seat loads around Q_ref [N]
    k2 = np.array([60e6, 100e6, 150e6])  # track stiffness per wheel [N/m]
    factor = law.load_factor(Q, k2)
    for n_steps in (1, 3, 40):
        steps = rng.lognormal(0.0, 2.0, n_steps)  # steps spanning orders of magnitude
        steps *= 3.2e6 / steps.sum()  # 3.2e6 cycles: 50 MGT of the example traffic
        e, N = np.zeros(3), 0.0
        for dN in steps:
            e += time_hardening_increment(law, factor, N, dN)
            N += dN
        np.testing.assert_allclose(e, closed_form(law, Q, k2, 3.2e6), rtol=1e-12)


def test_power_law_at_reference_is_K_s_times_N_beta():
    law = LAWS_UNDER_TEST[0]
    # At Q = Q_ref, k2 = k_ref the factor is 1; one cycle gives K_s, 1e5 cycles 10 K_s.
    assert law.load_factor(50e3, 100e6) == 1.0
    assert law.load_factor(100e3, 50e6) == pytest.approx(2.0**2 * 0.5**-1)  # α = 2, γ = -1
    assert time_hardening_increment(law, 1.0, 0.0, 1.0) == pytest.approx(0.5e-3, rel=1e-15)
    assert time_hardening_increment(law, 1.0, 0.0, 1e5) == pytest.approx(5e-3, rel=1e-12)


def test_step_size_meets_the_limit_exactly():
    """Power law: the largest step solves f K_s ((N + n dM)^β - N^β) = limit in closed form."""
    law = LAWS_UNDER_TEST[0]
    factor = np.array([[0.8, 1.2], [1.0, 1.1]])
    N = np.full((2, 2), 1e4)
    n = 64520.0  # cycles per MGT: 8 wheels x 8065 passages
    limit = 0.5e-3
    expected = (((limit / (factor.max() * law.K_s) + N[0, 1] ** 0.2) ** 5) - N[0, 1]) / n

    def increment(dm):
        return time_hardening_increment(law, factor, N, n * dm)

    dm = step_size(increment, cap=100.0, limit=limit)
    assert dm == pytest.approx(expected, rel=1e-8)
    assert step_size(increment, cap=0.1 * expected, limit=limit) == 0.1 * expected


def test_shipped_file_gives_value_unit_source_and_is_labelled_illustrative():
    from trackdyn.deterioration.law_files import DEFAULT_FILE

    data = read_toml(DEFAULT_FILE)
    assert set(data) == set(LAWS)
    for name, table in data.items():
        for key, entry in table.items():
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
        load_law("power", beta=1.5)
    with pytest.raises(TrackdynInputError, match="unknown settlement parameter 'gamma'"):
        load_law("power", gamma=1.0)
    with pytest.raises(TrackdynInputError, match="cannot read the file"):
        load_law("power", tmp_path / "missing.toml")


def test_varandas_closed_forms():
    """Varandas, Hölscher & Silva (2014): N0 cycles of F0 settle gamma; a second batch of
    N cycles at F2 < F1 after N at F1 settles (gamma/M) F2^(a+1)/(a+1) (S(2N) - S(N)),
    with M = F0^(a+1)/(a+1) S(N0) and S(N) = sum n^-beta, summed here term by term."""
    from trackdyn.deterioration.accumulation import memory

    law = load_law("varandas")
    S = np.cumsum(np.arange(1, 2_000_001, dtype=float) ** -law.beta)  # S(n) = S[n - 1]
    acc = memory(law, (2, 1))
    total = 0.0
    for dm in (0.2, 0.3, 0.5):  # N0 cycles of F0 in three steps, 1e6 cycles per MGT
        inc = acc.prepare([(0, 1e6, np.array([law.F0]), np.array([1e8]))])
        total += inc(dm)[0, 0]
        acc.advance(dm)
    assert total == pytest.approx(law.gamma, rel=1e-3)
    F2 = 25e3  # half of F0, on the load grid
    inc = acc.prepare([(0, 1e6, np.array([F2]), np.array([1e8]))])
    a = law.alpha + 1
    expect = law.gamma / (law.F0**a / a * S[1_000_000 - 1]) * F2**a / a * (S[-1] - S[999_999])
    assert inc(1.0)[0, 0] == pytest.approx(expect, rel=1e-3)
    assert inc(1.0)[0, 0] < 0.1 * total  # loads below those already seen add little


@pytest.mark.parametrize("name", list(LAWS))
def test_load_sensitivity_is_the_slope_of_settlement_against_load(name):
    # The loop's stable step rests on d ln e / d ln Q. Measured here through the
    # accumulation the loop uses: 8065 cycles on fresh ballast at 60 and 66 kN (k2 fixed).
    # Every law is a pure power of the load for one load level (Varandas: F^(alpha + 1),
    # up to its 500 N load cells), so the finite-difference slope is the exponent.
    from trackdyn.deterioration.accumulation import memory

    law = load_law(name)
    e = []
    for q in (60e3, 66e3):
        acc = memory(law, (1, 3))
        increment = acc.prepare([(0, 8065.0, np.full(3, q), np.full(3, 100e6))])
        e.append(float(increment(1.0)[0, 1]))
    slope = np.log(e[1] / e[0]) / np.log(1.1)
    assert slope == pytest.approx(law.load_sensitivity, rel=2e-3)
