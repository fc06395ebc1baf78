"""Runs in the vector lanes: ns per run-step for batches of L = 1, 2, 4, 8, 16 runs.

Run with ``python benchmarks/lanes.py`` (``--smoke`` for a short check in CI). On one
numba thread, a batch of L runs of one model goes as `central.solve` sends it (groups of
`LANES` runs side by side in the lanes, `advance_lanes`, the last with idle lanes when at
least `MIN_LANE_RUNS` are left over; fewer one by one, `advance`), timed against
the per-run loop (`advance`) in the same process, on the same track input (8 Hz, 1 mm, a
phase per run; input sampled beforehand, every 10th step stored, best of 5). The stored
arrays of each run are checked to equal the run alone, to the bit. "8 / one" is the time
of 8 runs storing every output (as a study's runs) over one run's; "wl kept", of 8 runs
storing only their wheel loads (as the deterioration loop's, `KEPT`) over one run's
storing everything (as a run alone always does).
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from trackdyn.deterioration.loads import KEPT
from trackdyn.lanewise import vectorised
from trackdyn.solver.central import in_threads
from trackdyn.solver.kernel import DONE, NOT_STARTED, advance
from trackdyn.solver.lanes import LANES, advance_lanes, in_lanes, lane_groups
from trackdyn.solver.matrices import run_matrices, step_matrices
from trackdyn.solver.statics import OUTPUTS, widths
from trackdyn.vehicle.models import MODELS, build_model
from trackdyn.vehicle.parameters import load_vehicle

DT = 2e-4
"""Time step [s]."""

STORE_EVERY = 10


def track_input(model, runs, steps):
    """Contact stiffness [N/m] and input [m] (steps, contacts, runs): 100 kN/mm per wheel,
    8 Hz of 1 mm with a random phase per contact and run."""
    rng = np.random.default_rng(0)
    axles = np.array([len(a) for a in model.contact_axles], float)
    k = np.broadcast_to((1e8 * axles)[None, :, None], (steps, axles.size, runs)).copy()
    t = np.arange(steps)[:, None, None] * DT
    r = 1e-3 * np.sin(2 * np.pi * 8 * t + 2 * np.pi * rng.random((axles.size, runs)))
    return k, r


def outputs(model, rows, keep=None):
    """The `OUTPUTS` arrays for ``rows`` stored steps (only those in ``keep`` with columns,
    as `central.solve` gives the lanes; all when None)."""
    return [np.empty((rows, w if keep is None or name in keep else 0))
            for name, w in widths(model).items()]  # fmt: skip


def per_run(model, k, r, repeat):
    """Best time [s] of `advance` over the steps of ``k`` (steps, contacts), its outputs."""
    steps = k.shape[0]
    out = outputs(model, (steps - 1) // STORE_EVERY + 1)
    k, r = np.ascontiguousarray(k), np.ascontiguousarray(r)
    table = np.zeros((0, k.shape[1], 0))
    mats = step_matrices(model, DT)
    best = np.inf
    for _ in range(repeat):
        z = np.zeros(2 * len(model.dof_names))
        t = time.perf_counter()
        status, _ = advance(*mats, model.static_wheel_load, k, r, table, 0.0, 1.0, z, DT, 0,
                            STORE_EVERY, 50, *out)  # fmt: skip
        best = min(best, time.perf_counter() - t)
        assert status == DONE, "the benchmark's run stopped"
    return best, out


def batch(model, k, r, repeat, keep=None):
    """Best time [s] of the runs of ``k`` (steps, contacts, runs) as `central.solve` sends
    them (groups in the lanes, the others one by one), and each run's outputs; the lanes
    store only the outputs in ``keep`` (all when None; then no run may go one by one)."""
    steps, nc, runs = k.shape
    take = lane_groups(runs)
    n_groups, grouped = take.shape[0], np.count_nonzero(take >= 0)
    one = slice(grouped, runs)
    rows = (steps - 1) // STORE_EVERY + 1
    mats = run_matrices([model] * runs, [DT] * runs)
    idx = {f for f in mats._fields if f.endswith("_idx")}
    lane_mats = [a if f in idx else in_lanes(a, take) for f, a in mats._asdict().items()]
    run_mats = [a if f in idx else a[one] for f, a in mats._asdict().items()]
    per_run = {
        "static": np.full(runs, model.static_wheel_load),
        "y_start": np.zeros(runs),
        "y_step": np.ones(runs),
        "dt": np.full(runs, DT),
        "every": np.full(runs, STORE_EVERY),
        "row0": np.arange(runs) * rows,
    }
    lane = {name: in_lanes(a, take) for name, a in per_run.items()}
    alone = {name: a[one] for name, a in per_run.items()}
    k_lanes, r_lanes = (in_lanes(np.moveaxis(a, 2, 0), take) for a in (k, r))
    k_one, r_one = (np.ascontiguousarray(np.moveaxis(a, 2, 0)[one].reshape(-1, nc)) for a in (k, r))
    in_start = np.arange(runs - grouped + 1) * steps
    count = np.where(take >= 0, steps, 0)  # idle lanes: none
    assert keep is None or grouped == runs, "a run one by one writes every output"
    out = outputs(model, rows * runs, keep)
    best = np.inf
    for _ in range(repeat):
        z = np.zeros((runs, 2 * len(model.dof_names)))
        lane_z = in_lanes(z, take)
        status = np.zeros((max(runs, take.size), 2), np.int64)
        status[runs:, 0] = NOT_STARTED  # the idle lanes'
        t = time.perf_counter()
        groups = [
            (*(a if f in idx else a[g] for f, a in zip(mats._fields, lane_mats, strict=True)),
             lane["static"][g], k_lanes[g], r_lanes[g], np.zeros((0, nc, LANES, 0)),
             lane["y_start"][g], lane["y_step"][g], count[g], lane_z[g], lane["dt"][g], 0,
             lane["every"][g], 50, lane["row0"][g], *out,
             status[: take.size].reshape(n_groups, LANES, 2)[g])
            for g in range(n_groups)
        ]  # fmt: skip
        with vectorised():
            in_threads(advance_lanes, groups)
        ones = [
            (*(a if f in idx else a[b] for f, a in zip(mats._fields, run_mats, strict=True)),
             alone["static"][b], k_one[in_start[b]:in_start[b + 1]],
             r_one[in_start[b]:in_start[b + 1]], np.zeros((0, nc, 0)), alone["y_start"][b],
             alone["y_step"][b], z[one][b], alone["dt"][b], 0, alone["every"][b], 50,
             *(o[alone["row0"][b]:] for o in out))
            for b in range(runs - grouped)
        ]  # fmt: skip
        for b, ended in enumerate(in_threads(advance, ones)):
            status[grouped + b] = ended
        best = min(best, time.perf_counter() - t)
        assert (status[:runs, 0] == DONE).all(), "a run of the benchmark stopped"
    return best, [[a[b * rows : (b + 1) * rows] for a in out] for b in range(runs)]


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="short run for CI")
    opts = parser.parse_args()
    steps = 5_000 if opts.smoke else 100_000
    repeat = 2 if opts.smoke else 5
    numba.set_num_threads(1)
    vehicle = load_vehicle("loaded")
    sizes = (1, 2, 4, 8, 16)
    print(f"ns per run-step on one thread, {steps} steps, every {STORE_EVERY}th stored")
    print(f"{'model':<11}{'per run':>9}" + "".join(f"{f'L={n}':>9}" for n in sizes)
          + f"{'8 / one':>9}{'wl kept':>9}{'bitwise':>9}")  # fmt: skip
    for name in MODELS:
        model = build_model(name, vehicle)
        k, r = track_input(model, max(sizes), steps)
        per_run(model, k[:10, :, 0], r[:10, :, 0], 1)  # compile
        batch(model, k[:10, :, :9], r[:10, :, :9], 1)
        one, alone = per_run(model, k[:, :, 0], r[:, :, 0], repeat)
        times = {n: batch(model, k[:, :, :n], r[:, :, :n], repeat) for n in sizes}
        kept, kept_out = batch(model, k[:, :, :8], r[:, :, :8], repeat, KEPT)
        same = all(
            np.array_equal(a, b) for n in sizes for a, b in zip(times[n][1][0], alone, strict=True)
        ) and np.array_equal(kept_out[0][OUTPUTS.index("wl")], alone[OUTPUTS.index("wl")])
        print(f"{name:<11}{one / steps * 1e9:9.0f}"
              + "".join(f"{times[n][0] / steps / n * 1e9:9.0f}" for n in sizes)
              + f"{times[8][0] / one:9.2f}{kept / one:9.2f}"
              + f"{'yes' if same else 'NO':>9}")  # fmt: skip


if __name__ == "__main__":
    main()
