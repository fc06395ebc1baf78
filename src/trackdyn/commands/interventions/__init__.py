"""`trackdyn study` of ``kind = "interventions"``: one deterioration scenario with
maintenance under alternatives, side by side with their costs.

```toml
kind = "interventions"
scenario = "deteriorate.toml"    # a trackdyn deteriorate scenario with [maintenance]

[costs]
currency = "EUR"                 # the costs' unit in every name (default "cu", currency units)
tamping_per_m = 10.0             # per metre of segment tamped
renewal_per_m = 0.0              # per metre of segment whose ballast is renewed
per_possession = 0.0             # per possession: each tamping run, whatever its length
discount_rate = 0.0              # [-/year]; 0: undiscounted (needs annual_mgt otherwise)
# annual_mgt = 10                # [MGT/year]; default the scenario's [maintenance] annual_mgt
# residual = "end-state work"    # default "condition": each segment's used share of a
                                 # tamping; "end-state work": those at the reference; "none"
# reference_sd_mm = 2.0          # its common reference; default the scenario's threshold

[[alternative]]
name = "base"                    # no changes: the scenario as it is

[[alternative]]
name = "soft-spot-fixed"
cost = 5000.0                    # of the intervention itself
cost_year = 0.0                  # when it is spent [year from the start]
supports_scale = [{ from_m = 560, to_m = 580, factor = 2.0 }]   # section = "..." optional
# settlement_scale = [{ from_m = 500, to_m = 700, factor = 0.56 }]  # settlement rate there
# settlement_overrides = { alpha = 0.3 }    # merged into [settlement] overrides
# vehicle_overrides = { mu = 0.2 }          # merged into every [[traffic]] overrides
# threshold_sd_mm = 2.0                     # replaces [loop] threshold_sd_mm
```

Every alternative runs every section of the scenario with the same rate-field and
maintenance seeds, so an alternative without changes gives the scenario's own results.
The costs, their present value and the residual rule are `trackdyn.studies.life_cycle`'s.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import (
    ConfigDict,
    Field,
    NonNegativeFloat,
    PositiveFloat,
    StrictFloat,
    field_validator,
    model_validator,
)

from trackdyn.commands.compiling import say_if_compiling
from trackdyn.commands.deteriorate.forecast import plan_forecast
from trackdyn.commands.deteriorate.outputs import life_cycle_table
from trackdyn.commands.deteriorate.scenario import DeteriorationScenario, load_deterioration
from trackdyn.commands.deteriorate.sections import NAME, section_tasks
from trackdyn.commands.interventions.spread import cost_spread, member_labelled
from trackdyn.commands.netcdf import write_netcdf
from trackdyn.commands.staging import Record, output_folder
from trackdyn.commands.tables import frame_table
from trackdyn.data import EXAMPLE_GEOMETRY, EXAMPLE_SUPPORTS, example_path
from trackdyn.deterioration.runs import Section
from trackdyn.errors import TrackdynInputError, named, require_workers
from trackdyn.options import Strict, load_toml, parse
from trackdyn.plots import save
from trackdyn.plots.interventions import plot_comparison
from trackdyn.progress import note
from trackdyn.studies.interventions import (
    Scale,
    maintenance_totals,
    scale_supports,
    support_extent,
)
from trackdyn.studies.life_cycle import Rates, costs, discounted_work, end_state, end_totals
from trackdyn.units import currency, money_name

MIN_SCALE, MAX_SCALE = 0.01, 100.0
"""Plausible range of a ``supports_scale`` or ``settlement_scale`` factor [-]: a hundredth
to a hundred times the track's stiffness or settlement rate."""


