"""Settlement at an embankment-to-bridge transition, per settlement law: steps, wall time,
and what a track engineer looks at (the deck against the embankment, the approach dip and
the step at the abutment).

Run with ``python benchmarks/transition.py`` (``--smoke`` for a short check in CI: 2 MGT,
7-DOF model). The track: 200 m of level track on uniform linear supports, 60 kN/mm per
wheel on the embankment and 240 kN/mm on a deck from 120 to 180 m; zones: approach
110-120 m, structure 120-180 m, open track elsewhere, with the shipped (illustrative)
parameters of each kind. Traffic: loaded and empty coal wagons at 60 km/h, 8065 passages
per MGT each; uniform ballast (no rate field); left rail reported.

- far: mean settlement of the embankment 40-90 m [mm]
- deck: mean settlement of the deck 125-175 m [mm]
- dip: deepest settlement within 20 m before the deck minus ``far`` [mm], and where
- step: mean settlement of the last 3 m before the deck minus the first 3 m on it [mm]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from trackdyn.deterioration import LAWS, LoopOptions, Traffic, Zone, load_law, predict
from trackdyn.options import RunOptions
from trackdyn.track.synthetic import Transition, synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

DECK = (120.0, 180.0)


def transition_track():
    """The 200 m section: 60 kN/mm embankment, 240 kN/mm deck over `DECK`."""
    deck = Transition(DECK[0], DECK[1] - DECK[0], 4.0)
    return synthetic_track(200.0, spectrum=None, stiffness=60e6, stiffness_cov=0.0, gap=0.0,
                           seed=1, features=(deck,))  # fmt: skip


def zones(name: str) -> list[Zone]:
    """Approach (10 m) and structure zones with the shipped parameters of ``name``."""
    return [Zone(DECK[0] - 10.0, DECK[0], "approach", load_law(name, kind="approach")),
            Zone(*DECK, "structure", load_law(name, kind="structure"))]  # fmt: skip


def measures(ds, mgt: float) -> dict:
    """far, deck, dip [mm], dip distance before the deck [m] and step [mm] at ``mgt``."""
    x = ds.sleeper_distance.values
    e = ds.settlement.sel(mgt=mgt).isel(rail=0).values * 1e3
    far = e[(x > 40) & (x < 90)].mean()
    soft = (x > DECK[0] - 20) & (x < DECK[0])
    k = int(np.argmax(e[soft]))
    return {
        "far": far,
        "deck": e[(x > DECK[0] + 5) & (x < DECK[1] - 5)].mean(),
        "dip": e[soft][k] - far,
        "dip_at": DECK[0] - x[soft][k],
        "step": e[(x > DECK[0] - 3) & (x < DECK[0])].mean()
        - e[(x > DECK[0]) & (x < DECK[0] + 3)].mean(),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="short run for CI")
    opts = parser.parse_args()
    total, model = (2.0, "7dof") if opts.smoke else (50.0, "11dof")
    marks = [m for m in (10.0, 50.0) if m <= total] or [total]
    traffic = [Traffic(load_vehicle(v), 60.0, 8065.0, v) for v in ("loaded", "empty")]
    track = transition_track()
    options = LoopOptions(run=RunOptions(model=model), rate_cov=0.0, total_mgt=total,
                          snapshot_every_mgt=10.0, segment_length_m=100.0)  # fmt: skip
    print(f"transition 60 -> 240 kN/mm, {model}, {total:g} MGT (settlement in mm)")
    for name in LAWS:
        clock = time.perf_counter()
        ds = predict(track, traffic, load_law(name), options, zones=zones(name))
        wall = time.perf_counter() - clock
        print(f"{name:9s} {ds.steps:4d} steps {wall:6.1f} s")
        for m in marks:
            r = measures(ds, m)
            print(f"    {m:4g} MGT: embankment {r['far']:5.2f}, deck {r['deck']:5.2f}, "
                  f"dip {r['dip']:5.2f} at {r['dip_at']:.1f} m before the deck, "
                  f"step {r['step']:5.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
