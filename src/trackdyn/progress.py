"""Progress and status of the commands (rich, on stderr), silent when not shown.

Results (tables) go to stdout; progress bars, status lines and notes go to stderr, so that
a command's output can be piped or redirected without them. `set_verbosity` (the CLI's
``-q``/``-v``) silences them or adds notes. Bars and spinners are drawn on a terminal
only: in a log file they would leave blank lines and nothing else.
"""

from __future__ import annotations

from contextlib import contextmanager, nullcontext

_settings = {"verbosity": 1}  # 0: quiet, 1: normal, 2: verbose
_waiting: list[str] = []  # why the next bar's first update will be slow (`expect_wait`)


def set_verbosity(level: int) -> None:
    """0: no progress or status; 1: progress and status; 2: also the notes."""
    _settings["verbosity"] = level


ETA_AFTER = 3
"""Updates of a bar before its time remaining is shown: the first ones come after the
solver is compiled or the workers have started, and the rate they give is far off."""


def verbosity() -> int:
    """The level `set_verbosity` set: 0 quiet, 1 normal, 2 verbose."""
    return _settings["verbosity"]


def _stderr():
    from rich.console import Console

    return Console(stderr=True)


def _columns() -> list:
    """Rich's default progress columns, the time remaining shown after `ETA_AFTER` updates."""
    from rich.progress import Progress, TimeRemainingColumn
    from rich.text import Text

    class Remaining(TimeRemainingColumn):
        def render(self, task):
            if task.fields.get("updates", 0) < ETA_AFTER:
                return Text("-:--:--", style="progress.remaining")
            return super().render(task)

    return [*Progress.get_default_columns()[:-1], Remaining()]


class _Silent:
    def advance(self, n: float = 1) -> None:
        """Nothing to show."""

    def update(self, completed: float) -> None:
        """Nothing to show."""


class _Bar:
    def __init__(self, progress, task, label: str):
        self._progress, self._task, self._updates = progress, task, 0
        self._label = label

    def advance(self, n: float = 1) -> None:
        """Move the bar on by ``n`` units."""
        self._updates += 1
        self._progress.update(self._task, advance=n, **self._fields())

    def update(self, completed: float) -> None:
        """Move the bar to ``completed`` units."""
        self._updates += 1
        self._progress.update(self._task, completed=completed, **self._fields())

    def _fields(self) -> dict:
        """The update count, and from the first update on the label without the wait."""
        return {"updates": self._updates, "description": self._label}


def expect_wait(text: str) -> None:
    """Show ``text`` with the next progress bar until its first update: why that comes late
    (e.g. the solver compiling). On a terminal only, like the bar, and gone with the bar, so
    that a refused input still ends the command with its one line on stderr."""
    _waiting[:] = [text]


@contextmanager
def progress_bar(show: bool, total: float, label: str):
    """Yield a bar with ``advance(n)`` and ``update(completed)``; removed when done.

    Parameters
    ----------
    show : bool
        Show the bar (False, verbosity 0 or stderr not a terminal: a silent stand-in).
    total : float
        Units of the whole job (steps, runs, MGT).
    label : str
        Text before the bar, with the unit, e.g. ``"tonnage [MGT]"``.
    """
    console = _stderr() if show and _settings["verbosity"] > 0 else None
    wait = f"{label}, {_waiting.pop()}" if _waiting else label
    if console is None or not console.is_terminal:
        yield _Silent()
        return
    from rich.progress import Progress

    with Progress(*_columns(), transient=True, console=console) as prog:
        yield _Bar(prog, prog.add_task(wait, total=total), label)


def status(text: str):
    """A spinner with ``text`` on stderr while the block runs (nothing when quiet or not on
    a terminal)."""
    console = _stderr() if _settings["verbosity"] > 0 else None
    if console is None or not console.is_terminal:
        return nullcontext()
    return console.status(text)


def note(text: str, level: int = 1) -> None:
    """Print ``text`` on stderr at verbosity ``level`` or more (rich markup off)."""
    if _settings["verbosity"] >= level:
        _stderr().print(text, markup=False, highlight=False, soft_wrap=True)
