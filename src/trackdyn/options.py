"""Run options and the vehicle source: one definition shared by the API, files and CLI.

`RunOptions` is the ``[run]`` table of every scenario kind (run, study, deteriorate) and
the options argument of `trackdyn.simulate`; a new option is a new field here. `VehicleSpec`
is the ``[vehicle]`` table, `TrackSpec` the ``[track]`` table; `vehicle_source`
(`trackdyn.vehicle.parameters`) is the one rule that tells a preset name from a parameter
file. `load_toml` reads and validates a scenario file of any kind.

```toml
[run]
model = "11dof"        # see trackdyn.vehicle.models.MODELS
speed_kmh = 60
dt_s = 2e-4            # optional; default chosen for accuracy and stability
store_every = 10       # optional; default: one stored step per millisecond
delta = 0.3            # dynamic wheel load increment of the linearisation
extrapolate = false    # true: allow Ps ± ΔP beyond the measured curves
nonlinear = false      # true: the bicubic track of 5.14 (single-wheel contacts)
# start_m = 100         # part of the track to run over [m]; default the whole track
# end_m = 400
solver = "central"     # "reference": scipy DOP853 at tight tolerance, to check a case
track = "winkler"      # "discrete": rails on pads, sleepers and ballast behind gaps
```
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PositiveFloat,
    PositiveInt,
    StrictFloat,
    ValidationError,
    field_validator,
    model_validator,
)

from trackdyn.errors import TrackdynInputError, unknown
from trackdyn.io import read_toml
from trackdyn.limits import MAX_SPEED_KMH
from trackdyn.strict import Strict
from trackdyn.track.formats import TrackFormat
from trackdyn.track.support import DELTA
from trackdyn.vehicle.parameters import load_vehicle, vehicle_source


class RunOptions(Strict):
    """How one vehicle runs over a track.

    Parameters
    ----------
    model : str
        Vehicle model, a key of `trackdyn.vehicle.models.MODELS`.
    speed_kmh : float
        Vehicle speed [km/h], up to `trackdyn.limits.MAX_SPEED_KMH`.
    dt_s : float, optional
        Time step [s]; default: `trackdyn.simulation.time_step`.
    store_every : int, optional
        Keep every n-th step; default: one stored step about every millisecond.
    delta : float
        Dynamic wheel load increment δ of the linearisation (5.9) [-].
    extrapolate : bool
        Allow the linearisation to go beyond the measured load-deflection curves.
    nonlinear : bool
        Take the track force from the bicubic surface of 5.14 instead of the linearised
        track (models whose contacts each stand for one wheel).
    start_m, end_m : float, optional
        Part of the track to run over [m]: the rear axle starts at ``start_m``, the run
        ends when the front axle reaches ``end_m``; default the whole track.
    solver : {"central", "reference"}
        The compiled central-difference scheme, or scipy's DOP853 at tight tolerance
        (slow; to check a case), see `trackdyn.solver`.
    track : {"winkler", "discrete"}
        The track under the wheels: the linearised pseudo-static support of the thesis
        (5.4), or the discretely supported track of `trackdyn.track.discrete` (rails as
        beams on pads, sleeper masses, tensionless ballast behind seating gaps; central
        solver only), which also gives the sleeper-ballast force of every sleeper.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)

    model: str = "11dof"
    speed_kmh: float = Field(60.0, gt=0, le=MAX_SPEED_KMH)
    dt_s: PositiveFloat | None = None
    store_every: PositiveInt | None = None
    delta: float = Field(DELTA, gt=0, lt=1)
    extrapolate: bool = False
    nonlinear: bool = False
    start_m: float | None = None
    end_m: float | None = None
    solver: Literal["central", "reference"] = "central"
    track: Literal["winkler", "discrete"] = "winkler"

    @field_validator("model")
    @classmethod
    def _known_model(cls, value):
        from trackdyn.vehicle.models import MODELS

        if value not in MODELS:
            raise unknown("model", value, MODELS)
        return value

    @model_validator(mode="after")
    def _ordered_range(self):
        start, end = self.start_m, self.end_m
        if start is not None and end is not None and not end > start:
            raise ValueError(f"end_m = {end:g} m is not beyond start_m = {start:g} m")
        return self

    @model_validator(mode="after")
    def _discrete_central(self):
        if self.track == "discrete" and (self.solver != "central" or self.nonlinear):
            raise ValueError(
                'track = "discrete" runs with solver = "central" and nonlinear = false'
            )
        return self

    @property
    def speed(self) -> float:
        """Vehicle speed [m/s]."""
        return self.speed_kmh / 3.6

    @property
    def integrator(self) -> str:
        """The solver that integrates the run (`trackdyn.solver.SOLVERS`): ``"discrete"``
        on the discrete track, `solver` on the Winkler track."""
        return "discrete" if self.track == "discrete" else self.solver

    def with_(self, **changes) -> RunOptions:
        """A validated copy with some options changed (names and values checked)."""
        return parse(RunOptions, {**self.model_dump(), **changes}, "run options")


