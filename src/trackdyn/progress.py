"""Progress and status of the commands (rich, on stderr), silent when not shown.

Results go to stdout; progress bars, status lines and notes go to stderr, so that a
command's output can be piped or redirected without them. `set_verbosity` (the CLI's
``-q``/``-v``) silences them or adds notes.
"""

from __future__ import annotations

from contextlib import contextmanager, nullcontext

_settings = {"verbosity": 1}  # 0: quiet, 1: normal, 2: verbose


def set_verbosity(level: int) -> None:
    """0: no progress or status; 1: progress and status; 2: also the notes."""
    _settings["verbosity"] = level


def _stderr():
    from rich.console import Console

    return Console(stderr=True)


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
        Show the bar (False, or verbosity 0: a silent stand-in).
    total : float
        Units of the whole job (steps, runs, MGT).
    label : str
        Text before the bar, with the unit, e.g. ``"tonnage [MGT]"``.
    """
    if not show or _settings["verbosity"] == 0:
        yield _Silent()
        return
    from rich.progress import Progress

    with Progress(transient=True, console=_stderr()) as prog:
        yield _Bar(prog, prog.add_task(label, total=total))


def status(text: str):
    """A spinner with ``text`` on stderr while the block runs (nothing when quiet)."""
    return nullcontext() if _settings["verbosity"] == 0 else _stderr().status(text)


def note(text: str, level: int = 1) -> None:
    """Print ``text`` on stderr at verbosity ``level`` or more (rich markup off)."""
    if _settings["verbosity"] >= level:
        _stderr().print(text, markup=False, highlight=False, soft_wrap=True)
