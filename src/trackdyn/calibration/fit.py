"""The least-squares fit of a calibration (`trackdyn.calibration.problem`).

With ``fit.rate_field = "estimate"`` (the default) each rail seat's settlement-rate factor
is fitted with the global parameters. Round 1 is the global fit on uniform ballast
(soft-L1 loss). Each later round estimates the field at the current values
(`trackdyn.calibration.field`: linearised about a run, strength by marginal likelihood),
runs on it, and fits the global parameters again with the field profiled out: every
evaluation's residual is a vector whose norm is a monotone function of the surveys'
marginal likelihood with the field integrated out and its strength and the noise at their
best (`FieldRound`; variable projection, Golub and Pereyra 2003), so that the parameters
are not held to a field estimated for others. Its Jacobian is taken once per round by
forward differences and then updated along each evaluated step by Broyden's rank-one
formula, at no further model runs (with the Jacobian held fixed instead, the fit stopped
short of the marginal likelihood's optimum along the ridge described below: on surveys
of a field of cov 0.3, seed 5, K_s +31 % and exponent -16 % off with 37 runs; +19 % and
-10 % with Broyden's update in 43; +16 % and -9 % with a new Jacobian at every step in 74;
seeds 6 and 8 end within 3 points of where they ended with the fixed Jacobian).
Rounds end when no fit coordinate moves by more than `ROUND_TOLERANCE`, when
a round ends with a marginal likelihood worse than the one before's by more than
`EVIDENCE_TOLERANCE` (which then stands: the rounds are not a descent method, each is
linearised about another field, and on surveys of a strong field they drift on past the
best), or after `FIELD_ROUNDS`. The standard errors of the global parameters come from the joint
problem of the parameters and the field at its strength (`_joint_covariance`).

Why not one least-squares problem over the parameters and the field (Gauss-Newton, the
prior as extra rows at the strength the marginal likelihood chose): the surveys see, to
first order, the settlement pattern ``K_s q^α (α δ + u)`` (``q`` the mean rail-seat load
over Q_ref, ``δ`` the load's pattern in ``ln``, ``u`` the field), so a smaller exponent with
a larger K_s and the field scaled by ``α`` fits them as well, and at a fixed strength the
prior penalty rewards the smaller field: that estimate slides down the ridge (measured on
surveys made with a field of cov 0.3: exponent 1.32 for 2.5). The marginal likelihood,
the field integrated out, has no such pull.

On more than one worker, every evaluation of the misfit at a point also runs its
forward-difference neighbours in the same batch of Dask tasks, so a Jacobian's ``n + 1``
model runs go to ``n + 1`` workers at once and the Jacobian at an accepted point costs no
further runs; in one process (``workers = 1``) the neighbours run only when the
optimiser asks for the Jacobian, so a rejected trial costs one run, not ``n + 1``.

References
----------
Golub, G., Pereyra, V. (2003). Separable nonlinear least squares: the variable projection
method and its applications. Inverse Problems 19(2), R1-R26.

Branch, M.A., Coleman, T.F., Li, Y. (1999). A subspace, interior, and conjugate gradient
method for large-scale bound-constrained minimization problems. SIAM Journal on Scientific
Computing 21(1), 1-23.

Broyden, C.G. (1965). A class of methods for solving nonlinear simultaneous equations.
Mathematics of Computation 19(92), 577-593.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from trackdyn.calibration.field import (
    FieldEstimate,
    Prior,
    band_matrix,
    estimate,
    evidence,
    joint_information,
    linearise,
    rail_transfer,
)
from trackdyn.calibration.problem import (
    FD_STEP,
    Calibration,
    Comparison,
    compare,
    residuals,
    run_laws,
)
from trackdyn.errors import Failure
from trackdyn.forecast.spread import Posterior

FAILED_RUN_MM = 100.0
"""Residual given to every comparison point of a trial whose run failed (settlement that
ran away past the plausible profile, too many steps) [mm]: the optimiser steps back."""

FIELD_ROUNDS = 6
"""Most rounds of field estimate and global fit, the first on uniform ballast included [-];
a fit whose last round still moved a parameter by more than `ROUND_TOLERANCE` is not
converged."""

ROUND_TOLERANCE = 0.01
"""A round whose global fit moves no fit coordinate by more than this is the last [-]
(1 % of a parameter fitted in log space)."""

EVIDENCE_TOLERANCE = 0.02
"""A round whose squared residual (the evidence, `FieldRound`) ends more than this
fraction above the round before's gives way to it [-]."""

