"""The deterioration results as one xarray Dataset, and the maintenance trigger."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import xarray as xr

from trackdyn.deterioration.quality import D1Assessment
from trackdyn.deterioration.record import LoopRecord
from trackdyn.track.quality import longitudinal_level
from trackdyn.track.track import RAILS

HANGING_GAP = 0.1e-3
"""Gap above which a sleeper counts as hanging in ``hanging_sleepers`` [m]."""


def trigger_mgt(mgt, sd, threshold: float):
    """Tonnage at which each series first reaches ``threshold`` [MGT].

    Linear interpolation between the stored tonnages; 0 if it starts at or above the
    threshold, ``inf`` if it never reaches it.

    Parameters
    ----------
    mgt : ndarray
        Tonnage of each state, increasing [MGT].
    sd : ndarray
        Standard deviation, tonnage on the first axis [mm].
    threshold : float
        Maintenance threshold [mm].
    """
    sd = np.asarray(sd, dtype=float)
    out = np.full(sd.shape[1:], np.inf)
    flat_sd, flat_out = sd.reshape(sd.shape[0], -1), out.reshape(-1)
    for j in range(flat_sd.shape[1]):
        above = np.flatnonzero(flat_sd[:, j] >= threshold)
        if above.size == 0:
            continue
        k = above[0]
        if k == 0:
            flat_out[j] = mgt[0]
            continue
        s0, s1 = flat_sd[k - 1, j], flat_sd[k, j]
        flat_out[j] = mgt[k - 1] + (threshold - s0) / (s1 - s0) * (mgt[k] - mgt[k - 1])
    return out


def make_dataset(record: LoopRecord) -> xr.Dataset:
    """Assemble the loop's record into a Dataset with units in the attributes.

    Variables: ``settlement`` (mgt, rail, sleeper) [m], ballast settlement under each
    rail seat, positive down; ``hanging_gap`` (mgt, rail, sleeper) [m], the gap under each
    sleeper with the rail at rest (0 where it bears); ``hanging_sleepers`` (mgt, rail),
    sleepers with a gap over `HANGING_GAP`; ``rate_factor`` (rail, sleeper) [-], the
    settlement-rate factor; ``zone_kind`` (sleeper), the zone each sleeper lies in;
    ``settlement_by_vehicle`` (vehicle, rail, sleeper) [m], each vehicle's part of the
    final settlement; ``d1_sd`` (mgt, rail, segment) [mm]; ``trigger_mgt`` (rail,
    segment) [MGT], when the D1 SD first reaches
    ``threshold_sd_mm`` (inf: not within the horizon), and ``trigger_mgt_any_rail``
    (segment); ``profile`` (snapshot, rail, distance) [m], the unloaded space curve at the
    snapshot tonnages; ``load_cycles`` (rail, sleeper) [-], cycles applied in total;
    per step: ``step_start``, ``step_end`` [MGT], ``step_max_settlement`` [m],
    ``step_load_updates``, the rail-seat load updates within it, and
    ``peak_rail_seat_load`` (step, rail, sleeper) [N], the largest load at its start;
    per intervention of the maintenance (`trackdyn.deterioration.maintenance`):
    ``intervention_mgt`` [MGT], ``intervention_segment``, ``intervention_kind`` (tamping or
    renewal), ``d1_sd_before`` and ``d1_sd_after`` (intervention, rail) [mm] and
    ``intervention_lift`` [m], the mean lift; ``interventions`` (segment), how many each
    segment had. With the loop's ``voids`` option (`trackdyn.deterioration.voids`; the
    void depth per sleeper over MGT is ``hanging_gap``): ``void_rate_factor`` (mgt, rail,
    sleeper) [-], the settlement-rate factor of ballast under a void; ``void_settlement``
    (rail, sleeper) [m], the part of the settlement due to it; ``void_d1_share`` (rail,
    segment) [-], the voids' share of the D1-band unevenness the settlement made in each
    segment (`void_d1_share`). With maintenance, the state stored at a tonnage is the one before any
    tamping at that tonnage. The attributes hold the law, the traffic, the seconds spent
    and the loop options in SI (`LoopOptions.in_si`, ``option_<name>``).

    Parameters
    ----------
    record : LoopRecord
        What the loop recorded (`trackdyn.deterioration.record`).
    """
    mgt = np.array([s.mgt for s in record.states])
    assess = D1Assessment(record.track.extent, record.options.segment_length)
    quality = [assess(s.geometry) for s in record.states]
    starts, ends = quality[0][1], quality[0][2]
    snap_index = [int(np.argmin(np.abs(mgt - m))) for m in record.snap_at]
    variables = {
        **_state_variables(record, mgt, np.array([q[0] for q in quality]), snap_index),
        **_section_variables(record),
        **_intervention_variables(record.interventions, starts.size),
        **_step_variables(record.steps, record.track.supports.position.size),
        **_void_variables(record, starts, ends),
    }
    coords = {
        "mgt": ("mgt", mgt, {"units": "MGT", "long_name": "accumulated traffic"}),
        "rail": list(RAILS),
        "vehicle": [t.label or t.vehicle.name for t in record.traffic],
        "sleeper_distance": ("sleeper", record.track.supports.position, {"units": "m"}),
        "distance": ("distance", record.track.geometry.distance, {"units": "m"}),
        "snapshot_mgt": ("snapshot", mgt[snap_index], {"units": "MGT"}),
        "segment_start": ("segment", starts, {"units": "m"}),
        "segment_end": ("segment", ends, {"units": "m"}),
    }
    return xr.Dataset(variables, coords=coords, attrs=_attributes(record))


def _state_variables(record: LoopRecord, mgt, sd, snap_index) -> dict:
    """The variables of the stored states: settlement, D1 SD and its triggers, the
    snapshots' profiles, the hanging sleepers."""
    trigger = trigger_mgt(mgt, sd, record.options.threshold_sd_mm)
    segments = sd.shape[-1]
    first = _first(record.interventions, segments)
    geometries = [record.states[k].geometry for k in snap_index]
    profiles = np.array([[g.profile(r) for r in RAILS] for g in geometries])
    gaps = np.array([s.hanging_gap for s in record.states])
    threshold = record.options.threshold_sd_mm
    return {
        "settlement": (
            ("mgt", "rail", "sleeper"),
            np.array([s.settlement for s in record.states]),
            {"units": "m", "long_name": "sleeper settlement", "positive": "down"},
        ),
        "d1_sd": (
            ("mgt", "rail", "segment"),
            sd,
            {"units": "mm", "long_name": "standard deviation of D1 longitudinal level"},
        ),
        "trigger_mgt": (
            ("rail", "segment"),
            trigger,
            {"units": "MGT", "long_name": f"tonnage at D1 SD >= {threshold} mm"},
        ),
        "trigger_mgt_any_rail": (
            "segment",
            np.minimum(trigger.min(axis=0), first),
            {"units": "MGT", "long_name": "first tonnage at which either rail triggers"},
        ),
        "profile": (
            ("snapshot", "rail", "distance"),
            profiles,
            {"units": "m", "long_name": "unloaded vertical space curve", "positive": "down"},
        ),
        "hanging_gap": (
            ("mgt", "rail", "sleeper"),
            gaps,
            {"units": "m", "long_name": "gap under the sleeper with the rail at rest"},
        ),
        "hanging_sleepers": (
            ("mgt", "rail"),
            np.sum(gaps > HANGING_GAP, axis=-1),
            {"units": "1", "long_name": f"sleepers hanging by more than {HANGING_GAP} m"},
        ),
    }


