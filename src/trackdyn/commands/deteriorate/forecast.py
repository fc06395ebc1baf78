"""The ensemble forecast of `trackdyn deteriorate` (a scenario's ``[forecast]`` table): its
members, tables and figures.

The deterministic run stays what it is without ``[forecast]``; the ensemble runs after it
(`trackdyn.forecast.ensemble.run_ensemble`) and adds ``forecast.csv`` (per section, segment
and quantity the members' p10, p50, p90, mean), ``forecast_probability.csv`` (the share of
members whose segment has had its first tamping by each year, or each 10 MGT), a fan chart
per section and the probability diagram.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from trackdyn.deterioration.ballast import read_field_draws
from trackdyn.errors import TrackdynInputError
from trackdyn.forecast.ensemble import run_ensemble
from trackdyn.forecast.spread import Growth, Members, read_posterior, sample_members
from trackdyn.forecast.summary import first_tamping, forecast_table, reach_probability

PROBABILITY_EVERY_MGT = 10.0
"""Tonnage between the probabilities of ``forecast_probability.csv`` without a horizon in
years [MGT]; a horizon shorter than twice this gets tenths of itself."""


@dataclass(frozen=True)
class Forecast:
    """An ensemble's results.

    Parameters
    ----------
    members : Members
        The members' samples.
    ensembles : list of list of xarray.Dataset
        Per section, its members' results.
    growth : Growth or None
        The traffic's growth, with a horizon in years.
    horizon_years : float or None
        The horizon in years, if given so [year].
    """

    members: Members
    ensembles: list
    growth: Growth | None
    horizon_years: float | None

    def years(self):
        """Per member, the year in which a tonnage is reached (None without years)."""
        if self.growth is None:
            return None
        g = self.growth
        return [lambda mgt, rate=rate: g.year_of(mgt, rate) for rate in self.members.growth]


@dataclass(frozen=True)
class Plan:
    """A scenario's ensemble, sampled before anything runs (so that a bad ``[forecast]``
    table or posterior file is refused before the deterministic run)."""

    members: Members
    growth: Growth | None
    horizon_years: float | None


def _field_draws(path, tasks):
    """The rate fields of ``[forecast] rate_field_draws`` on the one section of ``tasks``."""
    if len(tasks) > 1:
        raise TrackdynInputError(f"[forecast] rate_field_draws ({path}): a calibration's "
                                 f"draws belong to one section, the scenario has "
                                 f"{len(tasks)}")  # fmt: skip
    section = tasks[0].section
    return read_field_draws(path, section.track()
                            .supports.position)  # fmt: skip


def plan_forecast(spec, base, tasks) -> Plan:
    """Sample the members of a scenario's ``[forecast]``.

    Parameters
    ----------
    spec : DeteriorationScenario
        The scenario, with a ``forecast`` table.
    base : Path
        Folder its relative paths start from.
    tasks : list of SectionTask
        The sections' deterministic tasks (the first's law's values are the spreads'
        medians).
    """
    f, m = spec.forecast, spec.maintenance
    law = tasks[0].law
    fields = None if f.rate_field_draws is None else _field_draws(base / f.rate_field_draws,
                                                                  tasks)  # fmt: skip
    posterior = None if f.posterior is None else read_posterior(base / f.posterior,
                                                                spec.settlement.law)  # fmt: skip
    in_years = m is not None and m.horizon_years is not None
    growth = Growth(m.annual_mgt, f.annual_growth, f.annual_growth_sd) if in_years else None
    spreads = {name: s.spread() for name, s in f.parameters.items()}
    members = sample_members(f.members, f.seed, law, spreads=spreads, posterior=posterior,
                             growth=growth, fields=fields)  # fmt: skip
    return Plan(members, growth, m.horizon_years if in_years else None)


def run_forecast(plan: Plan, tasks, *, workers=None, scheduler=None, progress=False):
    """Run the planned members on every section.

    Parameters
    ----------
    plan : Plan
        The members (`plan_forecast`).
    tasks : list of SectionTask
        The sections' deterministic tasks.
    workers, scheduler, progress
        As `trackdyn.deterioration.runs.run_sections`.
    """
    ensembles = run_ensemble(tasks, plan.members, growth=plan.growth,
                             horizon_years=plan.horizon_years, workers=workers,
                             scheduler=scheduler, progress=progress)  # fmt: skip
    return Forecast(plan.members, ensembles, plan.growth, plan.horizon_years)


def tables(forecast: Forecast, names) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``forecast.csv`` and ``forecast_probability.csv`` of all sections.

    Parameters
    ----------
    forecast : Forecast
        The ensemble's results.
    names : list of str
        The sections' names, in the order of ``forecast.ensembles``.
    """
    quantiles, probabilities = [], []
    years = forecast.years()
    for name, members in zip(names, forecast.ensembles, strict=True):
        table = forecast_table(members, years)
        table.insert(0, "section", name)
        quantiles.append(table)
        first = np.array([first_tamping(ds) for ds in members])
        if years is not None and forecast.horizon_years is not None:
            first = np.array([y(f) for y, f in zip(years, first, strict=True)])
            at, column = np.arange(1.0, np.ceil(forecast.horizon_years) + 1.0), "by_year"
        else:
            total = max(float(ds.mgt[-1]) for ds in members)
            step = PROBABILITY_EVERY_MGT if total >= 2 * PROBABILITY_EVERY_MGT else total / 10
            at = np.arange(step, total + 1e-9 * total, step)
            column = "by_mgt"
        p = reach_probability(first, at)
        ds = members[0]
        for s in range(p.shape[1]):
            probabilities.append(pd.DataFrame({
                "section": name,
                "segment_start_m": float(ds.segment_start[s]),
                "segment_end_m": float(ds.segment_end[s]),
                column: at,
                "probability": p[:, s],
            }))  # fmt: skip
    return pd.concat(quantiles, ignore_index=True), pd.concat(probabilities, ignore_index=True)


