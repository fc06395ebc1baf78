"""The maintenance plan of `trackdyn deteriorate` (a scenario's ``[plan]`` table): made from
the forecast, followed in a run of its own, written as ``plan.csv``, ``plan_deferred.csv``,
``plan.png`` and the followed run's ``plan_life_cycle.csv`` and ``plan_interventions.csv``.

The forecast is the scenario's own run (its ``[maintenance]`` policy's tampings, each in
the year it comes in), and with ``[forecast]`` its members' share that tamp each segment
in each year; `trackdyn.deterioration.planning` makes the plan; each section then runs
again over the planning years with the maintenance policy ``"planned"``, which tamps what
the plan says and nothing else, so that the plan's life-cycle results and its "why" (the
D1 SD each stretch reaches before it is tamped) come from the run that follows it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from trackdyn.deterioration.planning import Needs, Plan, Rules, make_plan, planned_tampings
from trackdyn.units import money_name


def rules_of(spec) -> Rules:
    """The planning `Rules` of a scenario with ``[plan]``."""
    p, m = spec.plan, spec.maintenance
    return Rules(spec.plan_years, m.annual_mgt, p.min_stretch_m, p.bridge_gap_m,
                 p.min_probability, p.cap_m_per_year, p.budget_per_year, p.tamping_per_m,
                 p.per_possession)  # fmt: skip


def _by_year(ds, years_of, rules: Rules) -> np.ndarray:
    """(years, segments): whether the run ``ds`` tamps each segment in each year, its
    tonnages dated by ``years_of`` [year]."""
    out = np.zeros((rules.years, ds.sizes["segment"]), dtype=bool)
    year = np.floor(years_of(ds.intervention_mgt.values)).astype(int)
    inside = year < rules.years
    out[year[inside], ds.intervention_segment.values[inside]] = True
    return out


def needs_of(datasets, rules: Rules, forecast=None) -> list[Needs]:
    """Each section's `Needs` from its run (and the forecast's members, if given).

    Parameters
    ----------
    datasets : list of xarray.Dataset
        The sections' deterministic results, with a ``section`` attribute.
    rules : Rules
        The plan's rules (years, traffic per year).
    forecast : Forecast, optional
        The ensemble (`trackdyn.commands.deteriorate.forecast.run_forecast`).
    """
    lines = []
    for i, ds in enumerate(datasets):
        years = ds.intervention_mgt.values / rules.annual_mgt
        reach = np.full((rules.years, ds.sizes["segment"]), np.nan)
        for y, j in sorted(zip(years, ds.intervention_segment.values, strict=True), reverse=True):
            if y < rules.years:
                reach[int(y), j] = y  # the earliest in its year stays
        probability = _by_year(ds, lambda m: m / rules.annual_mgt, rules).astype(float)
        if forecast is not None:
            dated = forecast.years()
            members = forecast.ensembles[i]
            probability = np.mean([_by_year(m, d, rules) for m, d in
                                   zip(members, dated, strict=True)], axis=0)  # fmt: skip
        lines.append(Needs(ds.attrs["section"], ds.segment_start.values, ds.segment_end.values,
                           probability, reach))  # fmt: skip
    return lines


def followed_tasks(tasks, plan: Plan, lines: list[Needs], rules: Rules):
    """The sections' tasks over the planning years with the ``"planned"`` policy."""
    out = []
    for task, planned in zip(tasks, planned_tampings(plan, lines, rules), strict=True):
        o = task.options
        maintenance = o.maintenance.model_copy(update={"policy": "planned", "planned": planned})
        if not planned:  # nothing planned: no tamping
            maintenance = None
        options = o.model_copy(update={"maintenance": maintenance,
                                       "total_mgt": rules.years * rules.annual_mgt})  # fmt: skip
        out.append(dataclasses.replace(task, options=options))
    return out


def _worst(sd, segments) -> float:
    """The largest D1 SD of ``segments`` on either rail [mm] (``sd``: (rail, segment))."""
    return float(np.asarray(sd)[:, list(segments)].max())


