"""Wall time of an interventions study: the shipped example's five alternatives.

Run with ``python benchmarks/interventions.py`` (``--smoke``: 2 MGT instead of 50 and one
worker, for CI; ``--workers N``, default 2). Writes the example to a scratch folder, runs
``trackdyn study interventions.toml`` on a local Dask cluster of ``N`` workers in a fresh
process and reports its wall time, with the compared table (tampings, mean interval and
life-cycle cost per alternative).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="2 MGT on one worker, for CI")
    parser.add_argument("--workers", type=int, default=2, help="Dask workers (default 2)")
    opts = parser.parse_args()
    workers = 1 if opts.smoke else opts.workers
    trackdyn = [sys.executable, "-m", "trackdyn", "-q"]
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch) / "ex"
        subprocess.run([*trackdyn, "example", "interventions", "--to", str(folder)], check=True)
        if opts.smoke:
            scenario = folder / "maintained.toml"
            text = re.sub(r"(?m)^total_mgt = .*$", "total_mgt = 2", scenario.read_text())
            scenario.write_text(re.sub(r"(?m)^snapshot_every_mgt = .*$",
                                       "snapshot_every_mgt = 1", text))  # fmt: skip
        out = folder / "out"
        start = time.perf_counter()
        subprocess.run([*trackdyn, "study", str(folder / "interventions.toml"), "--out",
                        str(out), "--workers", str(workers)], check=True)  # fmt: skip
        took = time.perf_counter() - start
        table = pd.read_csv(out / "interventions_compared.csv")
    print(f"{len(table)} alternatives on {workers} worker(s): {took:.1f} s wall")
    columns = [
        "alternative",
        "tampings",
        "renewals",
        "mean_interval_mgt",
        "d1_sd_horizon_max_mm",
        "residual_cost_cu",
        "life_cycle_cost_cu",
    ]
    print(table[columns].to_string(index=False, float_format="%.1f"))


if __name__ == "__main__":
    main()