def headline(table: pd.DataFrame) -> list[dict]:
    """The first tamping of every segment as p10, p50, p90 [MGT], for ``summary.json``."""
    first = table[table.quantity == "first_tamping_mgt"]
    keep = ["section", "segment_start_m", "segment_end_m", "p10", "p50", "p90", "members"]
    return first[keep].to_dict(orient="records")


PROBABILITY_PANELS = 24
"""Most sections in ``forecast_probability.png``, a panel each (2.2 in high: a figure of 250
panels would pass matplotlib's limit of 65 536 pixels at 120 dpi); its table holds all."""


def forecast_figures(forecast: Forecast, names, probability, figures_of=None) -> dict:
    """The forecast's figures by file name, to be drawn (`trackdyn.commands.drawing.Drawing`):
    ``<section>_forecast_fan.png`` of each section ``figures_of`` names (default: all;
    `trackdyn.commands.deteriorate.outputs.figured`) and ``forecast_probability.png``, a
    panel for each of them, at most `PROBABILITY_PANELS` (none without a section).

    Parameters
    ----------
    forecast, names
        As `tables`.
    probability : pandas.DataFrame
        ``forecast_probability.csv``'s table (`tables`).
    figures_of : collection of str, optional
        The sections drawn.
    """
    from trackdyn.commands.drawing import Drawing
    from trackdyn.plots.deteriorate import plot_fan, plot_reach_probability

    chosen = set(names if figures_of is None else figures_of)
    figures = {
        f"{name}_forecast_fan.png": Drawing(plot_fan, (members,), {"title": f"{name}: "
                                                                   f"{len(members)} members"})
        for name, members in zip(names, forecast.ensembles, strict=True) if name in chosen
    }  # fmt: skip
    panels = [name for name in names if name in chosen][:PROBABILITY_PANELS]
    if panels:
        title = ("Probability of reaching the threshold" if len(panels) == len(chosen) else
                 f"Probability of reaching the threshold: the first {len(panels)} of the "
                 f"{len(chosen)} sections drawn")  # fmt: skip
        shown = probability[probability.section.isin(panels)]
        figures["forecast_probability.png"] = Drawing(plot_reach_probability, (shown,),
                                                      {"title": title})  # fmt: skip
    return figures


def write_forecast(
    forecast: Forecast, names, folder, pool=None, figures_of=None
) -> tuple[list[str], pd.DataFrame]:
    """Write the forecast's tables and figures into ``folder``, the figures drawn by the
    ``pool``'s helper process meanwhile if given (`trackdyn.commands.drawing`); the
    tables of all sections, the figures of those ``figures_of`` names (`forecast_figures`).

    Returns
    -------
    files : list of str
        The names written: ``forecast.csv``, ``forecast_probability.csv`` and the figures
        (`forecast_figures`).
    table : pandas.DataFrame
        ``forecast.csv``'s table.
    """
    from trackdyn.commands.drawing import drawn

    table, probability = tables(forecast, names)
    figures = forecast_figures(forecast, names, probability, figures_of)
    with drawn(figures, folder, pool):
        table.to_csv(folder / "forecast.csv", index=False, float_format="%.6g")
        probability.to_csv(folder / "forecast_probability.csv", index=False, float_format="%.6g")
    return ["forecast.csv", "forecast_probability.csv", *figures], table