class RangeScale(Strict):
    """One range of ``supports_scale`` (support stiffness) or ``settlement_scale``
    (settlement rate): times ``factor`` [-] from ``from_m`` to ``to_m`` [m] of ``section``
    (default: every section); ``ramp`` ``"up"`` or ``"down"`` runs the factor linearly from
    1 (a transition treatment), ``"none"`` (default) holds it over the range
    (`trackdyn.studies.interventions.RAMPS`)."""

    model_config = ConfigDict(strict=True)  # "5" is no number

    from_m: float
    to_m: float
    factor: float = Field(ge=MIN_SCALE, le=MAX_SCALE)
    section: str | None = None
    ramp: Literal["none", "up", "down"] = "none"

    @model_validator(mode="after")
    def _ordered(self):
        if self.to_m <= self.from_m:
            raise ValueError(f"to_m {self.to_m:g} m is not beyond from_m {self.from_m:g} m")
        return self


class Alternative(Strict):
    """``[[alternative]]``: a ``name``, its ``cost`` [currency] spent at ``cost_year``
    [year from the start] and the changes it makes."""

    model_config = ConfigDict(strict=True)

    name: str = Field(pattern=NAME.pattern)
    cost: NonNegativeFloat = 0.0
    cost_year: NonNegativeFloat = 0.0
    supports_scale: list[RangeScale] = Field(default_factory=list)
    settlement_scale: list[RangeScale] = Field(default_factory=list)
    settlement_overrides: dict[str, StrictFloat] = Field(default_factory=dict)
    vehicle_overrides: dict[str, StrictFloat] = Field(default_factory=dict)
    threshold_sd_mm: PositiveFloat | None = None


class Costs(Strict):
    """``[costs]``: the ``currency`` (default ``"cu"``, currency units, unnamed), the costs
    ``tamping_per_m`` and ``renewal_per_m`` [currency/m] and ``per_possession``
    [currency], the ``discount_rate`` [-/year] with ``annual_mgt`` [MGT/year] (default the
    scenario's ``[maintenance] annual_mgt``), and the ``residual`` rule (``"condition"``,
    default, ``"end-state work"`` or ``"none"``) with its ``reference_sd_mm`` [mm] (default the
    scenario's ``[loop] threshold_sd_mm``); `trackdyn.studies.life_cycle`."""

    model_config = ConfigDict(strict=True)

    currency: str = "cu"
    tamping_per_m: NonNegativeFloat = 0.0
    renewal_per_m: NonNegativeFloat = 0.0
    per_possession: NonNegativeFloat = 0.0
    discount_rate: float = Field(0.0, ge=0.0, lt=1.0)
    annual_mgt: PositiveFloat | None = None
    residual: Literal["condition", "end-state work", "none"] = "condition"
    reference_sd_mm: PositiveFloat | None = None

    @field_validator("currency")
    @classmethod
    def _currency(cls, value):
        return currency(value)

    def rates(self, spec: DeteriorationScenario) -> Rates:
        """The `Rates` of these costs on the scenario ``spec`` (its traffic per year and
        threshold where these give none)."""
        m = spec.maintenance
        annual = self.annual_mgt or (m.annual_mgt if m is not None else None)
        if self.discount_rate > 0 and annual is None:
            raise TrackdynInputError("[costs] discount_rate needs annual_mgt ([costs] "
                                     "annual_mgt or the scenario's [maintenance])")  # fmt: skip
        reference = self.reference_sd_mm or spec.loop.threshold_sd_mm
        tamped = None
        if self.residual == "condition" and m is not None:  # the tamping model's σ' at σ_ref
            tamped = m.recovery_offset_mm + m.recovery_slope * reference
        return Rates(self.tamping_per_m, self.renewal_per_m, self.per_possession,
                     self.discount_rate, annual,
                     None if self.residual == "none" else reference, tamped)  # fmt: skip


class InterventionsStudy(Strict):
    """An interventions study file."""

    kind: Literal["interventions"]
    scenario: Path
    costs: Costs = Costs()
    alternative: list[Alternative] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique(self):
        names = [a.name for a in self.alternative]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"alternative name {repeated[0]!r} is repeated")
        return self


