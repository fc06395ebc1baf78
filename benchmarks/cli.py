"""Start-up time of the command line: ``trackdyn --version`` and ``trackdyn --help``.

Run with ``python benchmarks/cli.py`` (``--smoke``: one try each, for CI). Each is timed
in a fresh process, best of 7, against a bare ``python -c pass`` on the same machine: the
difference is what trackdyn adds to the interpreter's own start.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time


def best_of(args: list[str], tries: int) -> float:
    """Shortest wall time of ``tries`` runs of ``args`` [s]."""
    times = []
    for _ in range(tries):
        start = time.perf_counter()
        subprocess.run(args, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="one try each")
    tries = 1 if parser.parse_args().smoke else 7
    bare = best_of([sys.executable, "-c", "pass"], tries)
    print(f"python -c pass: {bare:.3f} s")
    for option in ("--version", "--help"):
        took = best_of([sys.executable, "-m", "trackdyn", option], tries)
        print(f"trackdyn {option}: {took:.3f} s ({took - bare:+.3f} s over the interpreter)")


if __name__ == "__main__":
    main()