MAD_SCALE = 1.4826
"""Median absolute deviation to standard deviation of a normal distribution [-]."""


class Objective:
    """Residuals and Jacobian of a calibration, model runs cached by point.

    A misfit evaluation runs the point's forward-difference neighbours with it, in one
    batch, when there is more than one worker; in one process they wait for `jac`.

    Parameters
    ----------
    problem : Calibration
        The calibration.
    workers : int, optional
        Worker processes of each batch (default one per core; 1 runs in this process).
    scheduler : str, optional
        Address of a running Dask scheduler.
    log : callable, optional
        Called with a one-line message after each batch (a failed trial run with
        ``detail=True``, `fit`).
    residual : callable, optional
        Residuals [mm] of a run (a Dataset); default `residuals` of its `compare`.
    chord : bool
        Take the Jacobian by forward differences once, then update it by Broyden's formula
        along each step between evaluated points: later evaluations run their point only.
    """

    def __init__(self, problem: Calibration, workers=None, scheduler=None, log=None,
                 residual=None, chord: bool = False):  # fmt: skip
        self.problem, self.workers, self.scheduler, self.log = problem, workers, scheduler, log
        self.residual = residual or (lambda ds: residuals(problem, compare(problem, ds)))
        self.chord = chord
        self.ahead = not chord and (workers != 1 or scheduler is not None)
        self.fixed: np.ndarray | None = None  # the chord method's Jacobian, updated
        self.anchor: tuple | None = None  # the point it was last updated at, its residuals
        self.cache: dict[tuple, np.ndarray] = {}
        self.datasets: dict[tuple, object] = {}  # runs of the points evaluated, not neighbours
        self.runs = 0

    def _steps(self, theta) -> np.ndarray:
        """Forward step per coordinate, backward where it would leave the bounds."""
        return np.where(theta + FD_STEP <= self.problem.upper, FD_STEP, -FD_STEP)

    def _batch(self, theta, neighbours: bool = True) -> None:
        """Run the point (and its neighbours) where not cached yet."""
        h = self._steps(theta)
        points = [theta] + [theta + h[i] * np.eye(theta.size)[i] for i in range(theta.size)]
        points = points if neighbours else points[:1]
        for p in points:
            if _key(p) not in self.cache and _key(p) in self.datasets:  # run, not compared
                self.cache[_key(p)] = self.residual(self.datasets[_key(p)])
        todo = [p for p in points if _key(p) not in self.cache]
        if not todo:
            return
        laws = [self.problem.law_at(p) for p in todo]
        runs = run_laws(self.problem, laws, self.problem.fit_options, workers=self.workers,
                        scheduler=self.scheduler, keep_failures=True)  # fmt: skip
        if self.runs == 0 and isinstance(runs[0], Failure):
            raise runs[0].named("the run at the starting values failed").error()
        failed = []
        for p, ds in zip(todo, runs, strict=True):
            if isinstance(ds, Failure):
                failed.append((p, ds))
            else:
                self.cache[_key(p)] = self.residual(ds)
                if p is theta:
                    self.datasets[_key(p)] = ds
        for p, ds in failed:  # trials the optimiser must step back from
            size = next(iter(self.cache.values())).size
            self.cache[_key(p)] = np.full(size, FAILED_RUN_MM)
            if self.log:
                self.log(f"a trial run failed and counts as a misfit of {FAILED_RUN_MM:g} mm "
                         f"(the optimiser steps back from it): {ds}", detail=True)  # fmt: skip
        self.runs += len(todo)
        if self.log:
            rms = np.sqrt(np.mean(self.cache[_key(theta)] ** 2))
            values = self.problem.shown(_values(self.problem, theta))
            if any(p is theta for p, _ in failed):
                self.log(f"{self.runs} runs: {values}: the run failed (-v says why); "
                         "the optimiser steps back")  # fmt: skip
            else:
                self.log(f"{self.runs} runs: {values}: RMS residual {rms:.3f} mm")

    def dataset(self, theta):
        """The run at ``theta`` (run again when only its residuals were kept)."""
        key = _key(theta)
        if key not in self.datasets:
            (self.datasets[key],) = run_laws(
                self.problem, [self.problem.law_at(theta)], self.problem.fit_options,
                workers=self.workers, scheduler=self.scheduler,
            )  # fmt: skip
            self.runs += 1
        return self.datasets[key]

    def fun(self, theta) -> np.ndarray:
        """Residuals at fit coordinates ``theta`` [mm]."""
        theta = np.asarray(theta, dtype=float)
        self._batch(theta, neighbours=self.ahead)
        r = self.cache[_key(theta)]
        if self.fixed is not None and not np.all(r == FAILED_RUN_MM):
            self._broyden(theta, r)
        return r

    def _broyden(self, theta, r) -> None:
        """Broyden's rank-one update of the chord Jacobian along the step from the last
        evaluated point to ``theta`` (residuals ``r``), so that it maps that step onto the
        change of the residuals."""
        assert self.fixed is not None and self.anchor is not None
        x0, r0 = self.anchor
        step = theta - x0
        length = float(step @ step)
        if length > 0:
            self.fixed = self.fixed + np.outer(r - r0 - self.fixed @ step, step) / length
            self.anchor = (theta, r)

    def jac(self, theta) -> np.ndarray:
        """Forward-difference Jacobian of the residuals at ``theta`` [mm per coordinate]."""
        theta = np.asarray(theta, dtype=float)
        if self.fixed is not None:
            return self.fixed
        self._batch(theta)
        h = self._steps(theta)
        r0 = self.cache[_key(theta)]
        columns = [
            (self.cache[_key(theta + h[i] * np.eye(theta.size)[i])] - r0) / h[i]
            for i in range(theta.size)
        ]
        jacobian = np.column_stack(columns)
        if self.chord:
            self.fixed, self.anchor = jacobian, (theta, r0)
        return jacobian


