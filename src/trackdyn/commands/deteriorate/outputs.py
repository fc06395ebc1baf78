"""Files of a deterioration prediction: netCDF per section, CSV tables, figures."""

from __future__ import annotations

import numpy as np
import pandas as pd

from trackdyn.commands.drawing import Drawing, drawn
from trackdyn.commands.netcdf import write_netcdf
from trackdyn.deterioration.results import vehicle_shares
from trackdyn.plots.deteriorate import (
    plot_geometry_evolution,
    plot_line,
    plot_quality_evolution,
    plot_settlement_map,
    plot_straight_line,
)


def _shares(ds) -> pd.DataFrame:
    """`vehicle_shares` of a section, with its name."""
    frame = vehicle_shares(ds)
    frame.insert(0, "section", ds.attrs["section"])
    return frame


def summary(datasets) -> pd.DataFrame:
    """One row per section: steps, final settlement and D1 SD, first maintenance trigger,
    the sleeper rail seats hanging at the end (by more than
    `trackdyn.deterioration.results.HANGING_GAP`) and, with the loop's ``voids`` option,
    the largest share of a segment's D1-band unevenness due to ballast under voids.

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Results of `trackdyn.deterioration.predict` with a ``section`` attribute.
    """
    rows = []
    for ds in datasets:
        final = ds.settlement.isel(mgt=-1) * 1e3
        trigger = ds.trigger_mgt_any_rail.values
        rows.append(
            {
                "section": ds.attrs["section"],
                "mgt": float(ds.mgt[-1]),
                "steps": int(ds.attrs["steps"]),
                "settlement_min_mm": float(final.min()),
                "settlement_mean_mm": float(final.mean()),
                "settlement_max_mm": float(final.max()),
                "d1_sd_max_initial_mm": float(ds.d1_sd.isel(mgt=0).max()),
                "d1_sd_max_final_mm": float(ds.d1_sd.isel(mgt=-1).max()),
                "first_trigger_mgt": float(np.min(trigger)) if trigger.size else np.inf,
                "interventions": int(ds.sizes["intervention"]),
                "hanging_rail_seats_final": int(ds.hanging_sleepers.isel(mgt=-1).sum()),
            }
        )
        if "void_d1_share" in ds:
            rows[-1]["void_d1_share_max"] = float(ds.void_d1_share.max())
    return pd.DataFrame(rows)


def settlement_table(ds) -> pd.DataFrame:
    """Settlement per sleeper and rail at the snapshot tonnages [mm], one column each.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict` with a ``section`` attribute.
    """
    frames = []
    at = ds.settlement.sel(mgt=ds.snapshot_mgt.values)
    for rail in ds.rail.values:
        frame = pd.DataFrame({"distance_m": ds.sleeper_distance.values, "rail": str(rail)})
        for k, mgt in enumerate(ds.snapshot_mgt.values):
            frame[f"settlement_mm_at_{mgt:g}_MGT"] = at.isel(mgt=k).sel(rail=rail).values * 1e3
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)


def quality_table(ds) -> pd.DataFrame:
    """D1 SD per tonnage, rail and segment [mm], long format.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict` with a ``section`` attribute.
    """
    sd = ds.d1_sd.to_dataframe().reset_index()
    sd["segment_start_m"] = ds.segment_start.values[sd["segment"]]
    sd["segment_end_m"] = ds.segment_end.values[sd["segment"]]
    sd.insert(0, "section", ds.attrs["section"])
    return sd.rename(columns={"d1_sd": "d1_sd_mm"})[
        ["section", "mgt", "rail", "segment_start_m", "segment_end_m", "d1_sd_mm"]
    ]


def maintenance_table(ds) -> pd.DataFrame:
    """Per segment: D1 SD at the start and end per rail [mm], trigger tonnage [MGT].

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict` with a ``section`` attribute.
    """
    frame = pd.DataFrame(
        {
            "section": ds.attrs["section"],
            "segment_start_m": ds.segment_start.values,
            "segment_end_m": ds.segment_end.values,
        }
    )
    for rail in ds.rail.values:
        sd = ds.d1_sd.sel(rail=rail)
        frame[f"d1_sd_{rail}_initial_mm"] = sd.isel(mgt=0).values
        frame[f"d1_sd_{rail}_final_mm"] = sd.isel(mgt=-1).values
        frame[f"trigger_{rail}_mgt"] = ds.trigger_mgt.sel(rail=rail).values
    frame["trigger_mgt"] = ds.trigger_mgt_any_rail.values
    frame["threshold_sd_mm"] = float(ds.attrs["option_threshold_sd_mm"])
    return frame


