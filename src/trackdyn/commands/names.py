"""Words for the names of the commands' table columns and result variables.

The netCDF writer (`trackdyn.commands.netcdf`) gives a variable that has no ``long_name``
its words from here (the full name first, then the name without its unit), so that
``ds.tamped_m_per_100_mgt.attrs["long_name"]`` reads "length of track tamped per 100 MGT"
rather than "tamped".
"""

from __future__ import annotations

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
    "needs_work": "length of track at or over the reference D1 SD at the horizon",
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
}
"""Words by name (a column or variable name, or the name without its unit)."""


def words(name: str) -> str:
    """The words for ``name``: from `WORDS` (the full name, then without its unit), else
    the name without its unit, ``_`` as spaces."""
    stem = name_unit(name)[0]
    return WORDS.get(name) or WORDS.get(stem) or stem.replace("_", " ")
