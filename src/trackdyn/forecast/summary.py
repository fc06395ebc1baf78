"""An ensemble's forecast per segment: quantiles over the members, and the probability that
each segment has reached the maintenance threshold by a tonnage or a year.

Quantiles are empirical (``numpy.quantile`` with ``method="inverted_cdf"``: each is a
member's value, the smallest with at least that share of the members at or below it), so
that a member whose segment never reaches the threshold within the horizon (``inf``) stays
``inf`` in the quantiles it decides rather than being interpolated with finite values.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from trackdyn.track.track import RAILS

QUANTILES = {"p10": 0.1, "p50": 0.5, "p90": 0.9}
"""The forecast's quantiles, by column name."""


def quantile_row(values) -> dict[str, float]:
    """``p10``, ``p50``, ``p90``, ``mean`` and ``members`` of the members' ``values``
    (``inf``: beyond the horizon; the mean then ``inf`` too)."""
    v = np.asarray(values, dtype=float)
    row = {k: float(np.quantile(v, q, method="inverted_cdf")) for k, q in QUANTILES.items()}
    return {**row, "mean": float(np.mean(v)), "members": int(v.size)}


def first_tamping(ds) -> np.ndarray:
    """Tonnage of each segment's first tamping [MGT], per segment (``inf``: none within
    the horizon): the loop's first intervention of the segment with maintenance, else the
    tonnage at which the D1 SD of either rail first reaches the threshold."""
    if "intervention_mgt" in ds and ds.sizes.get("intervention", 0) > 0:
        out = np.full(ds.sizes["segment"], np.inf)
        for mgt, segment in zip(ds.intervention_mgt.values, ds.intervention_segment.values,
                                strict=True):  # fmt: skip
            out[int(segment)] = min(out[int(segment)], float(mgt))
        return out
    return np.asarray(ds.trigger_mgt_any_rail.values, dtype=float)


def member_quantities(ds) -> dict[str, np.ndarray]:
    """The quantities a forecast reports of one member, each per segment:
    ``first_tamping_mgt`` [MGT], ``tampings`` [-] over the horizon, and
    ``d1_sd_at_horizon_mm_<rail>`` [mm]."""
    out = {"first_tamping_mgt": first_tamping(ds)}
    segments = ds.sizes["segment"]
    out["tampings"] = (np.asarray(ds.interventions.values, dtype=float)
                       if "interventions" in ds else np.zeros(segments))  # fmt: skip
    final = ds.d1_sd.isel(mgt=-1).values
    for r, rail in enumerate(RAILS):
        out[f"d1_sd_at_horizon_mm_{rail}"] = np.asarray(final[r], dtype=float)
    return out


def forecast_table(members, years=None) -> pd.DataFrame:
    """One row per segment and quantity, with the members' quantiles.

    Parameters
    ----------
    members : sequence of xarray.Dataset
        The members' deterioration results (`trackdyn.deterioration.predict`), on the same
        segments.
    years : sequence of callable, optional
        Per member, the year in which a tonnage is reached (``years[m](mgt)`` [year]); adds
        ``first_tamping_year``.

    Returns
    -------
    pandas.DataFrame
        Columns ``segment_start_m``, ``segment_end_m``, ``quantity``, ``p10``, ``p50``,
        ``p90``, ``mean``, ``members``.
    """
    each = [member_quantities(ds) for ds in members]
    if years is not None:
        for q, year in zip(each, years, strict=True):
            q["first_tamping_year"] = np.asarray(year(q["first_tamping_mgt"]), dtype=float)
    first = members[0]
    starts, ends = first.segment_start.values, first.segment_end.values
    rows = []
    for s in range(starts.size):
        for quantity in each[0]:
            values = [q[quantity][s] for q in each]
            rows.append({"segment_start_m": float(starts[s]), "segment_end_m": float(ends[s]),
                         "quantity": quantity, **quantile_row(values)})  # fmt: skip
    return pd.DataFrame(rows)


def reach_probability(first, at) -> np.ndarray:
    """Share of the members whose segment has had its first tamping by each of ``at``.

    Parameters
    ----------
    first : ndarray
        First tamping per member and segment, (members, segments) [MGT or year].
    at : ndarray
        Tonnages or years to evaluate at [the unit of ``first``].

    Returns
    -------
    ndarray
        (at, segments) probability [-].
    """
    first = np.asarray(first, dtype=float)
    return (first[None, :, :] <= np.asarray(at, dtype=float)[:, None, None]).mean(axis=1)


def coverage(truth, low, high) -> float:
    """Share of the ``truth`` values within ``[low, high]`` (all arrays alike); a truth
    beyond the horizon (``inf``) is inside when ``high`` is ``inf`` too [-]."""
    truth, low, high = (np.asarray(a, dtype=float) for a in (truth, low, high))
    return float(np.mean((truth >= low) & (truth <= high)))
