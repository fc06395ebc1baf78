"""Make the three synthetic surveys of a 200 m section shipped with the calibration example.

The surveys are made by the model itself with known parameters (power law, K_s = 0.8 mm,
load exponent 2.5) at 0, 2 and 5 MGT of the coal traffic, with 0.3 mm of measurement
noise and a 2.7 m distance offset of the later surveys, so `trackdyn calibrate` can be
seen to find those values again. The files are shipped in the package, next to the
example's calibration.toml; ``trackdyn example calibration --to DIR`` writes them out:

    python examples/calibration/make_surveys.py     # remakes the shipped files
    trackdyn example calibration --to cal
    trackdyn calibrate cal/calibration.toml --out calibration-out
"""

from pathlib import Path

from trackdyn.calibration.problem import synthetic_surveys
from trackdyn.deterioration import LoopOptions, Traffic, load_law
from trackdyn.io import write_geometry, write_supports
from trackdyn.options import RunOptions
from trackdyn.track.synthetic import SoftSpot, synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

HERE = Path(__file__).parents[2] / "src" / "trackdyn" / "examples" / "calibration"


def main() -> None:
    spot = SoftSpot(centre=100.0, length=8.0, factor=0.45, gap=1.5e-3)
    track = synthetic_track(200.0, spectrum="fra5", seed=3, features=(spot,))
    traffic = [Traffic(load_vehicle(v), 60.0, 8065.0, v) for v in ("loaded", "empty")]
    law = load_law("power", K_s=0.8e-3, load_exponent=2.5)
    options = LoopOptions(run=RunOptions(model="7dof"), rate_cov=0.0, segment_length_m=100.0,
                          max_step_settlement_mm=2.0, start="as surveyed")  # fmt: skip
    surveys = synthetic_surveys(track, traffic, law, options, (0.0, 2.0, 5.0), seed=7)
    write_supports(track.supports, HERE / "supports.csv")
    for k, survey in enumerate(surveys):
        write_geometry(survey, HERE / f"survey_{k + 1}.csv")
    print(f"wrote supports.csv and survey_1..3.csv to {HERE}")


if __name__ == "__main__":
    main()
