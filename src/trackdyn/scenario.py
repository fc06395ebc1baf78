"""Scenario files (TOML) for `trackdyn run`: vehicle, track, model, speed, time step.

```toml
[vehicle]
preset = "loaded"          # or: file = "wagon.toml" (relative to this file)
overrides = { mu = 0.3 }   # seed symbols, SI units

[track]                    # omit for the built-in example section
geometry = "geometry.csv"  # distance_m,left_mm,right_mm
supports = "supports.csv"  # distance_m,rail,load_kN,deflection_mm

[run]
model = "11dof"
speed_kmh = 60
dt_s = 2e-4                # optional; default chosen for accuracy
# store_every = 10         # keep every n-th step; default: one per millisecond
delta = 0.3
extrapolate = false         # true: allow Ps ± ΔP beyond the measured curves
```
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, PositiveInt, ValidationError

from trackdyn.errors import TrackdynInputError


class Strict(BaseModel):
    """Base of scenario sections: unknown keys are refused."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class VehicleSpec(Strict):
    preset: str | None = "loaded"
    file: Path | None = None
    overrides: dict[str, float] = Field(default_factory=dict)

    def load(self, base: Path):
        from trackdyn.vehicle.parameters import load_vehicle

        source = base / self.file if self.file is not None else self.preset
        return load_vehicle(source, **self.overrides)


class TrackSpec(Strict):
    geometry: Path | None = None
    supports: Path | None = None

    def load(self, base: Path):
        from trackdyn.data import load_track

        paths = [None if p is None else base / p for p in (self.geometry, self.supports)]
        return load_track(*paths)


class RunSpec(Strict):
    model: Literal["2dof", "2dof-wedge", "4dof", "7dof", "11dof"] = "11dof"
    speed_kmh: PositiveFloat = 60.0
    dt_s: PositiveFloat | None = None
    store_every: PositiveInt | None = None
    delta: float = Field(0.3, gt=0, lt=1)
    extrapolate: bool = False
    nonlinear: bool = False


class Scenario(Strict):
    vehicle: VehicleSpec = VehicleSpec()
    track: TrackSpec = TrackSpec()
    run: RunSpec = RunSpec()


def parse(model: type[BaseModel], data: dict, where: str):
    """Validate ``data`` against a pydantic ``model``; errors become one-line messages."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(x) for x in err["loc"]) or "(top level)"
        if err["type"] == "extra_forbidden":
            raise TrackdynInputError(f"{where}: unknown key {loc!r}") from None
        raise TrackdynInputError(f"{where}: {loc}: {err['msg']}") from None


def read_toml(path) -> dict:
    """Read a TOML file; a missing or malformed file is a one-line error."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except OSError:
        raise TrackdynInputError(f"{path}: cannot read the file") from None
    except tomllib.TOMLDecodeError as exc:
        raise TrackdynInputError(f"{path}: not valid TOML ({exc})") from None


def load_scenario(path=None) -> tuple[Scenario, Path]:
    """The scenario in ``path`` (the built-in example when None) and its folder."""
    if path is None:
        return Scenario(), Path.cwd()
    return parse(Scenario, read_toml(path), str(path)), Path(path).resolve().parent
