"""Life-cycle costs: present values in closed form, possessions, the residual rule."""

import numpy as np
import pytest
import xarray as xr

from trackdyn.commands.deteriorate.scenario import DeteriorationScenario
from trackdyn.commands.interventions import Costs
from trackdyn.errors import TrackdynInputError
from trackdyn.studies.life_cycle import (
    Rates,
    costs,
    discounted_work,
    end_state,
    possessions,
    present_value,
)
from trackdyn.units import currency


def section(interventions, sd_end, horizon=30.0, length=50.0):
    """A section's result with only what costing reads: four segments of ``length`` [m],
    the interventions ``(mgt, segment, kind)`` and the D1 SD at the horizon per segment
    (the same on both rails) [mm]."""
    n = len(sd_end)
    mgt, seg, kind = (np.array(v) for v in zip(*interventions, strict=True)) if interventions \
        else (np.zeros(0), np.zeros(0, int), np.zeros(0, str))  # fmt: skip
    sd = np.stack([np.zeros((2, n)), np.broadcast_to(sd_end, (2, n))])
    return xr.Dataset({
        "segment_start": ("segment", np.arange(n) * length),
        "segment_end": ("segment", (np.arange(n) + 1) * length),
        "intervention_mgt": ("intervention", mgt.astype(float)),
        "intervention_segment": ("intervention", seg.astype(int)),
        "intervention_kind": ("intervention", kind.astype(str)),
        "d1_sd": (("mgt", "rail", "segment"), sd),
    }, coords={"mgt": [0.0, horizon]})  # fmt: skip


def test_npv_of_an_annuity_is_its_closed_form():
    """1000 a year at the end of years 1-10 at 4 %: 1000 (1 - 1.04^-10) / 0.04 = 8110.90
    (the present value of an annuity)."""
    years = np.arange(1.0, 11.0)
    got = float(present_value(np.full(10, 1000.0), years, 0.04).sum())
    assert got == pytest.approx(1000.0 * (1 - 1.04**-10) / 0.04, rel=1e-12)
    assert got == pytest.approx(8110.90, abs=0.01)


def test_a_tonnage_is_discounted_at_its_year():
    """25 MGT at 10 MGT/year is reached at 2.5 years: 1000 / 1.04^2.5."""
    rates = Rates(discount_rate=0.04, annual_mgt=10.0)
    assert float(rates.at(1000.0, 25.0)) == pytest.approx(1000.0 / 1.04**2.5, rel=1e-12)
    assert float(Rates().at(1000.0, 25.0)) == 1000.0  # undiscounted: the amount itself
    with pytest.raises(TrackdynInputError, match="discount_rate needs annual_mgt"):
        Rates(discount_rate=0.04).at(1000.0, 25.0)


def test_each_contiguous_run_at_one_tonnage_is_one_possession():
    ds = section([(5.0, 0, "tamping"), (5.0, 1, "tamping"), (5.0, 3, "renewal"),
                  (9.0, 1, "tamping")], [1.0, 1.0, 1.0, 1.0])  # fmt: skip
    # at 5 MGT segments 0-1 and 3 (two runs), at 9 MGT segment 1 (one)
    assert possessions(ds) == [(5.0, [0, 1]), (5.0, [3]), (9.0, [1])]


def test_the_end_state_owes_the_tamping_of_what_reached_the_reference():
    """Segments 1 and 2 (adjacent: one possession) end at or over the 2 mm reference,
    segment 3 last tamped at 21 MGT: over 30 MGT, 9 MGT since."""
    ds = section([(21.0, 3, "tamping")], [1.0, 2.0, 2.5, 1.9])
    end = end_state(ds, 2.0)
    assert end.needs_work.tolist() == [False, True, True, False]
    assert end.since_tamping_mgt.tolist() == [30.0, 30.0, 30.0, 9.0]
    rates = Rates(tamping_per_m=10.0, per_possession=100.0, reference_sd_mm=2.0)
    work = discounted_work(ds, rates)
    assert work["residual_m"] == 100.0 and work["residual_possessions"] == 1.0
    got = costs(work, rates)
    # tamping: 50 m x 10 + 100 possession = 600; residual: 100 m x 10 + 100 = 1100
    assert got["tamping_cost"] + got["possession_cost"] == 600.0
    assert got["residual_cost"] == 1100.0
    assert got["life_cycle_cost"] == 1700.0
    assert costs(discounted_work(ds, Rates(tamping_per_m=10.0)), Rates())["residual_cost"] == 0


