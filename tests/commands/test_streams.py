"""stdout holds the results (tables), stderr everything else; ``-q`` leaves stderr empty.

Each command runs twice on small inputs, normally and with ``-q``: the two stdouts are the
same (``-q`` removes only what goes to stderr), the normal stderr says what was written,
the quiet one is empty. The calibration's run is in ``tests/calibration/test_calibrate.py``
(a fit takes dozens of runs).
"""

import logging
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import synthetic_track

runner = CliRunner()

DETERIORATE = """
[run]
model = "4dof"
[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[loop]
total_mgt = 0.5
snapshot_every_mgt = 0.5
segment_length_m = 60
[track]
geometry = "geometry.csv"
supports = "supports.csv"
"""
"""Half an MGT of one vehicle, 4-DOF (deterioration needs both rails), over the 160 m
section: the shortest deterioration."""

SPEED = 'kind = "speed"\n[run]\nmodel = "2dof"\nend_m = 100\n[speed]\nspeeds_kmh = [40]\n'
"""One 2-DOF run over the first 100 m of the built-in section."""


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A 160 m synthetic section (the D2 band needs 140 m), a run scenario, a study and a
    deterioration scenario."""
    path = tmp_path_factory.mktemp("streams")
    trk = synthetic_track(160.0, spectrum="fra5", seed=3)
    write_geometry(trk.geometry, path / "geometry.csv")
    write_supports(trk.supports, path / "supports.csv")
    track = '[track]\ngeometry = "geometry.csv"\nsupports = "supports.csv"\n'
    (path / "run.toml").write_text(track + '[run]\nmodel = "2dof"\n')
    (path / "speed.toml").write_text(SPEED)
    (path / "deteriorate.toml").write_text(DETERIORATE)
    return path


def commands(folder):
    """Each command's arguments on the small inputs (the last one the output folder's flag),
    the title its stdout starts with, what its stderr says."""
    files = ["--geometry", str(folder / "geometry.csv"), "--supports", str(folder / "supports.csv")]
    serial = ["--workers", "1", "--out"]
    return {
        "track": (["track", *files, "--out"], "Track summary", "wrote"),
        "run": (["run", str(folder / "run.toml"), "--out"], "2dof: loaded", "wrote"),
        "study": (["study", str(folder / "speed.toml"), *serial], "speed study", "wrote"),
        "deteriorate": (
            ["deteriorate", str(folder / "deteriorate.toml"), *serial],
            "Deterioration, 4dof",
            "wrote",
        ),
        "example": (["example", "run", "--to"], "trackdyn run ", "wrote run.toml"),
    }


@pytest.mark.parametrize("command", ["track", "run", "study", "deteriorate", "example"])
def test_quiet_leaves_stdout_with_the_results_and_stderr_empty(folder, tmp_path, command):
    args, title, said = commands(folder)[command]
    normal = runner.invoke(app, [*args, str(tmp_path / "normal")])
    assert normal.exit_code == 0, normal.output
    quiet = runner.invoke(app, ["-q", *args, str(tmp_path / "quiet")])
    assert quiet.exit_code == 0, quiet.output
    assert quiet.stderr == ""
    assert quiet.stdout.lstrip().startswith(title), quiet.stdout
    assert quiet.stdout == normal.stdout.replace("normal", "quiet")  # example: the folder
    assert said in normal.stderr and said not in normal.stdout
    assert not normal.stderr.startswith("\n")


@pytest.mark.parametrize("command", ["run", "deteriorate"])
def test_verbose_adds_the_inputs_and_the_time_for_every_command(folder, tmp_path, command):
    args, _, _ = commands(folder)[command]
    verbose = runner.invoke(app, [*args, str(tmp_path / "out"), "-v"])  # -v after the command
    assert verbose.exit_code == 0, verbose.output
    assert f"input scenario: {args[1]} " in verbose.stderr
    assert "time total:" in verbose.stderr and "time total:" not in verbose.stdout


def test_global_flags_after_the_command_and_short_version(folder, tmp_path):
    args, _, _ = commands(folder)["example"]
    quiet = runner.invoke(app, [*args, str(tmp_path / "ex"), "-q"])
    assert quiet.exit_code == 0 and quiet.stderr == "" and quiet.stdout.startswith("trackdyn run")
    version = runner.invoke(app, ["-V"])
    assert version.exit_code == 0 and version.stdout.startswith("trackdyn ")


def test_the_track_title_names_the_built_in_example_not_its_path(tmp_path):
    result = runner.invoke(app, ["-q", "track", "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    title = result.stdout.strip().splitlines()[0]
    assert "built-in example, example_geometry.csv" in title and "/" not in title


def test_the_time_remaining_waits_for_a_few_updates():
    from rich.progress import Progress, TimeRemainingColumn

    from trackdyn.progress import ETA_AFTER, _columns

    clock = iter(range(100))  # one second per call: the rate is one unit per second
    remaining = _columns()[-1]
    with Progress(*_columns(), disable=True, get_time=lambda: next(clock)) as prog:
        task = prog.add_task("runs", total=100)
        for k in range(1, ETA_AFTER + 1):
            prog.update(task, advance=1, updates=k)
            shown = remaining.render(prog.tasks[0]).plain
            rich_eta = TimeRemainingColumn().render(prog.tasks[0]).plain
            assert shown == ("-:--:--" if k < ETA_AFTER else rich_eta), k
        assert rich_eta not in ("-:--:--", "0:00:00")  # rich's own column has a rate


def test_quiet_starts_the_local_cluster_with_its_logs_silenced(monkeypatch):
    import distributed

    from trackdyn import parallel
    from trackdyn.progress import set_verbosity

    given = {}
    monkeypatch.setattr(distributed, "LocalCluster", lambda **kw: given.update(kw))
    monkeypatch.setattr(distributed, "Client", lambda cluster: None)
    try:
        for level, expected in ((0, "CRITICAL"), (1, "WARNING")):
            set_verbosity(level)
            parallel._client(2, None)
            assert given["silence_logs"] == getattr(logging, expected)
    finally:
        set_verbosity(1)


@pytest.mark.slow
def test_quiet_study_on_a_local_cluster_writes_nothing_on_stderr(folder, tmp_path):
    """A first study on two worker processes: Dask's own warnings (a worker killed at
    shutdown) are not shown under -q."""
    args = ["study", str(folder / "speed.toml"), "--workers", "2", "--out", str(tmp_path / "o")]
    done = subprocess.run([sys.executable, "-m", "trackdyn", "-q", *args], capture_output=True,
                          text=True, timeout=600)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stderr == "" and done.stdout.lstrip().startswith("speed study")
