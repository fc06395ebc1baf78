"""Run independent tasks through Dask: a local cluster by default, or a scheduler's.

Tasks are small picklable objects (parameters and file paths, never track arrays); the
function run on each reports failures in its result instead of raising, so one failed
run does not stop the others. A task whose worker process died on every retry (killed by
the out-of-memory killer, say) comes back as a `trackdyn.errors.Failure` of status
``WORKER_LOST`` in place of its result. By default the tasks go to a
`distributed.LocalCluster` sized to the machine; with ``workers=1`` they run one after
another in this process; with ``scheduler`` they go to an existing cluster.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import os
import signal
import threading
from concurrent.futures import CancelledError
from contextvars import ContextVar

from trackdyn.errors import Failure, Status, TrackdynInputError, require_workers
from trackdyn.progress import progress_bar, verbosity


def _client(workers: int | None, scheduler: str | None):
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        from distributed.comm.addressing import get_address_host_port

        try:
            get_address_host_port(scheduler)
        except ValueError as exc:
            raise TrackdynInputError(
                f"--scheduler {scheduler!r} is not an address like tcp://HOST:PORT ({exc})"
            ) from None
        return _connect(Client, scheduler), None
    # Dask's statistical profiler takes the GIL every 10 ms (a 1 km 11-DOF run took up to
    # twice as long in a worker with it); local workers run without it. Dask's malloc
    # setting is undone by each task (`keep_freed_memory`). Under -q the cluster's own
    # warnings and errors are not shown (a worker "still alive after 4.0 seconds, killing",
    # or one whose heartbeat found the scheduler already closed, at shutdown): the level of
    # the 'distributed' loggers, here and in the workers (`silence_logs`); a task's own
    # failure still comes back to the command (`run_tasks`).
    with dask.config.set({"distributed.worker.profile.enabled": False}), interrupts_here():
        cluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            # the scheduler's HTTP server starts even without a dashboard; on a free port,
            # so a second cluster on the machine (another study, a notebook) is no clash
            dashboard_address=":0",
            silence_logs=logging.CRITICAL if verbosity() == 0 else logging.WARNING,
        )
    return Client(cluster), cluster


@contextlib.contextmanager
def interrupts_here():
    """Block SIGINT in this thread while child processes start (a local cluster, a
    command's helper process): the threads and processes started meanwhile (the cluster's
    event-loop thread and its workers) keep the mask, so that Ctrl-C (which a terminal
    sends to the whole process group) reaches this process only, whose handler stops the
    children (`trackdyn.commands.staging`). Without it a worker that the signal
    caught starting up or shutting down printed its KeyboardInterrupt (3 of 46 trials). A
    signal that comes meanwhile waits until the cluster is up. The resource tracker starts
    first: starting it unblocks SIGINT in the thread that does (multiprocessing's
    ``ResourceTracker.ensure_running``), which would be the cluster's."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()
    before = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


CONNECT_TIMEOUT = 10.0
"""Seconds allowed to reach a Dask scheduler and hear it answer as one [s]."""


def _connect(client_class, scheduler: str):
    """A client of the scheduler at ``scheduler``, or a one-line refusal within about
    `CONNECT_TIMEOUT`: Dask's own timeout covers the connection, not a listener that
    accepts and never answers (another service on that port), so the handshake runs in
    a thread that is given up on."""
    result: dict = {}

    def attempt():
        try:
            result["client"] = client_class(scheduler, timeout=f"{CONNECT_TIMEOUT:g}s")
        except Exception as exc:  # noqa: BLE001 - reported below as the refusal
            result["failure"] = Failure.of(exc)

    thread = threading.Thread(target=attempt, daemon=True)
    thread.start()
    thread.join(CONNECT_TIMEOUT + 2.0)
    if "client" in result:
        return result["client"]
    why = result["failure"].message if "failure" in result else "no answer"
    raise TrackdynInputError(
        f"cannot reach a Dask scheduler at {scheduler} within {CONNECT_TIMEOUT:g} s ({why})"
    )


_shared: ContextVar = ContextVar("trackdyn_shared_client", default=None)


