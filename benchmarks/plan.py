"""A maintenance plan for a line: the deterministic run, the plan, and the run that follows
it, each timed.

Run with ``python benchmarks/plan.py`` (``--smoke``: 2 sections of 300 m over 2 years, one
worker; ``--km N``: the line's length, default 100). Writes N synthetic 1 km sections (FRA
class 5 geometry, different seeds, the example's stiffness field) and a sections CSV into
a temporary folder, and plans 10 years of 10 MGT with the built-in example's traffic and
law (4-DOF model, tamped start, 200 m segments, threshold 2 mm) on 2 workers: stretches of
at least 200 m, gaps of 100 m bridged, at most 5 % of the line (and 200 m) a year. Reports the wall
time of each phase, the stretches planned and deferred.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from pathlib import Path

from trackdyn.commands.deteriorate.plan import followed_tasks, needs_of, rules_of
from trackdyn.commands.deteriorate.scenario import load_deterioration
from trackdyn.commands.deteriorate.sections import section_tasks
from trackdyn.deterioration.planning import make_plan
from trackdyn.deterioration.runs import run_sections

sys.path.insert(0, str(Path(__file__).parent))
from line import write_line  # noqa: E402 - the line benchmark's sections

SCENARIO = """
[run]
model = "4dof"
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
segment_length_m = 200
threshold_sd_mm = 2.0
[maintenance]
horizon_years = {years}
annual_mgt = 10
[plan]
min_stretch_m = 200
bridge_gap_m = 100
cap_m_per_year = {cap}
[track]
sections = "sections.csv"
start = "tamped"
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="2 sections of 300 m, 2 years")
    parser.add_argument("--km", type=int, default=100, help="length of the line [km]")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    opts = parser.parse_args()
    n, length, years = (2, 300.0, 2) if opts.smoke else (opts.km, 1000.0, 10)
    workers = 1 if opts.smoke else opts.workers
    with tempfile.TemporaryDirectory() as tmp:
        write_line(Path(tmp), n, length)
        cap = max(0.05 * n * length, 200.0)
        (Path(tmp) / "plan.toml").write_text(SCENARIO.format(years=years, cap=cap))
        spec, base = load_deterioration(Path(tmp) / "plan.toml")
        tasks = [dataclasses.replace(t, progress=False) for t in section_tasks(spec, base)]
        clock = time.perf_counter()
        datasets = run_sections(tasks, workers=workers)
        run_s = time.perf_counter() - clock
        clock = time.perf_counter()
        rules = rules_of(spec)
        lines = needs_of(datasets, rules)
        plan = make_plan(lines, rules)
        plan_s = time.perf_counter() - clock
        clock = time.perf_counter()
        run_sections(followed_tasks(tasks, plan, lines, rules), workers=workers)
        followed_s = time.perf_counter() - clock
    km = n * length / 1e3
    print(f"{km:g} km as {n} sections, {years} years of 10 MGT, {workers} worker(s)")
    print(f"  deterministic run {run_s:7.1f} s; plan {plan_s:6.2f} s "
          f"({len(plan.stretches)} stretches, {len(plan.deferred)} deferred); "
          f"the run that follows it {followed_s:7.1f} s")  # fmt: skip


if __name__ == "__main__":
    main()
