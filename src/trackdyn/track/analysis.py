"""What `trackdyn track` computes, as one xarray Dataset, and the figures' data.

Loaded profile and linearised stiffness (seed §5.2), D1/D2 longitudinal level quality, and
the deflection basin over a voided sleeper (the situation of the seed's Fig 5.2).

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading
and spatially varying track stiffness. PhD thesis, University of Pretoria, §5.1-5.2.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
import xarray as xr

from trackdyn.beam.static import linear_supports, solve_beam
from trackdyn.track.quality import longitudinal_level, segment_sd
from trackdyn.track.track import RAILS, LinearisedTrack
from trackdyn.units import GRAVITY

QUALITY_BANDS = ("D1", "D2")
SEGMENT_M = 200.0
"""Length of the quality segments [m]."""


def quality_table(
    distance, profiles: dict, segment_length: float = SEGMENT_M, where: str = "", first: int = 0
) -> xr.DataArray:
    """Standard deviation of longitudinal level per band, rail and segment [mm].

    Parameters
    ----------
    distance : ndarray
        Position along the track [m].
    profiles : dict
        Vertical profile per rail name [m].
    segment_length : float
        Segment length for the standard deviation [m].
    where : str
        Source of the profiles (a file) named in error messages.
    first : int
        Index of the sample where the first segment starts; the filters see all samples.
    """
    values, segments = [], None
    for band in QUALITY_BANDS:
        per_rail = []
        for rail in profiles:
            level = longitudinal_level(distance, profiles[rail], band, where=where)
            table = segment_sd(distance[first:], level[first:], segment_length)
            per_rail.append(table["sd_mm"].to_numpy())
            segments = table
        values.append(per_rail)
    assert segments is not None, "no profiles"
    return xr.DataArray(
        np.array(values),
        dims=("band", "rail", "segment"),
        coords={
            "band": list(QUALITY_BANDS),
            "rail": list(profiles),
            "segment_start": ("segment", segments["segment_start_m"].to_numpy(), {"units": "m"}),
            "segment_end": ("segment", segments["segment_end_m"].to_numpy(), {"units": "m"}),
        },
        attrs={"units": "mm", "long_name": "standard deviation of longitudinal level"},
    )


def track_dataset(lin: LinearisedTrack, keep=(-np.inf, np.inf)) -> xr.Dataset:
    """Profiles, linearised stiffness and geometry quality of a linearised track.

    Parameters
    ----------
    lin : LinearisedTrack
        Track linearised about the static wheel load.
    keep : tuple of float
        Keep the profile samples, sleepers and quality segments that start in ``[lo, hi)``
        [m], a section of a longer track; the quality filters see the whole of ``lin``.

    Returns
    -------
    xarray.Dataset
        ``unloaded_profile`` and ``loaded_profile`` (rail, distance) [m]; ``k2`` [N/m] and
        ``ys`` [m] (rail, sleeper); ``sd_unloaded`` and ``sd_loaded`` (band, rail,
        segment) [mm].
    """
    g = lin.track.geometry
    pos = lin.track.supports.position
    lo, hi = lin.track.extent
    inside = (g.distance >= lo) & (g.distance <= hi)
    x = g.distance[inside]
    unloaded = {r: g.profile(r)[inside] for r in RAILS}
    loaded = {r: lin.loaded_profile(r)[inside] for r in RAILS}
    bounds = np.asarray(keep) - 1e-9 * SEGMENT_M  # as segment_sd's tolerance
    a, b = np.searchsorted(x, bounds)
    sleepers = slice(*np.searchsorted(pos, bounds))
    sd = {}
    for name, profiles in (("sd_unloaded", unloaded), ("sd_loaded", loaded)):
        table = quality_table(x, profiles, where=g.where, first=a)
        sd[name] = table.isel(segment=table.segment_start.values < bounds[1])
    ds = xr.Dataset(
        {
            "unloaded_profile": (
                ("rail", "distance"),
                np.array([unloaded[r][a:b] for r in RAILS]),
                {"units": "m", "long_name": "unloaded vertical space curve", "positive": "down"},
            ),
            "loaded_profile": (
                ("rail", "distance"),
                np.array([loaded[r][a:b] for r in RAILS]),
                {"units": "m", "long_name": "loaded profile (unloaded + ys)", "positive": "down"},
            ),
            "k2": (
                ("rail", "sleeper"),
                lin.k2[:, sleepers],
                {"units": "N/m", "long_name": "effective linearised loaded stiffness (5.10)"},
            ),
            "ys": (
                ("rail", "sleeper"),
                lin.ys[:, sleepers],
                {"units": "m", "long_name": "static track deflection (5.11)"},
            ),
            **sd,
        },
        coords={
            "rail": list(RAILS),
            "distance": ("distance", x[a:b], {"units": "m"}),
            "sleeper_distance": ("sleeper", pos[sleepers], {"units": "m"}),
        },
        attrs={
            "static_wheel_load_N": lin.static_load,
            "delta": lin.delta,
            "geometry_source": g.where,
            "supports_source": lin.track.supports.where,
        },
    )
    return ds


def summary_table(ds: xr.Dataset) -> pd.DataFrame:
    """One row per rail: linearised stiffness, static deflection, worst D1/D2 quality.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `track_dataset`.
    """
    rows = []
    for r, name in enumerate(ds.rail.values):
        k2 = ds.k2.isel(rail=r).values / 1e6
        sd = ds.sd_unloaded.isel(rail=r)
        rows.append(
            {
                "rail": str(name),
                "k2_mean_kN_per_mm": k2.mean(),
                "k2_min_kN_per_mm": k2.min(),
                "k2_max_kN_per_mm": k2.max(),
                "ys_mean_mm": float(ds.ys.isel(rail=r).mean()) * 1e3,
                "d1_sd_max_mm": float(sd.sel(band="D1").max()),
                "d2_sd_max_mm": float(sd.sel(band="D2").max()),
            }
        )
    return pd.DataFrame(rows)


@dataclass(frozen=True)
class CurvePick:
    """A sleeper's measured curve picked for the load-deflection figure.

    Parameters
    ----------
    label : str
        Why it was picked (``softest``, ``stiffest``, ``largest ys``, ``median``, joined
        when one curve meets several).
    rail : str
        ``left`` or ``right``.
    position : float
        Sleeper position [m].
    curve : SupportCurve
        The measured curve.
    k2 : float
        Its linearised stiffness [N/m].
    ys : float
        Its static deflection [m].
    """

    label: str
    rail: str
    position: float
    curve: object
    k2: float
    ys: float


def curve_picks(k2: np.ndarray, ys: np.ndarray, position: np.ndarray, curve) -> list[CurvePick]:
    """The softest, stiffest, largest-ys and median sleepers, one pick per sleeper.

    Parameters
    ----------
    k2, ys : ndarray
        Linearised stiffness [N/m] and static deflection [m], (2 rails, sleepers).
    position : ndarray
        Sleeper positions [m].
    curve : callable
        ``curve(r, i)``: the measured curve of rail ``r`` at sleeper ``i``.
    """
    criteria = {
        "softest": np.argmin(k2),
        "stiffest": np.argmax(k2),
        "largest ys": np.argmax(ys),
        "median": np.argsort(k2, axis=None)[k2.size // 2],
    }
    labels: dict[int, list[str]] = {}
    for label, flat in criteria.items():
        labels.setdefault(int(flat), []).append(label)
    picks = []
    for flat, names in labels.items():
        r, i = (int(v) for v in np.unravel_index(flat, k2.shape))
        picks.append(
            CurvePick(" and ".join(names), RAILS[r], float(position[i]), curve(r, i),
                      float(k2[r, i]), float(ys[r, i]))
        )  # fmt: skip
    return picks


def most_voided(lin: LinearisedTrack, sleepers=slice(None)) -> tuple[int, int]:
    """Rail index and sleeper index of the largest seating gap among ``sleepers``.

    Ties go to the left rail, then to the first sleeper.

    Parameters
    ----------
    lin : LinearisedTrack
        Linearised track.
    sleepers : slice
        Sleepers to look at (indices of ``lin``'s sleepers).
    """
    gaps = lin.seating_gap()[:, sleepers]
    r, i = np.unravel_index(np.argmax(gaps), gaps.shape)
    return int(r), int(i) + range(lin.k2.shape[1])[sleepers].start


def voided_basin(lin: LinearisedTrack, rail_section, window: float = 12.0, sleepers=slice(None)):
    """Deflection basin under the static wheel load over the most voided sleeper.

    The supports within ``window`` [m] each side become tensionless linear springs with the
    stiffness equivalent to k2 (5.7 times the spacing) behind their seating gap; the same
    beam without gaps is the reference. The rail's own weight rests on the supports (it
    keeps the unloaded rail from lifting off); the basin shown is the wheel's addition.

    Parameters
    ----------
    lin : LinearisedTrack
        Linearised track.
    rail_section : RailSection
        Rail section (bending stiffness and mass per metre).
    window : float
        Half length of the modelled rail [m].
    sleepers : slice
        Sleepers among which the most voided is sought (`most_voided`).

    Returns
    -------
    rail : str
        Rail of the most voided sleeper.
    position : float
        Its position [m].
    with_gap, without_gap : BeamSolution
        Basins with the wheel, less the rail's own-weight state.
    """
    gaps = lin.seating_gap()
    r, i = most_voided(lin, sleepers)
    pos = lin.track.supports.position
    x0 = pos[i]
    near = np.abs(pos - x0) <= window
    x = pos[near]
    k = lin.support_stiffness(rail_section.EI)[r, near]
    weight = rail_section.mass * GRAVITY * np.gradient(x)
    solutions = []
    for gap in (gaps[r, near], 0.0):
        supports = linear_supports(x, k, gap)
        rest = solve_beam(supports, rail_section.EI, x, weight)
        loaded = solve_beam(supports, rail_section.EI, np.r_[x, x0], np.r_[weight, lin.static_load])
        solutions.append(
            replace(
                loaded,
                deflection=loaded.deflection - rest.deflection_at(loaded.x),
                support_deflection=loaded.support_deflection - rest.support_deflection,
                support_force=loaded.support_force - rest.support_force,
            )
        )
    return RAILS[r], float(x0), solutions[0], solutions[1]
