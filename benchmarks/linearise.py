"""Speed of reading and linearising track data: the 1 km built-in example section.

Run with ``python benchmarks/linearise.py`` (``--smoke`` for a short check in CI). Reports
the time to read the example CSVs (after a first read that imports pandas), to linearise
all sleepers in one pass (`Track.linearise`) and to build the nonlinear load surface of
one rail (`load_surface`, eq 5.14); the baseline is `secant_linearisation` called curve
by curve, as `Track.linearise` did before, timed in the same process (with ``--smoke`` on
100 curves, scaled to all).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from trackdyn.data import load_track
from trackdyn.track.support import secant_linearisation
from trackdyn.track.track import load_surface

STATIC_LOAD = 127.53e3
"""Static wheel load of the loaded wagon [N]."""


def best_time(func, repeat: int) -> float:
    """Best wall time of ``func()`` over ``repeat`` calls [s]."""
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - t)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="short run for CI")
    opts = parser.parse_args()
    repeat = 1 if opts.smoke else 5
    track = load_track()  # first read imports the CSV reader
    t_read = best_time(load_track, repeat)
    curves = (*track.supports.left, *track.supports.right)
    baseline = curves[:100] if opts.smoke else curves  # smoke: 100 curves, scaled up
    print(f"read CSVs [s] {t_read:.3f} ({len(curves)} curves)")
    print(f"{'method':<8}{'linearise new ms':>18}{'per-curve loop ms':>19}{'ratio':>7}")
    for method in ("cubic", "pchip"):
        t_new = best_time(lambda m=method: track.linearise(STATIC_LOAD, method=m), repeat)
        t_old = best_time(
            lambda m=method: [secant_linearisation(c, STATIC_LOAD, method=m) for c in baseline],
            1,
        ) * (len(curves) / len(baseline))
        print(f"{method:<8}{t_new * 1e3:18.1f}{t_old * 1e3:19.0f}{t_old / t_new:7.0f}")
    grid = np.linspace(0.0, 6e-3, 96)
    t_surface = best_time(lambda: load_surface(track, "left", grid), repeat)
    print(f"load_surface, one rail, 96 deflections [ms] {t_surface * 1e3:.0f}")


if __name__ == "__main__":
    main()