class VehicleSpec(Strict):
    """``[vehicle]``: a ``preset`` or a parameter ``file``, and ``overrides`` [SI units]."""

    preset: str = "loaded"
    file: Path | None = None
    overrides: dict[str, StrictFloat] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _one_source(self):
        if self.file is not None and "preset" in self.model_fields_set:
            raise ValueError("give a preset or a file, not both")
        return self

    def source(self, base: Path) -> str | Path:
        """The vehicle source (see `vehicle_source`)."""
        return vehicle_source(self.file if self.file is not None else self.preset, base)

    def load(self, base: Path):
        """The vehicle parameter set, overrides applied."""
        return load_vehicle(self.source(base), **self.overrides)


class TrackSpec(TrackFormat):
    """``[track]``: ``geometry`` and ``supports`` CSV files; neither: the built-in example;
    and what the geometry file holds (`trackdyn.track.formats.TrackFormat`)."""

    geometry: Path | None = None
    supports: Path | None = None

    def paths(self, base: Path) -> tuple[Path | None, Path | None]:
        """Both files relative to ``base`` (None where not given: the example)."""
        geometry, supports = (
            None if p is None else base / p for p in (self.geometry, self.supports)
        )
        return geometry, supports

    def load(self, base: Path):
        """The track (`trackdyn.track.track.Track`)."""
        from trackdyn.data import load_track

        return load_track(*self.paths(base), self.track_format())


def load_toml(model: type[BaseModel], path=None, default: BaseModel | None = None):
    """The scenario file ``path`` validated against ``model``, and its folder.

    Parameters
    ----------
    model : type of pydantic.BaseModel
        The file's model.
    path : path, optional
        TOML file; None gives ``default`` (``model()`` if not given) and the working folder.
    default : pydantic.BaseModel, optional
        The built-in scenario used without a file.

    Returns
    -------
    spec : pydantic.BaseModel
        The validated file.
    base : Path
        The folder its relative paths start from.
    """
    if path is None:
        return (model() if default is None else default), Path.cwd()
    return parse(model, read_toml(path), str(path)), Path(path).resolve().parent


def parse(model: type[BaseModel], data: dict, where: str):
    """Validate ``data`` against a pydantic ``model``; errors become one-line messages.

    Parameters
    ----------
    model : type of pydantic.BaseModel
        The table's model.
    data : dict
        The table as read.
    where : str
        File (or other source) named in the message.
    """
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(x) for x in err["loc"])
        if err["type"] == "extra_forbidden":
            raise TrackdynInputError(f"{where}: unknown key {loc or '(top level)'!r}") from None
        msg = err["msg"].removeprefix("Value error, ")
        raise TrackdynInputError(f"{where}: {loc + ': ' if loc else ''}{msg}") from None
