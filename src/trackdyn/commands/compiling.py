"""The note a command gives when its first run will compile the solver (numba's cache cold).

numba compiles each kernel on its first call and keeps it in its cache folder
(``NUMBA_CACHE_DIR``, which `trackdyn` sets to the user's cache folder): a folder per
source folder, named after it and the SHA-1 of its path, holding an index file
(``<module>.<function>-<line>.py<version>.nbi``) per compiled function. A kernel is taken
as cached when its index file is there and newer than its source file (numba rewrites the
index when the source changes). Checked from the file names alone, without importing
numba: the command has not imported it yet.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

KERNELS: dict[str, tuple[tuple[str, str], ...]] = {
    "run": (("solver/kernel.py", "advance"),),
    "study": (("solver/lanes.py", "advance_lanes"),),
    "deteriorate": (("solver/kernel.py", "advance"), ("beam/railseat.py", "_window_solve")),
    "calibrate": (("solver/kernel.py", "advance"), ("beam/railseat.py", "_window_solve")),
    "interventions": (
        ("solver/lanes.py", "advance_lanes"),
        ("beam/railseat.py", "_window_solve"),
    ),
}
"""Per command, the kernels whose compiling takes most of its first run (file under the
package, function), from ``benchmarks/coldstart.py --kernels``; each in the cache after the
command's first run on its built-in example (checked by hand: else the note would come
every time). ``interventions``: a study of ``kind = "interventions"``. A command not here
(track, example) compiles little."""

SECONDS: dict[str, int] = {
    "run": 7,
    "study": 30,
    "deteriorate": 14,
    "calibrate": 10,
    "interventions": 30,
}
"""Per command, what its first run took longer than the next on the built-in example on
this project's 2-core machine (``benchmarks/coldstart.py``), rounded up [s]."""


def cache_folder(source: Path) -> Path:
    """numba's cache folder for the functions of ``source`` (under ``NUMBA_CACHE_DIR``)."""
    folder = os.path.abspath(source.parent)
    digest = hashlib.sha1(folder.encode()).hexdigest()
    return Path(os.environ.get("NUMBA_CACHE_DIR", "")) / f"{Path(folder).name}_{digest}"


def cached(source: Path, function: str) -> bool:
    """Whether numba's cache holds ``function`` of ``source``, newer than the source."""
    version = f"py{sys.version_info.major}{sys.version_info.minor}"
    indexes = cache_folder(source).glob(f"{source.stem}.{function}-*.{version}.nbi")
    changed = source.stat().st_mtime
    return any(index.stat().st_mtime >= changed for index in indexes)


def compiling_note(command: str) -> str | None:
    """The note for ``command``'s run when it will compile its kernels; None when they are
    cached (or the command compiles little, or numba caches elsewhere: NUMBA_CACHE_DIR
    unset)."""
    if command not in KERNELS or not os.environ.get("NUMBA_CACHE_DIR"):
        return None
    package = Path(os.path.abspath(__file__)).parent.parent
    if all(cached(package / file, function) for file, function in KERNELS[command]):
        return None
    return f"compiling the solver once (about {SECONDS[command]} s; cached for later runs)"


def say_if_compiling(command: str, scheduler: str | None = None) -> None:
    """Say with the command's progress bar, until it first moves, that ``command``'s run
    will compile its kernels (`compiling_note`; `trackdyn.progress.expect_wait`: on a
    terminal, not under ``-q``); nothing with a ``scheduler``: its workers have their own
    cache."""
    from trackdyn.progress import expect_wait

    text = None if scheduler else compiling_note(command)
    if text:
        expect_wait(text)
