"""The one progress bar of trackdyn (rich), silent when not shown."""

from __future__ import annotations

from contextlib import contextmanager


class _Silent:
    def advance(self, n: float = 1) -> None:
        """Nothing to show."""

    def update(self, completed: float) -> None:
        """Nothing to show."""


class _Bar:
    def __init__(self, progress, task):
        self._progress, self._task = progress, task

    def advance(self, n: float = 1) -> None:
        """Move the bar on by ``n`` units."""
        self._progress.advance(self._task, n)

    def update(self, completed: float) -> None:
        """Move the bar to ``completed`` units."""
        self._progress.update(self._task, completed=completed)


@contextmanager
def progress_bar(show: bool, total: float, label: str):
    """Yield a bar with ``advance(n)`` and ``update(completed)``; removed when done.

    Parameters
    ----------
    show : bool
        Show the bar (False: a silent stand-in).
    total : float
        Units of the whole job (steps, runs, MGT).
    label : str
        Text before the bar, with the unit, e.g. ``"tonnage [MGT]"``.
    """
    if not show:
        yield _Silent()
        return
    from rich.progress import Progress

    with Progress(transient=True) as prog:
        yield _Bar(prog, prog.add_task(label, total=total))
