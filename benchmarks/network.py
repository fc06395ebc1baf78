"""Network scale on a real Dask cluster, and a section's deterioration in single runs.

Run with ``python benchmarks/network.py`` (``--smoke``: 2 sections of 300 m through a
3 MGT life, a short check for CI; ``--km`` and ``--mgt`` for a shorter line or horizon).
Starts a Dask scheduler and workers as subprocesses with the ``dask scheduler`` and ``dask
worker`` command lines on this machine (Dask's defaults, one thread a worker process),
first with 1 worker, then with 2 (a new cluster each time), and sends the sections of a
line of 20 synthetic 1 km sections (FRA class 5 geometry, different seeds, tamped start)
through the life-cycle horizon to it through `trackdyn.parallel.run_tasks` with
``scheduler=``: the built-in example's traffic, law and 11-DOF model, 300 MGT with the
life set-up of ``benchmarks/deteriorate.py --life`` (the default threshold maintenance
policy, 2 mm D1 SD, 200 m segments), as `run_sections` sends them: up to `TOGETHER`
sections a task, stepped together (`run_group`), fewer in the last tasks (`groups`).

Each task's cost is the CPU time (user and system, all threads) of the worker process
while it ran the task, in core-seconds (split evenly between its sections). Reported: wall
time and core-seconds on 1 and 2 workers, core-seconds per km and per km x MGT, the
speed-up from 1 to 2 workers, and, extrapolated from the 1-worker core-seconds per km x
MGT and the 2-worker parallel efficiency, the wall time of 1000 km through 300 MGT on 16
workers, against the goal of 10 minutes (9600 core-seconds). The 20 km line runs through
the whole 300 MGT (about 7 minutes on 1 worker and 4 on 2 on a 2-core machine); only the
1000 km figure is extrapolated. Dask's nanny starts each worker with
``MALLOC_TRIM_THRESHOLD_=65536``, which each task undoes
(`trackdyn.parallel.keep_freed_memory`); the CPU spent in the kernel is shown apart.

Then, in this process: one 11-DOF run (`simulate`, loaded wagon) over a 500 m section
(best of 5, before and after), and the deterioration of a line of `TOGETHER` (8) sections
of 500 m through 50 MGT (no maintenance) with ``--workers 1`` (one task, the sections
stepped together): a section's deterioration in single runs (goal: at most 8) and km x
MGT per core-second. ``--single`` runs only this part.

Every subprocess is stopped at the end, also on an error or Ctrl-C.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

from line import write_line
from trackdyn.commands.deteriorate.scenario import MaintenanceSpec, load_deterioration
from trackdyn.commands.deteriorate.sections import section_tasks
from trackdyn.deterioration.runs import TOGETHER, run_group
from trackdyn.errors import Failure
from trackdyn.parallel import run_tasks

GOAL_CORE_S = 9600.0
"""Goal: 1000 km through 300 MGT in 10 minutes on 16 workers [core-seconds]."""


def measured_group(tasks):
    """`run_group`, with the CPU time [s] of the process (all its threads; ``system_s`` of
    it in the kernel) and the wall time [s], split evenly between its sections, and each
    loop's own split of its wall time."""
    cpu, wall, times = time.process_time(), time.perf_counter(), os.times()
    results = run_group(tasks)
    share = {
        "cpu_s": (time.process_time() - cpu) / len(tasks),
        "wall_s": (time.perf_counter() - wall) / len(tasks),
        "system_s": (os.times().system - times.system) / len(tasks),
        "pid": os.getpid(),
    }
    out: list = []
    for ds in results:
        if isinstance(ds, Failure):
            out.append(ds)
            continue
        result = {**share, "steps": int(ds.attrs["steps"])}  # only what the benchmark reads
        result["tampings"] = int(ds.sizes.get("intervention", 0))
        for key in ("time_vehicle_runs_s", "time_beam_solves_s", "time_bookkeeping_s"):
            result[key] = float(ds.attrs.get(key, 0.0))
        out.append(result)
    return out


def _stop(proc: subprocess.Popen) -> None:
    """Stop ``proc`` and its process group (a worker's nanny and its worker process):
    SIGTERM, then SIGKILL to what is left after 30 s."""
    for sig, patience in ((signal.SIGTERM, 30.0), (signal.SIGKILL, 10.0)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        deadline = time.monotonic() + patience
        while time.monotonic() < deadline:
            proc.poll()  # reap the group's leader, so that an empty group is seen as gone
            try:
                os.killpg(proc.pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.1)
        else:
            continue
        break
    proc.wait()


STOP = {signal.SIGINT, signal.SIGTERM}


def _unblock() -> None:
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP)


