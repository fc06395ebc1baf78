"""Interventions study: a soft-spot fix, an alternative without changes, costs, bad input."""

import dataclasses

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.commands.deteriorate.scenario import load_deterioration
from trackdyn.commands.deteriorate.sections import section_tasks
from trackdyn.commands.interventions import (
    InterventionsStudy,
    alternative_tasks,
    run_alternatives,
)
from trackdyn.deterioration.runs import run_sections
from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_supports, write_geometry, write_supports
from trackdyn.options import load_toml
from trackdyn.studies.interventions import Scale, scale_supports
from trackdyn.track.synthetic import SoftSpot, synthetic_track

runner = CliRunner()

SPOT = SoftSpot(centre=30.0, length=6.0, factor=0.45, gap=1.5e-3)
"""The soft spot: full from 27 to 33 m, cosine taper to 21 and 39 m (`SoftSpot.weight`)."""

SCENARIO = """
[run]
model = "4dof"
[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[settlement]
law = "sato"
rate_cov = 0.0                  # uniform ballast: only the soft spot makes it uneven
[loop]
total_mgt = 8
snapshot_every_mgt = 4
segment_length_m = 60           # two segments: 0.5-60.5 m (the soft spot), 60.5-119.5 m
threshold_sd_mm = 0.12          # reached by the soft spot's segment in a few MGT
[maintenance]
min_interval_mgt = 1
recovery_offset_mm = 0.05       # below the threshold, so a tamping brings the segment back
[track]
geometry = "geometry.csv"
supports = "supports.csv"
"""

STUDY = """
kind = "interventions"
scenario = "scenario.toml"
[costs]
tamping_per_m = 10.0
renewal_per_m = 100.0
[[alternative]]
name = "base"
[[alternative]]
name = "spot-fixed"
cost = 1000.0
supports_scale = [{ from_m = 21, to_m = 39, factor = 2.2222222222 }]   # 1 / 0.45
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A 120 m level section with a soft spot at 30 m, a scenario and a study."""
    path = tmp_path_factory.mktemp("interventions")
    trk = synthetic_track(120.0, spectrum=None, stiffness_cov=0.0, seed=1, features=(SPOT,))
    write_geometry(trk.geometry, path / "geometry.csv")
    write_supports(trk.supports, path / "supports.csv")
    (path / "scenario.toml").write_text(SCENARIO)
    (path / "study.toml").write_text(STUDY)
    return path


