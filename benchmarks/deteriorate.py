"""Speed of the deterioration loop with the rail beam in the loop: the built-in example.

Run with ``python benchmarks/deteriorate.py`` (``--smoke`` for a short check in CI: 2 MGT
instead of 50). Runs the built-in example scenario (1 km, loaded and empty coal wagons,
11-DOF model, tamped start) in this process and reports the wall time and its split into
vehicle runs, rail-beam solves (rest states, linearisation and rail-seat loads) and the
rest (bookkeeping), as the loop records it in the dataset's attributes.

``--laws`` runs it with each settlement law and reports each one's steps against the
power law's. ``--life`` runs the example's life: 300 MGT with the default maintenance
policy (`trackdyn.deterioration.maintenance`) and a 2 mm threshold, and reports the
tampings and intervals per segment.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from trackdyn.commands.deteriorate.scenario import MaintenanceSpec, load_deterioration
from trackdyn.commands.deteriorate.sections import section_tasks
from trackdyn.deterioration.runs import run_section
from trackdyn.deterioration.settlement import LAWS
from trackdyn.errors import Failure


def run(spec, base):
    """Wall time [s] and Dataset of the example under ``spec``."""
    task = dataclasses.replace(section_tasks(spec, base)[0], progress=False)
    clock = time.perf_counter()
    result = run_section(task)
    wall = time.perf_counter() - clock
    if isinstance(result, Failure):
        raise SystemExit(result.message)
    return wall, result


def report(label: str, wall: float, ds) -> None:
    a = ds.attrs
    print(f"{label}, {float(ds.mgt[-1]):g} MGT, {a['steps']} steps: {wall:.1f} s")
    for key, name in (("time_vehicle_runs_s", "vehicle runs"),
                      ("time_beam_solves_s", "beam solves"),
                      ("time_bookkeeping_s", "bookkeeping")):  # fmt: skip
        if key in a:
            print(f"  {name:14s} {a[key]:6.1f} s")


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="short run for CI")
    parser.add_argument("--laws", action="store_true", help="every settlement law")
    parser.add_argument("--life", action="store_true", help="300 MGT with maintenance")
    opts = parser.parse_args()
    spec, base = load_deterioration(None)
    loop = {"total_mgt": 2.0} if opts.smoke else {}
    if opts.life:
        loop = {"total_mgt": 10.0 if opts.smoke else 300.0, "threshold_sd_mm": 2.0,
                "max_steps": 5000}  # fmt: skip
        spec = spec.model_copy(update={"maintenance": MaintenanceSpec()})
    spec = spec.model_copy(update={"loop": spec.loop.model_copy(update=loop)})
    if not opts.laws:
        wall, ds = run(spec, base)
        report("example", wall, ds)
        if opts.life:
            seg, at = ds.intervention_segment.values, ds.intervention_mgt.values
            for j in range(ds.sizes["segment"]):
                mine = np.sort(at[seg == j])
                gaps = np.diff(mine)
                print(f"  {float(ds.segment_start[j]):6.1f}-{float(ds.segment_end[j]):6.1f} m: "
                      f"{mine.size} interventions, intervals "
                      f"{', '.join(f'{g:.1f}' for g in gaps) or '-'} MGT")  # fmt: skip
        return
    steps = {}
    for law in LAWS:
        settle = spec.settlement.model_copy(update={"law": law})
        wall, ds = run(spec.model_copy(update={"settlement": settle}), base)
        report(law, wall, ds)
        steps[law] = int(ds.attrs["steps"])
    for law, n in steps.items():
        print(f"{law:9s} {n:4d} steps, {n / steps['power']:.2f} x the power law's")


if __name__ == "__main__":
    main()
