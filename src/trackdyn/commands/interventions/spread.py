"""An interventions study whose scenario has ``[forecast]``: every alternative runs on every
member, and its life-cycle cost is reported with its spread.

The members are the same for every alternative (their law parameters, rate fields and
traffic growth: common random numbers), so that the alternatives are compared member by
member: ``probability_cheapest`` is the share of the members in which the alternative's
life-cycle cost is the lowest (a tie shared equally). An alternative's own settlement
overrides give way to a member's sampled value of the same parameter.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from trackdyn.forecast.ensemble import member_tasks
from trackdyn.forecast.summary import quantile_row
from trackdyn.units import money_name


def member_labelled(labelled, plan) -> tuple[list, np.ndarray]:
    """The ``(alternative, task)`` pairs of every member, and each pair's member.

    Parameters
    ----------
    labelled : list of (str, SectionTask)
        Each alternative's deterministic section tasks (`alternative_tasks`).
    plan : Plan
        The members (`trackdyn.commands.deteriorate.forecast.plan_forecast`).
    """
    pairs, member = [], []
    for alt, task in labelled:
        for m, t in enumerate(member_tasks(task, plan.members, plan.growth, plan.horizon_years)):
            pairs.append((alt, t))
            member.append(m)
    return pairs, np.array(member)


def cost_spread(costs: np.ndarray, alternatives, code: str) -> pd.DataFrame:
    """Each alternative's life-cycle cost over the members and its chance to be cheapest.

    Parameters
    ----------
    costs : ndarray
        (members, alternatives) life-cycle cost [the study's currency].
    alternatives : list of str
        The alternatives' names, in the order of ``costs``' columns.
    code : str
        The currency, the last part of the costs' names (`trackdyn.units.money_name`).

    Returns
    -------
    pandas.DataFrame
        Columns ``alternative``, ``life_cycle_cost_p10_<currency>``, ``_p50_``, ``_p90_``,
        ``_mean_``, ``probability_cheapest`` [-] and ``members``.
    """
    lowest = costs == costs.min(axis=1, keepdims=True)
    share = (lowest / lowest.sum(axis=1, keepdims=True)).mean(axis=0)
    rows = []
    for a, name in enumerate(alternatives):
        q = quantile_row(costs[:, a])
        rows.append({"alternative": name,
                     **{money_name(f"life_cycle_cost_{k}", code): q[k]
                        for k in ("p10", "p50", "p90", "mean")},
                     "probability_cheapest": float(share[a]), "members": q["members"]})  # fmt: skip
    return pd.DataFrame(rows)
