"""Words for the names of the commands' table columns and result variables.

The netCDF writer (`trackdyn.commands.netcdf`) gives a variable that has no ``long_name``
its words from here (the full name first, then the name without its unit), so that
``ds.tamped_m_per_100_mgt.attrs["long_name"]`` reads "length of track tamped per 100 MGT"
rather than "tamped".
"""

from __future__ import annotations

from trackdyn.deterioration.results import HANGING_GAP
from trackdyn.units import name_unit

WORDS = {
    # a run's and a study's statistics (`trackdyn.results.summary`, a study's row)
    "dyn_load_max": "largest dynamic wheel load (wheel load less the static load)",
    "dyn_load_min": "smallest dynamic wheel load (wheel load less the static load)",
    "dyn_load_sd": "standard deviation of the dynamic wheel load, mean over the contacts",
    "secondary_max": "largest displacement across any secondary suspension",
    "body_bounce_acc_rms": "RMS of the body bounce acceleration",
    "dominant_frequency": "peak frequency of the first contact's dynamic wheel load",
    "error": "why the run failed (empty: it ran)",
    "run": "run of the study (0: first)",
    "speed": "vehicle speed",
    "parameter": "vehicle parameter varied",
    "factor": "factor on the parameter's value",
    "vehicle": "vehicle",
    "case": "case of the study matrix",
    "damping": "secondary damping variant",
    # an interventions study's comparison (`trackdyn.studies.interventions`)
    "alternative": "alternative compared",
    "tampings": "number of tampings",
    "renewals": "number of ballast renewals",
    "tamped_m": "length of track tamped",
    "renewed_m": "length of track with its ballast renewed",
    "mean_interval_mgt": "mean tonnage between two interventions on a segment",
    "tamped_m_per_100_mgt": "length of track tamped per 100 MGT",
    "tamping_cost": "cost of the tampings",
    "renewal_cost": "cost of the renewals",
    "possessions": "number of possessions (tamping runs)",
    "d1_sd_horizon_max": "largest D1 SD of a segment at the horizon (the worse rail)",
    "d1_sd_horizon_mean": "D1 SD at the horizon (the worse rail), mean over the segments",
    "since_tamping_mean": "tonnage since the last tamping at the horizon, segment mean",
    "needs_work_m": "length of track at or over the reference D1 SD at the horizon",
    "needs_work": "at or over the reference D1 SD at the horizon",
    "first_mgt": "tonnage of the first intervention",
    "d1_sd_horizon_mm": "D1 SD at the horizon (the worse rail)",
    "since_tamping_mgt": "tonnage since the last tamping at the horizon",
    "possession_cost": "cost of the possessions",
    "intervention_cost": "cost of the alternative's own works",
    "residual_cost": "residual cost: the work the end state leaves at the horizon",
    "life_cycle_cost": "life-cycle cost: tampings, renewals, possessions, works, residual",
    # positions and tonnages along a deterioration result or a track
    "sleeper_distance": "sleeper position along the track",
    "distance": "distance along the track",
    "segment_start": "start of the segment",
    "segment_end": "end of the segment",
    "snapshot_mgt": "tonnage of the snapshot",
    "step_start": "tonnage at the start of the step",
    "step_end": "tonnage at the end of the step",
    "intervention_segment": "segment of the intervention",
    "load_cycles": "load cycles applied to the rail seat",
    # headline figures (``summary.json``) and the columns of the tables written beside them
    "run.dyn_load_sd": "standard deviation of the dynamic wheel load",
    "run.dominant_frequency": "peak frequency of the contact's dynamic wheel load",
    "run headline.dyn_load_max": "largest dynamic wheel load, over the contacts",
    "run headline.dyn_load_min": "smallest dynamic wheel load, over the contacts",
    "dyn_load_sd_max": "standard deviation of the dynamic wheel load, largest over the contacts",
    "study headline.dyn_load_max": "largest dynamic wheel load, over the runs and contacts",
    "study headline.dyn_load_sd_max": "standard deviation of the dynamic wheel load (mean "
    "over the contacts), largest over the runs",
    "runs": "runs of the study",
    "failed_runs": "runs that failed",
    "contact": "wheel-rail contact",
    "mgt": "tonnage",
    "deteriorate headline.mgt": "tonnage simulated",
    "steps": "steps of the deterioration loop",
    "settlement_min": "smallest settlement at the end",
    "settlement_mean": "mean settlement at the end",
    "settlement_max": "largest settlement at the end",
    "d1_sd_max_initial": "largest D1 SD of a segment at the start",
    "d1_sd_max_final": "largest D1 SD of a segment at the end",
    "first_trigger": "tonnage at which the first segment reaches the threshold",
    "interventions": "number of interventions",
    "hanging_rail_seats_final": (
        f"sleeper rail seats hanging at the end (gap over {HANGING_GAP * 1e3:g} mm)"
    ),
    "void_d1_share_max": "largest share of a segment's D1 unevenness due to voids",
    "d1_sd_mm": "D1 SD",
    "d1_sd_left_initial": "D1 SD of the left rail at the start",
    "d1_sd_left_final": "D1 SD of the left rail at the end",
    "d1_sd_right_initial": "D1 SD of the right rail at the start",
    "d1_sd_right_final": "D1 SD of the right rail at the end",
    "trigger_left_mgt": "tonnage at which the left rail reaches the threshold",
    "trigger_right_mgt": "tonnage at which the right rail reaches the threshold",
    "trigger_mgt": "tonnage at which either rail reaches the threshold",
    "threshold_sd": "D1 SD threshold",
    "step": "step",
    "start_mgt": "tonnage at the start of the step",
    "end_mgt": "tonnage at the end of the step",
    "max_settlement": "largest settlement in the step",
    "vehicle_runs": "vehicle runs in the step",
    "load_updates": "rail-seat load updates in the step",
    "passages": "passages",
    "settlement_share": "share of the settlement",
    "settlement_share_per_1000_passages": "share of the settlement per 1000 passages",
    "settlement_mm_per_mgt": "settlement rate",
    "d1_variance_share": "share of the D1 variance",
    "members": "members of the forecast ensemble",
    "p10": "10th percentile",
    "p50": "median",
    "p90": "90th percentile",
    "stretches": "stretches planned",
    "deferred": "stretches deferred by the plan's cap",
    "years": "years planned",
    "k2_mean": "track stiffness k2, mean",
    "k2_min": "track stiffness k2, smallest",
    "k2_max": "track stiffness k2, largest",
    "ys_mean": "static deflection ys, mean",
    "d1_sd_max": "largest D1 SD of a segment",
    "d2_sd_max": "largest D2 SD of a segment",
    "status": "result of the fit",
    "rms_misfit_start": "RMS misfit of the D1-band change at the start",
    "rms_misfit_fitted": "RMS misfit of the D1-band change, fitted",
    "model_runs": "model runs of the fit",
    "value": "fitted value",
    "standard_error": "standard error",
}
"""Words by name (a column or variable name, or the name without its unit); a name
preceded by a command (``run.dyn_load_sd``: in its tables) or by a command's headline
(``study headline.dyn_load_sd_max``: in ``summary.json``) is what it means there where it
differs."""

