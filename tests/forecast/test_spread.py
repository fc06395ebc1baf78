"""The ensemble's samples against the distributions they come from."""

import numpy as np
import pytest

from trackdyn.deterioration import load_law
from trackdyn.deterioration.ballast import rate_field
from trackdyn.errors import TrackdynInputError
from trackdyn.forecast.spread import Growth, Lognormal, Posterior, Uniform, sample_members

LAW = load_law("power")


def test_posterior_samples_lie_on_the_ridge_of_the_fit():
    # a fit's report: K_s 0.81 mm +- 0.015, exponent 2.52 +- 0.034, errors correlated -0.9
    # (the D1-band surveys' ridge); both fitted as logarithms
    corr = np.array([[1.0, -0.9], [-0.9, 1.0]])
    post = Posterior.from_fit(("K_s", "load_exponent"), [0.81e-3, 2.52], [0.015e-3, 0.034],
                              corr, [True, True])  # fmt: skip
    m = sample_members(4000, 7, LAW, posterior=post)
    logs = np.log(np.column_stack([m.parameters["K_s"], m.parameters["load_exponent"]]))
    # sampling error of a correlation of -0.9 from 4000 samples: (1 - 0.81) / sqrt(4000)
    assert np.corrcoef(logs.T)[0, 1] == pytest.approx(-0.9, abs=4 * 0.19 / np.sqrt(4000))
    # the log coordinates' standard errors are the values' over the values (delta method)
    sd = logs.std(axis=0, ddof=1)
    np.testing.assert_allclose(sd, [0.015 / 0.81, 0.034 / 2.52], rtol=4 / np.sqrt(2 * 4000))
    np.testing.assert_allclose(np.exp(logs.mean(axis=0)), [0.81e-3, 2.52], rtol=2e-3)


def test_lognormal_and_uniform_spreads_have_their_moments():
    rng = np.random.default_rng(3)
    x = Lognormal(0.3).sample(2.0, rng, 20000)
    assert np.median(x) == pytest.approx(2.0, rel=0.01)  # the value is the median
    # cov of a lognormal: sqrt(exp(sigma^2) - 1) = cov by construction
    assert x.std() / x.mean() == pytest.approx(0.3, rel=0.03)
    u = Uniform(1.5, 3.0).sample(2.0, rng, 20000)
    assert u.min() >= 1.5 and u.max() <= 3.0
    assert u.mean() == pytest.approx(2.25, abs=4 * 1.5 / np.sqrt(12 * 20000))


def test_fresh_rate_fields_have_the_prior_cov():
    # the members' seeds: the section's seed (3) followed by the member's number
    fields = [rate_field(5000, 0.6, 0.3, 3.0, (3, m + 1)) for m in range(8)]
    assert not np.array_equal(fields[0], fields[1])
    allf = np.concatenate([f.ravel() for f in fields])
    # 8 x 2 x 5000 factors, correlated over 3 m (5 sleepers): ~ 8000 independent values
    assert allf.std() / allf.mean() == pytest.approx(0.3, rel=0.05)
    assert allf.mean() == pytest.approx(1.0, abs=0.02)


def test_the_same_seed_gives_the_same_members():
    spreads = {"K_s": Lognormal(0.2), "load_exponent": Uniform(1.5, 2.5)}
    a = sample_members(5, 11, LAW, spreads=spreads, growth=Growth(30.0, 0.02, 0.01))
    b = sample_members(5, 11, LAW, spreads=spreads, growth=Growth(30.0, 0.02, 0.01))
    for name in a.parameters:
        np.testing.assert_array_equal(a.parameters[name], b.parameters[name])
    np.testing.assert_array_equal(a.growth, b.growth)


def test_growth_integrates_the_annual_tonnage_and_inverts():
    g = Growth(30.0, 0.03)
    # closed form: integral of 30 (1.03)^t over 10 years = 30 (1.03^10 - 1) / ln 1.03
    assert g.mgt_by(10.0, 0.03) == pytest.approx(30 * (1.03**10 - 1) / np.log(1.03))
    assert g.mgt_by(10.0, 0.0) == pytest.approx(300.0)
    years = np.array([0.5, 3.0, 17.0])
    np.testing.assert_allclose(g.year_of(g.mgt_by(years, 0.03), 0.03), years)
    assert g.year_of(np.inf, 0.03) == np.inf
    # shrinking traffic never carries more than a / |ln(1 + g)|
    assert g.year_of(30.0 / -np.log(0.9) * 1.01, -0.1) == np.inf


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: sample_members(1, 0, LAW), "members must be an integer >= 2"),
        (lambda: sample_members(4, 0, LAW, spreads={"nope": Lognormal(0.1)}), "'nope' is not"),
        (lambda: Uniform(2.0, 1.0), "finite min < max"),
        (lambda: Lognormal(-0.1), "cov must be finite and > 0"),
        (
            lambda: Posterior(("K_s",), np.zeros(1), np.array([[np.inf]]), np.ones(1, bool)).sample(
                np.random.default_rng(0), 2
            ),
            "not tell",
        ),
        (lambda: Growth(30.0, 2.0), "growth rate must be within"),
    ],
)
def test_refusals(call, message):
    with pytest.raises(TrackdynInputError, match=message):
        call()
