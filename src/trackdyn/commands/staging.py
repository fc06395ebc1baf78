"""Output folders: checked before any work, filled as a whole or not at all.

A command writes into a hidden staging folder inside its output folder; only when every
file is written are they moved into place, replacing the files of the command's previous
run there. A manifest (`MANIFEST`) names the command and its files, so a folder holding
another command's outputs is refused unless ``overwrite`` is given. With a `Record` the
folder also gets `SUMMARY` (``summary.json``): the versions of trackdyn, Python and the
packages that shape results, the date, the command line, the options, every input file with
its SHA-256 (`trackdyn.provenance`), the headline figures, how long the run took and the
files; and ``report.html``, all of it with the tables and figures in one page
(`trackdyn.commands.report`); netCDF files written into the folder take their provenance
from the same record (`trackdyn.commands.netcdf`).

An interrupt (Ctrl-C, SIGTERM) ends the process at once with exit code 130: staging
folders and output folders this process created are removed, child processes (local Dask
workers) are killed. While files are being moved into place the interrupt waits for the
move to finish (a few renames), so a folder never holds half of a run; one that comes
after the move (while the command prints its summary) still exits 130 but leaves the
finished outputs in place. A staging folder left by a process killed outright (SIGKILL)
is removed by the next command writing there.

A file system that fills up while the outputs are written ends the command in one line,
``no space left on <folder>`` (`Status.NO_SPACE`): the staging folder is removed, the
previous run's files stay as they were.
"""

from __future__ import annotations

import errno
import gc
import json
import math
import os
import shutil
import signal
import sys
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from trackdyn.provenance import Recording, current, role_of, sha256, shown, utc_now, versions

MANIFEST = ".trackdyn.json"
"""File in an output folder naming the command that wrote it and its files."""

SUMMARY = "summary.json"
"""File in an output folder describing the run (with a `Record`)."""

FULL_BYTES = 1 << 20
"""Free space [bytes] under which a failed write counts as a full file system: netCDF-4
reports a write that ran out of space as ``NetCDF: HDF error``, without its errno, after
filling the file system to its last blocks."""

EXIT_INTERRUPTED = 130
"""Exit code after an interrupt (128 + SIGINT), as shells report it."""

_cleanup: list[Path] = []  # staging folders and created output folders, newest last
_state = {"committing": False, "pending": False}
_records: dict[Path, Record] = {}  # staging folder -> the record of its run


@dataclass
class Record:
    """What a command ran on and found: written to ``summary.json`` and the netCDF files.

    Parameters
    ----------
    title : str
        One line saying what the outputs are.
    inputs : dict
        Input files by role (``scenario``, ``geometry``, ...); None: no file (the built-in
        defaults). Every other file the command read (`trackdyn.provenance`) is added by
        its name (`input_digests`).
    options : dict
        The options the command ran with (values numbers, text, lists or tables).
    vehicle : dict
        Vehicle parameters by name [SI units], where a vehicle was run.
    command_line : str
        The command as typed; default the process's arguments when it is the ``trackdyn``
        command, else ``trackdyn <command> (called from Python)``.
    headline : dict
        The main results (filled by the command before its folder is committed), names with
        their units (``dyn_load_max_kN``).
    timings : dict
        How long parts of the run took [s]; kept out of the netCDF files.
    created : str
        When the command ran (UTC, ISO 8601; `trackdyn.provenance.utc_now`).
    currency : str, optional
        The currency that ends the names of costs in ``headline`` (``life_cycle_cost_EUR``),
        for ``report.html``'s headers.
    """

    title: str
    inputs: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    vehicle: dict = field(default_factory=dict)
    headline: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    command_line: str = ""
    created: str = field(default_factory=utc_now)
    currency: str | None = None
    _recording: Recording = field(default_factory=current, repr=False)

    def input_digests(self) -> dict[str, tuple[str, str]]:
        """Every input file by role, with its path as shown (`trackdyn.provenance.shown`)
        and SHA-256: the files of ``inputs``, then every other file the command read, in
        the order read, named by its stem (`trackdyn.provenance.role_of`)."""
        read = dict(self._recording.inputs)
        found: dict[str, tuple[str, str]] = {}
        for role, path in self.inputs.items():
            if path is not None:
                path = Path(path).resolve()
                found[role] = (shown(path), read.pop(path, "") or sha256(path))
        for path, digest in read.items():
            found[role_of(path, found)] = (shown(path), digest)
        return found

    def lines(self) -> list[str]:
        """The inputs with their SHA-256 and the timings, one line each, for a reader."""
        found = [f"input {k}: {p} {d}" for k, (p, d) in self.input_digests().items()]
        return found + [f"time {k}: {v:.3g} s" for k, v in self.timings.items()]

    def summary(self, command: str, files: list[str]) -> dict:
        """The content of ``summary.json``."""
        from trackdyn import __version__

        digests = self.input_digests()
        return {
            "trackdyn_version": __version__,
            "versions": versions(),
            "created": self.created,
            "command": command,
            "command_line": self.command_line,
            "title": self.title,
            "inputs": {k: {"path": p, "sha256": d} for k, (p, d) in digests.items()},
            "options": self.options,
            "vehicle": self.vehicle,
            "headline": self.headline,
            "timings_s": self.timings,
            "files": files,
        }


