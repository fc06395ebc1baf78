"""Ctrl-C at any moment: the process ends within seconds, exit 130, no output left.

Each command runs as a real subprocess and gets SIGINT at moments spread over its run
(measured first, uninterrupted, in the same test): while importing and computing, while
writing and while moving the files into place. A signal that arrives after the command has
finished finds it gone (exit 0, every file there); one that arrives after the files are in
place, while the command still prints its summary, ends it with 130 and leaves the folder
whole (every file of the uninterrupted run, nothing half-written). Ctrl-C in a terminal
goes to the whole process group, the Dask workers of a local cluster included: they block
SIGINT and are stopped by the command's handler.
"""

import os
import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.slow  # each command runs five times as a subprocess

GRACE = 3.0  # [s] allowed between the signal and the end of the process
FRACTIONS = (0.15, 0.5, 0.85, 0.97)  # of the uninterrupted run's wall time

STUDY = """kind = "speed"
[run]
model = "2dof"
[speed]
speeds_kmh = [40, 60, 80]
"""
DETERIORATE = """[run]
model = "7dof"
[loop]
total_mgt = 1
snapshot_every_mgt = 0.5
"""


def command(kind, tmp_path):
    if kind == "run":
        return ["run"]
    text = STUDY if kind == "study" else DETERIORATE
    (tmp_path / f"{kind}.toml").write_text(text)
    extra = ["--workers", "2"] if kind == "study" else []
    return [kind, str(tmp_path / f"{kind}.toml"), *extra]


def start(args, out, **popen):
    return subprocess.Popen(
        [sys.executable, "-m", "trackdyn", *args, "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        **popen,
    )


@pytest.mark.parametrize("kind", ["run", "study", "deteriorate"])
def test_interrupt_at_any_moment_leaves_nothing(tmp_path, kind):
    args = command(kind, tmp_path)
    t0 = time.perf_counter()
    whole = start(args, tmp_path / "whole")
    assert whole.wait(timeout=600) == 0, whole.stderr.read().decode()
    whole.stderr.close()
    duration = time.perf_counter() - t0
    expected = {p.name for p in (tmp_path / "whole").iterdir()}
    for i, fraction in enumerate(FRACTIONS):
        out = tmp_path / f"out{i}"
        proc = start(args, out)
        time.sleep(fraction * duration)
        proc.send_signal(signal.SIGINT)
        sent = time.perf_counter()
        try:
            code = proc.wait(timeout=GRACE + 10)
        except subprocess.TimeoutExpired:
            proc.kill()
            pytest.fail(f"{kind}: still running 10 s after SIGINT at {fraction:.0%} of the run")
        finally:
            proc.stderr.close()
        assert time.perf_counter() - sent < GRACE, f"{kind}: slow to stop at {fraction:.0%}"
        if code == 0:  # finished before the signal came
            assert {p.name for p in out.iterdir()} == expected
        else:
            assert code == 130, f"{kind}: exit {code} at {fraction:.0%}"
            left = sorted(p.name for p in out.iterdir()) if out.exists() else []
            # nothing, or (the signal after the files were moved into place) the whole run
            assert left in ([], sorted(expected)), f"{kind}: {left}"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_right_after_the_start_ends_quietly(tmp_path, sig):
    """The handlers are installed before any heavy import: a signal 0.15 s after the start
    (measured before: a KeyboardInterrupt traceback, and exit 143 for SIGTERM) ends the
    command with exit code 130, nothing on stderr and nothing written."""
    proc = start(["run"], tmp_path / "out")
    time.sleep(0.15)
    proc.send_signal(sig)
    try:
        code = proc.wait(timeout=GRACE + 10)
        err = proc.stderr.read().decode()
    finally:
        proc.stderr.close()
    assert code == 130 and err == "", (code, err)
    assert not (tmp_path / "out").exists()


def _sigint_blocked(task) -> bool:
    return signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, [])


def test_the_workers_of_a_local_cluster_block_sigint():
    """The signal a terminal sends to the whole process group does not reach a worker
    (before: a worker caught starting up or shutting down printed its KeyboardInterrupt),
    and this process takes it as before."""
    from trackdyn.parallel import run_tasks

    assert run_tasks([0, 1], _sigint_blocked, workers=2) == [True, True]
    assert not _sigint_blocked(None)


LINE = """[run]
model = "7dof"
[loop]
total_mgt = 1
snapshot_every_mgt = 0.5
segment_length_m = 50
[track]
sections = "sections.csv"
"""


def _line(folder):
    """Two 100 m sections: 8 figures, drawn by a second process too
    (`trackdyn.commands.drawing.HELPED_FIGURES`)."""
    from trackdyn.io import write_geometry, write_supports
    from trackdyn.track.synthetic import synthetic_track

    rows = ["name,geometry,supports"]
    for name in ("a", "b"):
        trk = synthetic_track(100.0, spectrum="fra5", seed=len(rows))
        write_geometry(trk.geometry, folder / f"{name}_geometry.csv")
        write_supports(trk.supports, folder / f"{name}_supports.csv")
        rows.append(f"{name},{name}_geometry.csv,{name}_supports.csv")
    (folder / "sections.csv").write_text("\n".join(rows) + "\n")
    (folder / "d.toml").write_text(LINE)
    return []


def _gone(group: int) -> bool:
    """No process left in process group ``group`` within 5 s."""
    for _ in range(50):
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    return False


@pytest.mark.parametrize("children", ["two workers", "a figures' helper"])
def test_ctrl_c_to_the_process_group_ends_quietly(tmp_path, children):
    """SIGINT to the process group (Ctrl-C in a terminal) of a deterioration run with child
    processes (a local cluster's 2 workers; a line's figures drawn by a second process) at
    moments spread over it, the children's start and end included (before: 3 of 46 trials
    2.8-4 s after the start of a cluster ended in a traceback): exit 130 and nothing on
    stderr, nothing written (or, after the end, the whole run), no process left behind."""
    if children == "two workers":
        (tmp_path / "d.toml").write_text(DETERIORATE)
        extra = ["--workers", "2"]
    else:
        extra = _line(tmp_path)
    # quiet: a run that ends before the signal says nothing either ("wrote ..." otherwise)
    args = ["-q", "deteriorate", str(tmp_path / "d.toml"), *extra]
    t0 = time.perf_counter()
    whole = start(args, tmp_path / "whole")
    assert whole.wait(timeout=600) == 0, whole.stderr.read().decode()
    whole.stderr.close()
    duration = time.perf_counter() - t0
    expected = sorted(p.name for p in (tmp_path / "whole").iterdir())
    for i, fraction in enumerate((0.3, 0.45, 0.6, 0.75, 0.9)):
        out = tmp_path / f"out{i}"
        proc = start(args, out, start_new_session=True)
        time.sleep(fraction * duration)
        os.killpg(proc.pid, signal.SIGINT)
        try:
            code = proc.wait(timeout=GRACE + 10)
            err = proc.stderr.read().decode()
        finally:
            proc.stderr.close()
        left = sorted(p.name for p in out.iterdir()) if out.exists() else []
        assert (code, err) in ((130, ""), (0, "")), (fraction, code, err)
        assert left in ([], expected), (fraction, left)
        assert _gone(proc.pid), fraction
