"""The driver of the central-difference scheme: runs of one model through the compiled
loops, block by block of steps.

`solve` sends the runs in groups of `LANES` side by side through
`trackdyn.solver.lanes.advance_lanes` and the rest one by one through
`trackdyn.solver.kernel.advance`, each group and run in threads (`in_threads`), the next
block's track input sampled while the loops run this one. The scheme itself is written out
in `trackdyn.solver.kernel`.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria, §5.4, eqs
5.15-5.18.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from trackdyn.errors import TrackdynInputError
from trackdyn.lanewise import LANES, vectorised
from trackdyn.solver.kernel import DONE, NEWTON_FAILED, NOT_FINITE, NOT_STARTED, advance
from trackdyn.solver.lanes import advance_lanes, in_lanes, lane_groups
from trackdyn.solver.matrices import run_matrices, start_state
from trackdyn.solver.statics import (
    OUTPUTS,
    Problem,
    failure,
    non_finite,
    table_step,
    track_input,
    widths,
)

CHUNK_STEPS = 8192
"""Steps of a run advanced per compiled call, at most: the input of the next block is
sampled while the loop runs this one. A block of 8192 steps keeps more of the lanes' input
in the cache (k and r of a group of 4 contacts, 2 MB each): with 20 000 steps a block, 4
sections of 500 m through 50 MGT took 3 % longer."""

ALONE_CHUNKS = 8
"""Blocks of `CHUNK_STEPS` in one block of a batch without lanes (its runs one by one),
after a first of `CHUNK_STEPS`: their input is a block of rows of their own, not the
lanes' layout, and fewer blocks pay less for each block's calls, sampling and hand-over
between the threads (2-DOF model, 1 km, every step stored, best of 8 in turn, two rounds:
20.7-21.5 ms end to end in blocks of 65 536 steps, 21.1-21.7 in 32 768, 21.7-22.8 in 8192,
21.2-21.8 in 131 072)."""

CHUNK_BYTES = 32 * 2**20
"""Memory of a block's sampled track input, all runs of a batch together, at most [B]
(a batch's block is shortened to fit; the nonlinear contacts' tables take most)."""


def in_threads(kernel, calls: list[tuple]) -> list:
    """``kernel(*args)`` for each ``args`` of ``calls``, their results in order: in numba's
    number of threads at once when that is more than one (the loops release the GIL), else
    one after the other.

    The runs one by one and the groups of lanes are spread over threads here, in Python,
    rather than by a compiled ``prange`` loop around `advance` and `advance_lanes`: such a
    loop is a kernel of its own to compile (5 s for the groups', 2.3 s for the runs' on
    this project's machine, beyond the loops they call), on every first run, for a call
    per block of 8192 steps. A single call does not ask numba for its threads: that asks
    through ctypes, which lets go of the GIL, and the main thread may then wait for the
    thread sampling the next block to hand it back.
    """
    threads = min(numba.get_num_threads(), len(calls)) if len(calls) > 1 else 1
    if threads <= 1:
        return [kernel(*args) for args in calls]
    with ThreadPoolExecutor(max_workers=threads) as pool:
        return [done.result() for done in [pool.submit(kernel, *args) for args in calls]]


def solve(problems: list[Problem], newton_max_iter: int = 50, advanced=None,
          keep=OUTPUTS) -> list:  # fmt: skip
    """Integrate runs of one model side by side: one compiled call per block of steps.

    The runs go in groups of `LANES` through `advance_lanes` (side by side in the vector
    lanes, the groups in threads, `in_threads`), the last group with idle lanes when at
    least `MIN_LANE_RUNS` runs are left over; fewer go through `advance` (one by one, in
    threads).

    Parameters
    ----------
    problems : list of Problem
        Runs of models with the same degrees of freedom, contacts and wedges, and the
        same kind of contact (linear or tabulated); dt, steps, storage, inputs and
        parameters may differ. A run's results do not depend on the others in the batch.
    newton_max_iter : int
        Newton iterations allowed per step.
    advanced : callable, optional
        Called with the number of steps done after each block.
    keep : sequence of str
        The `OUTPUTS` returned. The lanes neither stage nor write the others (staging
        every output of a stored step, lane by lane, cost a fifth of the 11-DOF model's
        step when only the wheel loads were kept); a run one by one writes them all, to
        arrays of its own (its loop is fastest unguarded).

    Returns
    -------
    list
        Per run, a dict of the kept `OUTPUTS` arrays, or the `TrackdynInputError` that
        stopped it.
    """
    batch = _Batch(problems, newton_max_iter, keep)
    for first, sampled in _sampled_blocks(batch.sample, batch.firsts,
                                          numba.get_num_threads() > 1):  # fmt: skip
        steps = batch.advance(first, sampled)
        if advanced is not None:
            advanced(steps)
    return batch.results()


class _Batch:
    """The runs of a `solve` call: their matrices, start states, outputs and status, the
    track input of a block of steps (`sample`), a block's steps (`advance`) and the
    results.

    Runs in the lanes (the first ``in_groups``) and one by one (the rest) have outputs of
    their own: ``flat`` (the kept arrays' columns) and ``flat_one`` (all columns, from row
    ``split`` on); the rows ``rows[b]:rows[b + 1]`` are run ``b``'s.
    """

    def __init__(self, problems: list[Problem], newton_max_iter: int, keep):
        self.problems, self.newton_max_iter, self.keep = problems, newton_max_iter, keep
        runs = self.runs = len(problems)
        take = self.take = lane_groups(runs)
        self.n_groups, self.in_groups = take.shape[0], np.count_nonzero(take >= 0)
        lanes = self.lanes = take.size
        mats = run_matrices([p.model for p in problems], [p.dt for p in problems])
        idx = {f for f in mats._fields if f.endswith("_idx")}  # shared by the runs
        grouped = self.n_groups > 0  # nothing goes into the lanes' layout without lanes
        lane_mats = [a if f in idx else in_lanes(a, take) for f, a in mats._asdict().items()
                     if grouped]  # fmt: skip
        # each group's and each run's matrices as `advance_lanes` and `advance` take them
        self.group_mats = [tuple(a if f in idx else a[g] for f, a in
                                 zip(mats._fields, lane_mats, strict=True))
                           for g in range(self.n_groups)]  # fmt: skip
        self.run_mats = {b: tuple(a if f in idx else a[b] for f, a in
                                  zip(mats._fields, mats, strict=True))
                         for b in range(self.in_groups, runs)}  # fmt: skip
        self.errors: list = [None] * runs
        # DONE: running; the rows of idle lanes follow the runs' (none one by one)
        status = self.status = np.zeros((max(runs, lanes), 2), np.int64)
        status[runs:, 0] = NOT_STARTED
        z = self.z = np.zeros((runs, 2 * len(problems[0].model.dof_names)))
        for b, p in enumerate(problems):
            try:
                z[b] = start_state(p, mats.wedge[b])
            except TrackdynInputError as exc:
                self.errors[b], status[b, 0] = exc, NOT_STARTED
        self.lane_z = in_lanes(z, take)  # (0, ...) without lanes
        self.lane_status = status[:lanes].reshape(self.n_groups, LANES, 2)
        rows = self.rows = np.cumsum([0] + [p.n_store for p in problems])
        width, split = widths(problems[0].model), rows[self.in_groups]
        self.split = split
        self.flat = {name: np.empty((split, w if name in keep else 0))
                     for name, w in width.items()}  # fmt: skip
        self.flat_one = {name: np.empty((rows[-1] - split, w)) for name, w in width.items()}
        self.per_run = dict(
            static=np.array([p.model.static_wheel_load for p in problems]),
            y_start=np.array([table_step(track_input(p).grid)[0] for p in problems]),
            y_step=np.array([table_step(track_input(p).grid)[1] for p in problems]),
            dt=np.array([p.dt for p in problems]),
            every=np.array([p.store_every for p in problems]),
        )
        self.lane = {name: in_lanes(a, take) for name, a in self.per_run.items() if grouped}
        nc, grid = len(problems[0].model.contact_names), track_input(problems[0]).grid.size
        self.nc, self.grid = nc, grid
        step_bytes = 8 * nc * (2 + grid)
        steps = CHUNK_STEPS * (1 if self.n_groups else ALONE_CHUNKS)
        block = max(1, min(steps, CHUNK_BYTES // step_bytes // runs))
        # the first block no longer than a block of the lanes: the loop waits for its input
        head, n_steps = min(block, CHUNK_STEPS), max(p.n_steps for p in problems)
        self.firsts = [0, *range(head, n_steps, block)]
        # each block's steps and which of the two buffers below takes its input
        self.blocks = {first: (min(head if i == 0 else block, n_steps - first), i % 2)
                       for i, first in enumerate(self.firsts)}  # fmt: skip
        # the lanes' input (k, r), two blocks' worth, allocated once: the next block is
        # sampled into one while the loop reads the other (`_sampled_blocks`); idle lanes,
        # and the steps past a lane's last in a block, are not read (none without lanes)
        depth = min(block, n_steps) if self.n_groups else 0
        self.buffers = np.zeros((2, 2, self.n_groups, depth, nc, LANES))
        # a group's runs are sampled into `staged`, each run's steps in a row, and go into
        # the lanes' layout in one copy: written run by run, each value there is a cache
        # line of its own (a row of the layout is `LANES` doubles)
        self.staged = np.zeros((2, LANES, depth, nc))

    def sample(self, first: int):
        """Track input of the block of steps from ``first`` on (none for stopped runs):
        in the lanes with each lane's number of steps, and of the runs one by one, by run
        (``(k, r, table)`` as their input gives it). Runs on the same input (one object)
        along the same path share one sample of it."""
        problems, nc, grid, take = self.problems, self.nc, self.grid, self.take
        block, buffer = self.blocks[first]
        count = np.zeros(max(self.runs, self.lanes), np.int64)
        for b, p in enumerate(problems):
            if self.status[b, 0] == DONE:
                count[b] = max(min(block, p.n_steps - first), 0)
        k, r = self.buffers[buffer]
        shape = (self.n_groups, int(count[: self.lanes].max(initial=0)), nc, LANES)
        table = np.zeros((*shape, grid) if grid else (self.n_groups, 0, nc, LANES, 0))
        sampled: dict = {}

        def inputs(b):
            p = problems[b]
            key = (id(p.inputs), p.centre0, p.speed, p.dt, count[b])
            if key not in sampled:
                at = p.centre0 + p.speed * p.dt * np.arange(first, first + count[b])
                sampled[key] = p.inputs(at)
            return sampled[key]

        for g in range(self.n_groups):
            mine = {b: inputs(b) for b in take[g].tolist() if b >= 0 and count[b]}
            for b, (_, _, tb) in mine.items():
                if grid:
                    table[g, : count[b], :, b % LANES] = tb
            if len({id(x) for x in mine.values()}) == 1:  # one input in every lane
                kb, rb, _ = next(iter(mine.values()))
                k[g, : len(kb)], r[g, : len(kb)] = kb[..., None], rb[..., None]
            elif mine:
                staged = self.staged
                for b, (kb, rb, _) in mine.items():
                    staged[0, b % LANES, : count[b]], staged[1, b % LANES, : count[b]] = kb, rb
                top = int(count[list(mine)].max())
                k[g, :top], r[g, :top] = staged[:, :, :top].transpose(0, 2, 3, 1)
        alone = {b: inputs(b) for b in range(self.in_groups, self.runs) if count[b]}
        per_lane = count[: self.lanes].reshape(self.n_groups, LANES)
        return (k, r, table, per_lane), alone, int(count.sum())

    def advance(self, first: int, sampled) -> int:
        """The block of steps from ``first`` on, on its ``sampled`` input (`sample`): the
        groups through `advance_lanes`, the runs one by one through `advance`, each in
        threads; a run that stopped gets its error. Returns the steps done."""
        (k, r, table, count), inputs, steps = sampled
        lane, per_run = self.lane, self.per_run
        row0 = self.rows[:-1] + (first + per_run["every"] - 1) // per_run["every"]
        if self.n_groups:
            lane_row0 = in_lanes(row0, self.take)
            groups = [  # each group's arguments of `advance_lanes`
                (*self.group_mats[g], lane["static"][g], k[g], r[g], table[g],
                 lane["y_start"][g], lane["y_step"][g], count[g], self.lane_z[g], lane["dt"][g],
                 first, lane["every"][g], self.newton_max_iter, lane_row0[g],
                 *self.flat.values(), self.lane_status[g])
                for g in range(self.n_groups)
            ]  # fmt: skip
            with vectorised():
                in_threads(advance_lanes, groups)
        going = [b for b in inputs if self.status[b, 0] == DONE]
        alone = [  # each running run's arguments of `advance`, one by one
            (*self.run_mats[b], per_run["static"][b], *inputs[b], per_run["y_start"][b],
             per_run["y_step"][b], self.z[b], per_run["dt"][b], first, per_run["every"][b],
             self.newton_max_iter, *(o[row0[b] - self.split:] for o in self.flat_one.values()))
            for b in going
        ]  # fmt: skip
        for b, ended in zip(going, in_threads(advance, alone), strict=True):
            self.status[b] = ended
        for b in range(self.runs):
            code, step = self.status[b]
            if code in (NEWTON_FAILED, NOT_FINITE) and self.errors[b] is None:
                stop = failure if code == NEWTON_FAILED else non_finite
                self.errors[b] = stop(self.problems[b], first + int(step))
        return steps

    def results(self) -> list:
        """Per run, a dict of its kept outputs, or the error that stopped it."""
        rows, in_groups = self.rows, self.in_groups
        where = [(self.flat, 0)] * in_groups + [(self.flat_one, self.split)] * (
            self.runs - in_groups
        )
        return [
            self.errors[b]
            or {name: out[name][rows[b] - at : rows[b + 1] - at] for name in self.keep}
            for b, (out, at) in enumerate(where)
        ]


def _sampled_blocks(sample, firsts: list, ahead: bool):
    """``(first, sample(first))`` for each block of steps. With ``ahead`` the next block's
    input is sampled in a thread while the compiled loop (which releases the GIL) advances
    this one: faster with a core to spare, as when numba may use more than one thread; a
    Dask worker's task runs on one (`trackdyn.parallel`), a core's worth of work, and a
    second thread there only takes turns with the loop. The first block is sampled here,
    while the thread starts (0.3 ms) and samples the second."""
    if not ahead:
        for first in firsts:
            yield first, sample(first)
        return
    with ThreadPoolExecutor(max_workers=1) as pool:
        coming = None
        for i, first in enumerate(firsts):
            sampled = sample(first) if coming is None else coming.result()
            if i + 1 < len(firsts):
                coming = pool.submit(sample, firsts[i + 1])
            yield first, sampled