@pytest.fixture(scope="module")
def compared(folder, tmp_path_factory):
    """The study run through the CLI, serially: its output folder."""
    out = tmp_path_factory.mktemp("out") / "out"
    args = ["study", str(folder / "study.toml"), "--out", str(out), "--workers", "1"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return out


def test_scaled_supports_divide_the_deflections_in_the_range_only(folder, tmp_path):
    scale_supports(folder / "supports.csv", tmp_path / "s.csv", [Scale(21.0, 39.0, 2.0)])
    before, after = read_supports(folder / "supports.csv"), read_supports(tmp_path / "s.csv")
    inside = (before.position >= 21.0) & (before.position <= 39.0)
    for rail in ("left", "right"):
        b, a = getattr(before, rail), getattr(after, rail)
        for i in range(len(b)):
            np.testing.assert_allclose(a[i].load, b[i].load)
            expected = b[i].deflection / (2.0 if inside[i] else 1.0)  # the scaling's definition
            np.testing.assert_allclose(a[i].deflection, expected, rtol=1e-8)


def test_a_ramp_runs_the_factor_linearly_over_its_range(folder, tmp_path):
    """A transition treatment: stiffness rising linearly from 1 at 21 m to 3 at 39 m
    (``ramp = "up"``), so each deflection is divided by ``1 + 2 (x - 21) / 18``."""
    scale_supports(folder / "supports.csv", tmp_path / "s.csv", [Scale(21.0, 39.0, 3.0, "up")])
    before, after = read_supports(folder / "supports.csv"), read_supports(tmp_path / "s.csv")
    x = before.position
    factor = np.where((x >= 21.0) & (x <= 39.0), 1.0 + 2.0 * (x - 21.0) / 18.0, 1.0)
    for i in range(len(before.left)):
        np.testing.assert_allclose(after.left[i].deflection, before.left[i].deflection / factor[i],
                                   rtol=1e-8)  # fmt: skip


def test_fixing_the_soft_spot_delays_and_does_not_add_tampings(compared):
    segments = pd.read_csv(compared / "interventions_segments.csv")
    spot = segments[segments["segment_start_m"] < 30.0].set_index("alternative")
    assert spot.loc["base", "interventions"] >= 1  # the soft spot triggers within 8 MGT
    assert spot.loc["spot-fixed", "interventions"] <= spot.loc["base", "interventions"]
    first = spot["first_mgt"].fillna(np.inf)  # NaN: never tamped within the horizon
    assert first["spot-fixed"] > first["base"]


def test_costs_add_up(compared):
    table = pd.read_csv(compared / "interventions_compared.csv").set_index("alternative")
    segments = pd.read_csv(compared / "interventions_segments.csv")
    for name, row in table.iterrows():
        # every segment is 60 m long (segment_length_m) and costs 10 per m tamped, 100 renewed
        # (the study's [costs], no currency given: "cu"); undiscounted, no possession cost
        assert row["tamped_m"] == pytest.approx(60.0 * row["tampings"])
        assert row["tamping_cost_cu"] == pytest.approx(10.0 * 60.0 * row["tampings"])
        assert row["renewal_cost_cu"] == pytest.approx(100.0 * 60.0 * row["renewals"])
        assert row["intervention_cost_cu"] == {"base": 0.0, "spot-fixed": 1000.0}[name]
        # the residual (the condition rule): 10 per m times each segment's used share of its
        # length (the CSVs' 6 significant digits)
        mine = segments[segments.alternative == name]
        share = mine.residual_share.to_numpy()
        length = (mine.segment_end_m - mine.segment_start_m).to_numpy()
        assert row["residual_cost_cu"] == pytest.approx(10.0 * (length * share).sum(), rel=1e-5)
        # the share in closed form: (σ_h - σ_t) / (σ_ref - σ_t), σ_ref the 0.12 mm threshold,
        # σ_t = 0.05 + 0.3 x 0.12 mm, the scenario's tamping model at the reference
        tamped = 0.05 + 0.3 * 0.12
        expected = np.clip((mine.d1_sd_horizon_mm - tamped) / (0.12 - tamped), 0.0, 1.0)
        np.testing.assert_allclose(share, expected, atol=1e-4)  # σ_h: 6 digits, x 1/0.034
        parts = (row["tamping_cost_cu"] + row["renewal_cost_cu"] + row["intervention_cost_cu"]
                 + row["residual_cost_cu"])  # fmt: skip
        assert row["life_cycle_cost_cu"] == pytest.approx(parts, rel=1e-5)  # 6 digits each
    assert {"interventions_compared.nc", "interventions_compared.png"} <= {
        p.name for p in compared.iterdir()
    }
    ds = xr.open_dataset(compared / "interventions_compared.nc")
    assert ds.sizes["alternative"] == 2
    assert ds.life_cycle_cost_cu.attrs["units"] == "cu"  # the currency as the cost's unit
    assert ds.tamped_m.attrs["units"] == "m"


def test_the_end_state_per_segment_is_the_runs_own(compared, folder):
    """``interventions_segments.csv``'s end terms of the base are the base run's: the D1 SD
    of its last state (worse rail) and the tonnage since its segment's last tamping."""
    segments = pd.read_csv(compared / "interventions_segments.csv")
    base = segments[segments.alternative == "base"].reset_index(drop=True)
    spec, where = load_deterioration(folder / "scenario.toml")
    ds = run_sections(section_tasks(spec, where), workers=1)[0]
    np.testing.assert_allclose(base.d1_sd_horizon_mm,
                               ds.d1_sd.isel(mgt=-1).max("rail").values, rtol=1e-5)  # fmt: skip
    for j in range(2):
        at = ds.intervention_mgt.values[ds.intervention_segment.values == j]
        since = 8.0 - (at.max() if at.size else 0.0)  # 8 MGT horizon; none: since the start
        assert base.since_tamping_mgt[j] == pytest.approx(since, rel=1e-5)


LATER = """
[[alternative]]
name = "later"                  # only the threshold raised: never tamps within 7 MGT
threshold_sd_mm = 5.0
"""


def test_deferring_is_no_longer_free(folder, tmp_path):
    """The constructed case: over 7 MGT the base tamps the soft spot's 60 m segment once
    (at 5.5 MGT, the threshold 0.12 mm; measured) and ends under the threshold; ``later``
    tamps nothing and leaves that segment over it. The end-state rule charges ``later`` that
    segment's tamping at the horizon: 60 m x 10 per m + one possession of 100, the base's
    own tamping and possession (600 + 100); without it, ``later`` would cost nothing."""
    from trackdyn.commands.interventions import compare

    for name in ("geometry.csv", "supports.csv"):
        (tmp_path / name).write_bytes((folder / name).read_bytes())
    (tmp_path / "scenario.toml").write_text(SCENARIO.replace("total_mgt = 8", "total_mgt = 7"))
    study = STUDY.replace("renewal_per_m = 100.0", "renewal_per_m = 100.0\nper_possession = 100"
                          '\nresidual = "end-state work"')  # fmt: skip
    (tmp_path / "study.toml").write_text(study + LATER)
    out = tmp_path / "out"
    args = ["study", str(tmp_path / "study.toml"), "--out", str(out), "--workers", "1"]
    assert runner.invoke(app, args).exit_code == 0
    table = pd.read_csv(out / "interventions_compared.csv").set_index("alternative")
    assert table.loc["base", "tampings"] == 1 and table.loc["base", "needs_work_m"] == 0
    assert table.loc["later", "tampings"] == 0 and table.loc["later", "needs_work_m"] == 60
    assert table.loc["later", "residual_cost_cu"] == 700.0
    assert table.loc["base", "life_cycle_cost_cu"] == 700.0  # 600 tamping + 100 possession
    assert table.loc["later", "life_cycle_cost_cu"] >= table.loc["base", "life_cycle_cost_cu"]
    # the same runs without the residual rule: deferring looks free
    spec = load_toml(InterventionsStudy, tmp_path / "study.toml")[0]
    labelled, scenario, _ = alternative_tasks(spec, tmp_path / "study.toml", tmp_path)
    free = spec.costs.model_copy(update={"residual": "none"}).rates(scenario)
    datasets = run_alternatives(labelled, workers=1)
    plain, _ = compare(spec, [a for a, _ in labelled], datasets, free)
    assert plain.set_index("alternative").loc["later", "life_cycle_cost_cu"] == 0.0


def test_an_alternative_without_changes_is_the_scenario_itself(folder, tmp_path):
    study, _ = load_toml(InterventionsStudy, folder / "study.toml")
    labelled, *_ = alternative_tasks(study, folder / "study.toml", tmp_path)
    alone = [(name, t) for name, t in labelled if name == "base"]
    spec, base = load_deterioration(folder / "scenario.toml")
    got = run_alternatives(alone, workers=1)[0]
    expected = run_sections(section_tasks(spec, base), workers=1)[0]
    for ds in (got, expected):  # the run's timings differ from run to run
        ds.attrs = {k: v for k, v in ds.attrs.items() if not k.startswith("time_")}
    xr.testing.assert_identical(got, expected)


PADS = """
[[alternative]]
name = "pads"
settlement_scale = [{ from_m = 21, to_m = 39, factor = 0.56 }]
"""


def test_settlement_scale_multiplies_the_rate_in_its_range_only(folder, tmp_path):
    """Under-sleeper pads over 21-39 m: the settlement rate there times 0.56 (44 % less
    ballast settlement, Gräbe et al. 2016, J. SAICE 58(2)); the loop's first step (one
    train, the same loads) settles exactly 0.56 times as much there and the same outside."""
    (tmp_path / "study.toml").write_text(STUDY + PADS)
    for name in ("scenario.toml", "geometry.csv", "supports.csv"):
        (tmp_path / name).write_bytes((folder / name).read_bytes())
    study, _ = load_toml(InterventionsStudy, tmp_path / "study.toml")
    labelled, *_ = alternative_tasks(study, tmp_path / "study.toml", tmp_path)
    task = {name: t for name, t in labelled}
    x = read_supports(tmp_path / "supports.csv").position
    inside = (x >= 21.0) & (x <= 39.0)
    np.testing.assert_array_equal(task["pads"].options.rate_scale, np.where(inside, 0.56, 1.0))
    assert task["base"].options.rate_scale is None
    short = {"total_mgt": 1e-3, "snapshot_every_mgt": 1e-3}
    first = [dataclasses.replace(task[n], options=task[n].options.model_copy(update=short))
             for n in ("base", "pads")]  # fmt: skip
    base, pads = (ds.settlement.isel(mgt=1).values for ds in run_sections(first, workers=1))
    assert base.min() > 0.0
    np.testing.assert_allclose(pads, base * np.where(inside, 0.56, 1.0), rtol=1e-12)


def test_a_failed_run_names_its_section_and_alternative(folder, tmp_path):
    study, _ = load_toml(InterventionsStudy, folder / "study.toml")
    labelled, *_ = alternative_tasks(study, folder / "study.toml", tmp_path)
    name, task = labelled[1]
    gone = dataclasses.replace(task.section, supports=str(tmp_path / "gone.csv"))
    with pytest.raises(TrackdynInputError, match="section geometry of alternative 'spot-fixed': "):
        run_alternatives([(name, dataclasses.replace(task, section=gone))], workers=1)


BAD = {
    "unknown alternative key": (
        'name = "x"\ncolour = "red"', "study.toml: unknown key 'alternative.0.colour'"),
    "negative factor": (
        'name = "x"\nsupports_scale = [{ from_m = 21, to_m = 39, factor = -2 }]',
        "study.toml: alternative.0.supports_scale.0.factor: Input should be greater than or "
        "equal to 0.01"),
    "a factor of 1e9": (
        'name = "x"\nsupports_scale = [{ from_m = 21, to_m = 39, factor = 1e9 }]',
        "alternative.0.supports_scale.0.factor: Input should be less than or equal to 100"),
    "a range from nan": (
        'name = "x"\nsettlement_scale = [{ from_m = nan, to_m = 39, factor = 2 }]',
        "alternative.0.settlement_scale.0.from_m: Input should be a finite number"),
    "a cost of inf": ('name = "x"\ncost = inf', "alternative.0.cost: Input should be a finite"),
    "a cost as text": ('name = "x"\ncost = "1000"', "alternative.0.cost: Input should be a valid"),
    "range outside the track": (
        'name = "x"\nsupports_scale = [{ from_m = 100, to_m = 150, factor = 2 }]',
        "study.toml: alternative 'x': supports_scale 100-150 m is outside section "
        "geometry's supports"),
    "unknown section": (
        'name = "x"\nsupports_scale = [{ from_m = 1, to_m = 5, factor = 2, section = "km9" }]',
        "study.toml: alternative 'x': supports_scale: no section 'km9'"),
    "a wedge that locks": (  # mu = 0.8 locks the wedge (above tan 36.3 deg = 0.73)
        'name = "x"\nvehicle_overrides = { mu = 0.8 }',
        "study.toml: alternative 'x': traffic 1: vehicle parameter mu = 0.8 locks the wedge"),
    "unknown law parameter": (
        'name = "x"\nsettlement_overrides = { nonsense = 1.0 }',
        "study.toml: alternative 'x': unknown settlement parameter of the sato law 'nonsense'"),
}  # fmt: skip


@pytest.mark.parametrize("case", BAD)
def test_bad_input_is_refused_in_one_line_naming_file_and_key(folder, tmp_path, case):
    table, message = BAD[case]
    study = f'kind = "interventions"\nscenario = "{folder / "scenario.toml"}"\n'
    (tmp_path / "study.toml").write_text(f"{study}[[alternative]]\n{table}\n")
    out = tmp_path / "out"
    result = runner.invoke(app, ["study", str(tmp_path / "study.toml"), "--out", str(out)])
    assert result.exit_code == 2, result.output
    line = " ".join(result.output.split())
    assert message in line
    assert not out.exists()


def test_the_shipped_example_expands_to_its_alternatives(tmp_path):
    to = tmp_path / "ex"
    assert runner.invoke(app, ["example", "interventions", "--to", str(to)]).exit_code == 0
    study, _ = load_toml(InterventionsStudy, to / "interventions.toml")
    labelled, *_ = alternative_tasks(study, to / "interventions.toml", tmp_path)
    assert [name for name, _ in labelled] == [a.name for a in study.alternative]  # 1 section
    # soft-spot-fixed and pads-at-the-bridge scale supports; a section of files is named
    # after its geometry
    assert sorted(p.name for p in tmp_path.glob("*.csv")) == [
        "pads-at-the-bridge_geometry_supports.csv",
        "soft-spot-fixed_geometry_supports.csv",
    ]
    pads = dict(labelled)["pads-at-the-bridge"].options.rate_scale
    assert min(pads) == 0.56 and max(pads) == 1.0


@pytest.mark.slow
def test_fixing_the_example_soft_spot_lengthens_its_segment_interval(tmp_path):
    """The issue's check on the built-in example: its soft spot (300 m) lies in the
    200.5-400.5 m segment; 50 MGT of the example traffic, the 4-DOF model (~1 min)."""
    to = tmp_path / "ex"
    assert runner.invoke(app, ["example", "interventions", "--to", str(to)]).exit_code == 0
    text = (to / "interventions.toml").read_text()
    (to / "two.toml").write_text(text[: text.index('[[alternative]]\nname = "high')])
    out = tmp_path / "out"
    args = ["study", str(to / "two.toml"), "--out", str(out), "--workers", "2"]
    assert runner.invoke(app, args).exit_code == 0
    segments = pd.read_csv(out / "interventions_segments.csv")
    spot = segments[segments["segment_start_m"] == 200.5].set_index("alternative")
    # the example starts freshly tamped, so the first tamping ends the first interval;
    # measured: one tamping either way in 50 MGT, at 16.1 MGT against 2.8
    assert spot.loc["soft-spot-fixed", "interventions"] <= spot.loc["base", "interventions"]
    assert spot.loc["soft-spot-fixed", "first_mgt"] > 2 * spot.loc["base", "first_mgt"]


def test_a_scenario_without_maintenance_is_refused(folder, tmp_path):
    text = SCENARIO.replace("[maintenance]\nmin_interval_mgt = 1\n", "")
    (tmp_path / "plain.toml").write_text(text.replace("recovery_offset_mm = 0.05", ""))
    for name in ("geometry.csv", "supports.csv"):
        (tmp_path / name).write_bytes((folder / name).read_bytes())
    study = STUDY.replace('scenario = "scenario.toml"', 'scenario = "plain.toml"')
    (tmp_path / "study.toml").write_text(study)
    out = tmp_path / "out"
    result = runner.invoke(app, ["study", str(tmp_path / "study.toml"), "--out", str(out)])
    assert result.exit_code == 2
    assert "plain.toml: no [maintenance] table: nothing to compare" in result.output
    assert not out.exists()


def test_cost_spread_in_closed_form():
    from trackdyn.commands.interventions.spread import cost_spread

    # 4 members x 2 alternatives: b cheapest in members 0 and 1, a in 2, a tie in 3
    costs = np.array([[5.0, 3.0], [6.0, 4.0], [1.0, 2.0], [7.0, 7.0]])
    got = cost_spread(costs, ["a", "b"], "EUR").set_index("alternative")
    # probability cheapest: b 2 + 0.5 of 4 members = 0.625, a 1 + 0.5 = 0.375
    assert got.loc["b", "probability_cheapest"] == 0.625
    assert got.loc["a", "probability_cheapest"] == 0.375
    # p10/p50/p90 are members' values (inverted_cdf): a's sorted 1, 5, 6, 7 -> 1, 5, 7
    assert got.loc["a", ["life_cycle_cost_p10_EUR", "life_cycle_cost_p50_EUR",
                         "life_cycle_cost_p90_EUR"]].tolist() == [1.0, 5.0, 7.0]  # fmt: skip
    assert got.loc["a", "life_cycle_cost_mean_EUR"] == 4.75 and got.loc["a", "members"] == 4


def test_a_forecast_scenario_gives_each_alternatives_cost_spread(folder, tmp_path):
    """With ``[forecast]`` (3 members, the Sato law's gamma lognormal cov 0.3), every
    alternative runs on every member; the spread file's quantiles are those of the members'
    own costs, which are the life-cycle costs of each member run alone (`member_tasks` then
    `compare`)."""
    from trackdyn.commands.deteriorate.forecast import plan_forecast
    from trackdyn.commands.interventions import compare
    from trackdyn.forecast.ensemble import member_tasks

    forecast = "[forecast]\nmembers = 3\nseed = 2\nparameters = { gamma = { cov = 0.3 } }\n"
    (tmp_path / "scenario.toml").write_text(
        SCENARIO.replace('"geometry.csv"', repr(str(folder / "geometry.csv")))
        .replace('"supports.csv"', repr(str(folder / "supports.csv"))) + forecast
    )  # fmt: skip
    (tmp_path / "study.toml").write_text(STUDY)
    out = tmp_path / "out"
    result = runner.invoke(app, ["study", str(tmp_path / "study.toml"), "--out", str(out),
                                 "--workers", "1"])  # fmt: skip
    assert result.exit_code == 0, result.output
    spread = pd.read_csv(out / "interventions_spread.csv").set_index("alternative")
    assert spread.probability_cheapest.sum() == pytest.approx(1.0)
    # the members' costs, run here member by member
    study, _ = load_toml(InterventionsStudy, tmp_path / "study.toml")
    labelled, spec, base = alternative_tasks(study, tmp_path / "study.toml", tmp_path)
    plan = plan_forecast(spec, base, [t for alt, t in labelled if alt == "base"])
    rates = study.costs.rates(spec)
    each = []
    for m in range(3):
        pairs = [(alt, member_tasks(t, plan.members)[m]) for alt, t in labelled]
        table, _ = compare(study, [a for a, _ in pairs], run_alternatives(pairs, workers=1),
                           rates)  # fmt: skip
        each.append(table.set_index("alternative").life_cycle_cost_cu)
    costs = pd.concat(each, axis=1)
    for name in ("base", "spot-fixed"):
        # the file's 6 significant digits
        p50, mean = sorted(costs.loc[name])[1], costs.loc[name].mean()
        assert spread.loc[name, "life_cycle_cost_p50_cu"] == pytest.approx(p50, rel=1e-5)
        assert spread.loc[name, "life_cycle_cost_mean_cu"] == pytest.approx(mean, rel=1e-5)
