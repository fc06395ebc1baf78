"""The options of the deterioration loop (`LoopOptions`) and the traffic mix (`Traffic`).

The API takes the names of the scenario files, each with its unit suffix
(``max_step_settlement_mm``, ``segment_length_m``, ``speed_kmh``); the loop's SI values are
properties of the options (``max_step_settlement`` [m], ``Traffic.speed`` [m/s]), derived
here and nowhere else.
"""

from __future__ import annotations

from dataclasses import dataclass

from pydantic import ConfigDict, Field

from trackdyn.deterioration.maintenance import MaintenanceOptions
from trackdyn.deterioration.voids import VoidParameters
from trackdyn.limits import MAX_TOTAL_MGT
from trackdyn.options import RunOptions, Strict
from trackdyn.vehicle.models import build_model
from trackdyn.vehicle.parameters import Vehicle


@dataclass(frozen=True)
class Traffic:
    """One kind of vehicle in the traffic mix.

    Parameters
    ----------
    vehicle : Vehicle
        Vehicle parameter set.
    speed_kmh : float
        Running speed [km/h] (the ``[[traffic]]`` key).
    passages_per_mgt : float
        Passages of this vehicle per million gross tonnes of traffic [-].
    label : str
        Name used in outputs.
    """

    vehicle: Vehicle
    speed_kmh: float
    passages_per_mgt: float
    label: str = ""

    @property
    def speed(self) -> float:
        """Running speed [m/s]."""
        return self.speed_kmh / 3.6

    def gross_mass(self, model: str) -> float:
        """Gross mass of the vehicle as the vehicle model ``model`` carries it [kg]."""
        return build_model(model, self.vehicle).gross_mass


MIN_SEGMENT_M = 25.0
"""Shortest segment of the D1 standard deviation [m]: the D1 band's longest wavelength."""

LOOP_TABLE = "loop"
"""Marker of the `LoopOptions` fields that are keys of a scenario file's ``[loop]`` table."""


def loop_key(default, **bounds):
    """A `LoopOptions` field that is also a key of the ``[loop]`` table (`LOOP_TABLE`)."""
    return Field(default, json_schema_extra={"table": LOOP_TABLE}, **bounds)