def _start(argv: list[str], log: Path, procs: list) -> None:
    """``python -m dask ARGV`` in its own session (Ctrl-C reaches only this process, which
    then stops the cluster in order), output into ``log``, added to ``procs``; Ctrl-C
    waits until it is there, so that no process is started and then forgotten."""
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, STOP)
    try:
        with open(log, "w") as out:
            procs.append(
                subprocess.Popen(
                    [sys.executable, "-m", "dask", *argv],
                    stdout=out,
                    stderr=subprocess.STDOUT,
                    start_new_session=True,
                    preexec_fn=_unblock,
                )
            )
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


def _tail(log: Path) -> str:
    return "\n".join(log.read_text(errors="replace").splitlines()[-20:])


@contextmanager
def cluster(workers: int, folder: Path):
    """Address of a new scheduler with ``workers`` registered single-threaded workers."""
    from distributed import Client

    folder.mkdir(parents=True)
    file = folder / "scheduler.json"
    procs: list[subprocess.Popen] = []
    try:
        log = folder / "scheduler.log"
        listen = ["--host", "127.0.0.1", "--no-dashboard"]
        _start(["scheduler", *listen, "--port", "0", "--scheduler-file", str(file)], log, procs)
        deadline = time.monotonic() + 60.0
        while not file.is_file():
            if procs[0].poll() is not None or time.monotonic() > deadline:
                raise SystemExit(f"the Dask scheduler did not start:\n{_tail(log)}")
            time.sleep(0.1)
        time.sleep(0.2)  # the file is written in one go; let it land
        address = json.loads(file.read_text())["address"]
        one = ["--nthreads", "1", "--nworkers", "1"]
        for i in range(workers):
            where = ["--name", f"w{i}", "--local-directory", str(folder / f"w{i}")]
            argv = ["worker", "--scheduler-file", str(file), *one, *listen, *where]
            _start(argv, folder / f"worker{i}.log", procs)
        with Client(address, timeout="30s") as client:
            try:
                client.wait_for_workers(workers, timeout=120)
            except TimeoutError:
                logs = "\n".join(_tail(folder / f"worker{i}.log") for i in range(workers))
                raise SystemExit(f"the Dask workers did not register:\n{logs}") from None
        yield address
    finally:
        # a signal now (a second Ctrl-C, or one a starting process passes on) is acted
        # on once every process is stopped
        noted: list[int] = []
        previous = {sig: signal.signal(sig, lambda n, _: noted.append(n)) for sig in STOP}
        try:
            for proc in reversed(procs):  # workers first, then the scheduler
                _stop(proc)
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        if noted:
            signal.raise_signal(noted[0])


def line_tasks(csv: Path, mgt: float, maintained: bool) -> list:
    """Tasks of the example scenario over the sections in ``csv`` through ``mgt``."""
    spec, base = load_deterioration(None)
    loop: dict = {"total_mgt": mgt}
    update: dict = {}
    if maintained:  # as benchmarks/deteriorate.py --life
        loop.update(threshold_sd_mm=2.0, max_steps=5000)
        update["maintenance"] = MaintenanceSpec()
    update["loop"] = spec.loop.model_copy(update=loop)
    update["track"] = spec.track.model_copy(update={"sections": csv, "start": "tamped"})
    spec = spec.model_copy(update=update)
    return [dataclasses.replace(t, progress=False) for t in section_tasks(spec, base)]


@dataclasses.dataclass
class Timing:
    """A line's run on some workers."""

    km: float
    mgt: float
    workers: int
    wall: float
    results: list

    @property
    def core_s(self) -> float:
        return sum(r["cpu_s"] for r in self.results)

    @property
    def per_km(self) -> float:
        return self.core_s / self.km

    @property
    def per_km_mgt(self) -> float:
        return self.core_s / (self.km * self.mgt)

    def line(self) -> str:
        steps = sum(r["steps"] for r in self.results)
        tampings = sum(r["tampings"] for r in self.results)
        return (
            f"  {self.workers} worker(s): wall {self.wall:7.1f} s, {self.core_s:7.1f} core-s "
            f"({self.per_km:6.1f} per km, {self.per_km_mgt:.3f} per km x MGT); "
            f"{steps} steps, {tampings} tampings\n"
            f"    of the core-s {sum(r['system_s'] for r in self.results):.1f} in the kernel; "
            f"the tasks' wall {sum(r['wall_s'] for r in self.results):.1f} s: vehicle runs "
            f"{sum(r['time_vehicle_runs_s'] for r in self.results):.1f} s, beam solves "
            f"{sum(r['time_beam_solves_s'] for r in self.results):.1f} s, bookkeeping "
            f"{sum(r['time_bookkeeping_s'] for r in self.results):.1f} s"
        )


def run_line(tasks, address, km, mgt, workers) -> Timing:
    clock = time.perf_counter()
    results = run_tasks(tasks, measured_group, scheduler=address, together=TOGETHER)
    wall = time.perf_counter() - clock
    failed = [r for r in results if isinstance(r, Failure)]
    if failed:
        raise SystemExit(failed[0].message)
    assert len({r["pid"] for r in results}) == workers, "not every worker ran sections"
    return Timing(km, mgt, workers, wall, results)


