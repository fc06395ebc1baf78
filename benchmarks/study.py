"""Speed-up of a 32-run study: batched against one by one, and on 2 workers against 1.

Run with ``python benchmarks/study.py`` (``--smoke`` for a 4-run check). The runs are a
one-at-a-time variation of 8 parameters at 4 factors, 11-DOF model, the built-in 1 km
example section at 60 km/h, every 10th step stored. In this process, one core: the runs
one by one (`run_task`), then in batches (`batches`, `run_batch`; one numba thread), each
after a warm-up run. The 2-worker time includes starting the cluster and each worker's
reading and linearising the track.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numba

from trackdyn.errors import Failure
from trackdyn.options import RunOptions
from trackdyn.parallel import run_tasks
from trackdyn.studies.runner import Task, batches, in_order, run_batch, run_task
from trackdyn.vehicle.parameters import load_vehicle

PARAMETERS = ("rho_p", "k1", "kp", "mu", "k_ss", "x_ss", "rho2", "m1")
FACTORS = (0.5, 0.75, 1.25, 1.5)


def study_tasks(n: int) -> list[Task]:
    base = load_vehicle("loaded")
    runs = [
        Task(labels={"parameter": p, "factor": f}, overrides={p: getattr(base, p) * f})
        for p in PARAMETERS
        for f in FACTORS
    ]
    return [dataclasses.replace(t, run=RunOptions(store_every=10)) for t in runs[:n]]


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="4 runs only")
    opts = parser.parse_args()
    runs = study_tasks(4 if opts.smoke else 32)
    numba.set_num_threads(1)
    run_task(runs[0])  # compile, read and linearise the track
    t = time.perf_counter()
    serial = run_tasks(runs, run_task, workers=1)
    one_by_one = time.perf_counter() - t
    t = time.perf_counter()
    batched = in_order(run_tasks(batches(runs), run_batch, workers=1))
    together = time.perf_counter() - t
    assert [out.row for _, out in batched] == [out.row for _, out in serial]
    print(
        f"{len(runs)} runs on one core: one by one {one_by_one:.1f} s, batched "
        f"{together:.1f} s, {one_by_one / together:.2f} times the throughput"
    )
    times = {}
    for workers in (1, 2):
        t = time.perf_counter()
        results = run_tasks(runs, run_task, workers=workers)
        times[workers] = time.perf_counter() - t
        failed = [out for _, out in results if isinstance(out, Failure)]
        assert not failed, failed[0].message
    print(
        f"{len(runs)} runs: 1 worker {times[1]:.1f} s, 2 workers {times[2]:.1f} s, "
        f"speed-up {times[1] / times[2]:.2f}"
    )


if __name__ == "__main__":
    main()
