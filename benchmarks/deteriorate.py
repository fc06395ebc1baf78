"""Speed of the deterioration loop with the rail beam in the loop: the built-in example.

Run with ``python benchmarks/deteriorate.py`` (``--smoke`` for a short check in CI: 2 MGT
instead of 50). Runs the built-in example scenario (1 km, loaded and empty coal wagons,
11-DOF model, tamped start) in this process and reports the wall time and its split into
vehicle runs, rail-beam solves (rest states, linearisation and rail-seat loads) and the
rest (bookkeeping), as the loop records it in the dataset's attributes.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

from trackdyn.commands.deteriorate.scenario import load_deterioration
from trackdyn.commands.deteriorate.sections import section_tasks
from trackdyn.deterioration.runs import run_section


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="short run for CI")
    opts = parser.parse_args()
    spec, base = load_deterioration(None)
    if opts.smoke:
        spec = spec.model_copy(update={"loop": spec.loop.model_copy(update={"total_mgt": 2.0})})
    task = section_tasks(spec, base)[0]
    task = dataclasses.replace(task, progress=False)
    clock = time.perf_counter()
    result = run_section(task)
    wall = time.perf_counter() - clock
    if "error" in result:
        raise SystemExit(result["error"])
    a = result["dataset"].attrs
    print(f"example, {spec.loop.total_mgt:g} MGT, {a['steps']} steps: {wall:.1f} s")
    for key, label in (("time_vehicle_runs_s", "vehicle runs"),
                       ("time_beam_solves_s", "beam solves"),
                       ("time_bookkeeping_s", "bookkeeping")):  # fmt: skip
        print(f"  {label:14s} {a[key]:6.1f} s")


if __name__ == "__main__":
    main()
