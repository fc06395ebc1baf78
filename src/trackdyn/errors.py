"""The one failure type of trackdyn (a `Status` and a one-line message), the exception for
bad input, and the checks that raise it.

Every failure that a caller reports and goes on from (a run of a study, a section of a
line, a model run of a fit, a lost worker) comes back as a `Failure`; raised, it is a
`TrackdynError`: `TrackdynInputError` for input that trackdyn refuses,
`TrackdynNumericalError` for a computation that did not succeed on input it accepted.
"""

from __future__ import annotations

import enum
import os
import traceback
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np


class Status(enum.Enum):
    """Why something did not give a result."""

    INPUT_REFUSED = "input refused"
    NEWTON_DIVERGED = "Newton iteration did not converge"
    NON_FINITE = "non-finite result"
    SETTLEMENT_RAN_AWAY = "settlement ran away"
    WORKER_LOST = "worker lost"
    NO_SPACE = "no space left on device"
    FAILED = "failed"  # anything else: a bug, reported with where it was raised


class TrackdynError(Exception):
    """A failure of trackdyn with its `Status`; the message is one line (line breaks in
    the text it is made from, such as a library's message quoted in it, become spaces).

    The CLI prints it without a traceback and exits with code 2.
    """

    status: Status = Status.FAILED

    def __init__(self, message: str, status: Status | None = None):
        super().__init__(" ".join(str(message).split()) if "\n" in str(message) else message)
        if status is not None:
            self.status = status

    def __reduce__(self):  # keep the status through pickling (Dask workers)
        return type(self), (str(self), self.status)


class TrackdynInputError(TrackdynError, ValueError):
    """Input that trackdyn refuses.

    The message is one line and names the file, row or parameter at fault.
    """

    status = Status.INPUT_REFUSED


class TrackdynNumericalError(TrackdynError):
    """A computation that did not succeed on input trackdyn accepted (`Status`:
    ``NEWTON_DIVERGED``, ``NON_FINITE``, ``SETTLEMENT_RAN_AWAY``)."""


@dataclass(frozen=True)
class Failure:
    """What a run, a section or a task gave instead of a result.

    Parameters
    ----------
    status : Status
        Why it failed.
    message : str
        One line: what failed, and where.
    """

    status: Status
    message: str

    @classmethod
    def of(cls, exc: BaseException) -> Failure:
        """The failure an exception stands for (its status; `FAILED` for a non-trackdyn
        exception, whose message then names its type and where it was raised)."""
        if isinstance(exc, TrackdynError):
            return cls(exc.status, str(exc))
        return cls(Status.FAILED, error_message(exc))

    def named(self, name: str) -> Failure:
        """The same failure, its message prefixed with ``name`` (``"section a: ..."``)."""
        return Failure(self.status, f"{name}: {self.message}")

    def error(self) -> TrackdynError:
        """The exception to raise for it: `TrackdynInputError` for refused input,
        `TrackdynNumericalError` for a numerical failure, else `TrackdynError`."""
        if self.status is Status.INPUT_REFUSED:
            return TrackdynInputError(self.message)
        if self.status in NUMERICAL:
            return TrackdynNumericalError(self.message, self.status)
        return TrackdynError(self.message, self.status)

    def __str__(self) -> str:
        return self.message


NUMERICAL = frozenset({Status.NEWTON_DIVERGED, Status.NON_FINITE, Status.SETTLEMENT_RAN_AWAY})
"""The statuses of `TrackdynNumericalError`."""


def shown(value) -> str:
    """``value`` as a message shows it: numpy scalars and arrays as plain Python values."""
    if isinstance(value, np.generic):
        value = value.item()
    elif isinstance(value, np.ndarray):
        value = value.tolist()
    return repr(value)


