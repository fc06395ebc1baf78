"""A scheduler address where no Dask scheduler answers, and a scheduler lost mid-run: each
ends in a one-line refusal within seconds, not a hang or a traceback."""

import logging
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from trackdyn import parallel
from trackdyn.errors import Status, TrackdynError, TrackdynInputError

pytestmark = pytest.mark.slow  # real sockets and a real cluster


def test_a_listener_that_is_not_a_scheduler_is_refused_in_seconds(monkeypatch):
    """Something accepts connections on the port and never answers (before: a hang of
    more than 600 s, Dask's connect timeout covering only the connection)."""
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT", 1.0)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    accepted = []
    threading.Thread(target=lambda: accepted.append(server.accept()), daemon=True).start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    clock = time.perf_counter()
    with pytest.raises(TrackdynInputError, match=f"cannot reach a Dask scheduler at {address}"):
        parallel.run_tasks([1.0], time.sleep, scheduler=address)
    assert time.perf_counter() - clock < 10.0
    for conn, _ in accepted:
        conn.close()
    server.close()


def test_a_scheduler_lost_mid_run_is_one_line():
    """The cluster is closed while its tasks run (before: an 87-line FutureCancelledError
    traceback): a one-line refusal saying the scheduler was lost."""
    from distributed import LocalCluster

    cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                           dashboard_address=":0")  # fmt: skip
    threading.Timer(3.0, cluster.close).start()
    clock = time.perf_counter()
    with pytest.raises(TrackdynError, match="lost the Dask scheduler at tcp://") as info:
        parallel.run_tasks([2.0] * 6, time.sleep, scheduler=cluster.scheduler_address)
    assert "\n" not in str(info.value)
    assert info.value.status is Status.WORKER_LOST  # not refused input: the CLI's line all the same
    assert time.perf_counter() - clock < 30.0


def _process(*args: str) -> subprocess.Popen:
    """A Dask command-line program (``dask_scheduler``, ``dask_worker``) of this Python."""
    command = [sys.executable, "-m", f"distributed.cli.{args[0]}", *args[1:], "--no-dashboard"]
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


class _Kept(logging.Handler):
    """A log handler that keeps the records it is given."""

    def __init__(self):
        super().__init__()
        self.records: list[logging.LogRecord] = []

    def emit(self, record):
        self.records.append(record)


def test_a_scheduler_killed_mid_run_logs_nothing():
    """A scheduler process killed outright (SIGKILL) while its worker runs the tasks
    (before: Dask's client logged 32 lines of tracebacks as it tried to reconnect, then
    the one line): the one line only."""
    with socket.socket() as probe:  # a free port
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    scheduler = _process("dask_scheduler", "--host", "127.0.0.1", "--port", str(port))
    worker = _process("dask_worker", address, "--nthreads", "1")
    kept = _Kept()
    logging.getLogger("distributed.client").addHandler(kept)
    try:
        threading.Timer(8.0, scheduler.send_signal, (signal.SIGKILL,)).start()
        with pytest.raises(TrackdynError, match="lost the Dask scheduler at tcp://"):
            parallel.run_tasks([2.0] * 10, time.sleep, scheduler=address)
    finally:
        logging.getLogger("distributed.client").removeHandler(kept)
        for process in (worker, scheduler):
            process.kill()
            process.wait()
    assert [r.getMessage() for r in kept.records if r.levelno >= logging.ERROR] == []