def alternative_scenario(spec: DeteriorationScenario, alt: Alternative, where: str):
    """The deterioration scenario with an alternative's overrides and threshold, checked."""
    data = spec.model_dump(exclude_unset=True)
    data["traffic"] = [
        {**t.model_dump(exclude_unset=True), "overrides": {**t.overrides, **alt.vehicle_overrides}}
        for t in spec.traffic
    ]
    settlement = data.setdefault("settlement", {})
    settlement["overrides"] = {**spec.settlement.overrides, **alt.settlement_overrides}
    if alt.threshold_sd_mm is not None:
        data.setdefault("loop", {})["threshold_sd_mm"] = alt.threshold_sd_mm
    return parse(DeteriorationScenario, data, where)


def _check_inside(key: str, ranges, sec: Section, extent) -> None:
    """Refuse a ``key`` range (`RangeScale`) outside the ``extent`` of the section's
    sleepers [m]."""
    first, last = extent
    for s in ranges:
        if s.from_m < first or s.to_m > last:
            raise TrackdynInputError(
                f"{key} {s.from_m:g}-{s.to_m:g} m is outside section "
                f"{sec.name}'s supports ({first:g}-{last:g} m)"
            )


def _scaled_section(sec: Section, alt: Alternative, folder: Path) -> Section:
    """The section with the alternative's supports ranges applied (written to ``folder``)."""
    mine = [s for s in alt.supports_scale if s.section in (None, sec.name)]
    if not mine:
        return sec
    source = sec.supports or str(example_path(EXAMPLE_SUPPORTS))
    _check_inside("supports_scale", mine, sec, support_extent(source))
    target = folder / f"{alt.name}_{sec.name}_supports.csv"
    scale_supports(source, target, [Scale(s.from_m, s.to_m, s.factor, s.ramp) for s in mine])
    geometry = sec.geometry or str(example_path(EXAMPLE_GEOMETRY))
    return dataclasses.replace(sec, geometry=geometry, supports=str(target))


def _settlement_scaled(options, sec: Section, alt: Alternative):
    """The loop options with the alternative's ``settlement_scale`` ranges of ``sec``."""
    mine = [s for s in alt.settlement_scale if s.section in (None, sec.name)]
    if not mine:
        return options
    position = sec.track().supports.position
    _check_inside("settlement_scale", mine, sec, (float(position[0]), float(position[-1])))
    factor = np.ones(position.size)
    for s in mine:
        factor *= Scale(s.from_m, s.to_m, s.factor, s.ramp).at(position)
    return options.model_copy(update={"rate_scale": tuple(factor.tolist())})


def scenario_file(study: InterventionsStudy, path) -> Path:
    """The deterioration scenario a study file names (relative to the study file)."""
    return Path(path).resolve().parent / study.scenario


def alternative_tasks(study: InterventionsStudy, path, folder: Path):
    """The section tasks of every alternative, in order, the scenario and its folder.

    Parameters
    ----------
    study : InterventionsStudy
        The study file.
    path : path
        Its file, named in messages; relative paths start from its folder.
    folder : Path
        Where scaled supports files are written for the runs.
    """
    scenario_path = scenario_file(study, path)
    if not scenario_path.is_file():
        raise TrackdynInputError(f"{path}: scenario: {scenario_path}: no such file")
    spec, base = load_deterioration(scenario_path)
    if spec.maintenance is None:
        raise TrackdynInputError(f"{scenario_path}: no [maintenance] table: nothing to compare")
    if spec.plan is not None:
        raise TrackdynInputError(f"{scenario_path}: [plan] is trackdyn deteriorate's; an "
                                 "interventions study compares without it")  # fmt: skip
    tasks = []
    for alt in study.alternative:
        where = f"{path}: alternative {alt.name!r}"
        with named(where):
            sections = section_tasks(alternative_scenario(spec, alt, where), base)
            names = {t.section.name for t in sections}
            for key in ("supports_scale", "settlement_scale"):
                given = {s.section for s in getattr(alt, key) if s.section is not None}
                unknown = sorted(given - names)
                if unknown:
                    raise TrackdynInputError(f"{key}: no section {unknown[0]!r}")
            for t in sections:
                sec = _scaled_section(t.section, alt, folder)
                options = _settlement_scaled(t.options, sec, alt)
                tasks.append((alt.name, dataclasses.replace(t, section=sec, options=options)))
    return tasks, spec, base