def void_d1_share(position, settlement, part, starts, ends) -> np.ndarray:
    """The share of a settlement's D1-band unevenness (EN 13848-1, along the sleepers) in
    each segment that a part of it makes, (rail, segment) [-].

    The variance is split by covariance, as each vehicle's share (`vehicle_shares`):
    ``Σ cov(D1(e_p), D1(e)) / Σ var(D1(e))`` over the segment's sleepers; NaN where the
    settlement is even. With tamping, it is the share of all the settlement so far, not of
    the geometry since the last tamping.

    Parameters
    ----------
    position : ndarray
        Sleeper positions [m].
    settlement, part : ndarray
        The settlement and its part, (rail, sleeper) [m].
    starts, ends : ndarray
        Segment bounds [m].
    """
    whole = np.array([longitudinal_level(position, e, "D1") for e in settlement])
    own = np.array([longitudinal_level(position, e, "D1") for e in part])
    out = np.full((whole.shape[0], len(starts)), np.nan)
    for j, (a, b) in enumerate(zip(starts, ends, strict=True)):
        inside = (position >= a) & (position <= b)
        variance = np.sum(whole[:, inside] ** 2, axis=-1)
        cov = np.sum(own[:, inside] * whole[:, inside], axis=-1)
        out[:, j] = np.divide(cov, variance, out=out[:, j], where=variance > 0)
    return out


