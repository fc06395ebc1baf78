"""What varies between the members of an ensemble forecast, and the members' samples.

A member is one deterioration run with its own settlement-law parameters, its own
realisation of the settlement-rate field and its own traffic growth. The law's parameters
are sampled either from a calibration's joint posterior (`Posterior`: a normal distribution
in the fit's coordinates, the logarithm of every parameter whose bounds are positive, with
the fitted covariance, so that samples follow the ridge the surveys leave them on) or from
a distribution given per parameter (`Lognormal` about the parameter's value, `Uniform`
between two bounds). Where no calibrated field is given, each member draws a fresh
realisation of the rate field (its own seed). Where the horizon is in years, each member's
annual tonnage grows at its own rate (`Growth`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trackdyn.errors import TrackdynInputError, require_positive, shown
from trackdyn.io import read_toml


@dataclass(frozen=True)
class Lognormal:
    """A positive parameter with a lognormal spread whose median is its value.

    Parameters
    ----------
    cov : float
        Coefficient of variation [-] (``sigma = sqrt(ln(1 + cov^2))`` of the logarithm).
    """

    cov: float

    def __post_init__(self):
        require_positive("cov", self.cov)

    def sample(self, value: float, rng, members: int) -> np.ndarray:
        """``members`` samples about ``value`` (the median) [its unit]."""
        if not value > 0:
            raise TrackdynInputError(f"a lognormal spread needs a positive value, got "
                                     f"{shown(value)}")  # fmt: skip
        sigma = np.sqrt(np.log1p(self.cov**2))
        return value * np.exp(sigma * rng.standard_normal(members))


@dataclass(frozen=True)
class Uniform:
    """A parameter uniformly distributed between ``low`` and ``high`` [its unit]."""

    low: float
    high: float

    def __post_init__(self):
        if not (np.isfinite(self.low) and np.isfinite(self.high) and self.low < self.high):
            raise TrackdynInputError(f"a uniform spread needs finite min < max, got "
                                     f"{shown(self.low)} and {shown(self.high)}")  # fmt: skip

    def sample(self, value: float, rng, members: int) -> np.ndarray:
        """``members`` samples (``value`` is not used) [its unit]."""
        return rng.uniform(self.low, self.high, members)


@dataclass(frozen=True)
class Posterior:
    """A calibration's joint posterior of the fitted parameters: normal in the fit's
    coordinates (``log`` of a parameter where ``log`` says so, the value otherwise).

    Parameters
    ----------
    names : tuple of str
        Fitted parameters.
    mean : ndarray
        Fitted values in fit coordinates.
    covariance : ndarray
        (parameters, parameters) covariance in fit coordinates, symmetric positive
        semi-definite and finite (a parameter the surveys do not tell has none).
    log : ndarray of bool
        Which parameters are fitted as their logarithm.
    """

    names: tuple[str, ...]
    mean: np.ndarray
    covariance: np.ndarray
    log: np.ndarray

    def __post_init__(self):
        n = len(self.names)
        if (
            np.shape(self.mean) != (n,)
            or np.shape(self.covariance) != (n, n)
            or np.shape(self.log) != (n,)
        ):
            raise TrackdynInputError(f"a posterior of {n} parameters needs {n} values, an "
                                     f"{n} x {n} covariance and {n} log flags")  # fmt: skip

    def check(self, where: str = "posterior") -> None:
        """Refuse a covariance that cannot be sampled: not finite (a parameter the surveys
        do not tell), not symmetric or not positive semi-definite."""
        cov = np.asarray(self.covariance, dtype=float)
        if not np.all(np.isfinite(cov)) or not np.allclose(cov, cov.T, rtol=1e-9, atol=0):
            raise TrackdynInputError(f"{where}: the covariance must be finite and symmetric "
                                     "(a parameter the surveys do not tell cannot be sampled "
                                     "from it)")  # fmt: skip
        if np.linalg.eigvalsh(cov).min() < -1e-12 * max(np.abs(cov).max(), 1e-300):
            raise TrackdynInputError(f"{where}: the covariance is not positive "
                                     "semi-definite")  # fmt: skip

    @classmethod
    def from_fit(cls, names, values, standard_errors, correlation, log) -> Posterior:
        """The posterior of a fit reported as values, standard errors [SI] and the
        correlation of their errors: the standard errors of log coordinates are those of
        the values over the values (to first order)."""
        values = np.asarray(values, dtype=float)
        log = np.asarray(log, dtype=bool)
        se = np.where(log, np.asarray(standard_errors) / np.abs(values), standard_errors)
        mean = np.where(log, np.log(np.abs(values)), values)
        return cls(tuple(names), mean, np.asarray(correlation) * np.outer(se, se), log)

    def sample(self, rng, members: int) -> dict[str, np.ndarray]:
        """``members`` joint samples, per parameter [SI] (`check` first)."""
        self.check()
        theta = rng.multivariate_normal(self.mean, self.covariance, members, method="eigh")
        values = np.where(self.log, np.exp(theta), theta)
        return {name: values[:, i] for i, name in enumerate(self.names)}


def posterior_toml(posterior: Posterior, law: str, source: str = "") -> str:
    """The text of a posterior file (`read_posterior`): the law, the fitted parameters,
    their log flags, mean and covariance in fit coordinates, full precision.

    Parameters
    ----------
    posterior : Posterior
        The posterior.
    law : str
        Name of the settlement law it belongs to (`trackdyn.deterioration.LAWS`).
    source : str
        What it comes from, written as a comment.
    """

    def floats(values) -> str:
        return "[" + ", ".join(repr(float(v)) for v in values) + "]"

    rows = ",\n  ".join(floats(r) for r in np.asarray(posterior.covariance))
    return "\n".join([
        "# The joint posterior of a calibration's fitted settlement-law parameters: normal",
        "# in fit coordinates (ln of the SI value where log is true), for [forecast] posterior.",
        *([f"# {source}"] if source else []),
        f'law = "{law}"',
        "parameters = [" + ", ".join(f'"{n}"' for n in posterior.names) + "]",
        "log = [" + ", ".join("true" if v else "false" for v in posterior.log) + "]",
        f"mean = {floats(posterior.mean)}",
        f"covariance = [\n  {rows},\n]",
        "",
    ])  # fmt: skip


def read_posterior(path, law: str) -> Posterior:
    """The posterior in the file ``path`` (`posterior_toml`), checked to be of ``law``.

    Parameters
    ----------
    path : path
        Posterior TOML file (``trackdyn calibrate`` writes ``posterior.toml``).
    law : str
        The scenario's settlement law.
    """
    table = read_toml(path)
    keys = {"law", "parameters", "log", "mean", "covariance"}
    if set(table) != keys:
        raise TrackdynInputError(f"{path}: a posterior file has the keys "
                                 f"{', '.join(sorted(keys))}")  # fmt: skip
    if table["law"] != law:
        raise TrackdynInputError(f"{path}: the posterior is of the {table['law']} law, the "
                                 f"scenario's is {law}")  # fmt: skip
    try:
        posterior = Posterior(tuple(table["parameters"]), np.array(table["mean"], dtype=float),
                              np.array(table["covariance"], dtype=float),
                              np.array(table["log"], dtype=bool))  # fmt: skip
    except (TypeError, ValueError) as exc:
        raise TrackdynInputError(f"{path}: {exc}") from None
    posterior.check(str(path))
    return posterior


@dataclass(frozen=True)
class Growth:
    """Annual tonnage that grows each year at a rate with a spread between members.

    Parameters
    ----------
    annual_mgt : float
        Tonnage of the first year [MGT/year].
    rate : float
        Mean growth per year [-] (0.02: 2 % a year).
    rate_sd : float
        Standard deviation of a member's growth rate [-], normal, held above -0.5.
    """

    annual_mgt: float
    rate: float = 0.0
    rate_sd: float = 0.0

    def __post_init__(self):
        require_positive("annual_mgt", self.annual_mgt)
        if not (-0.5 < self.rate < 1.0 and 0.0 <= self.rate_sd < 1.0):
            raise TrackdynInputError(f"growth rate must be within -0.5 to 1 and its sd within "
                                     f"0 to 1, got {shown(self.rate)} and "
                                     f"{shown(self.rate_sd)}")  # fmt: skip

    def rates(self, rng, members: int) -> np.ndarray:
        """Each member's growth rate [-]."""
        if self.rate_sd == 0.0:
            return np.full(members, float(self.rate))
        return np.maximum(self.rate + self.rate_sd * rng.standard_normal(members), -0.499)

    def mgt_by(self, years, rate) -> np.ndarray:
        """Tonnage carried in the first ``years`` at growth ``rate`` [MGT]: the annual
        tonnage ``a (1 + g)^t`` integrated over time, ``a ((1 + g)^y - 1) / ln(1 + g)``."""
        years, rate = np.asarray(years, dtype=float), np.asarray(rate, dtype=float)
        growth = np.log1p(rate)
        small = np.abs(growth) < 1e-12
        safe = np.where(small, 1.0, growth)
        return self.annual_mgt * np.where(small, years, np.expm1(years * growth) / safe)

    def year_of(self, mgt, rate) -> np.ndarray:
        """The year in which the tonnage ``mgt`` [MGT] has been carried (inverse of
        `mgt_by`); inf stays inf [year]."""
        mgt, rate = np.asarray(mgt, dtype=float), np.asarray(rate, dtype=float)
        growth = np.log1p(rate)
        small = np.abs(growth) < 1e-12
        safe = np.where(small, 1.0, growth)
        with np.errstate(invalid="ignore", divide="ignore"):
            years = np.log1p(mgt * safe / self.annual_mgt) / safe
        return np.where(small, mgt / self.annual_mgt, np.where(np.isnan(years), np.inf, years))