def _key(theta) -> tuple:
    return tuple(np.round(np.asarray(theta, dtype=float), 12))


def _values(problem: Calibration, theta) -> np.ndarray:
    return np.where(problem.log, np.exp(theta), theta)


@dataclass(frozen=True)
class FitResult:
    """Fitted parameters and how the fit went.

    Parameters
    ----------
    values, standard_errors : ndarray
        Fitted value and its standard error per fitted parameter [SI units]; with an
        estimated field, from the joint problem of the parameters and the field
        (`_joint_covariance`).
    correlation : ndarray
        (parameters, parameters) correlation of the fitted parameters' errors [-].
    posterior : Posterior
        The fitted parameters' joint posterior: normal in fit coordinates about the fit,
        with the covariance the standard errors and correlation come from
        (`trackdyn.forecast.spread.Posterior`; infinite variances where the surveys do not
        tell a parameter).
    start : ndarray
        Starting values [SI units].
    law, start_law : SettlementLaw
        The law with the fitted and with the starting values.
    rms_start, rms_fit : float
        RMS residual at the start and at the fit [mm].
    comparison, start_comparison : Comparison
        Measured and predicted changes of every survey (checks included) with the fitted
        and with the starting values.
    evaluations, runs : int
        Misfit evaluations of the optimiser (its last global fit) and model runs in all.
    message : str
        The optimiser's reason to stop.
    converged : bool
        False when the last global fit stopped at ``fit.max_iterations``, or the rounds of
        the rate field at `FIELD_ROUNDS` with the parameters still moving.
    stopped_by : str
        What stopped a fit that did not converge (empty when it did).
    field : FieldEstimate or None
        The estimated settlement-rate field; None for ``fit.rate_field = "uniform"``.
    rounds : int
        Rounds of field estimate and global fit [-].
    """

    values: np.ndarray
    standard_errors: np.ndarray
    correlation: np.ndarray
    posterior: Posterior
    start: np.ndarray
    law: object
    start_law: object
    rms_start: float
    rms_fit: float
    comparison: Comparison
    start_comparison: Comparison
    evaluations: int
    runs: int
    message: str
    converged: bool
    stopped_by: str
    field: FieldEstimate | None
    rounds: int


def _global_fit(obj: Objective, x0, loss: str = "soft_l1"):
    """`scipy.optimize.least_squares` of the global parameters from ``x0``."""
    problem = obj.problem
    f = problem.spec.fit
    return least_squares(
        obj.fun, x0, jac=obj.jac, bounds=(problem.lower, problem.upper), method="trf",
        loss=loss, f_scale=f.loss_scale_mm, xtol=1e-3, ftol=1e-4, max_nfev=f.max_iterations,
    )  # fmt: skip


