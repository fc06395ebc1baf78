"""Life-cycle costs of a section's maintenance on equal terms: the state each alternative
leaves at the horizon, the possessions its tampings take, and every cost at its present
value.

**End state.** Every segment reports its D1 SD at the horizon (the worse rail) [mm] and
the tonnage since its last tamping or renewal (since the start where it had none) [MGT].

**Residual rule: the end state's work.** Alternatives are compared over the same period,
and an alternative that leaves the track worse at its end owes the work that brings it
back: every segment whose D1 SD at the horizon has reached the common reference
(``reference_sd_mm``, the same for all alternatives: by default the scenario's own
threshold) is charged a tamping at the horizon (its length at the cost per metre tamped,
and one possession per contiguous run of such segments), discounted as a tamping then.
Deferring a tamping beyond the horizon therefore costs what the tamping costs, less only
the discounting of the years it was deferred. What the rule does not charge: a segment
just under the reference at the horizon owes nothing (a lower reference, e.g. the alert
limit, charges it), and no credit is given for the unused life of a recent tamping.

**Residual rule: the condition used.** With ``tamped_sd_mm``, the D1 SD a tamping leaves
a segment at the reference in (``recovery_offset_mm + recovery_slope × reference``, the
scenario's tamping model), every segment is charged the share of a tamping its condition
has used since: ``(σ_h - σ_t) / (σ_ref - σ_t)`` of its length at the cost per metre
tamped, between 0 (as tamped) and 1 (at the reference, when it also owes the
possession): straight-line depreciation of the last tamping in the condition it buys, so
that a segment just under the reference owes nearly a whole tamping and one just tamped
owes nearly nothing.

**Possessions.** Each maintenance event (the segments tamped or renewed at one tonnage)
takes one possession per contiguous run of its segments: the machine works a run in one
go, whatever its length.

**Present value.** A cost ``c`` spent ``t`` years from the start is worth
``c (1 + r)^-t`` today at the discount rate ``r`` [-/year]; a tonnage ``M`` [MGT] is
reached at ``t = M / annual_mgt`` (the fraction of a year counts). With ``r = 0`` every
factor is exactly 1 and the costs are the plain sums.

References
----------
EN 60300-3-3:2017. Dependability management - Part 3-3: Application guide - Life cycle
costing. CEN, Brussels (alternatives compared over one period of analysis, costs
discounted to their present value, the residual value at the end of the period).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from trackdyn.errors import TrackdynInputError


def present_value(amount, years, rate: float) -> np.ndarray:
    """``amount (1 + rate)^-years``: the value today of costs spent ``years`` from now.

    Parameters
    ----------
    amount : float or ndarray
        Costs [currency].
    years : float or ndarray
        When each is spent, from the start [year].
    rate : float
        Discount rate [-/year]; 0: the amounts themselves.
    """
    return np.asarray(amount, dtype=float) * (1.0 + rate) ** -np.asarray(years, dtype=float)


@dataclass(frozen=True)
class Rates:
    """What maintenance costs and how costs over time are compared.

    Parameters
    ----------
    tamping_per_m, renewal_per_m : float
        Cost of tamping and of renewing one metre of track [currency/m].
    per_possession : float
        Cost of one possession (a tamping run, whatever its length) [currency].
    discount_rate : float
        [-/year]; 0: undiscounted.
    annual_mgt : float, optional
        Traffic per year [MGT/year], which dates each tonnage; needed to discount.
    reference_sd_mm : float, optional
        The common end state: segments at or over this D1 SD at the horizon are charged
        their tamping (the residual rule) [mm]; None: no residual.
    tamped_sd_mm : float, optional
        The D1 SD a tamping leaves at the reference [mm]: with it, every segment is charged
        the share of a tamping its condition used (the condition rule); None: only those
        at the reference.
    """

    tamping_per_m: float = 0.0
    renewal_per_m: float = 0.0
    per_possession: float = 0.0
    discount_rate: float = 0.0
    annual_mgt: float | None = None
    reference_sd_mm: float | None = None
    tamped_sd_mm: float | None = None

    def at(self, amount, mgt) -> np.ndarray:
        """Present value of ``amount`` [currency] spent at the tonnage ``mgt`` [MGT]."""
        if self.discount_rate == 0.0:
            return present_value(amount, 0.0, 0.0)
        if self.annual_mgt is None:
            raise TrackdynInputError("discount_rate needs annual_mgt, the traffic per year")
        return present_value(amount, np.asarray(mgt, dtype=float) / self.annual_mgt,
                             self.discount_rate)  # fmt: skip


def runs(segments) -> list[list[int]]:
    """Contiguous runs of segment indices, in order."""
    out: list[list[int]] = []
    for i in sorted(int(s) for s in segments):
        if out and i == out[-1][-1] + 1:
            out[-1].append(i)
        else:
            out.append([i])
    return out


def possessions(ds) -> list[tuple[float, list[int]]]:
    """The possessions of a section's maintenance: ``(tonnage [MGT], segments)``, one per
    contiguous run of the segments treated at one tonnage.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict` with maintenance.
    """
    mgt, seg = ds.intervention_mgt.values, ds.intervention_segment.values
    return [(float(m), run) for m in np.unique(mgt) for run in runs(seg[mgt == m])]


def end_state(ds, reference_sd_mm: float | None,
              tamped_sd_mm: float | None = None) -> pd.DataFrame:  # fmt: skip
    """Per segment: its D1 SD at the horizon (worse rail) [mm], the tonnage since its last
    intervention or the start [MGT], whether it needs work to reach the reference and the
    share of a tamping the residual rule charges it.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.
    reference_sd_mm : float, optional
        The common reference D1 SD [mm]; None: no segment needs work.
    tamped_sd_mm : float, optional
        The D1 SD a tamping leaves (`Rates.tamped_sd_mm`) [mm]; None: the share is 1 for a
        segment that needs work, else 0.

    Returns
    -------
    pandas.DataFrame
        ``d1_sd_horizon_mm``, ``since_tamping_mgt``, ``needs_work`` (bool),
        ``residual_share`` [-], one row per segment.
    """
    horizon = float(ds.mgt[-1])
    sd = ds.d1_sd.isel(mgt=-1).max("rail").values
    last = np.zeros(sd.size)
    for m, j in zip(ds.intervention_mgt.values, ds.intervention_segment.values, strict=True):
        last[j] = max(last[j], float(m))
    need = np.zeros(sd.size, bool) if reference_sd_mm is None else sd >= reference_sd_mm
    share = need.astype(float)
    if reference_sd_mm is not None and tamped_sd_mm is not None:
        share = np.clip((sd - tamped_sd_mm) / (reference_sd_mm - tamped_sd_mm), 0.0, 1.0)
    return pd.DataFrame({"d1_sd_horizon_mm": sd, "since_tamping_mgt": horizon - last,
                         "needs_work": need, "residual_share": share})  # fmt: skip


def end_totals(datasets, reference_sd_mm: float | None) -> dict:
    """The end state of an alternative over its sections (`end_state`).

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Results of `trackdyn.deterioration.predict`, one per section.
    reference_sd_mm : float, optional
        The common reference D1 SD [mm].

    Returns
    -------
    dict
        ``d1_sd_horizon_max_mm`` and ``d1_sd_horizon_mean_mm`` (over the segments,
        weighted by their length) [mm], ``since_tamping_mean_mgt`` (the same) [MGT],
        ``needs_work_m``, the length at or over the reference at the horizon [m].
    """
    frames = [end_state(ds, reference_sd_mm).assign(
        length=(ds.segment_end - ds.segment_start).values) for ds in datasets]  # fmt: skip
    f = pd.concat(frames, ignore_index=True)
    w = f["length"].to_numpy()
    return {
        "d1_sd_horizon_max_mm": float(f["d1_sd_horizon_mm"].max()),
        "d1_sd_horizon_mean_mm": float(np.average(f["d1_sd_horizon_mm"], weights=w)),
        "since_tamping_mean_mgt": float(np.average(f["since_tamping_mgt"], weights=w)),
        "needs_work_m": float(w[f["needs_work"].to_numpy()].sum()),
    }


def discounted_work(ds, rates: Rates) -> dict:
    """One section's work, each part weighted by its present-value factor (`Rates.at`):
    ``tamped_m`` and ``renewed_m`` [m], ``possessions`` [-], and the residual rule's
    ``residual_m`` (each segment's length times its ``residual_share``) [m] and
    ``residual_possessions`` (of the runs that need work) [-] at the horizon. Undiscounted, the
    plain lengths and counts.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict` with maintenance.
    rates : Rates
        The discounting and the reference state.
    """
    seg = ds.intervention_segment.values
    length = (ds.segment_end - ds.segment_start).values
    kind = ds.intervention_kind.values.astype(str)
    factor = rates.at(1.0, ds.intervention_mgt.values)
    out = {f"{name}_m": float((length[seg] * factor)[kind == which].sum())
           for name, which in (("tamped", "tamping"), ("renewed", "renewal"))}  # fmt: skip
    out["possessions"] = float(sum(rates.at(1.0, m) for m, _ in possessions(ds)))
    end = end_state(ds, rates.reference_sd_mm, rates.tamped_sd_mm)
    need = np.flatnonzero(end["needs_work"].to_numpy())
    at_horizon = float(rates.at(1.0, float(ds.mgt[-1])))
    out["residual_m"] = float((length * end["residual_share"].to_numpy()).sum()) * at_horizon
    out["residual_possessions"] = len(runs(need)) * at_horizon
    return out


def costs(work: dict, rates: Rates, intervention: float = 0.0,
          intervention_year: float = 0.0) -> dict:  # fmt: skip
    """Present value of an alternative's costs [currency].

    Parameters
    ----------
    work : dict
        `discounted_work`, summed over the alternative's sections.
    rates : Rates
        The costs.
    intervention : float
        Cost of the intervention itself [currency].
    intervention_year : float
        When it is spent, from the start [year].

    Returns
    -------
    dict
        ``tamping_cost``, ``renewal_cost``, ``possession_cost``, ``intervention_cost``,
        ``residual_cost`` (the end state's work) and ``life_cycle_cost``, their sum.
    """
    out = {
        "tamping_cost": rates.tamping_per_m * work["tamped_m"],
        "renewal_cost": rates.renewal_per_m * work["renewed_m"],
        "possession_cost": rates.per_possession * work["possessions"],
        "intervention_cost": float(
            present_value(intervention, intervention_year, rates.discount_rate)
        ),  # fmt: skip
        "residual_cost": rates.tamping_per_m * work["residual_m"]
        + rates.per_possession * work["residual_possessions"],
    }
    out["life_cycle_cost"] = (out["tamping_cost"] + out["renewal_cost"] + out["possession_cost"]
                              + out["intervention_cost"] + out["residual_cost"])  # fmt: skip
    return out