@dataclass(frozen=True)
class Members:
    """The samples of an ensemble: per member its law parameters and growth rate.

    Parameters
    ----------
    parameters : dict of str to ndarray
        Sampled law parameters per name [SI], one value per member each.
    growth : ndarray
        Growth rate of each member's traffic [-], one per member.
    fresh_fields : bool
        Each member draws its own realisation of the rate field (seeded by its section's
        seed and its number, `trackdyn.forecast.ensemble.member_tasks`); False: every
        member has its section's field.
    fields : ndarray, optional
        Rate fields drawn from a calibration's posterior, (draws, 2 rails, sleepers) [-]
        (`trackdyn.deterioration.ballast.read_field_draws`): member ``m`` runs on draw ``m``
        modulo their number, in place of its section's field.
    """

    parameters: dict
    growth: np.ndarray
    fresh_fields: bool = True
    fields: np.ndarray | None = None

    @property
    def count(self) -> int:
        """Members [-]."""
        return len(self.growth)

    def overrides(self, member: int) -> dict[str, float]:
        """The law parameters of ``member`` [SI], for `trackdyn.deterioration.load_law`."""
        return {name: float(v[member]) for name, v in self.parameters.items()}

    def field(self, member: int) -> tuple[tuple[float, ...], ...] | None:
        """The rate field of ``member`` (`fields`), as `LoopOptions.rate_factor`; None
        without drawn fields."""
        if self.fields is None:
            return None
        return tuple(map(tuple, self.fields[member % len(self.fields)].tolist()))