class FieldRound:
    """The residual of a run with the field and its strength profiled out.

    The run's change is linearised in ``ln factor`` about the field ``log_factor`` it ran
    on (`trackdyn.calibration.field.linearise`); the residual
    is the vector whose squared norm is a monotone function of the marginal likelihood of
    the surveys with the field integrated out and ``λ``, ``σ²`` at their best
    (`trackdyn.calibration.field.Evidence`): minimising it is type-II maximum likelihood of
    the global parameters.
    """

    def __init__(self, problem, log_factor, band, prior):
        self.problem, self.log_factor, self.band, self.prior = problem, log_factor, band, prior

    def linearised(self, ds):
        """`Linearised` of the run ``ds``."""
        return linearise(self.problem, ds, self.log_factor, self.band)

    def __call__(self, ds) -> np.ndarray:
        return evidence(self.linearised(ds), self.prior).residual()

    def field(self, ds, observed) -> FieldEstimate:
        """The field of the run ``ds``: posterior mean at the best strength."""
        lin = self.linearised(ds)
        ev = evidence(lin, self.prior)
        return estimate(lin, self.prior, self.problem.position, observed, ev.lam, ev.sigma2)


def _covariance(information) -> np.ndarray:
    """Inverse of the Fisher ``information`` in fit coordinates; infinite variances when a
    parameter is not told by the surveys (a singular matrix)."""
    if np.linalg.matrix_rank(information) < information.shape[0]:
        return np.diag(np.full(information.shape[0], np.inf))
    return np.linalg.inv(information)


def _correlation(cov) -> np.ndarray:
    """Correlation matrix of a covariance; NaN where a variance is infinite."""
    sd = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore"):
        return cov / np.outer(sd, sd)


def _field_parts(problem: Calibration):
    """The D1 band-pass of each rail's settlement (`band_matrix` with the rail's
    bridging) and the field's `Prior`."""
    band = [band_matrix(problem.x, problem.position,
                        rail_transfer(problem.position, k, problem.EI))
            for k in problem.stiffness]  # fmt: skip
    s = problem.spec
    return band, Prior(problem.position, s.settlement.rate_correlation_length_m,
                       s.fit.rate_cov_max)  # fmt: skip


def _joint_covariance(obj: Objective, theta, field: FieldEstimate, parts) -> np.ndarray:
    """Covariance of the global parameters (fit coordinates) from the joint problem of the
    parameters and the field at its strength (`trackdyn.calibration.field.joint_information`):
    the Jacobian in the parameters by forward differences on the final field, the one in
    the field from its linearisation about the run at ``theta``.

    Parameters
    ----------
    obj : Objective
        Raw residuals of the calibration run on the field.
    theta : ndarray
        Fitted fit coordinates.
    field : FieldEstimate
        The field the calibration runs on.
    parts : tuple
        `_field_parts` of the calibration.
    """
    band, prior = parts
    lin = linearise(obj.problem, obj.dataset(theta), field.log_factor, band)
    sigma2 = field.noise_mm**2
    information = joint_information(obj.jac(theta), lin.a @ prior.root,
                                    field.prior_sd**2 / sigma2, sigma2)  # fmt: skip
    return _covariance(information)