def plan_tables(plan: Plan, lines, followed, rules: Rules, code: str):
    """``plan.csv`` and ``plan_deferred.csv``.

    Parameters
    ----------
    plan : Plan
        The plan.
    lines : list of Needs
        The forecast it was made from.
    followed : list of xarray.Dataset
        The sections' runs that follow it.
    rules : Rules
        The plan's rules.
    code : str
        The currency of the costs.
    """
    cost = money_name("cost", code)
    rows = []
    for s in plan.stretches:
        needs, ds = lines[s.section], followed[s.section]
        start, end = s.bounds(needs)
        at = (s.year - 1) * rules.annual_mgt
        mgt, seg = ds.intervention_mgt.values, ds.intervention_segment.values
        mine = (mgt >= at) & (mgt < at + rules.annual_mgt) & np.isin(seg, s.segments)
        rows.append({
            "year": s.year, "section": needs.section, "start_m": start, "end_m": end,
            "length_m": end - start, "action": "tamp", "segments_due": len(s.due),
            "d1_sd_before_mm": float(ds.d1_sd_before.values[mine].max()) if mine.any()
            else np.nan,
            "forecast_reach_year": s.reach_year, "probability": s.probability,
            cost: rules.cost(end - start),
        })  # fmt: skip
    deferred = []
    for s, to in plan.deferred:
        needs, ds = lines[s.section], followed[s.section]
        start, end = s.bounds(needs)
        sd = ds.d1_sd.sel(mgt=s.year * rules.annual_mgt, method="ffill").values
        deferred.append({
            "year": s.year, "section": needs.section, "start_m": start, "end_m": end,
            "length_m": end - start, "d1_sd_year_end_mm": _worst(sd, s.due),
            "probability": s.probability, "deferred_to": np.nan if to is None else to,
        })  # fmt: skip
    # the columns named, so that a plan of no stretch (a budget smaller than any) or nothing
    # deferred is a table of no rows with its header
    planned = ["year", "section", "start_m", "end_m", "length_m", "action", "segments_due",
               "d1_sd_before_mm", "forecast_reach_year", "probability", cost]  # fmt: skip
    columns = ["year", "section", "start_m", "end_m", "length_m", "d1_sd_year_end_mm",
               "probability", "deferred_to"]  # fmt: skip
    return pd.DataFrame(rows, columns=planned), pd.DataFrame(deferred, columns=columns)


def run_plan(spec, tasks, datasets, forecast, *, workers=None, scheduler=None):
    """Make the plan and run it.

    Returns
    -------
    plan : Plan
    lines : list of Needs
    followed : list of xarray.Dataset
        Each section's run that follows the plan, with a ``section`` attribute.
    rules : Rules
    """
    from trackdyn.deterioration.runs import run_sections

    rules = rules_of(spec)
    lines = needs_of(datasets, rules, forecast)
    plan = make_plan(lines, rules)
    followed = run_sections(followed_tasks(tasks, plan, lines, rules), workers=workers,
                            scheduler=scheduler, progress=True)  # fmt: skip
    for ds, needs in zip(followed, lines, strict=True):
        ds.attrs["section"] = needs.section
    return plan, lines, followed, rules


def write_plan(spec, result, folder) -> tuple[list[str], pd.DataFrame]:
    """Write the plan's files into ``folder`` (the module docstring); their names, and
    what the plan's cap deferred (``plan_deferred.csv``'s table)."""
    from trackdyn.commands.deteriorate.outputs import interventions_table, life_cycle_table
    from trackdyn.plots import save
    from trackdyn.plots.deteriorate import plot_plan

    plan, lines, followed, rules = result
    table, deferred = plan_tables(plan, lines, followed, rules, spec.plan.currency)
    frames = {
        "plan.csv": table,
        "plan_deferred.csv": deferred,
        "plan_life_cycle.csv": pd.concat([life_cycle_table(ds) for ds in followed]),
        "plan_interventions.csv": pd.concat([interventions_table(ds) for ds in followed]),
    }
    for name, frame in frames.items():
        frame.to_csv(folder / name, index=False, float_format="%.6g")
    bounds = [(n.section, float(n.starts[0]), float(n.ends[-1])) for n in lines]
    title = f"Maintenance plan, {rules.years} years"
    save(plot_plan(table, deferred, bounds, title=title), folder / "plan.png")
    return [*frames, "plan.png"], deferred
