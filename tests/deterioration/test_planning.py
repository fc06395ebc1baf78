"""The maintenance plan: stretches, caps and deferral on forecasts made here, the
``"planned"`` policy alone, and a plan made and followed through `trackdyn deteriorate`."""

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.deterioration.maintenance import Maintenance, MaintenanceOptions
from trackdyn.deterioration.planning import (
    FIRST_YEAR_LEAD,
    Needs,
    Rules,
    make_plan,
    planned_tampings,
)
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import SoftSpot, synthetic_track

runner = CliRunner()


def random_line(seed, sections=3, segments=20, years=6, length=50.0):
    """Sections of ``segments`` 50 m segments whose forecast gives each segment a
    probability of needing tamping in each year (uniform), due at 0.5 and over, with the
    deterministic forecast at a uniform time in the year where it is 1."""
    rng = np.random.default_rng(seed)
    lines = []
    for k in range(sections):
        p = rng.uniform(size=(years, segments))
        p[p < 0.4] = 0.0  # most segments need nothing in a year
        reach = np.where(p >= 0.5, np.arange(years)[:, None] + rng.uniform(size=p.shape), np.nan)
        starts = np.arange(segments) * length
        lines.append(Needs(f"s{k}", starts, starts + length, p, reach))
    return lines


def rows(plan, lines):
    """(year, section, start, end, length) of every planned stretch."""
    return [(s.year, s.section, *s.bounds(lines[s.section]), s.length(lines[s.section]))
            for s in plan.stretches]  # fmt: skip


@pytest.mark.parametrize("seed", range(5))
def test_a_plan_never_tamps_less_than_the_minimum_stretch(seed):
    lines = random_line(seed)
    rules = Rules(years=6, annual_mgt=10.0, min_stretch_m=200.0, bridge_gap_m=100.0)
    plan = make_plan(lines, rules)
    assert plan.stretches
    assert all(length >= 200.0 for *_, length in rows(plan, lines))
    # stretches of one year and section do not overlap or touch closer than the bridged gap
    for year in range(1, 7):
        for k in range(3):
            mine = sorted((a, b) for y, s, a, b, _ in rows(plan, lines) if (y, s) == (year, k))
            assert all(b2 - e1 > 100.0 for (_, e1), (b2, _) in zip(mine, mine[1:], strict=False))


@pytest.mark.parametrize("seed", range(5))
def test_without_a_cap_every_due_segment_is_planned_before_its_forecast(seed):
    """Each segment the forecast tamps in a year (probability 1 here counts; at least 0.5
    makes it due) lies in a stretch of that year, tamped at the year's start, before the
    forecast's tonnage (the first year's at 1 % of its traffic)."""
    lines = random_line(seed)
    rules = Rules(years=6, annual_mgt=10.0, min_stretch_m=200.0, bridge_gap_m=100.0)
    plan = make_plan(lines, rules)
    assert not plan.deferred
    for k, needs in enumerate(lines):
        for year, j in zip(*np.nonzero(needs.probability >= 0.5), strict=True):
            held = [s for s in plan.stretches if (s.year, s.section) == (year + 1, k)
                    and j in s.segments]  # fmt: skip
            assert len(held) == 1
            assert max(year, FIRST_YEAR_LEAD) <= needs.reach_year[year, j] or year == 0
    tamped = {(k, at) for k, stretches in enumerate(planned_tampings(plan, lines, rules))
              for at, _, _ in stretches}  # fmt: skip
    assert {at for _, at in tamped} <= {0.1, *(10.0 * y for y in range(1, 6))}


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("cap", [("cap_m_per_year", 600.0), ("budget_per_year", 9000.0)])
def test_a_cap_is_never_exceeded_and_defers_the_least_likely(seed, cap):
    """600 m a year, or 9000 a year at 10 per metre and 500 per stretch."""
    lines = random_line(seed)
    rules = Rules(years=6, annual_mgt=10.0, min_stretch_m=200.0, bridge_gap_m=100.0,
                  tamping_per_m=10.0, per_possession=500.0, **{cap[0]: cap[1]})  # fmt: skip
    plan = make_plan(lines, rules)
    assert plan.deferred  # the random needs are more than the cap
    for year in range(1, 7):
        taken = [s for s in plan.stretches if s.year == year]
        length = sum(s.length(lines[s.section]) for s in taken)
        spent = sum(rules.cost(s.length(lines[s.section])) for s in taken)
        assert (length if cap[0] == "cap_m_per_year" else spent) <= cap[1]
        deferred = [s for s, _ in plan.deferred if s.year == year]
        if taken and deferred:
            least = min((s.probability, -s.reach_year) for s in taken)
            most = max((s.probability, -np.nan_to_num(s.reach_year, nan=np.inf)) for s in deferred)
            assert least >= most
    # what is deferred is due the next year (or listed as beyond the plan)
    for s, to in plan.deferred:
        assert to == (s.year + 1 if s.year < 6 else None)
        if to is not None:
            later = [t for t in plan.stretches if (t.year, t.section) == (to, s.section)]
            held = {j for t in later for j in t.segments}
            deferred_again = {j for d, _ in plan.deferred if (d.year, d.section) == (to, s.section)
                              for j in d.due}  # fmt: skip
            assert set(s.due) <= held | deferred_again