def _field_rounds(problem, parts, workers, scheduler, log):
    """The global fit on uniform ballast, then rounds of global fit with the field profiled
    out, each linearised about the field estimated at the end of the one before (module
    docstring); returns the last round's objective and optimiser result, the problem on
    the final field, the field, the rounds, the model runs of all rounds, and whether the
    rounds ended by themselves: no parameter moved by more than `ROUND_TOLERANCE`, or the
    evidence got worse (the round before then stands)."""
    band, prior = parts
    x = problem.x[problem.valid]
    observed = (problem.position >= x[0]) & (problem.position <= x[-1])
    round_ = FieldRound(problem, np.zeros((2, problem.position.size)), band, prior)
    obj = Objective(problem, workers, scheduler, log)
    if log:
        log("round 1: the global fit on uniform ballast:")
    res = _global_fit(obj, np.clip(problem.start(), problem.lower, problem.upper))
    spent, rounds, settled, best = [obj], 1, False, np.inf
    for rounds in range(2, FIELD_ROUNDS + 1):
        before = obj.dataset(res.x)
        kept = (obj, res, round_)
        field = round_.field(before, observed)
        current = problem.with_field(field.factor)
        obj = Objective(current, workers, scheduler, log, chord=True)
        spent.append(obj)
        round_ = FieldRound(current, field.log_factor, band, prior)
        obj.residual = round_
        if log:
            log(f"round {rounds}: the global fit with the field profiled out, on the field "
                f"estimated (cov {field.cov:.2f}, noise {field.noise_mm:.3f} mm):")  # fmt: skip
        start, res = res.x, _global_fit(obj, res.x, "linear")
        if 2 * res.cost > (1 + EVIDENCE_TOLERANCE) * best:  # worse: the round before stands
            obj, res, round_ = kept
            rounds, settled = rounds - 1, True
            break
        best = 2 * res.cost
        settled = np.max(np.abs(res.x - start)) < ROUND_TOLERANCE
        if settled:
            break
    field = round_.field(obj.dataset(res.x), observed)
    runs = sum(o.runs for o in spent)
    return obj, res, problem.with_field(field.factor), field, rounds, runs, settled


def fit(problem: Calibration, *, workers=None, scheduler=None, log=None) -> FitResult:
    """Fit the parameters (and the rate field): soft-L1 least squares of the D1-band
    change, within bounds.

    Parameters
    ----------
    problem : Calibration
        The calibration (`trackdyn.calibration.problem.prepare`).
    workers : int, optional
        Worker processes (default one per core; 1 runs in this process).
    scheduler : str, optional
        Address of a running Dask scheduler.
    log : callable, optional
        Called with a one-line progress message after each batch of runs, and with
        ``detail=True`` for a line only a verbose reader wants (a trial run that failed,
        which the optimiser steps back from).
    """
    if problem.spec.fit.rate_field == "estimate":
        parts = _field_parts(problem)
        rounds_out = _field_rounds(problem, parts, workers, scheduler, log)
        obj, res, current, field, rounds, runs, settled = rounds_out
    else:
        obj, field, rounds, current = Objective(problem, workers, scheduler, log), None, 0, problem
        res = _global_fit(obj, np.clip(problem.start(), problem.lower, problem.upper))
        settled = True
    if res.status == 0:
        stopped_by = f"fit.max_iterations = {problem.spec.fit.max_iterations}"
    elif not settled:
        stopped_by = f"{FIELD_ROUNDS} rounds of the rate field, parameters still moving"
    else:
        stopped_by = ""
    if field is None:
        r, J = obj.fun(res.x), obj.jac(res.x)
        sigma = MAD_SCALE * float(np.median(np.abs(r)))
        cov = _covariance(J.T @ J / sigma**2)
        runs = obj.runs
    else:
        if log:
            log("standard errors: the parameters' Jacobian on the field, for the joint problem:")
        joint = Objective(current, workers, scheduler, log)
        cov = _joint_covariance(joint, res.x, field, parts)
        runs += joint.runs
    se_coord = np.sqrt(np.diag(cov))
    values = _values(problem, res.x)
    law = problem.law_at(res.x)
    (fitted,) = run_laws(current, [law], current.options, workers=workers, scheduler=scheduler)
    (start,) = run_laws(problem, [problem.law], problem.options, workers=workers,
                        scheduler=scheduler)  # fmt: skip
    fitted, start = compare(problem, fitted), compare(problem, start)
    return FitResult(
        values=values,
        standard_errors=np.where(problem.log, values * se_coord, se_coord),
        correlation=_correlation(cov),
        posterior=Posterior(problem.names, np.asarray(res.x, dtype=float), cov, problem.log),
        start=_values(problem, problem.start()),
        law=law,
        start_law=problem.law,
        rms_start=float(np.sqrt(np.mean(residuals(problem, start) ** 2))),
        rms_fit=float(np.sqrt(np.mean(residuals(problem, fitted) ** 2))),
        comparison=fitted,
        start_comparison=start,
        evaluations=int(res.nfev),
        runs=runs + 2,
        message=str(res.message),
        converged=not stopped_by,
        stopped_by=stopped_by,
        field=field,
        rounds=rounds,
    )