class LoopOptions(Strict):
    """Options of the deterioration loop; each default and plausible range lives here.

    The names are those of the scenario files, with their unit suffix (``_mm``, ``_m``,
    ``_kg``); the options the loop uses in SI are properties of the name without the
    suffix (``max_step_settlement`` [m], ...), derived here and nowhere else. The fields
    marked `LOOP_TABLE` are a scenario file's ``[loop]`` table (validated by this model);
    ``rate_cov``, ``rate_correlation_length_m`` and ``seed`` come from its
    ``[settlement]`` table, ``rail`` and ``start`` from ``[track]``, ``run`` from
    ``[run]`` and ``maintenance`` from ``[maintenance]``, by name.

    Parameters
    ----------
    total_mgt : float
        Traffic to predict over [MGT].
    max_step_settlement_mm : float
        Largest change of the settlement's shape (less its moving mean over
        `SHAPE_WAVELENGTH`) of any sleeper in one step [mm]; a sleeper's stable step
        (`stable_settlement`) may keep the load updates within it shorter. Default 1 mm:
        on the built-in example through 50 MGT the D1 SD of every segment is within
        0.25 % of that with 0.25 mm steps (15 steps against 55), its 300 MGT life has the
        tampings of 0.5 mm steps (91 steps against 153) to 0.5 MGT through 240 MGT and to
        6 MGT after (270.2 against 275.8 MGT, after which the bridge segment's last
        tamping, at 291 MGT, falls within the horizon only with 1 mm steps), and the
        Varandas law takes 29-42 steps (its D1 SD moving by up to 2 % between limits of
        0.5, 1 and 2 mm, without a trend, and by as much with round-off).
    snapshot_every_mgt : float
        Tonnage between stored geometry snapshots [MGT].
    threshold_sd_mm : float
        D1 standard deviation that triggers maintenance [mm]; default 1.6 mm, illustrative
        (set within what the tamped example reaches in 50 MGT; a railway sets its own).
    segment_length_m : float
        Segment length of the D1 standard deviation [m].
    max_steps : int
        Steps allowed before giving up.
    rate_cov : float
        Coefficient of variation of the lognormal settlement-rate factor per sleeper [-];
        default 0.3, illustrative (an engineering estimate, not a published value).
    rate_correlation_length_m : float
        Correlation length of that factor along the track [m]; default 3 m, illustrative
        (an engineering estimate: a few sleepers).
    seed : int or tuple of int
        Seed of the rate field.
    rate_factor : tuple of tuple of float, optional
        A rate field given per rail and sleeper (2, n) [-], e.g. estimated by `trackdyn
        calibrate`; ``rate_cov`` and ``seed`` are then not used.
    rate_scale : tuple of float, optional
        Multiplier of the settlement rate per sleeper (both rails) [-] on top of the rate
        field and the zones' own, e.g. under-sleeper pads over a range (the interventions
        study's ``settlement_scale``); default none (1).
    sleeper_mass_kg : float
        Sleeper mass per rail seat, hanging from the rail when its ballast sinks [kg];
        default 125.5 kg, the half-sleeper mass of Zhai et al. (2004).
    run : RunOptions
        Model (with wheels on both rails), linearisation increment, time step and solver
        of the vehicle runs; each vehicle's speed comes from its `Traffic`.
    rail : str
        Rail section, for the bending stiffness EI of the load distribution.
    output_spacing_m : float
        Travel between stored simulation samples [m] (sets ``store_every``).
    start : str
        ``"as measured"``: the track as its files give it; ``"tamped"``: freshly tamped
        (`trackdyn.deterioration.starts`: most of the D1 band removed, sleepers seated);
        ``"as surveyed"``: as measured without the wavelengths under 3 m, mostly
        measurement noise (`trackdyn.deterioration.starts.surveyed_geometry`).
    snapshot_mgt : tuple of float
        Further tonnages at which to store a geometry snapshot, e.g. those of surveys
        [MGT], each the end of a step; those beyond ``total_mgt`` are ignored.
    min_step_passages : float
        Shortest first step, in passages of the traffic mix [-]: one train; default 100
        (illustrative: a coal train of 100 wagons; the Richards Bay line runs 200). The
        first step after a tamping too.
    maintenance : MaintenanceOptions, optional
        Tamp over the horizon (`trackdyn.deterioration.maintenance`); None: no maintenance,
        the loop only reports when each segment reaches the threshold.
    voids : VoidParameters, optional
        Ballast under a void settles faster (`trackdyn.deterioration.voids`), with these
        parameters (the ``[voids]`` table of the settlement parameter file, read by
        `trackdyn.deterioration.voids.load_voids`; ``[settlement] voids = true`` in a
        scenario); None (default): off, the loop as without the option.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    total_mgt: float = loop_key(50.0, gt=0, le=MAX_TOTAL_MGT)
    max_step_settlement_mm: float = loop_key(1.0, ge=0.01, le=10.0)
    snapshot_every_mgt: float = loop_key(10.0, gt=0)
    threshold_sd_mm: float = loop_key(1.6, gt=0, le=20.0)
    segment_length_m: float = loop_key(200.0, ge=MIN_SEGMENT_M)
    max_steps: int = loop_key(1000, gt=0, le=100_000)
    rate_cov: float = 0.3
    rate_correlation_length_m: float = 3.0
    seed: int | tuple[int, ...] = 0
    rate_factor: tuple[tuple[float, ...], ...] | None = None
    rate_scale: tuple[float, ...] | None = None
    sleeper_mass_kg: float = 125.5
    run: RunOptions = RunOptions()
    rail: str = "60E1"
    output_spacing_m: float = 0.02
    start: str = "as measured"
    snapshot_mgt: tuple[float, ...] = ()
    min_step_passages: float = loop_key(100.0, gt=0, le=1e6)
    maintenance: MaintenanceOptions | None = None
    voids: VoidParameters | None = None

    @property
    def max_step_settlement(self) -> float:
        """``max_step_settlement_mm`` [m]."""
        return self.max_step_settlement_mm * 1e-3

    @property
    def segment_length(self) -> float:
        """``segment_length_m`` [m]."""
        return self.segment_length_m

    @property
    def rate_correlation_length(self) -> float:
        """``rate_correlation_length_m`` [m]."""
        return self.rate_correlation_length_m

    @property
    def sleeper_mass(self) -> float:
        """``sleeper_mass_kg`` [kg]."""
        return self.sleeper_mass_kg

    @property
    def output_spacing(self) -> float:
        """``output_spacing_m`` [m]."""
        return self.output_spacing_m

    @classmethod
    def loop_table(cls) -> tuple[str, ...]:
        """The options that are keys of a scenario file's ``[loop]`` table."""
        return tuple(name for name, f in cls.model_fields.items()
                     if isinstance(f.json_schema_extra, dict)
                     and f.json_schema_extra.get("table") == LOOP_TABLE)  # fmt: skip

    def in_si(self) -> dict:
        """Every option by name, those with an SI property (above) by its name and value
        (``max_step_settlement`` [m] for ``max_step_settlement_mm`` [mm], ...)."""
        out = {}
        for name in type(self).model_fields:
            si = name.rsplit("_", 1)[0]
            key = si if isinstance(getattr(type(self), si, None), property) else name
            out[key] = getattr(self, key)
        return out