def _void_variables(record: LoopRecord, starts, ends) -> dict:
    """The variables of ballast under a void, with the loop's ``voids`` option."""
    if record.void_settlement is None:
        return {}
    pos = record.track.supports.position
    total = record.states[-1].settlement
    return {
        "void_rate_factor": (
            ("mgt", "rail", "sleeper"),
            np.array([s.void_factor for s in record.states]),
            {"units": "1", "long_name": "settlement-rate factor of ballast under a void"},
        ),
        "void_settlement": (
            ("rail", "sleeper"),
            record.void_settlement,
            {"units": "m", "long_name": "part of the settlement due to voids", "positive": "down"},
        ),
        "void_d1_share": (
            ("rail", "segment"),
            void_d1_share(pos, total, record.void_settlement, starts, ends),
            {"units": "1", "long_name": "share of the settlement's D1 unevenness due to voids"},
        ),
    }


def _section_variables(record: LoopRecord) -> dict:
    """The variables of the section's ballast: rate field, zones, each vehicle's part of
    the settlement, the load cycles applied."""
    return {
        "rate_factor": (
            ("rail", "sleeper"),
            record.rate,
            {"units": "1", "long_name": "settlement-rate factor of the ballast"},
        ),
        "zone_kind": ("sleeper", record.kind, {"long_name": "zone of the track"}),
        "settlement_by_vehicle": (
            ("vehicle", "rail", "sleeper"),
            record.by_vehicle,
            {
                "units": "m",
                "long_name": "each vehicle's part of the settlement",
                "positive": "down",
            },
        ),
        "load_cycles": (("rail", "sleeper"), record.cycles, {"units": "1"}),
    }


def _intervention_variables(done: list, segments: int) -> dict:
    """The variables of the maintenance's interventions, and how many each segment had."""
    segment_of = np.array([i.segment for i in done], dtype=int)
    before = np.array([i.sd_before for i in done]).reshape(len(done), len(RAILS))
    after = np.array([i.sd_after for i in done]).reshape(len(done), len(RAILS))
    return {
        "intervention_mgt": (
            "intervention",
            np.array([i.mgt for i in done], dtype=float),
            {"units": "MGT", "long_name": "tonnage of the tamping or renewal"},
        ),
        "intervention_segment": ("intervention", segment_of, {"long_name": "segment"}),
        "intervention_kind": (
            "intervention",
            np.array([i.kind for i in done], dtype=str),
            {"long_name": "tamping or renewal"},
        ),
        "d1_sd_before": (
            ("intervention", "rail"),
            before,
            {"units": "mm", "long_name": "D1 SD of the segment before the intervention"},
        ),
        "d1_sd_after": (
            ("intervention", "rail"),
            after,
            {"units": "mm", "long_name": "D1 SD of the segment after the intervention"},
        ),
        "intervention_lift": (
            "intervention",
            np.array([i.lift for i in done], dtype=float),
            {"units": "m", "long_name": "mean lift of the segment's sleepers"},
        ),
        "interventions": (
            "segment",
            np.bincount(segment_of, minlength=segments),
            {"units": "1", "long_name": "tampings and renewals of the segment"},
        ),
    }


def _step_variables(steps: list, sleepers: int) -> dict:
    """The variables of the tonnage steps."""
    peak = np.array([s.peak_load for s in steps]).reshape(len(steps), len(RAILS), sleepers)
    return {
        "step_start": ("step", np.array([s.start for s in steps]), {"units": "MGT"}),
        "step_end": ("step", np.array([s.end for s in steps]), {"units": "MGT"}),
        "step_max_settlement": (
            "step",
            np.array([s.max_settlement for s in steps]),
            {"units": "m", "long_name": "largest settlement of any sleeper in the step"},
        ),
        "step_load_updates": (
            "step",
            np.array([s.load_updates for s in steps], dtype=int),
            {"units": "1", "long_name": "rail-seat load updates (beam solves) in the step"},
        ),
        "step_vehicle_runs": (
            "step",
            np.array([s.vehicle_runs for s in steps], dtype=int),
            {"units": "1", "long_name": "vehicles run in the step (the others held)"},
        ),
        "peak_rail_seat_load": (
            ("step", "rail", "sleeper"),
            peak,
            {"units": "N", "long_name": "largest rail-seat load of the step"},
        ),
    }


