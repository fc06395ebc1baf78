"""A scheduler address where no Dask scheduler answers, and a scheduler lost mid-run: each
ends in a one-line refusal within seconds, not a hang or a traceback."""

import socket
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
