"""The command around the loop: ``trackdyn deteriorate`` on a line, in single runs.

Run with ``python benchmarks/command.py`` (``--smoke``: 2 sections of 300 m through 1 MGT,
a short check for CI). Writes a line of 4 synthetic sections of 500 m (FRA class 5
geometry, different seeds, the example's stiffness field), a sections CSV and a scenario
TOML (the built-in example's traffic, law, loop and 11-DOF model, tamped start, 50 MGT,
no maintenance) into a temporary folder (``--sections N``: N sections; the cost of one more
section is the difference of 4 and 16), then:

1. times one 11-DOF `simulate` of the loaded wagon over the first 500 m section in this
   process (10 times, the compiled loop loaded beforehand; best and median: on a shared
   machine the same run took from 25 to 110 ms);
2. runs ``trackdyn -q deteriorate`` on the line in a new process, as a user would (start-up
   included; ``--workers`` as given, default none: the command's own choice), best of
   ``--tries``, and reports its wall time per section in single runs (goal: at most 10);
3. times a new process that only imports the packages the command uses (`PACKAGES`, best
   of ``--tries``): a floor under the command's start-up that no change to trackdyn can
   lower, reported in single runs per section too;
4. with ``--profile``, runs the command once more under ``cProfile`` and prints where
   its time went: imports, the runs (reading the tracks, the loops, the solver, which
   includes loading the compiled loops from numba's cache), netCDF, figures.

The compiled-code cache is the user's (warm); ``benchmarks/coldstart.py`` measures a cold
one.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from line import write_line

SCENARIO = """\
[run]
model = "11dof"

[[traffic]]
vehicle = "loaded"
speed_kmh = 60
passages_per_mgt = 8065
[[traffic]]
vehicle = "empty"
speed_kmh = 60
passages_per_mgt = 8065

[settlement]
law = "power"

[loop]
total_mgt = {mgt}
snapshot_every_mgt = {snapshot}

[track]
sections = "sections.csv"
start = "tamped"
"""

GOAL = 10.0
"""Goal: a section's deterioration through 50 MGT, start-up included, in single runs."""

PACKAGES = (
    "numpy", "scipy.signal", "scipy.interpolate", "pandas", "xarray", "netCDF4", "numba",
    "matplotlib.pyplot", "distributed", "pint", "pydantic", "typer", "rich",
)  # fmt: skip
"""The packages ``trackdyn deteriorate`` imports (found in ``sys.modules`` after a run of the
command, those it needs for the loop, its files, figures, cluster, units, scenario and
console), trackdyn itself not among them."""


def one_run(csv: Path, repeat: int) -> list[float]:
    """Wall times of `repeat` `simulate` calls over the line's first section, sorted [s]."""
    from trackdyn.commands.deteriorate.scenario import load_deterioration
    from trackdyn.data import load_track
    from trackdyn.simulation import simulate
    from trackdyn.vehicle.parameters import load_vehicle

    spec, _ = load_deterioration(None)
    folder = csv.parent
    track = load_track(folder / "km0_geometry.csv", folder / "km0_supports.csv")
    vehicle = load_vehicle("loaded")
    simulate(vehicle, track, spec.run)  # compile or load from numba's cache
    times = []
    for _ in range(repeat):
        clock = time.perf_counter()
        simulate(vehicle, track, spec.run)
        times.append(time.perf_counter() - clock)
    return sorted(times)


def command(folder: Path, workers: int | None) -> float:
    """Wall time of ``trackdyn -q deteriorate`` on the line in a new process [s]."""
    args = [sys.executable, "-m", "trackdyn", "-q", "deteriorate", str(folder / "line.toml"),
            "--out", str(folder / "out"), "--overwrite"]  # fmt: skip
    if workers is not None:
        args += ["--workers", str(workers)]
    clock = time.perf_counter()
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - clock


def imports() -> float:
    """Wall time of a new Python process that imports `PACKAGES` and nothing else [s]."""
    clock = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import " + ", ".join(PACKAGES)], check=True)
    return time.perf_counter() - clock


