"""A batch through the public API: `simulate_batch` of 8 runs against one `simulate`.

Run with ``python benchmarks/batch.py`` (``--smoke`` for a short check in CI). The 11-DOF
model on the built-in track at 60 km/h, every step stored, on one numba thread: one
`simulate` of the loaded vehicle, and `simulate_batch` of 8 loaded vehicles differing in
the wedge friction coefficient ``mu``, timed in turn in one process (best of
``--repeat``); "ratio" is the batch's time over the one run's. Each run of the batch is
checked to equal, to the bit, what `simulate` gives for it alone. Then the time of each
is split (a further round with timers around the parts): the runs' set-up (model,
linearisation, time step; `trackdyn.simulation._problem`), the sampling of the track
input, the compiled loops, the Datasets, and the rest (Python in the solver: start states,
matrices, output arrays, copies); "of which storing" is the loops' time over a batch of
the same runs that stores nothing (`run_batch` with no output kept), "in the kernel" the
process's system time (``getrusage``): mostly the pages of new memory for the stored
arrays, made and zeroed by the system on their first write (one run's arrays, 9 of at
most 8 MB over 300 m, are taken again from the memory the previous run freed; the
batch's, 9 of 8 runs' rows each, are mapped afresh each time). Last, a floor under the
batch: its runs' loops storing nothing, and the same 9 arrays as the batch's outputs made
new and written once by numpy (``fill``, best of ``--repeat``), which is what storing every
output of 8 runs costs at the least on this machine's memory; "ratio" of the floor is its
time over the one run's.
"""

from __future__ import annotations

import argparse
import resource
import time
from collections import defaultdict
from contextlib import contextmanager

import numba
import numpy as np

import trackdyn
from trackdyn import simulation
from trackdyn.options import RunOptions
from trackdyn.simulation import run_batch, simulate, simulate_batch
from trackdyn.solver import central
from trackdyn.track.inputs import ContactInput

RUNS = 8
"""Runs of the batch."""

PARTS = {
    "set-up": (simulation, "_problem"),
    "sampling": (ContactInput, "__call__"),
    "loops": (central, "advance_lanes"),
    "loops ": (central, "advance"),  # one run alone goes one by one
    "Datasets": (simulation, "make_dataset"),
}
"""The parts timed: the function of each, as (its module or class, its name)."""


@contextmanager
def timers():
    """Time spent in each of `PARTS` [s] while inside, summed over its calls (the
    functions swapped for timed wrappers, put back on leaving)."""
    spent: dict = defaultdict(float)
    before = {part: getattr(owner, name) for part, (owner, name) in PARTS.items()}

    def timed(part, func):
        def wrapper(*args, **kwargs):
            t = time.perf_counter()
            try:
                return func(*args, **kwargs)
            finally:
                spent[part.strip()] += time.perf_counter() - t

        return wrapper

    for part, (owner, name) in PARTS.items():
        setattr(owner, name, timed(part, before[part]))
    try:
        yield spent
    finally:
        for part, (owner, name) in PARTS.items():
            setattr(owner, name, before[part])


def elapsed(func) -> float:
    """Wall time of ``func()`` [s]."""
    t = time.perf_counter()
    func()
    return time.perf_counter() - t


def fresh_outputs(shapes) -> float:
    """Wall time [s] of making arrays of ``shapes`` anew and writing each once (numpy's
    ``fill``), then letting them go, as the batch's outputs are made, written and freed."""
    t = time.perf_counter()
    arrays = [np.empty(shape) for shape in shapes]
    for a in arrays:
        a.fill(1.0)
    del arrays
    return time.perf_counter() - t


def split(func) -> dict:
    """Time [s] of each part of ``func()`` (`PARTS`), ``rest`` and ``total``, and the
    system time [s] spent meanwhile, ``kernel`` (apart: it is within the parts)."""
    with timers() as spent:
        kernel = resource.getrusage(resource.RUSAGE_SELF).ru_stime
        total = elapsed(func)
        kernel = resource.getrusage(resource.RUSAGE_SELF).ru_stime - kernel
    parts = {part: spent[part] for part in dict.fromkeys(p.strip() for p in PARTS)}
    return {**parts, "rest": total - sum(parts.values()), "total": total, "kernel": kernel}


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="short run for CI")
    parser.add_argument("--repeat", type=int, default=7, help="timed rounds (best taken)")
    opts = parser.parse_args()
    repeat = 2 if opts.smoke else opts.repeat
    numba.set_num_threads(1)
    track = trackdyn.load_track()
    base = trackdyn.load_vehicle("loaded")
    vehicles = [
        trackdyn.load_vehicle("loaded", mu=base.mu * (0.7 + 0.6 * i / (RUNS - 1)))
        for i in range(RUNS)
    ]
    options = RunOptions(model="11dof", speed_kmh=60, end_m=30 if opts.smoke else 300,
                         store_every=1)  # fmt: skip
    batch = [options] * RUNS

    def one():
        return simulate(vehicles[0], track, options)

    def many():
        return simulate_batch(vehicles, track, batch)

    def bare():
        return run_batch(vehicles, track, batch, keep=())

    alone = [simulate(v, track, options) for v in vehicles]  # also compiles
    same = all(a.identical(b) for a, b in zip(alone, many(), strict=True))
    best = {"one": np.inf, "batch": np.inf}
    for _ in range(repeat):
        best["one"] = min(best["one"], elapsed(one))
        best["batch"] = min(best["batch"], elapsed(many))
    splits = {"one": split(one), "batch": split(many)}
    with timers() as spent:
        bare()
    stored = splits["batch"]["loops"] - spent["loops"]
    (first,) = run_batch(vehicles[:1], track, [options])
    shapes = [(RUNS * a.shape[0], *a.shape[1:]) for a in first.out.values()]
    memory = min(fresh_outputs(shapes) for _ in range(repeat))
    floor = spent["loops"] + memory
    steps = alone[0].time.size
    print(f"11dof, {options.end_m:g} m at 60 km/h, {steps} steps, every one stored, one "
          f"numba thread; best of {repeat}")  # fmt: skip
    print(f"one simulate {best['one'] * 1e3:.1f} ms, simulate_batch of {RUNS} "
          f"{best['batch'] * 1e3:.1f} ms: ratio {best['batch'] / best['one']:.2f}; "
          f"each run as alone, to the bit: {'yes' if same else 'NO'}")  # fmt: skip
    columns = [p for p in splits["one"] if p != "kernel"]
    print(f"{'time split [ms]':<16}" + "".join(f"{p:>10}" for p in columns))
    for name, parts in splits.items():
        print(f"{name:<16}" + "".join(f"{parts[p] * 1e3:10.1f}" for p in columns))
    print(f"of which storing in the batch's loops: {stored * 1e3:.1f} ms; in the kernel: "
          f"one {splits['one']['kernel'] * 1e3:.1f} ms, batch "
          f"{splits['batch']['kernel'] * 1e3:.1f} ms")  # fmt: skip
    megabytes = sum(np.prod(s) for s in shapes) * 8 / 1e6
    print(f"floor: the batch's loops storing nothing {spent['loops'] * 1e3:.1f} ms, its "
          f"outputs ({megabytes:.0f} MB) made new and written once {memory * 1e3:.1f} ms: "
          f"{floor * 1e3:.1f} ms, ratio {floor / best['one']:.2f}; the batch takes "
          f"{best['batch'] / floor:.2f} times it")  # fmt: skip
    assert same, "a run of the batch differs from the run alone"


if __name__ == "__main__":
    main()
