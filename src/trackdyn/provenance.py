"""Provenance: every file a command read, with its SHA-256, the date and the software.

Every file trackdyn reads passes through one function of `trackdyn.io`, which notes it
here (`note_read`); a file last changed after the command started is one it wrote for
itself (an interventions study's scaled supports) and is not an input. A command runs
inside `recording`
(the command functions are decorated with `recorded`), and its record
(`trackdyn.commands.staging.Record`) lists every file noted meanwhile: the scenario and
every file it names, to the files shipped with trackdyn that it used (a vehicle preset,
the example section, the settlement parameters). A file read in another process (a Dask
worker) is noted by the code that names it to the worker (`note_read` called directly).

Paths are written absolute (`shown`); a file shipped with trackdyn as
``built-in: trackdyn/<path in the package>``, the same on every machine. The date is the
time in UTC, ISO 8601 to the second, or ``SOURCE_DATE_EPOCH`` where that is set (the
reproducible-builds convention), so that two runs can write identical files.
"""

from __future__ import annotations

import functools
import hashlib
import os
import platform
import re
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

PACKAGES = ("trackdyn", "numpy", "numba", "xarray", "scipy")
"""Packages whose versions a result records, beside Python's."""
BUILT_IN = "built-in: "
"""Prefix of the path of a file shipped with trackdyn."""

_recordings: list[Recording] = []  # active recordings, innermost last


class Recording:
    """The input files read since ``started`` [ns since the epoch]: path -> SHA-256, in the
    order first read."""

    def __init__(self) -> None:
        self.started = time.time_ns()
        self.inputs: dict[Path, str] = {}


def note_read(path) -> None:
    """Note that the file ``path`` is read: hashed now, once per recording, unless it was
    changed after the recording started (a file the command wrote)."""
    if not _recordings:
        return
    path = Path(path).resolve()
    changed = path.stat().st_mtime_ns
    digest = None
    for rec in _recordings:
        if path not in rec.inputs and changed < rec.started:
            digest = digest or sha256(path)
            rec.inputs[path] = digest


@contextmanager
def recording() -> Iterator[Recording]:
    """Note the files read inside the block (nested blocks each see them)."""
    rec = Recording()
    _recordings.append(rec)
    try:
        yield rec
    finally:
        _recordings.pop(next(i for i, r in enumerate(_recordings) if r is rec))


def current() -> Recording:
    """The innermost active recording (a fresh, inactive one outside `recording`)."""
    return _recordings[-1] if _recordings else Recording()


def recorded(function):
    """Run ``function`` inside `recording` (a command: its record finds the recording)."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with recording():
            return function(*args, **kwargs)

    return wrapper


def sha256(path) -> str:
    """SHA-256 of the file ``path`` (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def shown(path) -> str:
    """``path`` as a result records it: absolute, or ``built-in: trackdyn/...``."""
    path = Path(path).resolve()
    package = Path(__file__).resolve().parent
    if path.is_relative_to(package):
        return BUILT_IN + (Path("trackdyn") / path.relative_to(package)).as_posix()
    return str(path)


def role_of(path, taken) -> str:
    """A name for the file ``path`` among inputs named ``taken``: its stem with characters
    other than letters, digits and ``_`` as ``_``, numbered from 2 when taken."""
    stem = re.sub(r"\W", "_", Path(path).stem, flags=re.ASCII).strip("_") or "file"
    stem = stem if stem[0].isalpha() else f"file_{stem}"
    role, n = stem, 1
    while role in taken:
        n += 1
        role = f"{stem}_{n}"
    return role


def versions() -> dict[str, str]:
    """Versions of trackdyn, Python and the packages of `PACKAGES` that shape results."""
    found = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            found[name] = version(name)
        except PackageNotFoundError:  # pragma: no cover - all are dependencies
            found[name] = "not installed"
    return dict(sorted(found.items(), key=lambda kv: (kv[0] != "trackdyn", kv[0])))


def utc_now() -> str:
    """The date and time in UTC, ISO 8601 to the second (``SOURCE_DATE_EPOCH`` if set)."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    when = datetime.fromtimestamp(int(epoch), UTC) if epoch else datetime.now(UTC)
    return when.strftime("%Y-%m-%dT%H:%M:%SZ")