def interventions_table(ds) -> pd.DataFrame:
    """Every tamping and renewal: tonnage [MGT], segment, D1 SD before and after per rail
    [mm], mean lift [mm].

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict` with a ``section`` attribute.
    """
    seg = ds.intervention_segment.values
    frame = pd.DataFrame(
        {
            "section": ds.attrs["section"],
            "mgt": ds.intervention_mgt.values,
            "segment_start_m": ds.segment_start.values[seg],
            "segment_end_m": ds.segment_end.values[seg],
            "kind": ds.intervention_kind.values.astype(str),
        }
    )
    for when in ("before", "after"):
        for rail in ds.rail.values:
            frame[f"d1_sd_{rail}_{when}_mm"] = ds[f"d1_sd_{when}"].sel(rail=rail).values
    frame["mean_lift_mm"] = ds.intervention_lift.values * 1e3
    return frame


def life_cycle_table(ds) -> pd.DataFrame:
    """Per segment: zone kinds, interventions, mean interval [MGT] and tamped length per
    100 MGT [m] over the horizon.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict` with a ``section`` attribute.
    """
    horizon = float(ds.mgt[-1])
    x, kinds = ds.sleeper_distance.values, ds.zone_kind.values.astype(str)
    rows = []
    for j in range(ds.sizes["segment"]):
        lo, hi = float(ds.segment_start[j]), float(ds.segment_end[j])
        at = np.sort(ds.intervention_mgt.values[ds.intervention_segment.values == j])
        inside = (x >= lo) & (x <= hi)
        rows.append(
            {
                "section": ds.attrs["section"],
                "segment_start_m": lo,
                "segment_end_m": hi,
                "zone_kinds": " ".join(sorted(set(kinds[inside]))),
                "interventions": at.size,
                "first_mgt": at[0] if at.size else np.nan,
                "mean_interval_mgt": float(np.diff(at).mean()) if at.size > 1 else np.nan,
                "tamped_m_per_100_mgt": at.size * (hi - lo) / horizon * 100.0,
            }
        )
    return pd.DataFrame(rows)


def steps_table(ds) -> pd.DataFrame:
    """Tonnage steps taken: start, end [MGT] and largest settlement [mm].

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict` with a ``section`` attribute.
    """
    return pd.DataFrame(
        {
            "section": ds.attrs["section"],
            "step": np.arange(ds.sizes["step"]) + 1,
            "start_mgt": ds.step_start.values,
            "end_mgt": ds.step_end.values,
            "max_settlement_mm": ds.step_max_settlement.values * 1e3,
            "vehicle_runs": ds.step_vehicle_runs.values,
            "load_updates": ds.step_load_updates.values,
        }
    )


def _line_title(datasets) -> str:
    """Title of a line's straight-line diagram: its sections, length and tonnage."""
    names = [str(ds.attrs["section"]) for ds in datasets]
    shown = ", ".join(names) if len(names) <= 4 else f"{names[0]} ... {names[-1]}"
    length = sum(float(ds.segment_end[-1] - ds.segment_start[0]) for ds in datasets)
    mgt = max(float(ds.mgt[-1]) for ds in datasets)
    return (f"Straight-line diagram of the line: {len(names)} sections ({shown}), "
            f"{length / 1e3:.2f} km, {mgt:g} MGT")  # fmt: skip


SECTION_FIGURES = {
    "geometry": plot_geometry_evolution,
    "quality": plot_quality_evolution,
    "settlement_map": plot_settlement_map,
    "straight_line": plot_straight_line,
}
"""Each section's figures: ``<name>_<kind>.png`` by its kind."""


FIGURED_SECTIONS = 12
"""Sections whose own figures are drawn by default (`figured`): every section of a line of
at most this many; of a longer line this many, the most urgent. The tables and netCDF files
hold every section, ``line.png`` the whole line."""


