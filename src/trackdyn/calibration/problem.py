"""Fit settlement-law parameters to repeated geometry surveys (`trackdyn calibrate`).

The calibration file is read by `trackdyn.commands.calibrate.spec`. Each later
survey is aligned to the first (`trackdyn.calibration.surveys`). The model runs from the
first survey (``[track] start``, default as surveyed: wavelengths under 3 m removed) over
the tonnage to each later one (its cycle count starts there: only tonnage differences
enter); each survey is aligned again to the profile predicted for it; the residuals are
the predicted minus the measured D1-band change per rail, every `RESIDUAL_SPACING` (about
independent samples of the band), leaving out `EDGE` at both ends and the ignored ranges.
They are minimised by `scipy.optimize.least_squares` (trust-region reflective, soft-L1
loss), in log space for parameters whose bounds are positive and as they are otherwise,
within the ``min`` and ``max`` of the parameter file
(`trackdyn.deterioration.law_files.law_bounds`). The Jacobian comes from forward
differences of `FD_STEP`; a point and its neighbours run as one batch through
`trackdyn.deterioration.runs.run_sections` (a few parameter sets per Dask task, stepped
together so that their vehicle runs share the solver's vector lanes). Standard
errors: ``σ² (JᵀJ)⁻¹`` at the solution, σ the robust (MAD) scale of the residuals, mapped
to the parameters by the delta method.

The settlement-rate field: uniform ballast (factor 1 at every rail seat) unless a field
is set (`Calibration.with_field`): `trackdyn.calibration.fit` estimates one per rail seat
(`trackdyn.calibration.field`) unless ``fit.rate_field = "uniform"``; the deterioration
model's random field (``rate_cov``, ``seed``) is never used.

References
----------
Branch, M.A., Coleman, T.F., Li, Y. (1999). A subspace, interior, and conjugate gradient
method for large-scale bound-constrained minimization problems. SIAM Journal on Scientific
Computing 21(1), 1-23.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from trackdyn.calibration.surveys import (
    MIN_OVERLAP,
    NOISE_FACTOR,
    REFINE,
    Alignment,
    align,
    change_and_noise,
    common_grid,
    d1_change,
    profiles_at,
    read_survey,
)
from trackdyn.data import check_coverage
from trackdyn.deterioration.law_files import law_bounds, law_file_table, law_units
from trackdyn.deterioration.loop import NO_TRAFFIC_LOAD, LoopOptions
from trackdyn.deterioration.runs import (
    TOGETHER,
    Section,
    SectionTask,
    run_group,
    run_sections,
)
from trackdyn.errors import TrackdynInputError
from trackdyn.io import read_supports
from trackdyn.track.quality import WAVEBANDS
from trackdyn.track.rails import rail_section
from trackdyn.track.track import Geometry, Track
from trackdyn.units import si_factor

RESIDUAL_SPACING = WAVEBANDS["D1"][0] / 2
"""Spacing of the residuals, half the shortest D1 wavelength [m]."""

EDGE = WAVEBANDS["D1"][1] / 2
"""Length left out at both ends, where the band-pass is less reliable [m]."""

NEED = 2 * WAVEBANDS["D1"][1] + 2 * EDGE
"""Shortest stretch the surveys and supports must share: twice the D1 band's longest
wavelength and the ends left out [m]."""

FD_STEP = 0.05
"""Forward-difference step of the Jacobian in fit coordinates (log or as is) [-]."""


@dataclass(frozen=True)
class Calibration:
    """A calibration ready to run: aligned surveys, measured changes, fit coordinates.

    Parameters
    ----------
    spec : CalibrationScenario
        The calibration as read (`trackdyn.commands.calibrate.spec`).
    base : Path
        Folder of the calibration file.
    section : Section
        First survey and supports files, the track the model runs on.
    traffic : tuple of Traffic
        Traffic of the period.
    law : SettlementLaw
        The law with its starting values.
    names : tuple of str
        Fitted parameters.
    log : ndarray
        Per fitted parameter: fitted in log space [bool].
    lower, upper : ndarray
        Bounds in fit coordinates.
    mgt : ndarray
        Tonnage of each survey after the first [MGT].
    alignments : tuple of Alignment
        Shift and correlation per survey against the first (the first: 0 and 1).
    grid : ndarray
        Indices of the first survey's distances compared.
    x : ndarray
        Those distances [m].
    geometries : tuple of Geometry
        The surveys as read.
    first : ndarray
        (2 rails, points) first survey's profiles on ``x`` [m].
    valid : ndarray
        Points not near the ends or in an ignored range [bool].
    use : ndarray
        Points of the residuals, ``valid`` every `RESIDUAL_SPACING` [bool].
    fitted : ndarray
        Per survey: its change is fitted (not the first, not a check) [bool].
    units : tuple of (str, float)
        Per fitted parameter: its unit in the parameter file and that unit in SI.
    options : LoopOptions
        Loop options to the last survey; ``fit_options`` to the last fitted one.
    position : ndarray
        Sleeper positions of the supports file [m].
    stiffness : ndarray
        (2 rails, sleepers) support stiffness per rail seat, the first survey linearised
        about the heaviest static wheel load of the traffic (as the loop's rail beam) [N/m].
    EI : float
        Bending stiffness of the rail [N m^2].
    """

    spec: Any  # a CalibrationScenario: the command layer's model, not imported here
    base: Path
    section: Section
    traffic: tuple
    law: object
    names: tuple
    log: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    mgt: np.ndarray
    alignments: tuple
    grid: np.ndarray
    x: np.ndarray
    geometries: tuple
    first: np.ndarray
    valid: np.ndarray
    use: np.ndarray
    fitted: np.ndarray
    units: tuple
    options: LoopOptions
    fit_options: LoopOptions
    position: np.ndarray
    stiffness: np.ndarray
    EI: float

    def with_field(self, factor) -> Calibration:
        """This calibration run on the settlement-rate ``factor`` (2, sleepers) [-]."""
        given = {"rate_factor": tuple(tuple(float(f) for f in row) for row in factor)}
        options = self.options.model_copy(update=given)
        fit_options = self.fit_options.model_copy(update=given)
        return dataclasses.replace(self, options=options, fit_options=fit_options)

    @property
    def fitted_extent(self) -> tuple[float, float]:
        """First and last compared distance [m]."""
        x = self.x[self.valid]
        return float(x[0]), float(x[-1])

    def law_at(self, theta):
        """The law with the fitted parameters at fit coordinates ``theta``."""
        values = np.where(self.log, np.exp(theta), theta)
        return dataclasses.replace(self.law, **dict(zip(self.names, values, strict=True)))

    def shown(self, values) -> str:
        """Fitted parameters' ``values`` [SI units] in the parameter file's units."""
        return ", ".join(f"{n} = {v / f:.4g}{'' if u == '-' else ' ' + u}" for n, v, (u, f)
                         in zip(self.names, values, self.units, strict=True))  # fmt: skip

    def start(self) -> np.ndarray:
        """Fit coordinates of the starting values."""
        values = np.array([getattr(self.law, n) for n in self.names])
        return np.where(self.log, np.log(np.abs(values)), values)


def _fit_coordinates(spec, base: Path, law):
    """Fitted names, log flags and bounds in fit coordinates; refuses unknown names,
    missing bounds and starting values outside them."""
    s = spec.settlement
    file = None if s.file is None else base / s.file
    known = law_units(s.law)
    bounds = law_bounds(s.law, file)
    table = law_file_table(s.law, file)
    where = s.file or "settlement.toml (shipped)"
    log, lower, upper, units = [], [], [], []
    for name in spec.fit.parameters:
        if name not in known:
            raise TrackdynInputError(
                f"fit.parameters: {name!r} is not a parameter of the {s.law} law "
                f"({', '.join(known)})"
            )
        if name not in bounds:
            raise TrackdynInputError(f"{where}: [{s.law}] {name} needs min and max to be fitted")
        lo, hi = bounds[name]
        value = getattr(law, name)
        if not lo <= value <= hi:
            raise TrackdynInputError(
                f"{where}: [{s.law}] {name} = {value:g} (SI) is outside its min and max"
            )
        positive = lo > 0
        unit = table[name]["unit"]
        units.append((unit, si_factor(unit, known[name])))
        log.append(positive)
        lower.append(np.log(lo) if positive else lo)
        upper.append(np.log(hi) if positive else hi)
    names = tuple(spec.fit.parameters)
    return names, np.array(log), np.array(lower), np.array(upper), tuple(units)


def _check_lengths(spec, geometries) -> None:
    """Refuse a survey shorter than `NEED` and a ``fit.max_shift_m`` beyond which no shift
    leaves `MIN_OVERLAP` of the first survey in common."""
    for i, (s, g) in enumerate(zip(spec.survey, geometries, strict=True)):
        x = g.distance
        if x[-1] - x[0] < NEED:
            raise TrackdynInputError(
                f"survey {i + 1} ({s.geometry}): covers {x[0]:g}-{x[-1]:g} m "
                f"({x[-1] - x[0]:g} m); the fit needs {NEED:g} m of surveys in common"
            )
    x = geometries[0].distance
    most = (1 - MIN_OVERLAP) * (x[-1] - x[0])
    if spec.fit.max_shift_m > most:
        raise TrackdynInputError(
            f"fit.max_shift_m = {spec.fit.max_shift_m:g} m is beyond {most:g} m, "
            f"{1 - MIN_OVERLAP:g} of the first survey's {x[-1] - x[0]:g} m "
            f"({spec.survey[0].geometry}): a survey shifted further shares less than "
            f"{MIN_OVERLAP:g} of it"
        )


def _check_change(spec, k: int, change, x, valid) -> None:
    """Refuse fitted survey ``k`` when its D1-band ``change`` from the first survey (2
    rails, points on ``x``) is not above `NOISE_FACTOR` times what its measurement noise
    alone gives there: nothing to fit (the same survey twice, too little traffic)."""
    rms, noise = change_and_noise(x, change, valid)
    if rms <= NOISE_FACTOR * noise:
        first, later = spec.survey[0], spec.survey[k]
        raise TrackdynInputError(
            f"survey {k + 1} ({later.geometry}) at {later.mgt:g} MGT: its D1-band change "
            f"from survey 1 ({first.geometry}) at {first.mgt:g} MGT is {rms * 1e3:.3g} mm "
            f"RMS, not above {NOISE_FACTOR:g} x its measurement noise in the band "
            f"({noise * 1e3:.3g} mm, from the sample-to-sample scatter): nothing to fit "
            "(the same survey twice?)"
        )


def prepare(spec, base: Path, traffic, law, options) -> Calibration:
    """Check the calibration, read and align the surveys, take the measured changes.

    Everything is refused here, before any model run.

    Parameters
    ----------
    spec : CalibrationScenario
        The calibration (`trackdyn.commands.calibrate.spec`).
    base : Path
        Folder that relative paths in it start from.
    traffic : sequence of Traffic
        Traffic of the period.
    law : SettlementLaw
        The law with its starting values.
    options : LoopOptions
        Loop options of the file; the tonnages and snapshots are set from the surveys.
    """
    names, log, lower, upper, units = _fit_coordinates(spec, base, law)
    files = [base / s.geometry for s in spec.survey]
    geometries = [read_survey(f) for f in files]
    _check_lengths(spec, geometries)
    supports_file = base / spec.track.supports
    supports = read_supports(supports_file)
    check_coverage(Track(geometries[0], supports), supports_file)
    extent = Track(geometries[0], supports).extent
    alignments: list[Alignment] = []
    for i, (g, file) in enumerate(zip(geometries, files, strict=True)):
        a = align(geometries[0], g, spec.fit.max_shift_m)
        if a.correlation < spec.fit.min_correlation:
            raise TrackdynInputError(
                f"survey {i + 1} ({file}): D1 profile correlates {a.correlation:.2f} with the "
                f"first survey's at its best shift ({a.shift:+.2f} m within "
                f"±{spec.fit.max_shift_m:g} m), below fit.min_correlation = "
                f"{spec.fit.min_correlation:g}: not the same section?"
            )
        alignments.append(a)
    shifts = [a.shift for a in alignments]
    grid = common_grid(geometries[0], geometries, shifts, extent, REFINE)
    x = geometries[0].distance[grid]
    if grid.size < 3 or x[-1] - x[0] < NEED:
        raise TrackdynInputError(
            f"{spec.track.supports}: the aligned surveys and the supports overlap over "
            f"{(x[-1] - x[0]) if grid.size else 0:g} m; the fit needs {NEED:g} m"
        )
    valid = (x >= x[0] + EDGE) & (x <= x[-1] - EDGE)
    for lo, hi in spec.fit.ignore_m:
        valid &= (x < lo) | (x > hi)
    stride = max(1, int(round(RESIDUAL_SPACING / float(np.median(np.diff(x))))))
    use = valid & (np.arange(x.size) % stride == 0)
    if not use.any():
        raise TrackdynInputError("fit.ignore_m: leaves no distance to compare the surveys on")
    mgt = np.array([s.mgt - spec.survey[0].mgt for s in spec.survey])
    fitted = np.array([i > 0 and not s.check for i, s in enumerate(spec.survey)])
    first = profiles_at(geometries[0], 0.0, x)
    for k in np.flatnonzero(fitted).tolist():
        change = profiles_at(geometries[k], alignments[k].shift, x) - first
        _check_change(spec, k, change, x, valid)
    options = options.model_copy(update={
        "rate_cov": 0.0,
        "rate_factor": None,
        "total_mgt": float(mgt[-1]),
        "snapshot_every_mgt": float(mgt[-1]),
        "snapshot_mgt": tuple(float(m) for m in mgt[1:]),
    })  # fmt: skip
    fit_options = options.model_copy(update={"total_mgt": float(mgt[fitted].max())})
    section = Section("calibration", str(files[0].resolve()), str(supports_file.resolve()))
    EI = rail_section(options.rail).EI
    heaviest = max((t.vehicle.static_wheel_load for t in traffic), default=NO_TRAFFIC_LOAD)
    lin = Track(geometries[0], supports).linearise(heaviest, options.run.delta,
                                                   extrapolate=options.run.extrapolate)  # fmt: skip
    return Calibration(spec, base, section, tuple(traffic), law, names, log, lower, upper, mgt,
                   tuple(alignments), grid, x, tuple(geometries), first, valid, use, fitted,
                   units, options, fit_options, supports.position,
                   lin.support_stiffness(EI), EI)  # fmt: skip


def run_laws(problem: Calibration, laws, options, *, workers=None, scheduler=None,
             keep_failures: bool = False) -> list:  # fmt: skip
    """One deterioration run per law on the first survey, as one batch of Dask tasks.

    Parameters
    ----------
    problem : Calibration
        The calibration.
    laws : sequence of SettlementLaw
        Parameter sets to run.
    options : LoopOptions
        Loop options (``problem.options`` or ``problem.fit_options``).
    workers : int, optional
        Worker processes (default one per core; 1 runs in this process).
    scheduler : str, optional
        Address of a running Dask scheduler.
    keep_failures : bool
        Return a failed run's `Failure` in its place instead of raising.
    """
    tasks = [SectionTask(problem.section, problem.traffic, law, options) for law in laws]
    if not keep_failures:
        return run_sections(tasks, workers=workers, scheduler=scheduler)
    from trackdyn.parallel import run_tasks

    return run_tasks(tasks, run_group, workers=workers, scheduler=scheduler, label="runs",
                     together=TOGETHER)  # fmt: skip


@dataclass(frozen=True)
class Comparison:
    """Measured and predicted D1-band change since the first survey, per survey.

    Parameters
    ----------
    measured, predicted : ndarray
        (surveys, 2 rails, points) change on ``Calibration.x`` [m]; NaN for surveys beyond
        the run's tonnage.
    alignments : tuple of Alignment
        Per survey: shift and correlation against the predicted profile (beyond the run,
        and for the first survey: those against the first survey).
    """

    measured: np.ndarray
    predicted: np.ndarray
    alignments: tuple


def compare(problem: Calibration, ds) -> Comparison:
    """Each survey aligned to the profile a run predicts for its tonnage, and the changes.

    Parameters
    ----------
    problem : Calibration
        The calibration.
    ds : xarray.Dataset
        A run of `run_laws`.
    """
    snaps = ds.snapshot_mgt.values
    distance = ds.distance.values
    measured = np.full((problem.mgt.size, *problem.first.shape), np.nan)
    predicted = measured.copy()
    alignments = list(problem.alignments)
    x, first = problem.x, problem.first
    for k, m in enumerate(problem.mgt):
        at = np.flatnonzero(np.isclose(snaps, m, rtol=1e-9, atol=1e-12))
        if not at.size:
            continue
        profile = ds.profile.values[at[0]]
        if k:
            model = Geometry(distance, profile[0], profile[1], "prediction")
            alignments[k] = align(model, problem.geometries[k], REFINE, problem.alignments[k].shift)
        z = profiles_at(problem.geometries[k], alignments[k].shift, x)
        measured[k] = d1_change(x, z - first)
        predicted[k] = d1_change(x, (profile - ds.profile.values[0])[:, problem.grid])
    return Comparison(measured, predicted, tuple(alignments))


def residuals(problem: Calibration, comparison: Comparison) -> np.ndarray:
    """Predicted minus measured D1-band change of the fitted surveys at the residual
    points, both rails [mm].

    Parameters
    ----------
    problem : Calibration
        The calibration.
    comparison : Comparison
        `compare` of a run.
    """
    diff = (comparison.predicted - comparison.measured)[problem.fitted][:, :, problem.use]
    return diff.ravel() * 1e3


def synthetic_surveys(track, traffic, law, options, mgt, *, noise=0.3e-3, offset=2.7, seed=0):
    """Surveys made by the model itself: for testing a calibration on known parameters.

    The model runs from ``track`` with ``law`` and the profiles at the tonnages ``mgt`` get
    white measurement noise; every survey but the first is offset in distance.

    Parameters
    ----------
    track : Track
        The true section.
    traffic : sequence of Traffic
        The traffic.
    law : SettlementLaw
        The true law.
    options : LoopOptions
        Loop options; ``total_mgt`` and the snapshots are set from ``mgt``.
    mgt : sequence of float
        Survey tonnages, the first 0, increasing [MGT].
    noise : float
        Standard deviation of the measurement noise [m].
    offset : float
        Distance offset of the later surveys: their distances read ``offset`` less [m].
    seed : int
        Seed of the noise.

    Returns
    -------
    list of Geometry
    """
    from trackdyn.deterioration.loop import predict

    o = options.model_copy(update={"total_mgt": float(mgt[-1]),
                                   "snapshot_every_mgt": float(mgt[-1]),
                                   "snapshot_mgt": tuple(float(m) for m in mgt[1:])})  # fmt: skip
    ds = predict(track, traffic, law, o)
    rng = np.random.default_rng(seed)
    x = track.geometry.distance
    surveys = []
    for k, m in enumerate(mgt):
        at = int(np.argmin(np.abs(ds.snapshot_mgt.values - m)))
        z = ds.profile.values[at] + rng.normal(0.0, noise, (2, x.size))
        surveys.append(Geometry(x - (offset if k else 0.0), z[0], z[1], f"survey at {m:g} MGT"))
    return surveys