@contextlib.contextmanager
def shared_cluster(workers: int | None = None, scheduler: str | None = None):
    """Keep one Dask client (and local cluster) for every `run_tasks` call in the block.

    For work that calls `run_tasks` many times (the model runs of each iteration of a
    fit): the cluster starts once instead of at each call. With ``workers=1`` and no
    scheduler nothing is started and the tasks run in this process.

    Parameters
    ----------
    workers : int, optional
        Worker processes of the local cluster (default: one per core).
    scheduler : str, optional
        Address of an existing Dask scheduler.
    """
    require_workers(workers)
    if workers == 1 and not scheduler:
        yield
        return
    with _cluster(workers, scheduler) as client:
        token = _shared.set(client)
        try:
            yield
        finally:
            _shared.reset(token)


def sharing() -> bool:
    """Whether a `shared_cluster` block holds a Dask client (its `run_tasks` calls use it)."""
    return _shared.get() is not None


@contextlib.contextmanager
def _cluster(workers: int | None, scheduler: str | None):
    """A Dask client (of a local cluster, or of ``scheduler``), closed with its cluster at
    the end; meanwhile Dask's client logs only what is critical: a lost scheduler, which
    it logs with tracebacks while it tries to reconnect, ends the work in one line
    (`run_tasks`). After a failure the client's log stays quiet: the client logs the end
    of its reconnection after it is closed."""
    import logging

    client, cluster = _client(workers, scheduler)  # importing distributed sets its log levels
    log = logging.getLogger("distributed.client")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    log.setLevel(level)


MMAP_THRESHOLD = 32 * 1024 * 1024
"""Size from which glibc's malloc maps an allocation on its own [bytes]: the largest its
adaptive threshold reaches on a 64-bit machine (glibc's ``DEFAULT_MMAP_THRESHOLD_MAX``)."""

TRIM_THRESHOLD = 2 * MMAP_THRESHOLD
"""Free memory at the top of glibc's heap kept for the next allocation [bytes] (glibc's
adaptive rule keeps twice the mmap threshold)."""


def keep_freed_memory() -> bool:
    """Let glibc's malloc keep freed memory for the next allocation, as by default.

    A Dask worker started by a nanny (``dask worker``, a real cluster) runs with
    ``MALLOC_TRIM_THRESHOLD_=65536``, Dask's default: glibc then hands every freed block
    over 64 KiB back to the system and maps every allocation over 128 KiB afresh, so each
    array a step allocates page-faults again. One 1 km section through 50 MGT with
    maintenance took 16.4 core-seconds under it, 6.2 of them in the kernel, with 2.0
    million page faults; 8.1 core-seconds and 11 000 faults with this (8.6 without the
    setting). Memory a task frees then stays with the worker process for its next task
    (Dask reports it as unmanaged memory).

    Returns
    -------
    bool
        Whether the thresholds were set (only where the C library is glibc).
    """
    import ctypes
    import platform

    if platform.libc_ver()[0] != "glibc":
        return False
    libc = ctypes.CDLL(None)
    m_trim_threshold, m_mmap_threshold = -1, -3  # glibc's malloc.h
    return bool(libc.mallopt(m_mmap_threshold, MMAP_THRESHOLD)) and bool(
        libc.mallopt(m_trim_threshold, TRIM_THRESHOLD)
    )


def _on_one_core(func, task):
    """``func(task)`` in a Dask worker, numba's parallel loops on one thread, with glibc's
    malloc keeping freed memory (`keep_freed_memory`).

    A worker process is one core's worth of work (Dask sets the same for the BLAS
    libraries); numba's thread count is per calling thread, so it is set here, in the
    thread that runs the task.
    """
    import numba

    numba.set_num_threads(1)
    keep_freed_memory()
    return func(task)


def groups(tasks: list, together: int, workers: int) -> list[list]:
    """``tasks`` in consecutive groups of at most ``together``. On one worker the groups are
    full; on more, each group takes about a ``2 workers``-th of the tasks left (guided
    self-scheduling), so that the groups get smaller towards the end and the last ones, which
    run while other workers may have nothing left, are short.

    Parameters
    ----------
    tasks : list
        The tasks.
    together : int
        Tasks in a group, at most.
    workers : int
        Workers the groups go to.
    """
    out, first = [], 0
    while first < len(tasks):
        left = len(tasks) - first
        size = together if workers == 1 else min(together, math.ceil(left / (2 * workers)))
        out.append(tasks[first : first + size])
        first += size
    return out


