"""First runs: each command on its built-in example with an empty compiled-code cache.

Run with ``python benchmarks/coldstart.py`` (``--smoke``: ``trackdyn track`` only, for CI;
``--commands`` to pick some). For each command, in a new process as a user would run it
(``python -m trackdyn -q COMMAND --out ...``), first with an empty ``NUMBA_CACHE_DIR`` (a
new temporary folder: the first run after an install), then again with the cache it
filled (the warm run). Reported: both wall times, their difference (goal: at most
`GOAL_S`) and the machine's load average over the last minute before each run (the
machine is shared: read the differences with it).

``--kernels`` compiles in this process instead, with an empty cache, what ``trackdyn run``,
``trackdyn study`` and ``trackdyn deteriorate`` compile on their built-in examples
(``--workers 1``: the runs in this process, as a Dask worker runs them), and lists numba's
compile time per function: its signatures (specialisations) compiled, the time inclusive of
the functions compiled inside it, and its own (exclusive) time.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

GOAL_S = 15.0
"""Goal: a command's first run at most this much longer than its warm run [s]."""

COMMANDS = {
    "track": ["track"],
    "run": ["run"],
    "study": ["study"],
    "interventions": ["study", "interventions.toml"],
    "deteriorate": ["deteriorate"],
    "calibrate": ["calibrate"],
}
"""Each measured command's arguments: its built-in example (the interventions study from
``trackdyn example interventions``, written into the run's folder)."""


def timed(args: list[str], folder: Path, cache: Path) -> tuple[float, float]:
    """Wall time of ``trackdyn -q ARGS`` in ``folder`` with ``NUMBA_CACHE_DIR=cache`` [s],
    and the load average of the minute before."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    load = os.getloadavg()[0]
    clock = time.perf_counter()
    subprocess.run([sys.executable, "-m", "trackdyn", "-q", *args], cwd=folder, env=env,
                   check=True, stdout=subprocess.DEVNULL)  # fmt: skip
    return time.perf_counter() - clock, load


def first_and_warm(name: str, folder: Path) -> None:
    """Print ``name``'s cold and warm run on an empty cache of its own."""
    cache = folder / f"cache-{name}"
    if name == "interventions":
        env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
        subprocess.run([sys.executable, "-m", "trackdyn", "-q", "example", "interventions",
                        "--to", "."], cwd=folder, env=env, check=True,
                       stdout=subprocess.DEVNULL)  # fmt: skip
    runs = []
    for kind in ("cold", "warm"):
        runs.append(timed([*COMMANDS[name], "--out", f"{name}-{kind}"], folder, cache))
    (cold, cold_load), (warm, warm_load) = runs
    extra = cold - warm
    verdict = "within" if extra <= GOAL_S else "over"
    print(f"{name:13s} first {cold:6.1f} s (load {cold_load:.1f})   warm {warm:6.1f} s "
          f"(load {warm_load:.1f})   first - warm {extra:+6.1f} s ({verdict} {GOAL_S:g} s)",
          flush=True)  # fmt: skip


def kernels() -> None:
    """Compile in this process with an empty cache and print numba's time per function."""
    cache = tempfile.mkdtemp(prefix="trackdyn-cold-")
    os.environ["NUMBA_CACHE_DIR"] = cache  # before numba is imported: it reads it then
    from numba.core import event

    from trackdyn.cli import app

    with tempfile.TemporaryDirectory() as out, event.install_recorder("numba:compile") as rec:
        clock = time.perf_counter()
        for args in (["run"], ["study", "--workers", "1"], ["deteriorate", "--workers", "1"]):
            app(["-q", *args, "--out", f"{out}/{args[0]}"], standalone_mode=False)
        wall = time.perf_counter() - clock
    rows = compile_times(rec.buffer)
    total = sum(own for _, _, own in rows.values())
    print(f"run, study, deteriorate in one process, empty cache: {wall:.1f} s wall, "
          f"{total:.1f} s compiling ({len(rows)} functions)")  # fmt: skip
    print(f"{'function':50s} {'signatures':>10s} {'inclusive [s]':>14s} {'own [s]':>8s}")
    for name, (count, inclusive, own) in sorted(rows.items(), key=lambda r: -r[1][2]):
        print(f"{name:50s} {count:10d} {inclusive:14.2f} {own:8.2f}")


def compile_times(buffer: list) -> dict[str, list]:
    """Per compiled function (module.name): signatures compiled, inclusive and own seconds,
    from numba's ``numba:compile`` events (nested: a function compiled while another was)."""
    rows: dict[str, list] = {}
    stack: list[list] = []  # [name, start, seconds of the compiles inside]
    for stamp, ev in buffer:
        disp = ev.data["dispatcher"]
        name = f"{disp.py_func.__module__.removeprefix('trackdyn.')}.{disp.py_func.__name__}"
        if ev.is_start:
            stack.append([name, stamp, 0.0])
            continue
        _, start, inner = stack.pop()
        took = stamp - start
        if stack:
            stack[-1][2] += took
        row = rows.setdefault(name, [0, 0.0, 0.0])
        row[0] += 1
        row[1] += took
        row[2] += took - inner
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="trackdyn track only")
    parser.add_argument("--commands", nargs="+", choices=list(COMMANDS), default=list(COMMANDS))
    parser.add_argument("--kernels", action="store_true", help="numba's time per function")
    opts = parser.parse_args()
    if opts.kernels:
        kernels()
        return
    print(f"{os.cpu_count()} cores; Python {sys.version.split()[0]}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in ["track"] if opts.smoke else opts.commands:
            first_and_warm(name, Path(tmp))


if __name__ == "__main__":
    main()
