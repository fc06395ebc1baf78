"""Figures drawn by a second process while the command writes its other files.

Drawing and saving a PNG is matplotlib's Python code, one core's work: a section of
`trackdyn deteriorate` has four figures (about 0.7 s), which took more than half the
command's time on a line of sections. A command that writes at least `HELPED_FIGURES`
figures starts a `helper` process when it starts (the helper imports matplotlib and
trackdyn's figures while the runs go on), hands it every figure as a `Drawing` (the
``plot_*`` function and its data, sent by pickle) and writes its own files meanwhile; then
it draws, from the last, the figures the helper has not begun (`drawn`). Either process
draws the same figure to the same bytes. On one core there is no helper and this process
draws them all.

The helper blocks SIGINT (`trackdyn.parallel.interrupts_here`), as a local cluster's
workers do: Ctrl-C in a terminal reaches the command, whose handler removes the staging
folder and kills its child processes (`trackdyn.commands.staging`). A helper that dies
leaves its figures to this process.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import BrokenExecutor, Future, ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from trackdyn.commands.staging import collect_rarely
from trackdyn.parallel import interrupts_here

HELPED_FIGURES = 8
"""Figures from which a command has them drawn by a helper process too. Measured with
`trackdyn deteriorate` (3 December 2026, 2 cores): a line of 4 sections, 17 figures, 6.7 ->
5.5 s; the built-in example, one section and 4 figures, 5.1-5.2 -> 5.3-5.7 s (the
helper's start, about a core-second, costs more than it takes over)."""


@dataclass(frozen=True)
class Drawing:
    """A figure to draw: ``draw(*args, **kwargs)``, a public ``plot_*`` function of
    `trackdyn.plots` and its data (both picklable, so that another process can draw it)."""

    draw: Callable
    args: tuple
    kwargs: dict = field(default_factory=dict)

    def figure(self):
        """The figure, drawn in this process (`matplotlib.figure.Figure`)."""
        return self.draw(*self.args, **self.kwargs)


def _save(drawing: Drawing, path: Path) -> None:
    from trackdyn.plots import save

    save(drawing.figure(), path)


def _ready() -> None:
    """The helper's start: the figures' modules imported before the first figure comes, the
    garbage collected as rarely as in the command (`trackdyn.commands.staging.collect_rarely`)."""
    collect_rarely()
    import trackdyn.plots  # noqa: F401 - matplotlib and pyplot, imported once


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


@contextmanager
def helper(figures: int):
    """A second process drawing the command's ``figures`` figures with it (`drawn`), started
    now; None for fewer than `HELPED_FIGURES` or on a machine (or an affinity) of one core.
    Ends with the block (figures not begun are dropped)."""
    if figures < HELPED_FIGURES or _cores() < 2:
        yield None
        return
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: no threads forked
    with interrupts_here():  # the process starts, blocking SIGINT, at the first submit
        pool = ProcessPoolExecutor(1, mp_context=context, initializer=_ready)
        pool.submit(int)
    try:
        yield pool
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


@contextmanager
def drawn(drawings: dict[str, Drawing], folder: Path, pool: ProcessPoolExecutor | None):
    """Save each ``drawings[file]`` as ``folder / file``: handed to the ``pool``'s helper
    (`helper`) when the block begins; when it ends, this process draws, from the last,
    those the helper has not begun, and waits for the others. Without a pool, or if the
    helper has died, this process draws them."""
    futures: dict[str, Future] = {}
    if pool is not None:
        try:
            futures = {file: pool.submit(_save, d, folder / file) for file, d in drawings.items()}
        except BrokenExecutor:
            futures = {}
    yield
    for file in reversed(list(drawings)):
        future = futures.get(file)
        if future is None or future.cancel():
            _save(drawings[file], folder / file)
    for file, future in futures.items():
        if future.cancelled():
            continue
        try:
            future.result()
        except BrokenExecutor:  # the helper died: its figure is drawn here
            _save(drawings[file], folder / file)
