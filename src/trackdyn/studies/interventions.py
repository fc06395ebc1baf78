"""Interventions compared: supports scaled over a range, and the maintenance each
alternative needs over the horizon with its cost.

A support stiffness scaled by ``factor`` over a distance range divides every deflection of
each load-deflection curve in the range by ``factor`` at the same loads (a linear support's
stiffness is multiplied by it): the secant stiffness at every load, and a void (the
deflection before the sleeper bears), scale by the same factor.

The costs over time, the possessions and the end state each alternative leaves are
`trackdyn.studies.life_cycle`'s.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trackdyn.errors import TrackdynInputError
from trackdyn.io import column, read_table
from trackdyn.studies.life_cycle import possessions

RAMPS = ("none", "up", "down")
"""How a scale runs over its range: all of it (``none``), or linearly from 1 at ``from_m``
to the factor at ``to_m`` (``up``: a transition treatment towards a stiff structure
beyond ``to_m``) or from the factor at ``from_m`` to 1 at ``to_m`` (``down``)."""


@dataclass(frozen=True)
class Scale:
    """Support stiffness times ``factor`` [-] from ``from_m`` to ``to_m`` [m], run over the
    range as ``ramp`` says (`RAMPS`)."""

    from_m: float
    to_m: float
    factor: float
    ramp: str = "none"

    def at(self, distance) -> np.ndarray:
        """The factor at each ``distance`` [m] (1 outside the range) [-]."""
        x = np.asarray(distance, dtype=float)
        inside = (x >= self.from_m) & (x <= self.to_m)
        along = (x - self.from_m) / (self.to_m - self.from_m)
        share = {"none": np.ones_like(x), "up": along, "down": 1.0 - along}[self.ramp]
        return np.where(inside, 1.0 + (self.factor - 1.0) * share, 1.0)


def support_extent(path) -> tuple[float, float]:
    """First and last sleeper position of a supports CSV [m]."""
    distance, _ = column(read_table(path, ("rail",)), "distance", "length", path)
    return float(distance.min()), float(distance.max())


def scale_supports(source, target, scales) -> None:
    """Write the supports CSV ``source`` to ``target`` with the stiffness scaled.

    Rows whose distance lies in a range (ends included) have their ``deflection_<unit>``
    divided, or their ``stiffness_<unit>`` multiplied, by the range's factor there
    (`Scale.at`); ranges that overlap multiply.

    Parameters
    ----------
    source, target : path
        Supports CSV read, and the one written.
    scales : sequence of Scale
        The ranges and factors.
    """
    frame = read_table(source, ("rail",))
    distance, _ = column(frame, "distance", "length", source)
    factor = np.ones(distance.size)
    for s in scales:
        factor *= s.at(distance)
    value = [c for c in frame.columns if c.startswith(("deflection_", "stiffness_"))]
    if len(value) != 1:
        raise TrackdynInputError(f"{source}: no deflection_<unit> or stiffness_<unit> column")
    name = value[0]
    numbers = frame[name].astype(float).to_numpy()
    frame[name] = numbers / factor if name.startswith("deflection_") else numbers * factor
    frame.to_csv(Path(target), index=False, float_format="%.9g")


def maintenance_totals(datasets) -> dict:
    """Maintenance of one alternative over the horizon, summed over its sections.

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Results of `trackdyn.deterioration.predict` (one per section), with maintenance.

    Returns
    -------
    dict
        ``tampings``, ``renewals`` [-]; ``tamped_m`` and ``renewed_m``, the segment length
        treated [m]; ``possessions``, the tamping runs (`trackdyn.studies.life_cycle.
        possessions`) [-]; ``mean_interval_mgt``, the mean tonnage between two interventions of
        a segment [MGT] (NaN without two on one segment); ``tamped_m_per_100_mgt``, the
        length tamped or renewed per 100 MGT [m].
    """
    out = dict.fromkeys(("tampings", "renewals", "tamped_m", "renewed_m", "possessions"), 0.0)
    intervals: list[float] = []
    per_100 = 0.0
    for ds in datasets:
        seg = ds.intervention_segment.values
        length = (ds.segment_end - ds.segment_start).values[seg]
        kind = ds.intervention_kind.values.astype(str)
        for name, metres, which in (("tampings", "tamped_m", "tamping"),
                                    ("renewals", "renewed_m", "renewal")):  # fmt: skip
            out[name] += int(np.sum(kind == which))
            out[metres] += float(length[kind == which].sum())
        out["possessions"] += len(possessions(ds))
        for j in np.unique(seg):
            intervals.extend(np.diff(np.sort(ds.intervention_mgt.values[seg == j])))
        per_100 += float(length.sum()) / float(ds.mgt[-1]) * 100.0
    out["mean_interval_mgt"] = float(np.mean(intervals)) if intervals else np.nan
    out["tamped_m_per_100_mgt"] = per_100
    return out