def run_alternatives(labelled, *, workers=None, scheduler=None, progress=False) -> list:
    """Run the ``(alternative, task)`` pairs of `alternative_tasks` through `run_sections`;
    the Datasets in order. A failed run is refused naming its section and alternative."""
    from trackdyn.deterioration.runs import run_sections

    tasks = [
        dataclasses.replace(t, section=dataclasses.replace(
            t.section, name=f"{t.section.name} of alternative {alt!r}"))
        for alt, t in labelled
    ]  # fmt: skip
    datasets = run_sections(tasks, workers=workers, scheduler=scheduler, progress=progress)
    for (_, t), ds in zip(labelled, datasets, strict=True):
        ds.attrs["section"] = t.section.name
    return datasets


def compare(study: InterventionsStudy, names, datasets,
            rates: Rates) -> tuple[pd.DataFrame, pd.DataFrame]:  # fmt: skip
    """The comparison (one row per alternative) and the life cycle of every segment.

    Parameters
    ----------
    study : InterventionsStudy
        The study (costs, alternatives).
    names : list of str
        The alternative of each Dataset.
    datasets : list of xarray.Dataset
        The sections' results, in the order of ``names``.
    rates : Rates
        The costs (`Costs.rates`).

    Returns
    -------
    comparison : pandas.DataFrame
        Per alternative: `maintenance_totals`, `end_totals` and the `costs`, named with
        the currency (`trackdyn.units.money_name`).
    segments : pandas.DataFrame
        Per alternative and segment: `life_cycle_table` and the `end_state`.
    """
    rows, segments = [], []
    code = study.costs.currency
    for alt in study.alternative:
        mine = [ds for n, ds in zip(names, datasets, strict=True) if n == alt.name]
        work = [discounted_work(ds, rates) for ds in mine]
        summed = {k: sum(w[k] for w in work) for k in work[0]}
        money = costs(summed, rates, alt.cost, alt.cost_year)
        rows.append({"alternative": alt.name, **maintenance_totals(mine),
                     **end_totals(mine, rates.reference_sd_mm),
                     **{money_name(k, code): v for k, v in money.items()}})  # fmt: skip
        for ds in mine:
            table = life_cycle_table(ds)
            end = end_state(ds, rates.reference_sd_mm, rates.tamped_sd_mm)
            segments.append(pd.concat([table, end], axis=1).assign(alternative=alt.name))
    frame = pd.concat(segments, ignore_index=True)
    return pd.DataFrame(rows), frame[["alternative", *frame.columns[:-1]]]


SPREAD_FILE = "interventions_spread.csv"
"""Each alternative's life-cycle cost over the forecast's members (`cost_spread`), written
when the scenario has ``[forecast]``."""


def _plan(spec, base, labelled):
    """The scenario's forecast members (`plan_forecast` on the first alternative's
    sections), or None without ``[forecast]``."""
    if spec.forecast is None:
        return None
    first = [t for alt, t in labelled if alt == labelled[0][0]]
    return plan_forecast(spec, base, first)


