"""A Dask worker process killed in the middle of a study: Dask reruns its lost runs, and a
task that kills every worker it runs on comes back as a worker-lost failure.

A real `LocalCluster` of two worker processes runs a speed study. As soon as a worker has
started a run (it leaves a marker file naming its process), that worker process is killed
(SIGKILL, as the out-of-memory killer would). The nanny restarts it, the scheduler
reschedules the runs it held, and the study finishes with every run present and the same
table as the serial run.
"""

import os
import signal
import threading
import time
from pathlib import Path

import dask
import pandas as pd
import psutil
import pytest

from trackdyn.errors import Failure, Status
from trackdyn.options import RunOptions
from trackdyn.parallel import run_tasks
from trackdyn.studies.runner import Task, gather, run_task

pytestmark = pytest.mark.slow  # a real cluster whose worker is killed

SPEEDS_KMH = [30.0, 40.0, 50.0, 60.0, 70.0, 80.0]
MARKERS = "TRACKDYN_TEST_MARKERS"


def marked_run(task):
    """`run_task`, after leaving a marker file named by this process id."""
    folder = os.environ.get(MARKERS)
    if folder:
        Path(folder, str(os.getpid())).touch()
    return run_task(task)


def kill_first_busy_worker(folder: Path, killed: list):
    def kill():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            for marker in folder.iterdir():
                psutil.Process(int(marker.name)).kill()
                killed.append(int(marker.name))
                return
            time.sleep(0.02)

    thread = threading.Thread(target=kill, daemon=True)
    thread.start()
    return thread


def test_study_survives_a_killed_worker(tmp_path, monkeypatch):
    runs = [
        Task(labels={"speed_kmh": v}, run=RunOptions(model="7dof", speed_kmh=v, store_every=10))
        for v in SPEEDS_KMH
    ]
    serial, _ = gather(run_tasks(runs, run_task, workers=1))
    monkeypatch.setenv(MARKERS, str(tmp_path))
    killed = []
    thread = kill_first_busy_worker(tmp_path, killed)
    table, _ = gather(run_tasks(runs, marked_run, workers=2))
    thread.join(timeout=5)
    assert killed and killed[0] != os.getpid(), "no worker was killed: nothing was tested"
    assert (table["error"] == "").all()
    pd.testing.assert_frame_equal(table, serial)


def dying_run(seconds):
    """Sleep ``seconds``; a negative value: then kill this worker process (SIGKILL)."""
    time.sleep(abs(seconds))
    if seconds < 0:
        os.kill(os.getpid(), signal.SIGKILL)
    return seconds


def test_a_task_whose_worker_always_dies_comes_back_as_a_worker_lost_failure():
    # Dask allowed no rerun: the task that kills its worker is given up on after one try,
    # and its place in the results holds the failure; the quick task finished before it
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        results = run_tasks([0.01, -2.0], dying_run, workers=2)
    assert results[0] == 0.01
    assert isinstance(results[1], Failure) and results[1].status is Status.WORKER_LOST
    assert "worker process died running it (tries: 1;" in results[1].message