def as_json(value):
    """``value`` as JSON takes it: numpy numbers as Python's, NaN and infinity (a tonnage
    never reached) as null, anything else unknown as text."""
    if isinstance(value, dict):
        return {str(k): as_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [as_json(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if hasattr(value, "item"):  # numpy scalar
        value = value.item()
    if isinstance(value, int | float):
        return value if isinstance(value, int) or math.isfinite(value) else None
    return str(value)


def _command_line(command: str) -> str:
    if Path(sys.argv[0]).name in ("trackdyn", "__main__.py") and command in sys.argv:
        return " ".join(["trackdyn", *sys.argv[1:]])
    return f"trackdyn {command} (called from Python)"


def record_of(path) -> Record | None:
    """The record of the output folder whose staging folder holds ``path`` (None: none)."""
    return _records.get(Path(path).parent)


def _remove_and_exit() -> None:
    for path in reversed(_cleanup):
        shutil.rmtree(path, ignore_errors=True)
    try:
        import psutil

        for child in psutil.Process().children(recursive=True):
            child.kill()
    except Exception:  # noqa: BLE001, S110 - exiting anyway; best effort
        pass
    os._exit(EXIT_INTERRUPTED)


def _on_interrupt(signum, frame) -> None:
    if _state["committing"]:
        _state["pending"] = True
        return
    _remove_and_exit()


def handle_interrupts() -> None:
    """End the process on SIGINT/SIGTERM with exit code 130 and no partial outputs.

    Installed by the ``trackdyn`` command (`trackdyn.__main__`) only: a program that calls
    the CLI's functions keeps its own signal handlers.
    """
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _on_interrupt)


COLLECTIONS = (50_000, 20, 20)
"""Thresholds of Python's cyclic garbage collector in a command's processes (its default:
700, 10, 10): a command lives a few seconds, and by default the collector goes through every
object of the imported packages dozens of times on the way (`collect_rarely`)."""


def collect_rarely() -> None:
    """Collect cyclic garbage less often in this process (`COLLECTIONS`): `trackdyn
    deteriorate` on 4 x 500 m (benchmarks/command.py) 6.2-6.4 -> 5.7-5.9 s, its peak memory
    448 -> 479 MB. Set by the ``trackdyn`` command (`trackdyn.__main__`) and its figures'
    helper process (`trackdyn.commands.drawing`) only, like `handle_interrupts`; nothing
    computed changes."""
    gc.set_threshold(*COLLECTIONS)


def _manifest(out: Path) -> dict:
    try:
        data = json.loads((out / MANIFEST).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


@contextmanager
def output_folder(
    out, command: str, overwrite: bool = False, record: Record | None = None, flag: str = "--out"
):
    """Yield a staging folder; on success its files replace the command's files in ``out``.

    Parameters
    ----------
    out : str or Path
        Output folder, created if missing.
    command : str
        The command writing it (``run``, ``study``, ...), recorded in the manifest.
    overwrite : bool
        Replace the outputs of another command found in ``out``.
    record : Record, optional
        The run's provenance: ``summary.json`` is written from it, netCDF files written into
        the staging folder carry it.
    flag : str
        The command-line option that names the folder, for messages.
    """
    from trackdyn.errors import TrackdynInputError

    started = time.perf_counter()
    if not str(out).strip():
        raise TrackdynInputError(f"{flag} is empty: name an output folder")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise TrackdynInputError(f"{flag} {out}: exists and is not a folder")
    previous = _manifest(out) if out.is_dir() else {}
    other = previous.get("command")
    if other and other != command and not overwrite:
        raise TrackdynInputError(
            f"{flag} {out}: holds the outputs of 'trackdyn {other}'; choose another folder "
            "or give --overwrite"
        )
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
        _remove_stale_stages(out)
        stage = Path(tempfile.mkdtemp(prefix=f".staging-{os.getpid()}-", dir=out))
    except OSError as exc:
        if _out_of_space(exc, out):
            raise _no_space(out) from None
        raise TrackdynInputError(f"{flag} {out}: cannot write there ({exc.strerror})") from None
    if created:
        _cleanup.append(out)
    _cleanup.append(stage)
    if record is not None:
        record.command_line = record.command_line or _command_line(command)
        _records[stage] = record
    try:
        yield stage
        if record is not None:
            from trackdyn.commands.report import REPORT, render

            files = sorted([p.name for p in stage.iterdir()] + [SUMMARY, REPORT])
            record.timings["total"] = time.perf_counter() - started
            summary = record.summary(command, files)
            text = json.dumps(as_json(summary), indent=2, allow_nan=False)
            (stage / SUMMARY).write_text(text + "\n")
            page = render(summary, stage, record.currency)
            (stage / REPORT).write_text(page, encoding="utf-8")
        _commit(out, stage, command, previous)
    except BaseException as exc:
        full = _out_of_space(exc, stage)  # before the staged files are removed
        shutil.rmtree(stage, ignore_errors=True)
        if created:
            shutil.rmtree(out, ignore_errors=True)
        if full:
            raise _no_space(out) from None
        raise
    finally:
        _cleanup[:] = [p for p in _cleanup if p not in (out, stage)]
        _records.pop(stage, None)


def _out_of_space(exc: BaseException, folder: Path) -> bool:
    """Whether ``exc``, raised while writing into ``folder``, says its file system is full:
    an OSError of errno ENOSPC or EDQUOT, or netCDF's HDF error with less than
    `FULL_BYTES` left there."""
    if isinstance(exc, OSError):
        return exc.errno in (errno.ENOSPC, errno.EDQUOT)
    if isinstance(exc, RuntimeError) and "HDF error" in str(exc):
        try:
            return shutil.disk_usage(folder).free < FULL_BYTES
        except OSError:
            return False
    return False


def _no_space(out: Path):
    """The failure of a command whose output folder ``out`` ran out of space."""
    from trackdyn.errors import Status, TrackdynError

    return TrackdynError(
        f"no space left on {out}: nothing written there (the previous outputs, if any, are "
        "kept); free some space or choose another --out",
        Status.NO_SPACE,
    )


def _remove_stale_stages(out: Path) -> None:
    """Remove staging folders left by processes that no longer run (killed with SIGKILL,
    which no handler sees); their process id is in their name."""
    for stage in out.glob(".staging-*"):
        pid = stage.name.split("-")[1]
        if pid.isdigit() and not _running(int(pid)):
            shutil.rmtree(stage, ignore_errors=True)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _commit(out: Path, stage: Path, command: str, previous: dict) -> None:
    """Move the staged files into ``out``, replacing the previous run's; interrupts wait."""
    names = sorted(p.name for p in stage.iterdir())
    (stage / MANIFEST).write_text(json.dumps({"command": command, "files": names}))
    _state["committing"] = True
    try:  # renames only from here: nothing that can run out of space
        for name in previous.get("files", []):
            if name not in names and (out / name).is_file() and "/" not in name:
                (out / name).unlink()
        for name in names:
            os.replace(stage / name, out / name)
        os.replace(stage / MANIFEST, out / MANIFEST)
        stage.rmdir()
    finally:
        _state["committing"] = False
    if _state["pending"]:
        _remove_and_exit()
