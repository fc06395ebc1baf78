"""The shipped example files are valid and expand as their tables say."""

from pathlib import Path

import pytest

from trackdyn.commands.calibrate.spec import load_calibration
from trackdyn.commands.study import load_study
from trackdyn.studies.scenarios import tasks

EXAMPLES = Path(__file__).parents[2] / "examples"


def expected_runs(study) -> int:
    """Runs a study should give, counted from its tables (not from the expansion)."""
    if study.kind == "matrix":
        m = study.matrix
        return len(m.vehicles) * len(m.damping) * len(m.cases)
    if study.kind == "speed":
        return len(study.speed.speeds_kmh)
    s = study.sensitivity
    return len(s.factors) ** len(s.parameters) if s.grid else 1 + len(s.parameters) * len(s.factors)


@pytest.mark.parametrize("name", ["matrix-2dof.toml", "sensitivity.toml", "speed.toml"])
def test_study_examples_expand_as_their_tables_say(name):
    study, base = load_study(EXAMPLES / name)
    runs = tasks(study, base)
    assert len(runs) == expected_runs(study)
    assert {r.run.model for r in runs} == {study.run.model}


def test_calibration_example_is_valid():
    spec, _ = load_calibration(EXAMPLES / "calibration" / "calibration.toml")
    assert len(spec.survey) >= 2 and spec.fit.parameters
