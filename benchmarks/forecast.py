"""Honest intervals: the forecast's 10-90 % interval of each segment's first tamping against
truths the model makes itself; and the ensemble's speed.

Run with ``python benchmarks/forecast.py`` (``--smoke``: 2 truths for CI; ``--truths N``).
Each truth: a 200 m section (the German high-level spectrum, D1 SD about 1.5 mm, geometry
seed = the truth's number), the power law at K_s = 0.8 mm and exponent 2.5, a settlement-
rate field of cov 0.3 over 3 m (its own seed), the 4-DOF model, loaded and empty coal
wagons. Surveys at 0, 2 and 5 MGT (0.3 mm noise, a 2.7 m offset) are calibrated as
``trackdyn calibrate`` does (K_s and the exponent with the rate field), and the section is
forecast from the first survey to `HORIZON_MGT` with `MEMBERS` members drawn from the
calibration's posterior (``posterior.toml``), each on a draw of its rate field's posterior
(``rate_field_draws.csv``). The truth's first tamping of each 100 m segment (its D1 SD reaching
`THRESHOLD_MM` on either rail, the true law and field) is inside or outside the members'
p10-p90; the coverage is the share inside over all segments of all truths (an honest 80 %
interval holds 0.65-0.95 of them), with the mean width of the finite intervals.

``--speed`` instead runs 32 members of the built-in example's life (300 MGT, tamping at 2
mm) on one core against the deterministic life, and reports members per core-second.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from trackdyn.calibration.problem import synthetic_surveys
from trackdyn.cli import app
from trackdyn.deterioration import LoopOptions, Traffic, load_law
from trackdyn.deterioration.ballast import read_field_draws
from trackdyn.deterioration.loop import predict
from trackdyn.deterioration.runs import Section, SectionTask
from trackdyn.forecast.ensemble import run_ensemble
from trackdyn.forecast.spread import Lognormal, read_posterior, sample_members
from trackdyn.forecast.summary import coverage, first_tamping
from trackdyn.io import write_geometry, write_supports
from trackdyn.options import RunOptions
from trackdyn.track.synthetic import synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

TRUE = {"K_s": 0.8e-3, "load_exponent": 2.5}  # [SI]
SURVEYS_MGT = (0.0, 2.0, 5.0)
HORIZON_MGT = 30.0
THRESHOLD_MM = 3.3
MEMBERS = 16
TRAFFIC = [Traffic(load_vehicle(v), 60.0, 8065.0, v) for v in ("loaded", "empty")]


def options(seed) -> LoopOptions:
    """The loop of every truth, calibration and member."""
    return LoopOptions(run=RunOptions(model="4dof"), rate_cov=0.3, seed=seed,
                       segment_length_m=100.0, max_step_settlement_mm=2.0,
                       threshold_sd_mm=THRESHOLD_MM, total_mgt=HORIZON_MGT,
                       start="as surveyed")  # fmt: skip


def calibration_toml() -> str:
    """The calibration file of a truth's surveys (as `tests/calibration`)."""
    wagons = "".join(f'[[traffic]]\nvehicle = "{v}"\nspeed_kmh = 60\npassages_per_mgt = 8065\n'
                     for v in ("loaded", "empty"))  # fmt: skip
    surveys = "".join(f'[[survey]]\ngeometry = "survey_{k + 1}.csv"\nmgt = {m}\n'
                      for k, m in enumerate(SURVEYS_MGT))  # fmt: skip
    return ('[run]\nmodel = "4dof"\n' + wagons + '[settlement]\nlaw = "power"\n'
            + "[loop]\nmax_step_settlement_mm = 2\nsegment_length_m = 100\n"
            + '[track]\nsupports = "supports.csv"\n' + surveys
            + '[fit]\nparameters = ["K_s", "load_exponent"]\nmin_correlation = 0.5\n')  # fmt: skip