def test_a_short_gap_is_bridged_and_a_short_run_grows_to_the_likelier_side():
    """Segments of 50 m; 2 and 5 due (a 100 m gap, bridged at 100 m): one stretch 2-5;
    alone, 12 grows to 200 m towards the likelier side: 13 (0.3), then 11 (0.1 against
    14's 0), then on a tie to the left, 10: 10-13, 200 m from 2-5 (not bridged)."""
    p = np.zeros((1, 16))
    p[0, [2, 5, 12]] = 1.0
    p[0, 13], p[0, 11] = 0.3, 0.1
    starts = np.arange(16) * 50.0
    needs = Needs("a", starts, starts + 50.0, p, np.where(p == 1.0, 0.5, np.nan))
    plan = make_plan([needs], Rules(1, 10.0, min_stretch_m=200.0, bridge_gap_m=100.0))
    assert [s.segments for s in plan.stretches] == [(2, 3, 4, 5), (10, 11, 12, 13)]


def test_the_planned_policy_tamps_each_stretch_once_when_its_tonnage_has_come():
    options = MaintenanceOptions().model_copy(update={
        "policy": "planned", "planned": ((0.1, 0.0, 100.0), (10.0, 100.0, 200.0))})  # fmt: skip
    starts = np.arange(4) * 50.0
    m = Maintenance(options, np.arange(0.0, 200.0, 0.6), starts, starts + 50.0, 2.0)
    sd = np.zeros((2, 4))
    assert m.next_due(0.0) == 0.1 and m.next_due(0.1) == 10.0 and m.next_due(10.0) == np.inf
    assert m.due(0.05, sd).tolist() == []
    assert m.due(0.1, sd).tolist() == [0, 1]
    assert m.due(5.0, sd).tolist() == []  # done once
    assert m.due(10.0, sd).tolist() == [2, 3]


def test_the_planned_policy_is_not_a_maintenance_key(tmp_path):
    (tmp_path / "s.toml").write_text('[maintenance]\npolicy = "planned"\n')
    result = runner.invoke(app, ["deteriorate", str(tmp_path / "s.toml"), "--out",
                                 str(tmp_path / "out")])  # fmt: skip
    assert result.exit_code == 2
    assert "come from a scenario's [plan] table" in " ".join(result.output.split())


SCENARIO = """
[run]
model = "4dof"
[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[settlement]
law = "sato"
[loop]
snapshot_every_mgt = 2
segment_length_m = 30           # four segments of the 120 m section (D1: at least 25 m)
threshold_sd_mm = 0.12          # the soft spot's segments reach it within a year
[maintenance]
min_interval_mgt = 3
recovery_offset_mm = 0.05
horizon_years = 4
annual_mgt = 2
[plan]
min_stretch_m = 60
bridge_gap_m = 30
tamping_per_m = 10
per_possession = 100
currency = "EUR"
[track]
geometry = "geometry.csv"
supports = "supports.csv"
"""