GROUPS = {
    "sections": "Sections",
    "forecast_first_tamping_mgt": "First tamping per segment, forecast ensemble",
    "plan": "Plan",
    "alternatives": "Alternatives compared",
    "life_cycle_cost_spread": "Life-cycle cost over the forecast members",
    "parameters": "Fitted parameters (the parameter file's units)",
    "rails": "Per rail",
}
"""Titles of the headline's tables (a group of figures in ``summary.json``)."""

FIGURES = {
    # run
    "wheel_loads": "Wheel loads of the front and back contacts along the track",
    "wheel_load_exceedance": "Share of the run with a wheel load above each value",
    "secondary_displacement": "Displacement across the secondary suspensions",
    "wedge_friction": "Friction wedges: force against displacement and velocity",
    # track
    "track_overview": "The track: unloaded profile, D1 band, static deflection, stiffness",
    "load_deflection": "Load-deflection curves of the supports",
    "deflection_basin": "Deflection basin under the static wheel load",
    # study
    "study_cases": "Statistics of the study's cases",
    "tornado": "Sensitivity of the dynamic wheel load to each parameter",
    "speed_sweep": "Dynamic wheel load against speed",
    "spectra": "Wheel-load spectra",
    # deteriorate (per section: ``<section>_<kind>``)
    "line": "The line: D1 SD of every section's segments over the tonnage",
    "quality": "D1 SD per segment over the tonnage, with each tamping",
    "straight_line": "Straight-line diagram: segments along the track against tonnage",
    "geometry": "Track geometry at the snapshot tonnages",
    "settlement_map": "Settlement along the track against tonnage",
    "forecast_fan": "D1 SD per segment: the forecast members' median and 10-90 % band",
    "forecast_probability": "Share of the forecast members that reach the threshold",
    "plan": "Stretches planned by year along the line",
    # study of interventions
    "interventions_compared": "Interventions compared: tampings, renewals and costs",
    # calibrate
    "calibration": "Measured against predicted change of the surveys",
    "rate_field": "Settlement-rate factor along both rails",
}
"""Figure captions by file stem (a deterioration section's figures by the stem's end), in
the order a report shows them: each command's main figure first."""


def words(name: str, command: str | None = None) -> str:
    """The words for ``name``: from `WORDS` (the full name, then without its unit; each
    first as ``command`` means it), else the name without its unit, ``_`` as spaces."""
    stem = name_unit(name)[0]
    keys = [f"{command}.{name}", f"{command}.{stem}"] if command else []
    found = (WORDS.get(key) for key in [*keys, name, stem])
    return next((w for w in found if w), stem.replace("_", " "))


def caption(stem: str) -> tuple[int, str]:
    """A figure's place in a report and its caption, from `FIGURES` by its file ``stem``
    (``wheel_loads``; ``<section>_quality``: the section named after the caption); a figure
    not listed comes last, its stem in words."""
    order = list(FIGURES)
    if stem in FIGURES:
        return order.index(stem), FIGURES[stem]
    kinds = sorted((k for k in order if stem.endswith(f"_{k}")), key=len)  # straight_line
    if kinds:
        kind = kinds[-1]
        return order.index(kind), f"{FIGURES[kind]}: section {stem.removesuffix(f'_{kind}')}"
    return len(order), stem.replace("_", " ")