def _spread(study, labelled, plan, rates, workers, scheduler) -> pd.DataFrame:
    """Run every alternative on every member; `cost_spread` of their life-cycle costs."""
    pairs, member = member_labelled(labelled, plan)
    datasets = run_alternatives(pairs, workers=workers, scheduler=scheduler, progress=True)
    names = np.array([alt for alt, _ in pairs])
    alternatives = [alt.name for alt in study.alternative]
    member_costs = np.empty((len(plan.members.growth), len(alternatives)))
    for m in range(member_costs.shape[0]):
        mine = np.flatnonzero(member == m)
        table, _ = compare(study, list(names[mine]), [datasets[i] for i in mine], rates)
        lcc = money_name("life_cycle_cost", study.costs.currency)
        member_costs[m] = table.set_index("alternative").loc[alternatives, lcc]
    return cost_spread(member_costs, alternatives, study.costs.currency)


def _with_currency(table: pd.DataFrame, code: str):
    """The comparison as a Dataset, its costs with the currency as their unit."""
    ds = table.set_index("alternative").to_xarray()
    for name in ds.data_vars:
        if str(name).endswith(f"_{code}"):
            ds[name].attrs["currency"] = code
    return ds


def interventions(path, out, overwrite: bool, workers, scheduler, console) -> None:
    """Run an interventions study; write interventions_compared.csv/.nc, the life cycle per
    segment (interventions_segments.csv) and interventions_compared.png.

    Parameters
    ----------
    path : path
        Study TOML file (``kind = "interventions"``).
    out : str or Path
        Output folder.
    overwrite : bool
        Replace another command's outputs in ``out``.
    workers : int, optional
        Worker processes (default: one per core; 1: serial).
    scheduler : str, optional
        Address of a running Dask scheduler.
    console : rich.console.Console
        Where the table is shown.
    """
    study, _ = load_toml(InterventionsStudy, path)
    require_workers(workers)
    code = study.costs.currency
    with tempfile.TemporaryDirectory(prefix="trackdyn-interventions-") as scratch:
        labelled, spec, base = alternative_tasks(study, path, Path(scratch))
        with named(str(path)):
            rates = study.costs.rates(spec)
        plan = _plan(spec, base, labelled)
        title = f"trackdyn study: interventions, {len(study.alternative)} alternatives"
        record = Record(title, {"study": path, "scenario": scenario_file(study, path)},
                        {"study": study.model_dump(mode="json"),
                         "scenario": spec.model_dump(mode="json")}, currency=code)  # fmt: skip
        with output_folder(out, "study", overwrite, record) as stage:
            say_if_compiling("interventions", scheduler)
            datasets = run_alternatives(labelled, workers=workers, scheduler=scheduler,
                                        progress=True)  # fmt: skip
            table, segments = compare(study, [alt for alt, _ in labelled], datasets, rates)
            record.headline = {"alternatives": table.to_dict(orient="records")}
            write_netcdf(_with_currency(table, code), stage / "interventions_compared.nc")
            table.to_csv(stage / "interventions_compared.csv", index=False, float_format="%.6g")
            segments.to_csv(stage / "interventions_segments.csv", index=False,
                            float_format="%.6g")  # fmt: skip
            title = f"Interventions over {spec.horizon_mgt:g} MGT"
            save(plot_comparison(table, code, title=title), stage / "interventions_compared.png")
            spread = None
            if plan is not None:
                spread = _spread(study, labelled, plan, rates, workers, scheduler)
                record.headline["life_cycle_cost_spread"] = spread.to_dict(orient="records")
                spread.to_csv(stage / SPREAD_FILE, index=False, float_format="%.6g")
    console.print(frame_table(table, f"Interventions over {spec.horizon_mgt:g} MGT", code))
    if spread is not None:
        console.print(frame_table(spread, f"Life-cycle cost over {len(plan.members.growth)} "
                                          "forecast members", code))  # fmt: skip
    written = ", ".join(["interventions_compared.csv/.nc/.png", "interventions_segments.csv",
                         *([SPREAD_FILE] if spread is not None else [])])  # fmt: skip
    note(f"wrote {written} to {out}")
    note("\n".join(record.lines()), 2)