def one_truth(k: int, folder: Path):
    """Truth ``k``: its first tampings and the forecast's p10, p90 per segment [MGT]."""
    trk = synthetic_track(200.0, spectrum="german_high", seed=100 + k)
    law = load_law("power", **TRUE)
    truth = options(200 + k)
    for j, survey in enumerate(synthetic_surveys(trk, TRAFFIC, law, truth, SURVEYS_MGT,
                                                 seed=300 + k)):  # fmt: skip
        write_geometry(survey, folder / f"survey_{j + 1}.csv")
    write_supports(trk.supports, folder / "supports.csv")
    write_geometry(trk.geometry, folder / "geometry.csv")
    (folder / "calibration.toml").write_text(calibration_toml())
    out = folder / "out"
    result = CliRunner().invoke(app, ["-q", "calibrate", str(folder / "calibration.toml"),
                                      "--out", str(out), "--workers", "1",
                                      "--allow-not-converged"])  # fmt: skip
    if result.exit_code != 0:
        raise SystemExit(f"truth {k}: calibration failed: {result.output}")
    first_true = first_tamping(predict(trk, TRAFFIC, law, truth))
    fitted = load_law("power", out / "settlement_fitted.toml")
    fields = read_field_draws(out / "rate_field_draws.csv", trk.supports.position)
    section = Section(f"truth {k}", str(folder / "survey_1.csv"), str(folder / "supports.csv"))
    task = SectionTask(section, tuple(TRAFFIC), fitted, truth)
    posterior = read_posterior(out / "posterior.toml", "power")
    members = sample_members(MEMBERS, k, fitted, posterior=posterior, fields=fields)
    (ensemble,) = run_ensemble([task], members, workers=1)
    first = np.array([first_tamping(ds) for ds in ensemble])
    low, high = (np.quantile(first, q, axis=0, method="inverted_cdf") for q in (0.1, 0.9))
    return first_true, low, high


def honest(truths: int) -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(truths):
            clock = time.perf_counter()
            folder = Path(tmp) / f"truth{k}"
            folder.mkdir()
            truth, low, high = one_truth(k, folder)
            rows.append((truth, low, high))
            shown = ", ".join(f"{t:.3g} in [{a:.3g}, {b:.3g}]" for t, a, b in
                              zip(truth, low, high, strict=True))  # fmt: skip
            print(f"truth {k}: first tamping [MGT] {shown} ({time.perf_counter() - clock:.0f} s)")
    truth, low, high = (np.concatenate(x) for x in zip(*rows, strict=True))
    with np.errstate(invalid="ignore"):  # inf - inf: an interval beyond the horizon
        width = high - low
    finite = np.isfinite(width)
    seen = np.isfinite(truth)
    print(
        f"coverage of the segment-truths tamped within the horizon: "
        f"{coverage(truth[seen], low[seen], high[seen]):.2f} of {seen.sum()}"
    )
    print(
        f"coverage of the 10-90 % interval: {coverage(truth, low, high):.2f} of "
        f"{truth.size} segment-truths (honest: 0.65-0.95); mean width "
        f"{np.mean(width[finite]) if finite.any() else np.inf:.3g} MGT over the "
        f"{finite.sum()} finite intervals"
    )


def speed(smoke: bool) -> None:
    from trackdyn.commands.deteriorate.scenario import MaintenanceSpec, load_deterioration
    from trackdyn.commands.deteriorate.sections import section_tasks
    from trackdyn.deterioration.runs import run_section

    spec, base = load_deterioration(None)
    total = 10.0 if smoke else 300.0
    loop = spec.loop.model_copy(update={"total_mgt": total, "threshold_sd_mm": 2.0})
    spec = spec.model_copy(update={"loop": loop, "maintenance": MaintenanceSpec()})
    task = dataclasses.replace(section_tasks(spec, base)[0], progress=False)
    clock = time.process_time()
    run_section(task)
    one = time.process_time() - clock
    count = 8 if smoke else 32
    members = sample_members(count, 0, task.law, spreads={"K_s": Lognormal(0.2)})
    clock = time.process_time()
    run_ensemble([task], members, workers=1)
    many = time.process_time() - clock
    print(
        f"the example's life, {total:g} MGT: deterministic {one:.1f} core-s; {count} "
        f"members {many:.1f} core-s = {many / one:.2f} deterministic lives "
        f"({count / many:.2f} members per core-s)"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--smoke", action="store_true", help="2 truths (CI)")
    parser.add_argument("--truths", type=int, default=10, help="truths to check")
    parser.add_argument("--speed", action="store_true", help="the ensemble's speed instead")
    opts = parser.parse_args()
    if opts.speed:
        speed(opts.smoke)
    else:
        honest(2 if opts.smoke else opts.truths)


if __name__ == "__main__":
    main()
