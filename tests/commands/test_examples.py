"""The shipped examples: written by `trackdyn example`, valid, and (slow) runnable."""

from importlib.resources import files

import pytest
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.commands.calibrate.spec import load_calibration
from trackdyn.commands.deteriorate.scenario import load_deterioration
from trackdyn.commands.deteriorate.sections import section_tasks
from trackdyn.commands.examples import EXAMPLES
from trackdyn.commands.run import load_scenario
from trackdyn.commands.study import load_study
from trackdyn.studies.scenarios import tasks

runner = CliRunner()


def expected_runs(study) -> int:
    """Runs a study should give, counted from its tables (not from the expansion)."""
    if study.kind == "matrix":
        m = study.matrix
        return len(m.vehicles) * len(m.damping) * len(m.cases)
    if study.kind == "speed":
        return len(study.speed.speeds_kmh)
    s = study.sensitivity
    return len(s.factors) ** len(s.parameters) if s.grid else 1 + len(s.parameters) * len(s.factors)


def written(name, tmp_path):
    """The folder `trackdyn example NAME --to` wrote, after checking its files."""
    to = tmp_path / name
    result = runner.invoke(app, ["example", name, "--to", str(to)])
    assert result.exit_code == 0, result.output
    assert {p.name for p in to.iterdir()} - {".trackdyn.json"} == set(EXAMPLES[name][1])
    assert result.stdout.startswith("trackdyn ")  # the command that runs it
    return to


def test_every_shipped_file_is_in_an_example():
    package = files("trackdyn")
    shipped = {
        f"examples/{p.name}" for p in package.joinpath("examples").iterdir() if p.is_file()
    } | {
        f"examples/calibration/{p.name}" for p in package.joinpath("examples/calibration").iterdir()
    }
    used = {source for _, sources, _ in EXAMPLES.values() for source in sources.values()}
    assert shipped <= used
    assert all(package.joinpath(source).is_file() for source in used)


@pytest.mark.parametrize("name", ["matrix-2dof.toml", "sensitivity.toml", "speed.toml"])
def test_study_examples_expand_as_their_tables_say(name, tmp_path):
    study, base = load_study(written("study", tmp_path) / name)
    runs = tasks(study, base)
    assert len(runs) == expected_runs(study)
    assert {r.run.model for r in runs} == {study.run.model}


def test_run_deteriorate_and_calibration_examples_are_valid(tmp_path):
    spec, base = load_scenario(written("run", tmp_path) / "run.toml")
    assert spec.track.geometry is not None and spec.vehicle.load(base).name.startswith("loaded")
    for name, toml, sections in (
        ("deteriorate", "deteriorate.toml", 1),
        ("sections", "sections.toml", 2),
    ):
        spec, base = load_deterioration(written(name, tmp_path) / toml)
        assert len(section_tasks(spec, base)) == sections
    spec, _ = load_calibration(written("calibration", tmp_path) / "calibration.toml")
    assert len(spec.survey) == 3 and spec.fit.parameters


def test_listing_and_unknown_example(tmp_path):
    listing = runner.invoke(app, ["example"])
    assert listing.exit_code == 0 and all(name in listing.stdout for name in EXAMPLES)
    result = runner.invoke(app, ["example", "bridge", "--to", str(tmp_path / "x")])
    assert result.exit_code == 2 and "unknown example 'bridge'" in result.stderr


@pytest.mark.slow
@pytest.mark.parametrize("name", list(EXAMPLES))
def test_every_example_runs_as_its_command_says(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for line in runner.invoke(app, ["example", name, "--to", "ex"]).stdout.splitlines():
        command = line.split()
        assert command[0] == "trackdyn"
        serial = ["--workers", "1"] if command[1] != "run" else []
        result = runner.invoke(app, ["-q", *command[1:], *serial])
        assert result.exit_code == 0, result.output
        if name == "survey":  # what was done to a recording car's file is said, even with -q
            assert "profile recovered from versines" in result.stderr
        else:
            assert result.stderr == ""  # -q: the results on stdout, nothing else
        assert (tmp_path / command[-1] / ".trackdyn.json").is_file()


def test_the_study_example_names_each_of_its_studies(tmp_path):
    to = tmp_path / "ex"
    lines = runner.invoke(app, ["example", "study", "--to", str(to)]).stdout.splitlines()
    studies = [line.split()[2] for line in lines]  # trackdyn study FILE --out DIR
    assert studies == [str(to / n) for n in ("matrix-2dof.toml", "sensitivity.toml", "speed.toml")]
    assert set(EXAMPLES["study"][1]) == {"matrix-2dof.toml", "sensitivity.toml", "speed.toml"}
    assert len({line.split()[-1] for line in lines}) == 3  # each its own output folder


def test_example_refuses_to_overwrite_files_unless_told(tmp_path):
    to = tmp_path / "ex"
    assert runner.invoke(app, ["example", "run", "--to", str(to)]).exit_code == 0
    (to / "run.toml").write_text("# edited by the user\n")
    result = runner.invoke(app, ["example", "deteriorate", "--to", str(to)])
    assert result.exit_code == 2  # its geometry.csv and supports.csv are there
    assert result.stderr.strip() == (
        f"error: --to {to}: geometry.csv, supports.csv already there; choose another folder "
        "or give --overwrite to replace them"
    )
    assert not (to / "deteriorate.toml").exists()  # nothing written
    result = runner.invoke(app, ["example", "run", "--to", str(to)])
    assert result.exit_code == 2 and "run.toml, geometry.csv" in result.stderr
    assert (to / "run.toml").read_text() == "# edited by the user\n"
    # another example's files beside them: the edited run.toml stays
    assert runner.invoke(app, ["example", "study", "--to", str(to)]).exit_code == 0
    assert (to / "run.toml").read_text() == "# edited by the user\n"
    assert runner.invoke(app, ["example", "run", "--to", str(to), "--overwrite"]).exit_code == 0
    shipped = files("trackdyn").joinpath(EXAMPLES["run"][1]["run.toml"]).read_text()
    assert (to / "run.toml").read_text() == shipped
    assert sorted(p.name for p in to.iterdir()) == sorted(
        {*EXAMPLES["run"][1], *EXAMPLES["study"][1]}
    )


def test_every_command_has_its_own_default_output_folder():
    import typer

    group = typer.main.get_command(app)
    defaults = {}
    for name, command in group.commands.items():
        (out,) = [p.default for p in command.params if p.name in ("out", "to")]
        defaults[name] = out
    assert defaults == {
        "track": "trackdyn-out/track",
        "run": "trackdyn-out/run",
        "study": "trackdyn-out/study",
        "deteriorate": "trackdyn-out/deteriorate",
        "calibrate": "trackdyn-out/calibrate",
        "example": "trackdyn-example",
    }


@pytest.mark.slow
def test_every_command_runs_bare_one_after_the_other(tmp_path, monkeypatch):
    """As getting-started says: each command without a file runs on the built-in example,
    one after the other in one folder (each into its own default output folder)."""
    monkeypatch.chdir(tmp_path)
    serial = ["--workers", "1"]
    for command, extra in (("run", []), ("track", []), ("deteriorate", serial),
                           ("calibrate", serial)):  # fmt: skip
        result = runner.invoke(app, ["-q", command, *extra])
        assert result.exit_code == 0, (command, result.output)
        assert (tmp_path / "trackdyn-out" / command / ".trackdyn.json").is_file()
