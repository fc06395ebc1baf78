"""Study files and the runs they expand to: the §5.4.1 matrix, parameter variation, speeds.

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
"""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, PositiveFloat

from trackdyn.errors import TrackdynInputError
from trackdyn.scenario import RunSpec, Strict, TrackSpec, VehicleSpec, parse, read_toml
from trackdyn.studies.runner import Task, TrackRef
from trackdyn.track.track import Geometry, LinearisedTrack
from trackdyn.vehicle.parameters import PARAMETERS, load_vehicle

RIGID_STIFFNESS = 1e11
"""Track stiffness per wheel standing in for infinitely stiff track in case (i) [N/m]:
about 1000 times real track, so the wheel follows the geometry within 0.1 %."""

CASES = {
    "i": "space curve, infinitely stiff track",
    "ii": "space curve, constant stiffness",
    "iii": "varying stiffness, level track",
    "iv": "space curve and varying stiffness",
}


def excitation_case(lin: LinearisedTrack, case: str) -> LinearisedTrack:
    """The linearised track as one of the four excitation cases of §5.4.1.

    (i) the unloaded space curve on infinitely stiff track (`RIGID_STIFFNESS`, no static
    deflection); (ii) the space curve with the mean k2 and ys everywhere; (iii) level rails
    with the measured k2 and ys; (iv) the track as measured.
    """
    if case not in CASES:
        raise TrackdynInputError(f"unknown excitation case {case!r}; known: {', '.join(CASES)}")
    if case == "iv":
        return lin
    if case == "iii":
        g = lin.track.geometry
        level = Geometry(g.distance, np.zeros_like(g.left), np.zeros_like(g.right), g.where)
        return dataclasses.replace(lin, track=dataclasses.replace(lin.track, geometry=level))
    if case == "ii":
        return dataclasses.replace(
            lin, k2=np.full_like(lin.k2, lin.k2.mean()), ys=np.full_like(lin.ys, lin.ys.mean())
        )
    return dataclasses.replace(
        lin, k2=np.full_like(lin.k2, RIGID_STIFFNESS), ys=np.zeros_like(lin.ys)
    )


class MatrixSpec(Strict):
    vehicles: list[str] = ["empty", "loaded"]
    cases: list[Literal["i", "ii", "iii", "iv"]] = ["i", "ii", "iii", "iv"]
    damping: dict[str, dict[str, PositiveFloat]] = {"low": {}, "high": {"rho1": 4.0, "mu": 1.4}}


class SensitivitySpec(Strict):
    parameters: list[str] = ["rho_p", "k1", "kp", "mu"]
    factors: list[PositiveFloat] = [0.5, 0.75, 1.25, 1.5]
    grid: bool = False


class SpeedSpec(Strict):
    speeds_kmh: list[PositiveFloat] = Field(default_factory=lambda: [20, 40, 60, 80])


class Study(Strict):
    kind: Literal["matrix", "sensitivity", "speed"] = "matrix"
    vehicle: VehicleSpec = VehicleSpec()
    track: TrackSpec = TrackSpec()
    run: RunSpec = RunSpec()
    matrix: MatrixSpec = MatrixSpec()
    sensitivity: SensitivitySpec = SensitivitySpec()
    speed: SpeedSpec = SpeedSpec()


def load_study(path=None) -> tuple[Study, Path]:
    """The study in ``path`` (the built-in example: the 2-DOF §5.4.1 matrix, when None)."""
    if path is None:
        return Study(run=RunSpec(model="2dof")), Path.cwd()
    return parse(Study, read_toml(path), str(path)), Path(path).resolve().parent


def _vehicle_source(spec: VehicleSpec, base: Path, name: str | None = None) -> str:
    if name is not None:
        return str(base / name) if name.endswith(".toml") else name
    return str(base / spec.file) if spec.file is not None else str(spec.preset)


def _scaled(source: str, overrides: dict, factors: dict) -> dict:
    """Overrides that multiply the vehicle's values by ``factors`` (names checked)."""
    unknown = sorted(set(factors) - set(PARAMETERS))
    if unknown:
        raise TrackdynInputError(f"unknown vehicle parameter {unknown[0]!r} in the study")
    values = load_vehicle(source, **overrides).as_dict()
    return {**overrides, **{k: values[k] * f for k, f in factors.items()}}


def tasks(study: Study, base: Path) -> list[Task]:
    """Expand a study into its independent runs."""
    t = study.track
    paths = [None if p is None else str(base / p) for p in (t.geometry, t.supports)]
    r = study.run
    template = Task(
        labels={},
        vehicle=_vehicle_source(study.vehicle, base),
        overrides=dict(study.vehicle.overrides),
        track=TrackRef(*paths),
        model=r.model,
        speed_kmh=r.speed_kmh,
        dt_s=r.dt_s,
        delta=r.delta,
        extrapolate=r.extrapolate,
        nonlinear=r.nonlinear,
        store_every=r.store_every,
    )
    if study.kind == "matrix":
        out = []
        for name, (damping, factors), case in itertools.product(
            study.matrix.vehicles, study.matrix.damping.items(), study.matrix.cases
        ):
            source = _vehicle_source(study.vehicle, base, name)
            out.append(
                dataclasses.replace(
                    template,
                    vehicle=source,
                    overrides=_scaled(source, template.overrides, factors),
                    track=TrackRef(*paths, case=case),
                    labels={"vehicle": Path(name).stem, "damping": damping, "case": case},
                )
            )
        return out
    if study.kind == "speed":
        return [
            dataclasses.replace(template, speed_kmh=v, labels={"speed_kmh": v})
            for v in study.speed.speeds_kmh
        ]
    s = study.sensitivity
    base_run = dataclasses.replace(template, labels={"parameter": "baseline", "factor": 1.0})
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
