"""A Dask worker process killed in the middle of a study: Dask reruns its lost runs.

A real `LocalCluster` of two worker processes runs a speed study. As soon as a worker has
started a run (it leaves a marker file naming its process), that worker process is killed
(SIGKILL, as the out-of-memory killer would). The nanny restarts it, the scheduler
reschedules the runs it held, and the study finishes with every run present and the same
table as the serial run.
"""

import os
import threading
import time
from pathlib import Path

import pandas as pd
import psutil
import pytest

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
