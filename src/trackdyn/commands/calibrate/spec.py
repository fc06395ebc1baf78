"""Calibration files (TOML) for `trackdyn calibrate`.

A calibration file is a deterioration scenario (`trackdyn.commands.deteriorate.scenario`:
``[run]``, ``[[traffic]]``, ``[settlement]``, ``[loop]``) whose geometry comes from the
surveys, plus ``[[survey]]`` entries and a ``[fit]`` table:

```toml
[track]
supports = "supports.csv"       # support curves, on the first survey's distances
rail = "60E1"
start = "as surveyed"           # the first survey without wavelengths under 3 m (default),
                                # or "as measured"

[[survey]]                      # two or more, in order of increasing tonnage
geometry = "survey_1.csv"       # distance_m,left_mm,right_mm
mgt = 0                         # traffic since the last tamping (or any common origin)
[[survey]]
geometry = "survey_2.csv"
mgt = 10
[[survey]]
geometry = "survey_3.csv"
mgt = 20
check = true                    # not fitted: predicted with the fitted and starting values

[fit]
parameters = ["K_s", "load_exponent"]  # of the [settlement] law; each needs min and max
min_correlation = 0.7           # refuse a survey whose D1 profile matches the first less
max_shift_m = 20                # largest distance offset searched (at most 100 m and half
                                # the first survey's length)
loss_scale_mm = 0.2             # residual size where the soft-L1 loss turns linear
ignore_m = [[700, 740]]         # distance ranges left out (bridges, switches)
max_iterations = 30             # evaluations of the misfit (each global fit)
rate_field = "estimate"         # each rail seat's settlement-rate factor estimated with the
                                # law (default), or "uniform": factor 1 everywhere
rate_cov_max = 0.5              # largest coefficient of variation of that factor (illustrative)
```

``[loop] total_mgt`` and ``snapshot_every_mgt`` are refused: the surveys set them; so are
``[settlement] rate_cov``, ``seed`` and ``rate_field``: a calibration does not run the
deterioration model's random field, its field is ``fit.rate_field``
(``rate_correlation_length_m`` is the estimate's correlation length).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, NonNegativeFloat, PositiveFloat, PositiveInt, model_validator

from trackdyn.calibration.field import DEFAULT_RATE_COV_MAX
from trackdyn.calibration.problem import Calibration, prepare
from trackdyn.commands.deteriorate.scenario import (
    DeteriorationScenario,
    loop_options,
    resolve_inputs,
)
from trackdyn.deterioration.ballast import MAX_RATE_COV
from trackdyn.options import Strict, load_toml

MAX_SHIFT_M = 100.0
"""Largest plausible ``fit.max_shift_m`` [m]: a recording car's distance reference drifts by
metres between runs, not by hundreds of metres."""


class SurveySpec(Strict):
    """``[[survey]]``: ``geometry`` CSV, its tonnage ``mgt`` [MGT], and ``check`` (not
    fitted, only predicted)."""

    geometry: Path
    mgt: NonNegativeFloat
    check: bool = False


class FitSpec(Strict):
    """``[fit]``: ``parameters`` to fit, ``min_correlation`` [-], ``max_shift_m`` [m],
    ``loss_scale_mm`` [mm], ``ignore_m`` ranges [m], ``max_iterations`` (of each global
    fit), ``rate_field``: ``"estimate"`` (each rail seat's settlement-rate factor, with the
    law) or ``"uniform"``, ``rate_cov_max`` [-]: the largest coefficient of variation of
    the estimated factor (`trackdyn.calibration.field.DEFAULT_RATE_COV_MAX`)."""

    parameters: list[str] = Field(min_length=1)
    min_correlation: float = Field(0.7, gt=0, le=1)
    max_shift_m: float = Field(20.0, gt=0, le=MAX_SHIFT_M)
    loss_scale_mm: PositiveFloat = 0.2
    ignore_m: list[tuple[float, float]] = Field(default_factory=list)
    max_iterations: PositiveInt = 30
    rate_field: Literal["estimate", "uniform"] = "estimate"
    rate_cov_max: float = Field(DEFAULT_RATE_COV_MAX, gt=0, le=MAX_RATE_COV)

    @model_validator(mode="after")
    def _check(self):
        if len(set(self.parameters)) < len(self.parameters):
            raise ValueError("parameters: a parameter is named twice")
        for lo, hi in self.ignore_m:
            if not lo < hi:
                raise ValueError(f"ignore_m: range [{lo:g}, {hi:g}] does not have start < end")
        return self


class CalibrationTrackSpec(Strict):
    """``[track]`` of a calibration: ``supports`` CSV, ``rail`` section; the geometry is
    the first survey, ``start`` ``"as surveyed"`` (wavelengths under 3 m removed) or
    ``"as measured"``."""

    supports: Path
    rail: str = "60E1"
    start: Literal["as surveyed", "as measured"] = "as surveyed"


class CalibrationScenario(DeteriorationScenario):
    """A deterioration scenario with surveys and what to fit."""

    # a calibration's own [track] model replaces the scenario's: pydantic allows a field
    # of another type in a subclass, mypy flags it as an incompatible override
    track: CalibrationTrackSpec  # type: ignore[assignment]
    survey: list[SurveySpec] = Field(min_length=2)
    fit: FitSpec

    @model_validator(mode="after")
    def _surveys(self):
        if self.survey[0].check or sum(not s.check for s in self.survey) < 2:
            raise ValueError("survey: the first survey and at least one more must be fitted")
        for i in range(1, len(self.survey)):
            if self.survey[i].mgt <= self.survey[i - 1].mgt:
                raise ValueError(
                    f"survey {i + 1} ({self.survey[i].geometry}): mgt {self.survey[i].mgt:g} "
                    f"is not above the {self.survey[i - 1].mgt:g} of the one before"
                )
        unused = [t for t in ("maintenance", "forecast") if getattr(self, t) is not None]
        if unused:
            raise ValueError(
                f"[{unused[0]}]: not used by a calibration (it fits the law to the surveys, "
                "untamped, without an ensemble), leave it out"
            )
        given = sorted({"total_mgt", "snapshot_every_mgt"} & self.loop.model_fields_set)
        if given:
            raise ValueError(f"loop.{given[0]}: set by the survey tonnages, leave it out")
        given = sorted({"rate_cov", "seed", "rate_field"} & self.settlement.model_fields_set)
        if given:
            raise ValueError(
                f"settlement.{given[0]}: a calibration estimates the rate field or takes it "
                'uniform (fit.rate_field = "estimate" or "uniform"), leave it out'
            )
        return self


def load_calibration(path) -> tuple[CalibrationScenario, Path]:
    """The calibration in ``path`` and the folder its relative paths start from.

    Parameters
    ----------
    path : path
        Calibration TOML file.
    """
    return load_toml(CalibrationScenario, path)


def calibration_problem(spec: CalibrationScenario, base: Path) -> Calibration:
    """The `Calibration` of a calibration file: its traffic, law and loop options resolved,
    the surveys read and aligned (`trackdyn.calibration.problem.prepare`).

    Parameters
    ----------
    spec : CalibrationScenario
        The calibration.
    base : Path
        Folder that relative paths in it start from.
    """
    traffic, law = resolve_inputs(spec, base)
    return prepare(
        spec, base, traffic, law, loop_options(spec, (spec.settlement.seed, 0), base=base)
    )
