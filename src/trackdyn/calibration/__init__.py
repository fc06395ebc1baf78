"""Calibration: settlement-law parameters fitted to repeated geometry surveys.

`trackdyn.calibration.surveys` reads and aligns the surveys; `prepare` builds the
`Calibration` (aligned surveys, measured changes, fit coordinates); `fit` minimises the misfit
of the predicted D1-band change (`trackdyn.deterioration.predict`) by least squares, with
each rail seat's settlement-rate factor estimated alongside (`trackdyn.calibration.field`,
a `FieldEstimate`); `synthetic_surveys` makes surveys from the model itself, for testing on
known parameters.
"""

from trackdyn.calibration.field import FieldEstimate
from trackdyn.calibration.fit import FitResult, Objective, fit
from trackdyn.calibration.problem import Calibration, prepare, synthetic_surveys

__all__ = [
    "FieldEstimate",
    "FitResult",
    "Objective",
    "Calibration",
    "fit",
    "prepare",
    "synthetic_surveys",
]