def sample_members(members: int, seed: int, law, *, spreads=None, posterior=None,
                   growth: Growth | None = None, fields=None) -> Members:  # fmt: skip
    """Draw the members of an ensemble, each with a fresh realisation of the rate field.

    The random numbers come in a fixed order from one generator seeded with ``seed``: the
    posterior's samples, then each spread's in the order given, then the growth rates.

    Parameters
    ----------
    members : int
        Ensemble size [-], at least 2.
    seed : int
        Seed of the samples.
    law : LawParameters
        The law whose parameters vary (its values are the spreads' medians).
    spreads : dict of str to Lognormal or Uniform, optional
        Distributions given per parameter.
    posterior : Posterior, optional
        A calibration's joint posterior; a parameter cannot have both.
    growth : Growth, optional
        Traffic growth; None: every member's rate is 0.
    fields : ndarray, optional
        Rate fields drawn from a calibration's posterior (`Members.fields`).
    """
    if not isinstance(members, int) or members < 2:
        raise TrackdynInputError(f"forecast members must be an integer >= 2, got "
                                 f"{shown(members)}")  # fmt: skip
    spreads = dict(spreads or {})
    both = set(spreads) & set(posterior.names if posterior is not None else ())
    if both:
        raise TrackdynInputError(f"parameter {sorted(both)[0]!r} has a spread and a posterior; "
                                 "give one")  # fmt: skip
    for name in [*spreads, *(posterior.names if posterior is not None else ())]:
        if not hasattr(law, name):
            raise TrackdynInputError(f"forecast: {name!r} is not a parameter of the "
                                     f"{type(law).__name__}")  # fmt: skip
    rng = np.random.default_rng(seed)
    parameters = {} if posterior is None else posterior.sample(rng, members)
    for name, spread in spreads.items():
        parameters[name] = spread.sample(float(getattr(law, name)), rng, members)
    rates = np.zeros(members) if growth is None else growth.rates(rng, members)
    return Members(parameters, rates, fields=fields)
