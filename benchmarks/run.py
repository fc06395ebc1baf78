"""Speed and memory of the solver: ns per step, s per km, peak memory, per model.

Run with ``python benchmarks/run.py`` (``--smoke`` for a short check in CI). The compiled
loop is timed on its own (track input sampled beforehand) and end to end through
`simulate`; the same loop run as plain Python (numba's ``py_func``) is the baseline.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from trackdyn.simulate import simulate
from trackdyn.solver.central import integrate_chunk, step_matrices
from trackdyn.track.synthetic import example_track
from trackdyn.vehicle.models import build_model
from trackdyn.vehicle.parameters import load_vehicle

MODELS = ("2dof", "2dof-wedge", "4dof", "7dof", "11dof")


def kernel_args(model, n_steps, dt, rng):
    """Arguments of `integrate_chunk` for ``n_steps`` of random but realistic input."""
    m = model
    mats = step_matrices(m.M, m.C, m.K, m.Dc, m.Dw, dt)
    nc, n, nw = len(m.contact_names), len(m.dof_names), len(m.wedge_names)
    k = np.full((n_steps, nc), 2e8 if nc > 1 else 1e8)
    r = 1e-3 * np.sin(np.arange(n_steps)[:, None] * dt * 2 * np.pi * 8 + rng.random(nc))
    out = [np.empty((n_steps, w)) for w in (n, n, n, nc, nw, nw)]
    return (
        *mats[:4],
        m.Dc,
        m.Dw,
        mats[4],
        m.wedge_params,
        m.static_wheel_load,
        k,
        r,
        np.zeros((0, nc, 2)),
        0.0,
        1.0,
        np.zeros(n),
        np.zeros(n),
        dt,
        0,
        1,
        1e-10,
        50,
        *out,
    )


def time_kernel(func, args, repeat):
    best = np.inf
    for _ in range(repeat):
        fresh = list(args)
        fresh[14], fresh[15] = np.zeros_like(args[14]), np.zeros_like(args[15])
        t = time.perf_counter()
        func(*fresh)
        best = min(best, time.perf_counter() - t)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="short run for CI")
    opts = parser.parse_args()
    steps = 20_000 if opts.smoke else 400_000
    py_steps = 200 if opts.smoke else 2_000
    length = 150.0 if opts.smoke else 1000.0
    vehicle = load_vehicle("loaded")
    lin = example_track().linearise(vehicle.static_wheel_load)
    rng = np.random.default_rng(0)
    dt = 2e-4
    print(
        f"{'model':<11}{'ns/step':>9}{'python us/step':>16}{'speed-up':>10}"
        f"{'s per km':>10}{'km/s':>8}{'peak MB':>9}"
    )
    for name in MODELS:
        model = build_model(name, vehicle)
        args = kernel_args(model, steps, dt, rng)
        integrate_chunk(*kernel_args(model, 10, dt, rng))  # compile
        t_fast = time_kernel(integrate_chunk, args, 3) / steps
        py_args = kernel_args(model, py_steps, dt, rng)
        t_py = time_kernel(integrate_chunk.py_func, py_args, 1) / py_steps
        simulate(vehicle, lin, 60 / 3.6, name, end=50.0)  # warm caches
        tracemalloc.start()
        t = time.perf_counter()
        ds = simulate(vehicle, lin, 60 / 3.6, name, end=length)
        elapsed = time.perf_counter() - t
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        km = (float(ds.distance[-1] - ds.distance[0])) / 1e3
        print(
            f"{name:<11}{t_fast * 1e9:9.0f}{t_py * 1e6:16.0f}{t_py / t_fast:10.0f}"
            f"{elapsed / km:10.2f}{km / elapsed:8.2f}{peak:9.0f}"
        )


if __name__ == "__main__":
    main()
