"""Speed-up of a 32-run study on a LocalCluster with 2 workers against 1 (serial).

Run with ``python benchmarks/study.py`` (``--smoke`` for a 4-run check). The runs are a
one-at-a-time variation of 8 parameters at 4 factors, 11-DOF model, the built-in 1 km
example section at 60 km/h, every 10th step stored. The 2-worker time includes starting
the cluster and each worker's reading and linearising the track.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

from trackdyn.options import RunOptions
from trackdyn.parallel import run_tasks
from trackdyn.studies.runner import Task, run_task
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
    times = {}
    for workers in (1, 2):
        t = time.perf_counter()
        results = run_tasks(runs, run_task, workers=workers)
        times[workers] = time.perf_counter() - t
        failed = [r for r in results if "error" in r]
        assert not failed, failed[0]["error"]
    print(
        f"{len(runs)} runs: 1 worker {times[1]:.1f} s, 2 workers {times[2]:.1f} s, "
        f"speed-up {times[1] / times[2]:.2f}"
    )


if __name__ == "__main__":
    main()