def single_runs(folder: Path, n: int, length: float, mgt: float, repeat: int) -> None:
    """Item 3: a section's deterioration in units of one 11-DOF run over it."""
    from trackdyn.data import load_track
    from trackdyn.simulation import simulate
    from trackdyn.vehicle.parameters import load_vehicle

    csv = write_line(folder, n, length)
    tasks = line_tasks(csv, mgt, maintained=False)
    spec, _ = load_deterioration(None)
    vehicle = load_vehicle("loaded")
    sec = tasks[0].section
    track = load_track(sec.geometry, sec.supports)

    def one_run() -> tuple[float, float]:
        """Best CPU and wall time [s] of `simulate` over the first section."""
        best = (float("inf"), float("inf"))
        for _ in range(repeat):
            cpu, wall = time.process_time(), time.perf_counter()
            simulate(vehicle, track, spec.run)
            best = min(best, (time.process_time() - cpu, time.perf_counter() - wall))
        return best

    one_run()  # compile or load from numba's cache
    before = one_run()
    cpu, wall = time.process_time(), time.perf_counter()
    results = run_tasks(tasks, measured_group, workers=1, together=TOGETHER)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    failed = [r for r in results if isinstance(r, Failure)]
    if failed:
        raise SystemExit(failed[0].message)
    after = one_run()
    run_cpu, run_wall = min(before[0], after[0]), min(before[1], after[1])
    km = n * length / 1e3
    steps = sum(r["steps"] for r in results) / n
    print(
        f"\nA section's deterioration in single runs (in this process, --workers 1):\n"
        f"  one 11-DOF run (loaded wagon) over {length:g} m: {run_cpu * 1e3:.0f} ms CPU, "
        f"{run_wall * 1e3:.0f} ms wall (best of {repeat}, before: {before[0] * 1e3:.0f} ms, "
        f"after: {after[0] * 1e3:.0f} ms CPU)\n"
        f"  {n} sections of {length:g} m through {mgt:g} MGT (no maintenance): {cpu:.1f} s CPU, "
        f"{wall:.1f} s wall, {steps:.0f} steps a section\n"
        f"  a section's deterioration = {cpu / n / run_cpu:.1f} single runs by CPU "
        f"({wall / n / run_wall:.1f} by wall; goal: at most 8); "
        f"{km * mgt / cpu:.2f} km x MGT per core-second"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="2 short sections, 3 MGT")
    parser.add_argument("--km", type=int, default=20, help="sections of 1 km in the line")
    parser.add_argument("--mgt", type=float, default=300.0, help="horizon [MGT]")
    parser.add_argument(
        "--single",
        action="store_true",
        help="only a section's deterioration in single runs (no cluster)",
    )
    opts = parser.parse_args()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(128 + signal.SIGTERM))
    if opts.single:
        with tempfile.TemporaryDirectory() as tmp:
            single(Path(tmp), opts.smoke)
        return
    n, length, mgt = (2, 300.0, 3.0) if opts.smoke else (opts.km, 1000.0, opts.mgt)
    km = n * length / 1e3
    timings: dict[int, Timing] = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "line").mkdir()
        tasks = line_tasks(write_line(folder / "line", n, length), mgt, maintained=True)
        for workers in (1, 2):
            with cluster(workers, folder / f"cluster{workers}") as address:
                timings[workers] = run_line(tasks, address, km, mgt, workers)
        print(f"{km:g} km as {n} sections through {mgt:g} MGT with maintenance, on a Dask "
              f"cluster of 'dask scheduler' and 'dask worker' (1 thread a worker), "
              f"{os.cpu_count()} cores:")  # fmt: skip
        for t in timings.values():
            print(t.line())
        t1, t2 = timings[1], timings[2]
        speed_up = t1.wall / t2.wall
        efficiency = speed_up / 2
        print(f"  speed-up {speed_up:.2f} (parallel efficiency {efficiency:.2f})")
        cost = t1.per_km_mgt
        core_s = cost * 1000 * 300
        wall16 = core_s / (16 * efficiency)
        print(f"Extrapolated (not run): 1000 km through 300 MGT at {cost:.3f} core-s per km x "
              f"MGT: {core_s:.0f} core-s; on 16 workers at a parallel efficiency of "
              f"{efficiency:.2f}: {wall16 / 60:.0f} min (goal: 10 min, {GOAL_CORE_S:.0f} "
              f"core-s; {core_s / GOAL_CORE_S:.1f} times that)")  # fmt: skip
        single(folder, opts.smoke)


def single(folder: Path, smoke: bool) -> None:
    """`single_runs` on a line of `TOGETHER` sections of 500 m through 50 MGT (one task)."""
    n, length, mgt, repeat = (2, 300.0, 1.0, 2) if smoke else (TOGETHER, 500.0, 50.0, 5)
    (folder / "single").mkdir()
    single_runs(folder / "single", n, length, mgt, repeat)


if __name__ == "__main__":
    main()
