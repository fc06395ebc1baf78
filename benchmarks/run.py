"""Speed and memory of the solver: ns per step, s per km, peak memory, per model.

Run with ``python benchmarks/run.py`` (``--smoke`` for a short check in CI). The compiled
loop is timed on its own (track input sampled beforehand) and end to end through
`simulate` with every step stored (best of 5; ratio end to end / loop, same process); the same loop
run as plain Python (numba's ``py_func``) is the baseline. Then: the compile time of the
solver in a fresh process without and with numba's disk cache, and runs per second per
core of the 11-DOF model in batches of 1 and of 64 runs (`simulate_batch`, one thread).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
import tracemalloc

import numba
import numpy as np

from trackdyn.options import RunOptions
from trackdyn.simulation import simulate, simulate_batch
from trackdyn.solver.kernel import DONE, advance
from trackdyn.solver.matrices import step_matrices
from trackdyn.track.synthetic import example_track
from trackdyn.vehicle.models import MODELS, build_model
from trackdyn.vehicle.parameters import load_vehicle


def kernel_args(model, n_steps, dt, rng, store_every=1):
    """Arguments of `advance` for ``n_steps`` of realistic input (8 Hz, 1 mm)."""
    m = model
    nc, n, nw = len(m.contact_names), len(m.dof_names), len(m.wedge_names)
    ns = len(m.suspension_names)
    # 100 kN/mm per wheel: a bogie contact stands for two wheels
    k = np.array([1e8 * len(a) for a in m.contact_axles]) * np.ones((n_steps, 1))
    r = 1e-3 * np.sin(np.arange(n_steps)[:, None] * dt * 2 * np.pi * 8 + rng.random(nc))
    rows = (n_steps - 1) // store_every + 1
    out = [np.empty((rows, w)) for w in (n, n, n, nc, ns, nw, nw, nc, nc)]
    z = np.zeros(2 * n)
    args = (
        *step_matrices(m, dt),
        m.static_wheel_load,
        k,
        r,
        np.zeros((0, nc, 2)),
        0.0,
        1.0,
        z,
        dt,
        0,
        store_every,
        50,
        *out,
    )
    return args, z


def time_kernel(func, model, n_steps, dt, repeat, store_every=1):
    """Best time per step [s] of ``func`` over ``repeat`` runs from rest."""
    rng = np.random.default_rng(0)
    args, z = kernel_args(model, n_steps, dt, rng, store_every)
    best = np.inf
    for _ in range(repeat):
        z[:] = 0.0
        t = time.perf_counter()
        status, _ = func(*args)
        best = min(best, time.perf_counter() - t)
        assert status == DONE, "the benchmark's run stopped"
    return best / n_steps


COMPILE = """
import time
t = time.perf_counter()
from trackdyn.options import RunOptions
from trackdyn.simulation import simulate
from trackdyn.track.synthetic import example_track
from trackdyn.vehicle.parameters import load_vehicle
v = load_vehicle("loaded")
lin = example_track().linearise(v.static_wheel_load)
t = time.perf_counter()
simulate(v, lin, RunOptions(end_m=30.0))
print(time.perf_counter() - t)
"""


def first_call_time(cache_dir: str) -> float:
    """Time [s] of the first `simulate` call in a new process with numba's cache there."""
    env = {"NUMBA_CACHE_DIR": cache_dir}
    import os

    out = subprocess.run(
        [sys.executable, "-c", COMPILE],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        check=True,
    )
    return float(out.stdout.split()[-1])


def batch_rate(vehicle, lin, n_runs, length):
    """Runs per second on one thread of 11-DOF runs over ``length`` m, ``n_runs`` a batch."""
    base = vehicle.as_dict()
    vehicles = [
        type(vehicle)(**{**base, "kp": base["kp"] * (0.8 + 0.4 * i / max(n_runs - 1, 1))})
        for i in range(n_runs)
    ]
    options = [RunOptions(store_every=10, end_m=length)] * n_runs
    simulate_batch(vehicles[:1], lin, [RunOptions(store_every=10, end_m=30.0)])
    t = time.perf_counter()
    results = simulate_batch(vehicles, lin, options)
    elapsed = time.perf_counter() - t
    assert not any(isinstance(r, Exception) for r in results)
    return n_runs / elapsed


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="short run for CI")
    opts = parser.parse_args()
    steps = 20_000 if opts.smoke else 400_000
    py_steps = 200 if opts.smoke else 2_000
    length = 150.0 if opts.smoke else None  # None: the whole 1 km example
    vehicle = load_vehicle("loaded")
    lin = example_track().linearise(vehicle.static_wheel_load)
    dt = 2e-4
    print(
        f"{'model':<11}{'ns/step':>9}{'every10':>10}{'python us/step':>16}{'speed-up':>10}"
        f"{'s per km':>10}{'km/s':>8}{'peak MB':>9}{'e2e/loop':>9}"
    )
    for name in MODELS:
        model = build_model(name, vehicle)
        time_kernel(advance, model, 10, dt, 1)  # compile
        t_fast = time_kernel(advance, model, steps, dt, 5)
        t_fast10 = time_kernel(advance, model, steps, dt, 5, store_every=10)
        t_py = time_kernel(advance.py_func, model, py_steps, dt, 1)
        simulate(vehicle, lin, RunOptions(model=name, end_m=50.0))  # warm caches
        options = RunOptions(model=name, store_every=1, end_m=length)
        elapsed = np.inf
        for _ in range(5):
            t = time.perf_counter()
            ds = simulate(vehicle, lin, options)
            elapsed = min(elapsed, time.perf_counter() - t)
        tracemalloc.start()  # apart from the timing, which it slows down
        simulate(vehicle, lin, options)
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        km = (float(ds.distance[-1] - ds.distance[0])) / 1e3
        print(
            f"{name:<11}{t_fast * 1e9:9.0f}{t_fast10 * 1e9:10.0f}{t_py * 1e6:16.0f}"
            f"{t_py / t_fast:10.0f}{elapsed / km:10.2f}{km / elapsed:8.2f}{peak:9.0f}"
            f"{elapsed / ds.time.size / t_fast:9.2f}"
        )
    with tempfile.TemporaryDirectory() as cache:
        cold, warm = first_call_time(cache), first_call_time(cache)
    print(f"first simulate in a new process: {cold:.1f} s compiling, {warm:.2f} s from the cache")
    numba.set_num_threads(1)
    batch_length = 60.0 if opts.smoke else 300.0
    rates = {n: batch_rate(vehicle, lin, n, batch_length) for n in (1, 8 if opts.smoke else 64)}
    (n1, r1), (nb, rb) = rates.items()
    print(
        f"11dof, {batch_length:.0f} m, one thread: {r1:.2f} runs/s in batches of {n1}, "
        f"{rb:.2f} in batches of {nb} ({rb / r1:.2f} times)"
    )


if __name__ == "__main__":
    main()
