"""Studies and the runs they expand to: the §5.4.1 matrix, parameter variation, speeds.

```toml
kind = "matrix"                  # matrix, sensitivity or speed
[vehicle]                        # as in a run scenario
[track]
[run]
[matrix]
vehicles = ["empty", "loaded"]   # presets or files
cases = ["i", "ii", "iii", "iv"]
damping = { low = {}, high = { rho1 = 4.0, mu = 1.4 } }   # factors on the vehicle's values
[sensitivity]
parameters = ["rho_p", "k1", "kp", "mu"]
factors = [0.5, 0.75, 1.25, 1.5]
grid = false                     # true: every combination
[speed]
speeds_kmh = [20, 40, 60, 80]
```

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria,
§5.4.1 (empty and loaded, low and high
damping, excitation cases i-iv) and §5.4.3 (the parameter variation analysis).
"""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, PositiveFloat

from trackdyn.errors import TrackdynInputError
from trackdyn.limits import MAX_SPEED_KMH
from trackdyn.options import RunOptions, Strict, TrackSpec, VehicleSpec, vehicle_source
from trackdyn.studies.runner import Task, TrackRef
from trackdyn.track.excitation import CASES
from trackdyn.vehicle.parameters import PARAMETERS, load_vehicle


class MatrixSpec(Strict):
    """``[matrix]``: ``vehicles`` (presets or files), excitation ``cases``, ``damping``
    variants (factors on the vehicle's values)."""

    vehicles: list[str] = Field(["empty", "loaded"], min_length=1)
    cases: list[Literal[tuple(CASES)]] = Field(list(CASES), min_length=1)  # type: ignore[valid-type]  # noqa: E501 (a Literal from the CASES registry, which pydantic checks)
    damping: dict[str, dict[str, PositiveFloat]] = {"low": {}, "high": {"rho1": 4.0, "mu": 1.4}}


class SensitivitySpec(Strict):
    """``[sensitivity]``: ``parameters``, ``factors`` on them, ``grid`` of every combination."""

    parameters: list[str] = Field(["rho_p", "k1", "kp", "mu"], min_length=1)
    factors: list[PositiveFloat] = Field([0.5, 0.75, 1.25, 1.5], min_length=1)
    grid: bool = False


class SpeedSpec(Strict):
    """``[speed]``: ``speeds_kmh`` [km/h]."""

    speeds_kmh: list[Annotated[float, Field(gt=0, le=MAX_SPEED_KMH)]] = Field(
        default_factory=lambda: [20.0, 40.0, 60.0, 80.0], min_length=1
    )


class Study(Strict):
    """A study file: its ``kind`` and the tables of a run scenario and of each kind."""

    kind: Literal["matrix", "sensitivity", "speed"] = "matrix"
    vehicle: VehicleSpec = VehicleSpec()
    track: TrackSpec = TrackSpec()
    run: RunOptions = RunOptions()
    matrix: MatrixSpec = MatrixSpec()
    sensitivity: SensitivitySpec = SensitivitySpec()
    speed: SpeedSpec = SpeedSpec()


def _scaled(source: str, overrides: dict, factors: dict) -> dict:
    """Overrides that multiply the vehicle's values by ``factors`` (names checked)."""
    unknown = sorted(set(factors) - set(PARAMETERS))
    if unknown:
        raise TrackdynInputError(f"unknown vehicle parameter {unknown[0]!r} in the study")
    values = load_vehicle(source, **overrides).as_dict()
    return {**overrides, **{k: values[k] * f for k, f in factors.items()}}


def tasks(study: Study, base: Path) -> list[Task]:
    """Expand a study into its independent runs."""
    geometry, supports = (None if p is None else str(p) for p in study.track.paths(base))
    form = study.track.track_format()
    template = Task(
        labels={},
        vehicle=str(study.vehicle.source(base)),
        overrides=dict(study.vehicle.overrides),
        track=TrackRef(geometry, supports, track_format=form),
        run=study.run,
    )
    if study.kind == "matrix":
        out = []
        for name, (damping, factors), case in itertools.product(
            study.matrix.vehicles, study.matrix.damping.items(), study.matrix.cases
        ):
            source = str(vehicle_source(name, base))
            out.append(
                dataclasses.replace(
                    template,
                    vehicle=source,
                    overrides=_scaled(source, template.overrides, factors),
                    track=TrackRef(geometry, supports, case=case, track_format=form),
                    labels={"vehicle": Path(name).stem, "damping": damping, "case": case},
                )
            )
        return out
    if study.kind == "speed":
        return [
            dataclasses.replace(
                template, run=template.run.with_(speed_kmh=v), labels={"speed_kmh": v}
            )
            for v in study.speed.speeds_kmh
        ]
    s = study.sensitivity
    base_run = dataclasses.replace(template, labels={"parameter": "baseline", "factor": 1.0})
    labels: list[dict[str, object]]
    if s.grid:
        combos = itertools.product(s.factors, repeat=len(s.parameters))
        variants = [dict(zip(s.parameters, c, strict=True)) for c in combos]
        labels = [{f"factor_{k}": f for k, f in v.items()} for v in variants]
    else:
        variants = [{p: f} for p in s.parameters for f in s.factors]
        labels = [{"parameter": p, "factor": f} for v in variants for p, f in v.items()]
    runs = [
        dataclasses.replace(
            template, labels=lab, overrides=_scaled(template.vehicle, template.overrides, v)
        )
        for v, lab in zip(variants, labels, strict=True)
    ]
    return runs if s.grid else [base_run, *runs]
