"""The least-squares fit of a calibration (`trackdyn.calibration.problem`).

Every evaluation of the misfit at a point also runs its forward-difference neighbours in
the same batch of Dask tasks, so a Jacobian's ``n + 1`` model runs go to ``n + 1``
workers at once and the Jacobian at an accepted point costs no further runs.

References
----------
Branch, M.A., Coleman, T.F., Li, Y. (1999). A subspace, interior, and conjugate gradient
method for large-scale bound-constrained minimization problems. SIAM Journal on Scientific
Computing 21(1), 1-23.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from trackdyn.calibration.problem import (
    FD_STEP,
    Calibration,
    Comparison,
    compare,
    residuals,
    run_laws,
)
from trackdyn.errors import TrackdynInputError

FAILED_RUN_MM = 100.0
"""Residual given to every comparison point of a trial whose run failed (settlement that
ran away past the plausible profile, too many steps) [mm]: the optimiser steps back."""

MAD_SCALE = 1.4826
"""Median absolute deviation to standard deviation of a normal distribution [-]."""


class Objective:
    """Residuals and Jacobian of a calibration, model runs cached by point.

    Parameters
    ----------
    problem : Calibration
        The calibration.
    workers : int, optional
        Worker processes of each batch (default one per core; 1 runs in this process).
    scheduler : str, optional
        Address of a running Dask scheduler.
    log : callable, optional
        Called with a one-line message after each batch.
    """

    def __init__(self, problem: Calibration, workers=None, scheduler=None, log=None):
        self.problem, self.workers, self.scheduler, self.log = problem, workers, scheduler, log
        self.cache: dict[tuple, np.ndarray] = {}
        self.runs = 0

    def _steps(self, theta) -> np.ndarray:
        """Forward step per coordinate, backward where it would leave the bounds."""
        return np.where(theta + FD_STEP <= self.problem.upper, FD_STEP, -FD_STEP)

    def _batch(self, theta) -> None:
        """Run the point and its neighbours that are not cached yet."""
        h = self._steps(theta)
        points = [theta] + [theta + h[i] * np.eye(theta.size)[i] for i in range(theta.size)]
        todo = [p for p in points if _key(p) not in self.cache]
        if not todo:
            return
        laws = [self.problem.law_at(p) for p in todo]
        runs = run_laws(self.problem, laws, self.problem.fit_options, workers=self.workers,
                        scheduler=self.scheduler, keep_failures=True)  # fmt: skip
        if self.runs == 0 and isinstance(runs[0], str):
            raise TrackdynInputError(f"the run at the starting values failed: {runs[0]}")
        failed = []
        for p, ds in zip(todo, runs, strict=True):
            if isinstance(ds, str):
                failed.append((p, ds))
            else:
                self.cache[_key(p)] = residuals(self.problem, compare(self.problem, ds))
        for p, ds in failed:  # trials the optimiser must step back from
            size = next(iter(self.cache.values())).size
            self.cache[_key(p)] = np.full(size, FAILED_RUN_MM)
            if self.log:
                self.log(f"a run failed and counts as a misfit of {FAILED_RUN_MM:g} mm: {ds}")
        self.runs += len(todo)
        if self.log:
            rms = np.sqrt(np.mean(self.cache[_key(theta)] ** 2))
            values = ", ".join(
                f"{n} = {v:.4g}" for n, v in zip(self.problem.names, _values(self.problem, theta),
                                                  strict=True)
            )  # fmt: skip
            self.log(f"{self.runs} runs: {values} (SI): RMS misfit {rms:.3f} mm")

    def fun(self, theta) -> np.ndarray:
        """Residuals at fit coordinates ``theta`` [mm]."""
        theta = np.asarray(theta, dtype=float)
        self._batch(theta)
        return self.cache[_key(theta)]

    def jac(self, theta) -> np.ndarray:
        """Forward-difference Jacobian of the residuals at ``theta`` [mm per coordinate]."""
        theta = np.asarray(theta, dtype=float)
        self._batch(theta)
        h = self._steps(theta)
        r0 = self.cache[_key(theta)]
        columns = [
            (self.cache[_key(theta + h[i] * np.eye(theta.size)[i])] - r0) / h[i]
            for i in range(theta.size)
        ]
        return np.column_stack(columns)


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
        Fitted value and its standard error per fitted parameter [SI units].
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
        Misfit evaluations of the optimiser and model runs in all.
    message : str
        The optimiser's reason to stop.
    """

    values: np.ndarray
    standard_errors: np.ndarray
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


def fit(problem: Calibration, *, workers=None, scheduler=None, log=None) -> FitResult:
    """Fit the parameters: soft-L1 least squares of the D1-band change, within bounds.

    Parameters
    ----------
    problem : Calibration
        The calibration (`trackdyn.calibration.problem.prepare`).
    workers : int, optional
        Worker processes (default one per core; 1 runs in this process).
    scheduler : str, optional
        Address of a running Dask scheduler.
    log : callable, optional
        Called with a one-line progress message after each batch of runs.
    """
    obj = Objective(problem, workers, scheduler, log)
    f = problem.spec.fit
    x0 = np.clip(problem.start(), problem.lower, problem.upper)
    res = least_squares(
        obj.fun, x0, jac=obj.jac, bounds=(problem.lower, problem.upper), method="trf",
        loss="soft_l1", f_scale=f.loss_scale_mm, xtol=1e-3, ftol=1e-4,
        max_nfev=f.max_iterations,
    )  # fmt: skip
    r, J = obj.fun(res.x), obj.jac(res.x)
    sigma = MAD_SCALE * float(np.median(np.abs(r)))
    normal = J.T @ J
    if np.linalg.matrix_rank(normal) < res.x.size:
        se_coord = np.full(res.x.size, np.inf)  # a parameter the surveys do not tell
    else:
        se_coord = sigma * np.sqrt(np.diag(np.linalg.inv(normal)))
    values = _values(problem, res.x)
    law = problem.law_at(res.x)
    runs = run_laws(problem, [law, problem.law], problem.options, workers=workers,
                    scheduler=scheduler)  # fmt: skip
    fitted, start = (compare(problem, ds) for ds in runs)
    return FitResult(
        values=values,
        standard_errors=np.where(problem.log, values * se_coord, se_coord),
        start=_values(problem, problem.start()),
        law=law,
        start_law=problem.law,
        rms_start=float(np.sqrt(np.mean(residuals(problem, start) ** 2))),
        rms_fit=float(np.sqrt(np.mean(r**2))),
        comparison=fitted,
        start_comparison=start,
        evaluations=int(res.nfev),
        runs=obj.runs + len(runs),
        message=str(res.message),
    )
