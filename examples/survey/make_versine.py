"""Make the recording-car file shipped with the survey example: the built-in section's
profile as an asymmetric-chord car measures it.

The car ran towards decreasing chainage (rows from 1.000 km down, in km) with its chord
2.5 m behind and 7.5 m ahead of the measuring point; the versine is rounded to 0.01 mm,
and 1 m of rows at 0.600 km is missing where it lost its reference. In increasing
chainage the car's chord lies 7.5 m behind and 2.5 m ahead, so its versine is that
chord's (`trackdyn.track.chord.Chord`). ``trackdyn example survey --to DIR`` writes it out
with the example's supports and a run scenario:

    python examples/survey/make_versine.py     # remakes the shipped file
    trackdyn example survey --to survey
    trackdyn run survey/survey.toml --out survey-out
"""

from pathlib import Path

import numpy as np
import pandas as pd

from trackdyn.data import EXAMPLE_GEOMETRY, example_path
from trackdyn.io import read_geometry
from trackdyn.track.chord import Chord

HERE = Path(__file__).parents[2] / "src" / "trackdyn" / "examples" / "survey"


def main() -> None:
    geometry = read_geometry(example_path(EXAMPLE_GEOMETRY))
    x = geometry.distance
    seen = Chord(7.5, 2.5)  # the car's 2.5 m back, 7.5 m front, turned to increasing x
    versine = {r: seen.versine(x, geometry.profile(r)) for r in ("left", "right")}
    keep = np.isfinite(versine["left"]) & ~((x > 600.0) & (x < 601.0))
    frame = pd.DataFrame(
        {
            "chainage_km": x[keep] / 1e3,
            "left_mm": np.round(versine["left"][keep] * 1e3, 2),
            "right_mm": np.round(versine["right"][keep] * 1e3, 2),
        }
    ).iloc[::-1]
    frame.to_csv(HERE / "versine.csv", index=False, float_format="%.5f")


if __name__ == "__main__":
    main()