def _as_list(func):
    """``func`` of one task as a function of a list of them (of one)."""
    return functools.partial(_each, func)


def _each(func, tasks: list) -> list:
    """``func`` on each of ``tasks``."""
    return [func(t) for t in tasks]


def _outcomes(client, futures, parts) -> list:
    """The results of the groups of tasks, in order, once every future is done: for each
    task of a group that Dask gave up on after its worker died on every retry, a `Failure`
    of status ``WORKER_LOST``. An exception the function raised is raised here, as it is
    when the tasks run in this process."""
    from distributed.scheduler import KilledWorker

    lost = [f for f in futures if f.status == "error" and isinstance(f.exception(), KilledWorker)]
    keys = {f.key for f in lost}
    kept = [f for f in futures if f.key not in keys]
    results = dict(zip((f.key for f in kept), client.gather(kept), strict=True))
    failure = Failure(
        Status.WORKER_LOST,
        f"its Dask worker process died running it (tries: {dask_allowed_failures() + 1}; "
        "killed: out of memory?)",
    )
    out: list = []
    for future, part in zip(futures, parts, strict=True):
        out += [failure] * len(part) if future.key in keys else results[future.key]
    return out


def dask_allowed_failures() -> int:
    """Times Dask reruns a task whose worker died before it gives up on it
    (``distributed.scheduler.allowed-failures``)."""
    import dask

    return int(dask.config.get("distributed.scheduler.allowed-failures"))


def run_tasks(
    tasks: list,
    func,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    label: str = "runs",
    together: int = 1,
) -> list:
    """Run ``func`` on every task; results in the order of ``tasks``.

    Parameters
    ----------
    tasks : list
        Independent tasks; small picklable objects.
    func : callable
        Module-level function run on each task (or, with ``together``, on each list of
        tasks, returning a list of their results); it should report failures in its
        result rather than raise. On a cluster, a task whose worker died on every retry
        gets a `Failure` of status ``WORKER_LOST`` in place of its result.
    workers : int, optional
        Worker processes of the local cluster (default: one per core); 1 runs the tasks
        serially in this process.
    scheduler : str, optional
        Address of an existing Dask scheduler, e.g. ``tcp://10.0.0.5:8786``.
    progress : bool
        Show a progress bar counting finished tasks.
    label : str
        What the progress bar counts.
    together : int
        Tasks ``func`` takes at once, at most (`groups`); 1: one task, not a list.
    """
    require_workers(workers)
    call = func if together > 1 else _as_list(func)
    with progress_bar(progress, len(tasks), label) as bar:
        if workers == 1 and not scheduler:
            results = []
            for group in groups(tasks, together, 1):
                results += call(group)
                bar.advance(len(group))
            return results
        shared = _shared.get()
        with (
            contextlib.nullcontext(shared)
            if shared is not None
            else _cluster(workers, scheduler) as client
        ):
            return _on_cluster(client, tasks, call, together, bar, scheduler)


def _on_cluster(client, tasks: list, call, together: int, bar, scheduler: str | None) -> list:
    """The results of ``call`` on ``tasks`` in groups, run through ``client``; a lost
    scheduler is a one-line `TrackdynError` of status ``WORKER_LOST``."""
    from distributed import as_completed

    try:
        count = max(1, len(client.scheduler_info()["workers"]))
        parts = groups(tasks, together, count)
        futures = client.map(functools.partial(_on_one_core, call), parts, pure=False)
        size = {f.key: len(part) for f, part in zip(futures, parts, strict=True)}
        for future in as_completed(futures):
            bar.advance(size[future.key])
        return _outcomes(client, futures, parts)
    except (CancelledError, OSError) as exc:  # the scheduler went away mid-run
        where = f" at {scheduler}" if scheduler else ""
        reason = str(exc).rpartition("reason: ")[2].strip(" .") or type(exc).__name__
        lost = f"lost the Dask scheduler{where} during the run; nothing was written ({reason})"
        raise Failure(Status.WORKER_LOST, lost).error() from None