def _attributes(record: LoopRecord) -> dict:
    """The Dataset's attributes: law, traffic, steps, seconds, sources, options in SI."""
    traffic, timing, track = record.traffic, record.timing, record.track
    return {
        "settlement_law": type(record.law).__name__,
        "settlement_parameters_SI": dataclasses.asdict(record.law),
        "passages_per_mgt": ";".join(f"{t.passages_per_mgt:.17g}" for t in traffic),
        "traffic": "; ".join(
            f"{t.label or t.vehicle.name} at {t.speed_kmh:g} km/h, "
            f"{t.passages_per_mgt:g} passages/MGT"
            for t in traffic
        ),
        "gross_tonnes_per_mgt_of_traffic": sum(
            t.gross_mass(record.options.run.model) / 1e3 * t.passages_per_mgt for t in traffic
        ),
        "steps": len(record.steps),
        "time_vehicle_runs_s": timing.vehicle,
        "time_beam_solves_s": timing.beam,
        "time_bookkeeping_s": timing.total - timing.vehicle - timing.beam,
        "geometry_source": track.geometry.where,
        "supports_source": track.supports.where,
        **{f"option_{k}": v for k, v in _flat_options(record.options).items()},
    }


def _first(done, segments: int) -> np.ndarray:
    """Tonnage of each segment's first intervention [MGT] (inf: none): with maintenance a
    segment is due within `trackdyn.deterioration.maintenance.DUE_MARGIN` of the
    threshold, which the stored states may not show."""
    first = np.full(segments, np.inf)
    for i in done[::-1]:
        first[i.segment] = i.mgt
    return first


def _flat_options(options) -> dict:
    """Loop options in SI (`LoopOptions.in_si`), the run and maintenance options spelled
    out as ``run_<name>`` and ``maintenance_<name>``."""
    flat = options.in_si()
    run, maintenance, voids = flat.pop("run"), flat.pop("maintenance"), flat.pop("voids")
    flat.update({f"run_{k}": v for k, v in run.model_dump().items()})
    if voids is not None:
        flat.update({f"voids_{k}": v for k, v in voids.model_dump().items()})
    if maintenance is not None:
        flat.update({f"maintenance_{k}": v for k, v in maintenance.model_dump().items()})
    return flat


def vehicle_shares(ds) -> pd.DataFrame:
    """Each vehicle's share of a section's settlement and of its D1-band unevenness.

    The settlement is the sum of each vehicle's part (`settlement_by_vehicle`, from the
    equivalent cycles of the law, `trackdyn.deterioration.accumulation`), so its shares
    add up to 1. The unevenness that D1 SD measures is not a sum; its variance is split by
    covariance, ``share_v = Σ_r cov(D1(e_v), D1(e)) / Σ_r var(D1(e))`` over the rails ``r``,
    with ``e_v`` the vehicle's settlement and ``D1`` the D1 band (EN 13848-1) along the
    sleepers: shares that add up to 1, NaN where the settlement is even.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.

    Returns
    -------
    pandas.DataFrame
        Per vehicle: ``passages_per_mgt``, ``settlement_share``,
        ``settlement_mm_per_mgt`` (mean over the rail seats),
        ``settlement_share_per_1000_passages``, ``d1_variance_share``.
    """
    pos = ds.sleeper_distance.values
    parts = ds.settlement_by_vehicle.values  # (vehicle, rail, sleeper) [m]
    total = parts.sum(axis=0)
    level = np.array(
        [[longitudinal_level(pos, p[r], "D1") for r in range(p.shape[0])] for p in parts]
    )
    whole = level.sum(axis=0)
    variance = float(np.sum(whole * whole))
    mean_total = float(total.mean())
    passages = [float(p) for p in ds.attrs["passages_per_mgt"].split(";") if p]
    mgt = float(ds.mgt[-1])
    rows = []
    for v, name in enumerate(ds.vehicle.values):
        share = float(parts[v].mean()) / mean_total if mean_total > 0 else 0.0
        cov = float(np.sum(level[v] * whole))
        rows.append(
            {
                "vehicle": str(name),
                "passages_per_mgt": passages[v],
                "settlement_share": share,
                "settlement_mm_per_mgt": float(parts[v].mean()) * 1e3 / mgt,
                "settlement_share_per_1000_passages": (
                    share / (passages[v] * mgt) * 1e3 if passages[v] > 0 else 0.0
                ),
                "d1_variance_share": cov / variance if variance > 0 else np.nan,
            }
        )
    return pd.DataFrame(rows)