def figured(table, limit: int = FIGURED_SECTIONS) -> list[str]:
    """Names of the sections whose own figures are drawn, in the line's order: all of them
    for at most ``limit`` sections; else the ``limit`` that reach the maintenance threshold
    first (``first_trigger_mgt`` of ``table``, the line's `summary`), those never reaching
    it by the worst D1 SD at the end.

    On a network the figures would be most of the command's time (0.9 core-s a section,
    where its runs take about 0.3 s) and of the report, which embeds each of them.
    """
    if len(table) <= limit:
        return list(table.section)
    urgent = table.sort_values(["first_trigger_mgt", "d1_sd_max_final_mm"],
                               ascending=[True, False], kind="stable").head(limit)  # fmt: skip
    chosen = set(urgent.section)
    return [name for name in table.section if name in chosen]


def section_figures(ds) -> dict[str, Drawing]:
    """A section's figures by file name: ``<name>_geometry.png``, ``<name>_quality.png``,
    ``<name>_settlement_map.png``, ``<name>_straight_line.png`` (`trackdyn.plots.deteriorate`),
    to be drawn (`Drawing.figure`).

    Parameters
    ----------
    ds : xarray.Dataset
        A section's prediction, with its ``section`` and ``traffic`` attributes.
    """
    name = ds.attrs["section"]
    title = f"{name}: {ds.attrs['traffic']}"
    return {f"{name}_{kind}.png": Drawing(draw, (ds,), {"title": title})
            for kind, draw in SECTION_FIGURES.items()}  # fmt: skip


def line_figure(datasets) -> dict[str, Drawing]:
    """``line.png``, the straight-line diagram of the whole line, for two or more sections
    (none for one), to be drawn (`Drawing.figure`)."""
    if len(datasets) < 2:
        return {}
    return {"line.png": Drawing(plot_line, (list(datasets),), {"title": _line_title(datasets)})}


def write_outputs(datasets, folder, pool=None, figures_of=None) -> list[str]:
    """Write every file of a prediction into ``folder``; return the file names.

    Per section ``<name>``: ``deterioration_<name>.nc``, ``settlement_<name>.csv`` and, for
    the sections ``figures_of`` names, the figures ``<name>_geometry.png``,
    ``<name>_quality.png`` (the life cycle: D1 SD per segment with the tampings),
    ``<name>_settlement_map.png``, ``<name>_straight_line.png`` (segments along the
    chainage against tonnage); for all sections: ``summary.csv``,
    ``quality.csv``, ``maintenance.csv`` (first triggers), ``steps.csv``, ``line.png``
    (for two or more sections: the straight-line diagram of the whole line),
    ``vehicle_shares.csv`` and, with maintenance, ``interventions.csv`` and
    ``life_cycle.csv``.

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Results of `trackdyn.deterioration.predict` with a ``section`` attribute.
    folder : Path
        Output folder.
    pool : concurrent.futures.ProcessPoolExecutor, optional
        Its helper process draws the figures meanwhile (`trackdyn.commands.drawing.helper`).
    figures_of : collection of str, optional
        Sections whose own figures are drawn (`figured`); default: all.
    """
    names = []

    def csv(frame, name):
        frame.to_csv(folder / name, index=False, float_format="%.6g")
        names.append(name)

    chosen = {ds.attrs["section"] for ds in datasets} if figures_of is None else figures_of
    figures = [section_figures(ds) if ds.attrs["section"] in chosen else {}
               for ds in datasets]  # fmt: skip
    line = line_figure(datasets)
    tables = [
        ("quality.csv", quality_table),
        ("maintenance.csv", maintenance_table),
        ("steps.csv", steps_table),
        ("vehicle_shares.csv", _shares),
    ]
    if any(ds.attrs.get("option_maintenance_policy") for ds in datasets):
        tables += [("interventions.csv", interventions_table), ("life_cycle.csv", life_cycle_table)]
    with drawn({f: d for each in [*figures, line] for f, d in each.items()}, folder, pool):
        for ds, drawings in zip(datasets, figures, strict=True):
            name = ds.attrs["section"]
            write_netcdf(ds, folder / f"deterioration_{name}.nc")
            names.append(f"deterioration_{name}.nc")
            csv(settlement_table(ds), f"settlement_{name}.csv")
            names += drawings
        names += line
        csv(summary(datasets), "summary.csv")
        for name, table in tables:
            csv(pd.concat([table(ds) for ds in datasets], ignore_index=True), name)
    return names
