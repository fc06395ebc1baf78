"""Peak memory of a run against the length of its track, and the refusal of a track too
long for this machine's memory.

Run with ``python benchmarks/memory.py`` (``--smoke``: 1 km only; ``--km 1 10 40``: the
lengths). Writes a synthetic track of each length (FRA class 5 geometry, the example's
stiffness field), runs ``trackdyn run`` on it (11-DOF model, 60 km/h, the default storage)
in a fresh process, and reports the wall time and the peak resident memory of that process
(``getrusage`` of the children), per km; then asks for 200 km, which the memory
estimate made before any allocation refuses on a machine with less than about 29 GB.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import synthetic_track

SCENARIO = """
[vehicle]
preset = "loaded"
[track]
geometry = "geometry.csv"
supports = "supports.csv"
[run]
model = "11dof"
speed_kmh = 60
"""


def run(folder: Path, km: float) -> tuple[float, float, int, str]:
    """``trackdyn run`` on ``km`` of track in ``folder``: wall time [s], the peak resident
    memory of the largest child so far [MB], the exit code and stderr's last line."""
    trk = synthetic_track(km * 1e3, spectrum="fra5", seed=7)
    write_geometry(trk.geometry, folder / "geometry.csv")
    write_supports(trk.supports, folder / "supports.csv")
    (folder / "run.toml").write_text(SCENARIO)
    clock = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "trackdyn", "-q", "run", str(folder / "run.toml"),
                           "--out", str(folder / "out"), "--overwrite"],
                          capture_output=True, text=True)  # fmt: skip
    took = time.perf_counter() - clock
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    last = (done.stderr.strip().splitlines() or [""])[-1]
    return took, peak, done.returncode, last


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="1 km only")
    parser.add_argument("--km", type=float, nargs="+", default=[1.0, 10.0])
    opts = parser.parse_args()
    lengths = [1.0] if opts.smoke else sorted(opts.km)
    with tempfile.TemporaryDirectory() as tmp:
        for km in lengths:  # increasing: the children's peak is the latest run's
            took, peak, code, last = run(Path(tmp), km)
            assert code == 0, last
            print(f"{km:6g} km: {took:6.1f} s, peak {peak:7.0f} MB ({peak / km:.0f} MB per km)")
        if not opts.smoke:
            took, _, code, last = run(Path(tmp), 200.0)
            print(f"   200 km: exit {code} in {took:.1f} s: {last}")


if __name__ == "__main__":
    main()
