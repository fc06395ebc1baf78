"""Deterioration scenario files (TOML) for `trackdyn deteriorate`.

```toml
[run]                           # trackdyn.options.RunOptions; speed_kmh comes from [[traffic]]
model = "11dof"                 # a model with wheels on both rails (4dof, 7dof, 11dof)
delta = 0.3                     # dynamic wheel load increment of the linearisation
# dt_s = 2e-4                   # optional; default chosen by simulate

[[traffic]]                     # one table per kind of vehicle; none: no traffic
vehicle = "loaded"              # preset, or a vehicle file "wagon.toml" (relative)
overrides = {}                  # vehicle parameters, SI units
speed_kmh = 60
passages_per_mgt = 8065         # 1e6 t / (104 t + 20 t) for alternating loaded and empty

[[traffic]]
vehicle = "empty"
speed_kmh = 60
passages_per_mgt = 8065

[settlement]
law = "power"                   # power, shenton, sato or varandas
# file = "settlement.toml"      # default: the shipped illustrative, uncalibrated values
overrides = {}                  # law parameters, SI units
rate_cov = 0.3                  # lognormal settlement-rate factor per sleeper (illustrative)
rate_correlation_length_m = 3   # its correlation length along the track (illustrative)
seed = 0
# rate_field = "rate_field.csv" # or the factor per rail seat (trackdyn calibrate's file)
# voids = true                  # ballast under a void settles faster; parameters: the
                                # file's [voids] table (trackdyn.deterioration.voids)

[loop]                          # trackdyn.deterioration.LoopOptions, its [loop] keys
total_mgt = 50
max_step_settlement_mm = 0.5
snapshot_every_mgt = 10
threshold_sd_mm = 1.6           # D1 SD that triggers maintenance (illustrative)
segment_length_m = 200
max_steps = 1000
min_step_passages = 100         # the first step: one train (illustrative)

[maintenance]                   # omit: no tamping, the loop only reports the triggers
policy = "threshold"            # tamp a segment when its D1 SD reaches threshold_sd_mm;
                                # or "fixed" with interval_mgt
min_interval_mgt = 5            # and every other trackdyn.deterioration.maintenance option
# horizon_years = 30            # with annual_mgt: the horizon instead of [loop] total_mgt
# annual_mgt = 10

[forecast]                      # omit: one deterministic run; with it, an ensemble too
members = 32                    # ensemble size
seed = 0                        # seed of the members' samples
# posterior = "calibration-out/posterior.toml"  # the law's parameters from a calibration
# rate_field_draws = "calibration-out/rate_field_draws.csv"  # and its rate field's posterior:
                                # member m on draw m (one section; with [settlement]
                                # rate_field = "calibration-out/rate_field.csv")
parameters = { K_s = { cov = 0.3 } }  # or spreads per parameter (SI): { cov = ... }
                                # lognormal about the law's value, { min = ..., max = ... }
                                # uniform; the rate field: a fresh realisation per member
# annual_growth = 0.02          # with horizon_years: growth of annual_mgt per year [-]
# annual_growth_sd = 0.01       # its spread between members [-]

[plan]                          # omit: no plan; with it, the plan and the run that follows it
# years = 10                    # planning years; default the horizon's ([maintenance]
                                # horizon_years and annual_mgt are needed)
min_stretch_m = 200             # the shortest stretch a machine tamps
bridge_gap_m = 100              # gaps up to this between due stretches are tamped with them
# min_probability = 0.5         # with [forecast]: the share of members that makes it due
# cap_m_per_year = 2000         # most metres tamped a year; or budget_per_year (currency)
# tamping_per_m = 10            # the plan's costs: per metre tamped, per stretch, the unit
# per_possession = 500
# currency = "EUR"

[track]                         # omit for the built-in example section
geometry = "geometry.csv"
supports = "supports.csv"
# sections = "sections.csv"     # or a list of sections: name,geometry,supports[,zones]
# zones = "zones.csv"           # start_m,end_m,kind: open, structure, approach or your own
rail = "60E1"                   # rail section for the load distribution (EI)
start = "as measured"           # or "tamped", or "as surveyed" (wavelengths < 3 m removed);
                                # default: tamped for the built-in example, as measured
                                # for track files
```
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import (
    Field,
    NonNegativeFloat,
    PositiveFloat,
    PositiveInt,
    StrictFloat,
    field_serializer,
    field_validator,
    model_serializer,
    model_validator,
)

from trackdyn.deterioration.maintenance import MaintenanceOptions
from trackdyn.deterioration.options import LoopOptions
from trackdyn.errors import TrackdynInputError
from trackdyn.limits import MAX_SPEED_KMH, MAX_TOTAL_MGT
from trackdyn.options import RunOptions, Strict, load_toml, vehicle_source
from trackdyn.track.formats import TrackFormat


def _default(name: str):
    """The default of a `LoopOptions` field (the same name and unit as the file's key)."""
    return LoopOptions.model_fields[name].default


class TrafficSpec(Strict):
    """``[[traffic]]``: ``vehicle`` preset or file, ``overrides`` [SI], ``speed_kmh`` [km/h],
    ``passages_per_mgt`` [-], optional ``label``."""

    vehicle: str = "loaded"
    overrides: dict[str, StrictFloat] = Field(default_factory=dict)
    speed_kmh: float = Field(60.0, gt=0, le=MAX_SPEED_KMH)
    passages_per_mgt: NonNegativeFloat
    label: str | None = None

    def load(self, base: Path):
        """The vehicle of this entry (a preset, or a file relative to ``base``)."""
        from trackdyn.vehicle.parameters import load_vehicle

        return load_vehicle(vehicle_source(self.vehicle, base), **self.overrides)


DEFAULT_TRAFFIC = [
    TrafficSpec(vehicle="loaded", speed_kmh=60.0, passages_per_mgt=8065.0),
    TrafficSpec(vehicle="empty", speed_kmh=60.0, passages_per_mgt=8065.0),
]
"""Alternating loaded (104 t) and empty (20 t) coal wagons: 1e6 t / 124 t = 8065 each."""


class SettlementSpec(Strict):
    """``[settlement]``: ``law`` name, parameter ``file``, ``overrides`` [SI], the lognormal
    settlement-rate field's ``rate_cov`` [-], ``rate_correlation_length_m`` [m] (defaults
    those of `LoopOptions`) and ``seed``, or ``rate_field``, a CSV file of the factor per
    rail seat (`trackdyn.deterioration.ballast.read_rate_field`); ``voids``, ballast under a
    void settles faster (`trackdyn.deterioration.voids`, the parameter file's ``[voids]``
    table)."""

    law: str = "power"
    file: Path | None = None
    overrides: dict[str, StrictFloat] = Field(default_factory=dict)
    rate_cov: NonNegativeFloat = _default("rate_cov")
    rate_correlation_length_m: PositiveFloat = _default("rate_correlation_length_m")
    seed: int = Field(0, ge=0)
    rate_field: Path | None = None
    voids: bool = False

    @model_validator(mode="after")
    def _one_field(self):
        if self.rate_field is not None and {"rate_cov", "seed"} & self.model_fields_set:
            raise ValueError("give rate_field or rate_cov and seed, not both")
        return self

    @field_validator("law")
    @classmethod
    def _known_law(cls, value):
        from trackdyn.deterioration.settlement import LAWS

        if value not in LAWS:
            raise ValueError(f"unknown settlement law {value!r}; known: {', '.join(LAWS)}")
        return value


class TrackSectionsSpec(TrackFormat):
    """``[track]``: ``geometry`` and ``supports`` CSV files, or a ``sections`` CSV list;
    ``zones``, a zone table (`trackdyn.deterioration.zones`; in a sections list, its
    ``zones`` column); ``rail`` section for the bending stiffness EI; ``start``, ``"tamped"``, ``"as
    measured"`` or ``"as surveyed"`` (default: tamped for the built-in example, as
    measured for files); what the geometry files hold (`trackdyn.track.formats.TrackFormat`,
    the same for every section of a list)."""

    geometry: Path | None = None
    supports: Path | None = None
    sections: Path | None = None
    zones: Path | None = None
    rail: str = "60E1"
    start: Literal["tamped", "as measured", "as surveyed"] | None = None

    @model_validator(mode="after")
    def _one_source(self):
        if self.sections is not None and (self.geometry or self.supports):
            raise ValueError("give either sections or geometry and supports, not both")
        if self.sections is not None and self.zones is not None:
            raise ValueError("with sections, give each section's zones in the sections list")
        if (self.geometry is None) != (self.supports is None):
            raise ValueError("give both geometry and supports, or neither for the example")
        return self


class MaintenanceSpec(MaintenanceOptions):
    """``[maintenance]``: the `MaintenanceOptions`, and optionally the horizon as
    ``horizon_years`` [years] of ``annual_mgt`` [MGT/year] instead of ``[loop] total_mgt``."""

    horizon_years: float | None = Field(None, gt=0.0, le=200.0)
    annual_mgt: float | None = Field(None, gt=0.0, le=1000.0)

    @model_validator(mode="after")
    def _both_or_neither(self):
        if (self.horizon_years is None) != (self.annual_mgt is None):
            raise ValueError("give horizon_years and annual_mgt together, or neither")
        return self

    @model_validator(mode="after")
    def _not_planned(self):
        if "planned" in self.model_fields_set:
            raise ValueError("planned is written by a [plan] table, not given")
        return self

    def options(self) -> MaintenanceOptions:
        """The maintenance options without the horizon."""
        fields = self.model_dump(exclude={"horizon_years", "annual_mgt"})
        return MaintenanceOptions(**fields)


class SpreadSpec(Strict):
    """A parameter's spread in ``[forecast.parameters]``: ``cov`` (lognormal about the law's
    value) or ``min`` and ``max`` (uniform) [SI]."""

    cov: PositiveFloat | None = None
    min: float | None = None
    max: float | None = None

    @model_validator(mode="after")
    def _one_kind(self):
        if (self.cov is None) == (self.min is None and self.max is None):
            raise ValueError("give cov, or min and max")
        if self.cov is None and (self.min is None or self.max is None):
            raise ValueError("give min and max together")
        return self

    def spread(self):
        """The `trackdyn.forecast.spread.Lognormal` or `Uniform` it stands for."""
        from trackdyn.forecast.spread import Lognormal, Uniform

        if self.cov is not None:
            return Lognormal(self.cov)
        assert self.min is not None and self.max is not None  # the model's check
        return Uniform(self.min, self.max)


MAX_MEMBERS = 1000
"""Most members of an ensemble: each is a whole deterioration run."""


class ForecastSpec(Strict):
    """``[forecast]``: ``members``, ``seed``, the law's parameters from a calibration's
    ``posterior`` file and/or ``parameters`` spreads, a calibration's ``rate_field_draws``
    (each member on one of them), the traffic's ``annual_growth`` and ``annual_growth_sd``
    [-/year] (with a horizon in years)."""

    members: int = Field(32, ge=2, le=MAX_MEMBERS)
    seed: int = Field(0, ge=0)
    posterior: Path | None = None
    rate_field_draws: Path | None = None
    parameters: dict[str, SpreadSpec] = Field(default_factory=dict)
    annual_growth: float = Field(0.0, gt=-0.5, lt=1.0)
    annual_growth_sd: float = Field(0.0, ge=0.0, lt=1.0)


class PlanSpec(Strict):
    """``[plan]``: planning ``years`` (default the horizon's), ``min_stretch_m`` and
    ``bridge_gap_m`` [m], ``min_probability`` [-] (with ``[forecast]``), the yearly caps
    ``cap_m_per_year`` [m] and ``budget_per_year`` [currency], the costs ``tamping_per_m``
    [currency/m] and ``per_possession`` [currency] in ``currency``
    (`trackdyn.deterioration.planning`)."""

    years: PositiveInt | None = None
    min_stretch_m: NonNegativeFloat = 200.0
    bridge_gap_m: NonNegativeFloat = 0.0
    min_probability: float = Field(0.5, gt=0.0, le=1.0)
    cap_m_per_year: PositiveFloat | None = None
    budget_per_year: PositiveFloat | None = None
    tamping_per_m: NonNegativeFloat = 0.0
    per_possession: NonNegativeFloat = 0.0
    currency: str = "cu"

    @field_validator("currency")
    @classmethod
    def _currency(cls, value):
        from trackdyn.units import currency

        return currency(value)

    @model_validator(mode="after")
    def _fits(self):
        if self.cap_m_per_year is not None and self.cap_m_per_year < self.min_stretch_m:
            raise ValueError(f"cap_m_per_year {self.cap_m_per_year:g} m is below min_stretch_m "
                             f"{self.min_stretch_m:g} m: no stretch fits")  # fmt: skip
        if self.budget_per_year is not None and self.tamping_per_m + self.per_possession == 0:
            raise ValueError("budget_per_year needs tamping_per_m or per_possession")
        return self


MOVED_TO_RUN = ("model", "delta", "dt_s")
"""Top-level keys of earlier scenario files that now belong in ``[run]``."""


class DeteriorationScenario(Strict):
    """A deterioration scenario: ``[run]`` options and the traffic, law, loop and track;
    optionally maintenance, an ensemble forecast and a maintenance plan."""

    run: RunOptions = RunOptions()
    traffic: list[TrafficSpec] = Field(default_factory=lambda: list(DEFAULT_TRAFFIC))
    settlement: SettlementSpec = SettlementSpec()
    loop: LoopOptions = LoopOptions()
    track: TrackSectionsSpec = TrackSectionsSpec()
    maintenance: MaintenanceSpec | None = None
    forecast: ForecastSpec | None = None
    plan: PlanSpec | None = None

    @model_validator(mode="after")
    def _plan_in_years(self):
        m, p = self.maintenance, self.plan
        if p is None:
            return self
        if m is None or m.horizon_years is None:
            raise ValueError("[plan] needs [maintenance] with horizon_years and annual_mgt")
        if p.years is not None and p.years > m.horizon_years:
            raise ValueError(f"[plan] years {p.years} is beyond the horizon "
                             f"({m.horizon_years:g} years)")  # fmt: skip
        return self

    @property
    def plan_years(self) -> int:
        """Planning years of ``[plan]`` (the horizon's, whole, by default) [-]."""
        assert self.plan is not None and self.maintenance is not None  # the model's check
        given, horizon = self.plan.years, self.maintenance.horizon_years
        assert horizon is not None
        return given if given is not None else max(1, int(horizon))

    @model_validator(mode="after")
    def _growth_in_years(self):
        f, m = self.forecast, self.maintenance
        growing = f is not None and (f.annual_growth != 0.0 or f.annual_growth_sd != 0.0)
        if growing and (m is None or m.horizon_years is None):
            raise ValueError("forecast annual_growth needs the horizon in years: [maintenance] "
                             "horizon_years and annual_mgt")  # fmt: skip
        return self

    @model_validator(mode="after")
    def _reachable(self):
        m, loop, total = self.maintenance, self.loop, self.horizon_mgt
        if m is not None and m.horizon_years is not None and total > MAX_TOTAL_MGT:
            raise ValueError(f"horizon_years x annual_mgt is {total:g} MGT, outside the "
                             f"plausible 0 to {MAX_TOTAL_MGT:g} MGT")  # fmt: skip
        if m is None:
            return self
        if loop.threshold_sd_mm <= m.recovery_offset_mm:
            raise ValueError(f"[loop] threshold_sd_mm = {loop.threshold_sd_mm:g} mm is not above "
                             f"[maintenance] recovery_offset_mm = {m.recovery_offset_mm:g} mm, "
                             "the least D1 SD a tamping leaves: it could never bring a "
                             "segment under the threshold")  # fmt: skip
        if m.policy == "fixed" and m.interval_mgt is not None and m.interval_mgt > total:
            raise ValueError(f"[maintenance] interval_mgt = {m.interval_mgt:g} MGT is beyond "
                             f"the horizon of {total:g} MGT: no tamping would happen")  # fmt: skip
        return self

    @model_validator(mode="after")
    def _one_horizon(self):
        m = self.maintenance
        if (
            m is not None
            and m.horizon_years is not None
            and "total_mgt" in self.loop.model_fields_set
        ):
            raise ValueError("give the horizon as [loop] total_mgt or as [maintenance] "
                             "horizon_years and annual_mgt, not both")  # fmt: skip
        return self

    @field_validator("loop", mode="before")
    @classmethod
    def _loop_table(cls, value):
        table = LoopOptions.loop_table()
        given = value if isinstance(value, dict) else {}
        other = [k for k in given if k in LoopOptions.model_fields and k not in table]
        if other:
            raise ValueError(f"{other[0]!r} is not a key of [loop]; its keys are "
                             f"{', '.join(table)}")  # fmt: skip
        return value

    @model_serializer(mode="wrap")
    def _without_forecast(self, handler):
        # a scenario without [forecast] records its options as it did before the table
        data = handler(self)
        for table in ("forecast", "plan"):
            if getattr(self, table) is None:
                data.pop(table, None)
        return data

    @field_serializer("loop", mode="wrap")
    def _loop_keys(self, loop, handler):
        table = LoopOptions.loop_table()
        return {k: v for k, v in handler(loop).items() if k in table}

    @property
    def horizon_mgt(self) -> float:
        """Traffic to predict over [MGT]."""
        m = self.maintenance
        if m is not None and m.horizon_years is not None:
            assert m.annual_mgt is not None  # given together (the model's check)
            return m.horizon_years * m.annual_mgt
        return self.loop.total_mgt

    @model_validator(mode="before")
    @classmethod
    def _moved_keys(cls, data):
        moved = [k for k in MOVED_TO_RUN if isinstance(data, dict) and k in data]
        if moved:
            raise ValueError(f"key {moved[0]!r} belongs in the [run] table now")
        return data


def load_deterioration(path=None) -> tuple[DeteriorationScenario, Path]:
    """The deterioration scenario in ``path`` (the built-in example when None) and its folder.

    Parameters
    ----------
    path : path, optional
        Scenario TOML file.
    """
    return load_toml(DeteriorationScenario, path)


def loop_options(spec: DeteriorationScenario, seed, example: bool = False, base=None):
    """`LoopOptions` of a scenario: its ``[loop]`` table and the loop options of its other
    tables, by name (the same names and units).

    Parameters
    ----------
    spec : DeteriorationScenario
        The scenario.
    seed : int or tuple of int
        Rate-field seed of one section.
    example : bool
        The section is the built-in example (starts tamped unless ``[track] start`` says).
    base : Path, optional
        Folder that the parameter file's path starts from (``[settlement] voids``).
    """
    from trackdyn.deterioration.voids import load_voids

    s = spec.settlement
    file = None if s.file is None else (base or Path(".")) / s.file
    return spec.loop.model_copy(update={
        "total_mgt": spec.horizon_mgt,
        "rate_cov": s.rate_cov,
        "rate_correlation_length_m": s.rate_correlation_length_m,
        "seed": seed,
        "run": spec.run,
        "rail": spec.track.rail,
        "start": spec.track.start or ("tamped" if example else "as measured"),
        "maintenance": None if spec.maintenance is None else spec.maintenance.options(),
        "voids": load_voids(file) if s.voids else None,
    })  # fmt: skip


def resolve_inputs(spec: DeteriorationScenario, base: Path):
    """Traffic and settlement law of a scenario, checked before anything runs.

    Parameters
    ----------
    spec : DeteriorationScenario
        The scenario.
    base : Path
        Folder that relative paths in the scenario start from.

    Returns
    -------
    traffic : list of Traffic
    law : SettlementLaw
    """
    from trackdyn.deterioration.law_files import load_law
    from trackdyn.deterioration.loads import cycles_per_passage
    from trackdyn.deterioration.options import Traffic
    from trackdyn.track.rails import rail_section
    from trackdyn.vehicle.models import build_model

    rail_section(spec.track.rail)
    traffic = []
    for i, t in enumerate(spec.traffic):
        try:
            vehicle = t.load(base)
            cycles_per_passage(build_model(spec.run.model, vehicle))  # wheels on both rails
        except TrackdynInputError as exc:
            raise TrackdynInputError(f"traffic {i + 1}: {exc}") from None
        label = t.label or Path(t.vehicle).stem
        traffic.append(Traffic(vehicle, t.speed_kmh, t.passages_per_mgt, label))
    s = spec.settlement
    law = load_law(s.law, None if s.file is None else base / s.file, "open", **s.overrides)
    return traffic, law