PHASES = {
    "imports (inside the command)": ("_bootstrap>", "_find_and_load"),
    "the runs (run_sections: tracks read, loops)": ("runs.py", "run_sections"),
    "  of which the loops stepped together": ("driver.py", "step_together"),
    "  of which the solver (compiled loops)": ("solver/__init__.py", "solve"),
    "outputs (write_outputs)": ("outputs.py", "write_outputs"),
    "  of which netCDF": ("netcdf.py", "write_netcdf"),
    "  of which figures drawn (plot_*)": ("plots/deteriorate.py", "plot_"),
    "  of which figures saved (PNG)": ("plots/__init__.py", "save"),
}
"""Phases of the command's profile: (end of the file name, the function's name, or the start
of the names of several when it ends in ``_``)."""

PROFILED = """
import cProfile, pstats, sys
from trackdyn.cli import app
profile = cProfile.Profile()
profile.enable()
app(sys.argv[2:], standalone_mode=False)
profile.disable()
profile.dump_stats(sys.argv[1])
"""


def phases(folder: Path, workers: int | None) -> None:
    """Run the command once under cProfile and print where its time went."""
    import pstats

    stats = folder / "command.prof"
    args = ["-q", "deteriorate", str(folder / "line.toml"), "--out", str(folder / "out"),
            "--overwrite"]  # fmt: skip
    if workers is not None:
        args += ["--workers", str(workers)]
    clock = time.perf_counter()
    subprocess.run([sys.executable, "-c", PROFILED, str(stats), *args], check=True,
                   stdout=subprocess.DEVNULL)  # fmt: skip
    wall = time.perf_counter() - clock
    table = pstats.Stats(str(stats)).stats  # (file, line, name) -> (.., .., .., cumulative, ..)
    total = max(row[3] for row in table.values())
    print(f"one run under cProfile: {wall:.2f} s wall, {total:.2f} s in the command")
    for label, (file, name) in PHASES.items():
        # cumulative: a call inside another of the same function (an import inside an
        # import) counted once
        took = sum(row[3] for (f, _, n), row in table.items()
                   if f.endswith(file) and (n == name or name.endswith("_") and
                                            n.startswith(name)))  # fmt: skip
        print(f"  {label:45s} {took:6.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="2 sections of 300 m, 1 MGT")
    parser.add_argument("--workers", type=int, default=None, help="the command's --workers")
    parser.add_argument("--tries", type=int, default=3, help="runs of the command")
    parser.add_argument("--profile", action="store_true", help="the command's phases")
    parser.add_argument("--sections", type=int, default=4, help="sections of 500 m in the line")
    opts = parser.parse_args()
    n, length, mgt, repeat = (2, 300.0, 1.0, 1) if opts.smoke else (opts.sections, 500.0, 50.0, 10)
    tries = 1 if opts.smoke else opts.tries
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        csv = write_line(folder, n, length)
        snapshot = mgt if opts.smoke else 10
        (folder / "line.toml").write_text(SCENARIO.format(mgt=mgt, snapshot=snapshot))
        single = one_run(csv, repeat)
        load = os.getloadavg()[0]
        walls = [command(folder, opts.workers) for _ in range(tries)]
        floor = min(imports() for _ in range(tries))
        if opts.profile:
            phases(folder, opts.workers)
    wall = min(walls)
    workers = "default" if opts.workers is None else opts.workers
    best, median = single[0], single[len(single) // 2]
    print(f"one simulate over {length:g} m (11-DOF, loaded wagon): best {best * 1e3:.0f} ms, "
          f"median {median * 1e3:.0f} ms ({repeat} runs)")  # fmt: skip
    each = ", ".join(f"{w:.2f}" for w in walls)
    print(f"trackdyn deteriorate, {n} x {length:g} m through {mgt:g} MGT, --workers {workers}: "
          f"{wall:.2f} s wall (best of {tries}: {each}); load {load:.1f}")  # fmt: skip
    print(f"  a section in single runs, start-up included: {wall / n / median:.1f} of the "
          f"median run, {wall / n / best:.1f} of the best (goal: at most {GOAL:g})")  # fmt: skip
    print(f"  a new process importing the packages it uses, nothing else: {floor:.2f} s, "
          f"{floor / n / median:.1f} single runs a section of the median run")  # fmt: skip


if __name__ == "__main__":
    main()