def test_the_condition_rule_charges_the_share_of_a_tamping_used():
    """The same section, the condition rule with σ_t = 1.2 mm (0.6 + 0.3 x 2 mm): segment
    shares (1.0 - 1.2)/0.8 -> 0, (2.0 - 1.2)/0.8 = 1, 1 (over the reference), (1.9 -
    1.2)/0.8 = 0.875; residual 50 m x (0 + 1 + 1 + 0.875) = 143.75 m at 10 per m plus the
    one possession of the run that needs work (segments 1-2)."""
    ds = section([(21.0, 3, "tamping")], [1.0, 2.0, 2.5, 1.9])
    end = end_state(ds, 2.0, 1.2)
    np.testing.assert_allclose(end.residual_share, [0.0, 1.0, 1.0, 0.875], rtol=1e-12)
    rates = Rates(tamping_per_m=10.0, per_possession=100.0, reference_sd_mm=2.0,
                  tamped_sd_mm=1.2)  # fmt: skip
    work = discounted_work(ds, rates)
    assert work["residual_m"] == pytest.approx(143.75) and work["residual_possessions"] == 1.0
    assert costs(work, rates)["residual_cost"] == pytest.approx(1537.5)


def test_discounted_costs_of_a_known_stream():
    """A tamping of 50 m at 10 MGT and a renewal of 50 m at 20 MGT, 10 MGT/year, 5 %; the
    residual of segment 2 at the horizon (30 MGT, year 3); the intervention in year 1."""
    ds = section([(10.0, 0, "tamping"), (20.0, 1, "renewal")], [1.0, 1.0, 3.0, 1.0])
    rates = Rates(10.0, 200.0, 100.0, 0.05, 10.0, 2.0)
    got = costs(discounted_work(ds, rates), rates, intervention=5000.0, intervention_year=1.0)
    assert got["tamping_cost"] == pytest.approx(500.0 / 1.05)
    assert got["renewal_cost"] == pytest.approx(10000.0 / 1.05**2)
    assert got["possession_cost"] == pytest.approx(100.0 / 1.05 + 100.0 / 1.05**2)
    assert got["intervention_cost"] == pytest.approx(5000.0 / 1.05)
    assert got["residual_cost"] == pytest.approx(600.0 / 1.05**3)
    parts = sum(v for k, v in got.items() if k != "life_cycle_cost")
    assert got["life_cycle_cost"] == pytest.approx(parts)


def test_costs_default_to_the_scenarios_traffic_and_threshold():
    scenario = DeteriorationScenario.model_validate(
        {"loop": {"threshold_sd_mm": 1.8},
         "maintenance": {"horizon_years": 10, "annual_mgt": 12}})  # fmt: skip
    rates = Costs(discount_rate=0.03).rates(scenario)
    assert (rates.annual_mgt, rates.reference_sd_mm) == (12.0, 1.8)
    assert Costs(residual="none").rates(scenario).reference_sd_mm is None
    with pytest.raises(TrackdynInputError, match=r"\[costs\] discount_rate needs annual_mgt"):
        Costs(discount_rate=0.03).rates(DeteriorationScenario())


@pytest.mark.parametrize("code", ["EUR", "ZAR", "cu"])
def test_a_currency_is_a_short_word(code):
    assert currency(code) == code


@pytest.mark.parametrize("code", ["t", "m", "kN", "euro cents", ""])
def test_a_currency_that_reads_as_a_unit_or_is_no_word_is_refused(code):
    with pytest.raises(ValueError, match="currency"):
        currency(code)