def require_positive(name: str, value) -> np.ndarray:
    """Return ``value`` as a float array after checking it is finite and > 0.

    Parameters
    ----------
    name : str
        Parameter name used in the error message.
    value : float or array_like
        Value to check.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TrackdynInputError(f"{name} must be a number, got {shown(value)}") from None
    if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise TrackdynInputError(f"{name} must be finite and > 0, got {shown(value)}")
    return arr


def unknown(kind: str, name, known, where: str = "") -> TrackdynInputError:
    """The refusal of a name that is not a key of a registry.

    Parameters
    ----------
    kind : str
        What the name names (``model``, ``rail section``, ...).
    name : object
        The name given.
    known : iterable of str
        The registry's names, listed in the message.
    where : str
        Prefix naming the source (``"wagon.toml: "``), or empty.

    Returns
    -------
    TrackdynInputError
        ``unknown <kind> <name>; known: <names>``, for the caller to raise.
    """
    return TrackdynInputError(f"{where}unknown {kind} {name!r}; known: {', '.join(known)}")


def check_series(
    distance, values=None, *, name: str = "profile", min_points: int = 1, where: str = ""
):
    """Validate ``distance`` [m] (1-D, finite, strictly increasing) and optional ``values``.

    Returns ``x`` or ``(x, values)`` as float arrays. Errors name the first bad row; ``name``
    names the values and ``where`` (a file or data set) the source in messages.
    """
    at = f"{where}: " if where else ""
    x = np.asarray(distance, dtype=float)
    if x.ndim != 1 or x.size < min_points:
        raise TrackdynInputError(f"{at}distance must be 1-D with at least {min_points} points")
    z = x if values is None else np.asarray(values, dtype=float)
    if z.shape != x.shape:
        raise TrackdynInputError(f"{at}{name} has shape {z.shape} but distance has {x.shape}")
    for label, arr in (("distance", x), (name, z)):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise TrackdynInputError(f"{at}{label} is NaN or infinite at row {bad[0]}")
    bad = np.flatnonzero(np.diff(x) <= 0)
    if bad.size:
        raise TrackdynInputError(f"{at}distance is not strictly increasing at row {bad[0] + 1}")
    return x if values is None else (x, z)


def error_message(exc: BaseException) -> str:
    """One line describing a failure of a run that the caller reports and goes on from.

    Refused input keeps its message; anything else (a bug) gets its type and the place it
    was raised, so a report from a remote worker can be traced.

    Parameters
    ----------
    exc : BaseException
        The exception caught.
    """
    if isinstance(exc, TrackdynError):
        return str(exc)
    frames = traceback.extract_tb(exc.__traceback__)
    where = f" ({frames[-1].filename}:{frames[-1].lineno})" if frames else ""
    return f"{type(exc).__name__}: {exc}{where}"


@contextmanager
def named(source):
    """Prefix a refusal with the scenario file it comes from (if it does not name it).

    Parameters
    ----------
    source : path or None
        The scenario file; None: the built-in example.
    """
    try:
        yield
    except TrackdynInputError as exc:
        where = str(source) if source is not None else "built-in example"
        if str(exc).startswith(where):
            raise
        raise TrackdynInputError(f"{where}: {exc}") from None


WORKERS_PER_CORE = 4
"""Most worker processes per core: more only share the cores and multiply the memory."""


def require_workers(workers: int | None) -> None:
    """Refuse a ``--workers`` count below 1 or above `WORKERS_PER_CORE` per core.

    A count far above the cores is refused rather than capped: each worker holds a whole
    run in memory, so such a count ends in killed workers, not in a faster run.

    Parameters
    ----------
    workers : int or None
        Worker processes asked for; None: the default, one per core.
    """
    if workers is None:
        return
    if workers < 1:
        raise TrackdynInputError(f"--workers must be >= 1, got {workers}")
    cores = os.cpu_count() or 1
    if workers > WORKERS_PER_CORE * cores:
        raise TrackdynInputError(
            f"--workers {workers} is outside the plausible 1 to {WORKERS_PER_CORE * cores} "
            f"({WORKERS_PER_CORE} per core on this machine's {cores} cores)"
        )