@pytest.fixture(scope="module", params=[None, 60.0], ids=["uncapped", "capped"])
def planned(request, tmp_path_factory):
    """`trackdyn deteriorate` with ``[plan]`` on a 120 m section with a soft spot at 30 m
    (rate field cov 0.3, seed 0), without and with a cap of 60 m a year: its folder."""
    path = tmp_path_factory.mktemp("plan")
    spot = SoftSpot(centre=30.0, length=6.0, factor=0.45, gap=1.5e-3)
    trk = synthetic_track(120.0, spectrum=None, stiffness_cov=0.0, seed=1, features=(spot,))
    write_geometry(trk.geometry, path / "geometry.csv")
    write_supports(trk.supports, path / "supports.csv")
    cap = "" if request.param is None else f"cap_m_per_year = {request.param}\n"
    (path / "scenario.toml").write_text(SCENARIO.replace("[track]", f"{cap}[track]"))
    out = path / "out"
    args = ["deteriorate", str(path / "scenario.toml"), "--out", str(out), "--workers", "1"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return out, request.param


def test_a_followed_plan_gives_the_tampings_it_planned(planned):
    out, _ = planned
    plan = pd.read_csv(out / "plan.csv")
    done = pd.read_csv(out / "plan_interventions.csv")
    assert len(plan) and plan.cost_EUR.tolist() == (10.0 * plan.length_m + 100.0).tolist()
    expected = {(y, a) for y, s, e in zip(plan.year, plan.start_m, plan.end_m, strict=True)
                for a in np.arange(0.5, 120.0, 30.0)[:4] if s <= a < e}  # fmt: skip
    # tamped at the year's start (2 MGT a year; the first year's at 1 % of it, 0.02 MGT)
    assert set(done.mgt) <= {max(y - 1, 0.01) * 2.0 for y in plan.year}
    got = {(int(m // 2.0) + 1, a) for m, a in zip(done.mgt, done.segment_start_m, strict=True)}
    assert got == expected
    assert (out / "plan.png").is_file() and (out / "plan_life_cycle.csv").is_file()


def test_without_a_cap_every_segment_is_planned_before_the_run_reaches_the_threshold(planned):
    out, cap = planned
    if cap is not None:
        pytest.skip("the uncapped plan")
    plan = pd.read_csv(out / "plan.csv")
    run = pd.read_csv(out / "interventions.csv")  # the deterministic run's tampings
    for mgt, start in zip(run.mgt, run.segment_start_m, strict=True):
        year = int(mgt // 2.0) + 1  # 2 MGT a year, 4 years
        mine = plan[(plan.year == year) & (plan.start_m <= start) & (plan.end_m > start)]
        assert len(mine) == 1
        assert max(year - 1, 0.01) * 2.0 <= mgt


def test_a_capped_plan_stays_under_its_cap_and_lists_what_it_defers(planned):
    out, cap = planned
    if cap is None:
        pytest.skip("the capped plan")
    plan = pd.read_csv(out / "plan.csv")
    deferred = pd.read_csv(out / "plan_deferred.csv")
    assert plan.groupby("year").length_m.sum().max() <= cap
    assert len(deferred)  # 60 m a year is less than the section needs
    assert deferred.d1_sd_year_end_mm.notna().all()


def test_a_budget_below_every_stretch_plans_nothing_and_defers_everything(tmp_path):
    # a budget of 650 a year against 700 for the shortest stretch (60 m at 10 a metre and
    # 100 a possession): no stretch fits, so the plan has no row (its files and figure
    # still written, the header kept; a KeyError from the empty table's figure before)
    spot = SoftSpot(centre=30.0, length=6.0, factor=0.45, gap=1.5e-3)
    trk = synthetic_track(120.0, spectrum=None, stiffness_cov=0.0, seed=1, features=(spot,))
    write_geometry(trk.geometry, tmp_path / "geometry.csv")
    write_supports(trk.supports, tmp_path / "supports.csv")
    scenario = SCENARIO.replace("[track]", "budget_per_year = 650\n[track]")
    (tmp_path / "scenario.toml").write_text(scenario)
    out = tmp_path / "out"
    args = ["deteriorate", str(tmp_path / "scenario.toml"), "--out", str(out), "--workers", "1"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    plan = pd.read_csv(out / "plan.csv")
    assert plan.empty and "cost_EUR" in plan.columns and "year" in plan.columns
    deferred = pd.read_csv(out / "plan_deferred.csv")
    assert len(deferred) and (out / "plan.png").is_file()
    assert deferred.deferred_to.isna().any()  # what no year of the horizon could take
