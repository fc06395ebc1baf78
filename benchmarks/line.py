"""A whole line through the deterioration loop: 20 km as 20 sections, 1 and 2 workers.

Run with ``python benchmarks/line.py`` (``--smoke``: 2 sections of 300 m over 1 MGT).
Writes 20 synthetic 1 km sections (FRA class 5 geometry, different seeds, the example's
stiffness field) and a sections CSV into a temporary folder, then runs the built-in
example scenario's traffic, law and loop (50 MGT, tamped start, 11-DOF model) over them,
serially in this process and on a 2-worker LocalCluster, as `run_sections` sends them (up
to `TOGETHER` sections stepped together a task). Reports wall times, the speed-up and the
peak memory (resident set) of the processes that ran the sections.
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import tempfile
import time
from pathlib import Path

from trackdyn.commands.deteriorate.scenario import load_deterioration
from trackdyn.commands.deteriorate.sections import section_tasks
from trackdyn.deterioration.runs import TOGETHER, run_group
from trackdyn.errors import Failure
from trackdyn.io import write_geometry, write_supports
from trackdyn.parallel import run_tasks
from trackdyn.track.synthetic import synthetic_track


def write_line(folder: Path, n: int, length: float) -> Path:
    """``n`` synthetic sections and their sections CSV in ``folder``."""
    rows = ["name,geometry,supports"]
    for i in range(n):
        trk = synthetic_track(length, spectrum="fra5", seed=100 + i, where=f"km{i}")
        write_geometry(trk.geometry, folder / f"km{i}_geometry.csv")
        write_supports(trk.supports, folder / f"km{i}_supports.csv")
        rows.append(f"km{i},km{i}_geometry.csv,km{i}_supports.csv")
    (folder / "sections.csv").write_text("\n".join(rows) + "\n")
    return folder / "sections.csv"


def measured_group(tasks):
    """`run_group`, with the peak resident memory of the process that ran it [MB]."""
    results = run_group(tasks)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return [r if isinstance(r, Failure) else {"peak_MB": peak} for r in results]


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="2 short sections, 1 MGT")
    opts = parser.parse_args()
    n, length, mgt = (2, 300.0, 1.0) if opts.smoke else (20, 1000.0, 50.0)
    with tempfile.TemporaryDirectory() as tmp:
        csv = write_line(Path(tmp), n, length)
        spec, base = load_deterioration(None)
        loop = spec.loop.model_copy(update={"total_mgt": mgt, "segment_length_m": 100.0})
        track = spec.track.model_copy(update={"sections": csv, "start": "tamped"})
        spec = spec.model_copy(update={"loop": loop, "track": track})
        tasks = [dataclasses.replace(t, progress=False) for t in section_tasks(spec, base)]
        times, peaks = {}, {}
        for workers in (1, 2):
            clock = time.perf_counter()
            results = run_tasks(tasks, measured_group, workers=workers, together=TOGETHER)
            times[workers] = time.perf_counter() - clock
            failed = [r for r in results if isinstance(r, Failure)]
            assert not failed, failed[0].message
            peaks[workers] = max(r["peak_MB"] for r in results)
    km = n * length / 1e3
    print(f"{km:g} km as {n} sections, {mgt:g} MGT each")
    for w in (1, 2):
        print(f"  {w} worker(s): {times[w]:7.1f} s, peak memory per process {peaks[w]:.0f} MB")
    print(f"  speed-up {times[1] / times[2]:.2f}; {km * mgt / times[2]:.1f} km MGT per second")


if __name__ == "__main__":
    main()
