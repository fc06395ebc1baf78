"""Figures of `trackdyn deteriorate`: per section the geometry, the quality per segment, the
settlement map and the straight-line diagram; for a line of sections its diagram."""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import MaxNLocator

from trackdyn.plots import RAIL_COLOURS, Figure, finished, panels, plt

VOID_SHOWN = 1e-3
"""Gap at rest above which the straight-line diagram marks a sleeper as hanging [m]: the
1 mm void of Lundqvist & Dahlberg (2005), Proc IMechE F 219(2), 67-77 (the dataset's
``hanging_sleepers`` counts those over 0.1 mm)."""


def plot_geometry_evolution(ds, ax=None, *, title: str = "") -> Figure:
    """Unloaded space curve of each rail at the snapshot tonnages, and the settlement.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.
    ax : array of 3 matplotlib Axes, optional
        Where to draw the left and right rail profiles and the settlement; default: a new
        figure.
    title : str
        Figure title.
    """
    fig, axes = panels(ax, 3, 1, figsize=(12, 9), sharex=True)
    colours = _snapshot_colours(ds.sizes["snapshot"])
    for a, rail in zip(axes[:2], ds.rail.values, strict=True):
        for k, colour in enumerate(colours):
            mgt = float(ds.snapshot_mgt[k])
            z = ds.profile.isel(snapshot=k).sel(rail=rail).values * 1e3
            a.plot(ds.distance, z - z.mean(), color=colour, lw=0.6, label=f"{mgt:g} MGT")
        a.set_ylabel(f"{rail} rail profile [mm]\nless its mean (down +)")
    final = ds.settlement.isel(mgt=-1)
    for rail in ds.rail.values:
        axes[2].plot(
            ds.sleeper_distance,
            final.sel(rail=rail) * 1e3,
            color=RAIL_COLOURS[str(rail)],
            lw=0.7,
            label=str(rail),
        )
    axes[2].set_ylabel(f"settlement at\n{float(ds.mgt[-1]):g} MGT [mm]")
    for a in axes:
        a.invert_yaxis()
        a.grid(alpha=0.3)
        a.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)  # clear of the data
    axes[0].set_title("each profile less its mean: the mean settlement (below) shifts the "
                      "whole rail", fontsize=9, loc="left")  # fmt: skip
    axes[-1].set_xlabel("distance [m]")
    fig.suptitle(title or "Track geometry over accumulated traffic")
    return finished(fig, ax)


def plot_quality_evolution(ds, ax=None, *, title: str = "") -> Figure:
    """The life cycle: D1 standard deviation of each segment against tonnage, with the
    threshold and the tampings (a triangle at each, the D1 SD dropping to its value after).

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.
    ax : array of 2 matplotlib Axes, optional
        Where to draw the left and right rail; default: a new figure.
    title : str
        Figure title.
    """
    fig, axes = panels(ax, 1, 2, figsize=(12.5, 4.5), sharey=True)
    colours = _segment_colours(ds.sizes["segment"])
    threshold = float(ds.attrs["option_threshold_sd_mm"])
    for a, rail in zip(axes, ds.rail.values, strict=True):
        for j, colour in enumerate(colours):
            lo, hi = float(ds.segment_start[j]), float(ds.segment_end[j])
            mgt, sd = _sawtooth(ds, rail, j)
            a.plot(mgt, sd, "-", color=colour, lw=1.0, label=f"{lo:.0f}-{hi:.0f} m")
            mine = ds.intervention_segment.values == j
            a.plot(
                ds.intervention_mgt.values[mine],
                ds.d1_sd_before.sel(rail=rail).values[mine],
                "v",
                color=colour,
                ms=4,
            )
        a.axhline(threshold, color="k", ls="--", lw=1, label=f"threshold {threshold:g} mm")
        a.plot([], [], "v", color="grey", ms=4, ls="none", label="tamping (D1 SD before it)")
        a.set_title(f"{rail} rail")
        a.set_xlabel("accumulated traffic [MGT]")
        a.grid(alpha=0.3)
    axes[0].set_ylabel("D1 standard deviation [mm]")
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1))  # clear of the data
    fig.suptitle(title or "Geometry quality per segment")
    return finished(fig, ax)


def plot_settlement_map(ds, ax=None, *, title: str = "") -> Figure:
    """Settlement of each sleeper against tonnage, one panel per rail.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.
    ax : array of 2 matplotlib Axes, optional
        Where to draw the left and right rail; default: a new figure.
    title : str
        Figure title.
    """
    fig, axes = panels(ax, 2, 1, figsize=(11, 7), sharex=True)
    settle = ds.settlement * 1e3
    vmax = float(settle.max()) or 1.0
    for a, rail in zip(axes, ds.rail.values, strict=True):
        mesh = a.pcolormesh(
            ds.sleeper_distance,
            ds.mgt,
            settle.sel(rail=rail),
            shading="nearest",
            cmap="magma_r",
            vmin=0.0,
            vmax=vmax,
        )
        a.set_ylabel(f"{rail} rail\naccumulated traffic [MGT]")
        a.set_ylim(0.0, float(ds.mgt[-1]))
        fig.colorbar(mesh, ax=a, label="settlement [mm]")
        _zone_outlines(a, ds)
        _tampings(a, ds)
    axes[-1].set_xlabel("sleeper position [m]")
    fig.suptitle(title or "Sleeper settlement")
    return finished(fig, ax)


ZONE_COLOURS = {"open": "#e8e8e8", "approach": "#f4c27a", "structure": "#b39ddb"}
"""Colour of each zone kind in the figures, the same in every run (a kind of the user's
own takes one of `EXTRA_ZONE_COLOURS`); none is the red or green of the D1 SD scale."""

EXTRA_ZONE_COLOURS = ("#90caf9", "#bcaaa4", "#f8bbd0", "#80cbc4")


def zone_colours(kinds) -> dict:
    """Colour of each zone kind in ``kinds`` (`ZONE_COLOURS`, others in sorted order)."""
    others = sorted(set(kinds) - set(ZONE_COLOURS))
    extra = {k: EXTRA_ZONE_COLOURS[i % len(EXTRA_ZONE_COLOURS)] for i, k in enumerate(others)}
    return {**ZONE_COLOURS, **extra}


def _snapshot_colours(n: int):
    """The first snapshot black, the later ones along viridis from blue to yellow."""
    later = plt.cm.viridis(np.linspace(0.25, 0.95, max(n - 1, 1)))[: n - 1]
    return [(0.0, 0.0, 0.0, 1.0), *later]


def _zone_outlines(ax, ds) -> None:
    """Each stretch of a zone other than open track outlined in its kind's colour."""
    x, kind = ds.sleeper_distance.values, ds.zone_kind.values.astype(str)
    colours = zone_colours(set(kind))
    starts = np.r_[0, np.flatnonzero(kind[1:] != kind[:-1]) + 1]
    ends = np.r_[starts[1:], kind.size]
    shown = set()
    for i, j in zip(starts, ends, strict=True):
        if kind[i] == "open":
            continue
        lo = 0.5 * (x[i - 1] + x[i]) if i else x[0]
        hi = 0.5 * (x[j - 1] + x[j]) if j < x.size else x[-1]
        ax.axvspan(lo, hi, fill=False, edgecolor=colours[kind[i]], lw=1.8,
                   label=None if kind[i] in shown else kind[i])  # fmt: skip
        shown.add(kind[i])


def _tampings(ax, ds) -> None:
    """A white circle at each tamping, at the middle of its segment."""
    seg = ds.intervention_segment.values
    if seg.size:
        mid = 0.5 * (ds.segment_start.values + ds.segment_end.values)
        ax.plot(mid[seg], ds.intervention_mgt.values, "o", ms=5, mfc="white", mec="k",
                ls="none", label="tamping (segment middle)")  # fmt: skip
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", fontsize=7)


def _segment_colours(n: int):
    """One colour per segment, distinct for up to 20 (tab20), then cycling."""
    return plt.cm.tab20(np.arange(n) % 20) if n > 10 else plt.cm.tab10(np.arange(n))


def _sawtooth(ds, rail, j):
    """Tonnage [MGT] and D1 SD [mm] of segment ``j`` with a drop at each intervention."""
    mgt, sd = list(ds.mgt.values), list(ds.d1_sd.sel(rail=rail).isel(segment=j).values)
    mine = np.flatnonzero(ds.intervention_segment.values == j)
    for k in mine[::-1]:
        at = float(ds.intervention_mgt[k])
        i = int(np.searchsorted(mgt, at, side="right"))
        mgt.insert(i, at)
        sd.insert(i, float(ds.d1_sd_after.sel(rail=rail)[k]))
    return np.array(mgt), np.array(sd)


def plot_straight_line(ds, ax=None, *, title: str = "") -> Figure:
    """Segments along the chainage against tonnage, coloured by the D1 SD (the worse
    rail), with the tampings, the zones and the hanging sleepers.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.
    ax : array of 2 matplotlib Axes, optional
        Where to draw the zones strip and the diagram; default: a new figure.
    title : str
        Figure title.
    """
    fig, (top, diagram) = panels(
        ax, 2, 1, figsize=(11, 7), sharex=True, gridspec_kw={"height_ratios": [1, 6]}
    )
    threshold = float(ds.attrs["option_threshold_sd_mm"])
    mesh = _quality_mesh(diagram, ds, 0.0, _top(ds, threshold))
    bar = fig.colorbar(mesh, ax=[top, diagram], label="D1 SD, worse rail [mm]")
    bar.ax.axhline(threshold, color="k", lw=1.5)
    mgt, seg = ds.mgt.values, ds.intervention_segment.values
    diagram.set_ylabel("accumulated traffic [MGT]")
    diagram.set_xlabel("distance [m]")
    diagram.set_ylim(0.0, float(mgt[-1]))
    if seg.size:
        diagram.legend(loc="upper left", bbox_to_anchor=(0.0, -0.1), ncol=2, fontsize=8)
    x = ds.sleeper_distance.values
    kind = ds.zone_kind.values.astype(str)
    names = sorted(set(kind))
    colours = zone_colours(names)
    for name in names:
        top.fill_between(x, 0, 1, where=kind == name, color=colours[name], step="mid",
                         label=name)  # fmt: skip
    hanging = ds.hanging_gap.isel(mgt=-1).max("rail").values > VOID_SHOWN
    top.plot(x[hanging], np.full(hanging.sum(), 0.5), "v", color="k", ms=4,
             label=f"hanging > {VOID_SHOWN * 1e3:g} mm at the end")  # fmt: skip
    top.set_ylim(0, 1)
    top.set_xlim(float(ds.distance[0]), float(ds.distance[-1]))  # the section, no margin
    top.set_yticks([])
    top.set_ylabel("zones", rotation=0, ha="right", va="center")
    top.legend(loc="lower left", bbox_to_anchor=(0.0, 1.02), ncol=len(names) + 1, fontsize=8)
    fig.suptitle(title or "Straight-line diagram")
    return fig  # laid out by hand: tight_layout does not fit the shared colour bar


D1_SCALE_MM = 4.0
"""Top of the D1 SD colour scale of the straight-line diagrams [mm], the same in every run
(beyond the 2.5 mm of EN 13848-6 class D at 80-120 km/h); raised to the worst value where
a run goes past it."""


def _top(ds, threshold: float) -> float:
    """Top of the D1 SD colour scale [mm]: `D1_SCALE_MM`, or the threshold or the worst
    value where higher."""
    return max(D1_SCALE_MM, threshold, float(ds.d1_sd.max()))


def _quality_mesh(ax, ds, offset: float, vmax: float):
    """Draw a section's segments against tonnage coloured by the D1 SD of the worse rail,
    and its tampings and renewals, ``offset`` [m] along the x axis; return the mesh."""
    edges_x = offset + np.append(ds.segment_start.values, ds.segment_end.values[-1])
    mgt = ds.mgt.values
    edges_m = np.append(mgt, mgt[-1])  # each state holds until the next
    mesh = ax.pcolormesh(edges_x, edges_m, ds.d1_sd.max("rail").values, shading="flat",
                         cmap="RdYlGn_r", vmin=0.0, vmax=vmax)  # fmt: skip
    mid = offset + 0.5 * (ds.segment_start.values + ds.segment_end.values)
    seg = ds.intervention_segment.values
    kinds = ds.intervention_kind.values.astype(str)
    for kind, marker in (("tamping", "o"), ("renewal", "s")):
        on = kinds == kind
        if on.any():
            ax.plot(mid[seg[on]], ds.intervention_mgt.values[on], marker, ms=5, mfc="white",
                    mec="k", ls="none", label=kind)  # fmt: skip
    return mesh


def plot_line(datasets, ax=None, *, title: str = "") -> Figure:
    """The straight-line diagram of a whole line: every section's segments end to end in
    the order of the sections list, against tonnage, coloured by the D1 SD of the worse
    rail, with the tampings; one colour scale and the threshold for all.

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Results of `trackdyn.deterioration.predict` with a ``section`` attribute.
    ax : matplotlib.axes.Axes, optional
        Where to draw; default: a new figure.
    title : str
        Figure title.
    """
    threshold = max(float(ds.attrs["option_threshold_sd_mm"]) for ds in datasets)
    vmax = max(_top(ds, threshold) for ds in datasets)
    fig, axis = panels(ax, figsize=(12, 6))
    offset, mesh = 0.0, None
    for ds in datasets:
        start = float(ds.segment_start[0])
        mesh = _quality_mesh(axis, ds, offset - start, vmax)
        length = float(ds.segment_end[-1]) - start
        axis.axvline(offset, color="k", lw=0.8)
        axis.text(offset + length / 2, 1.01, ds.attrs["section"], ha="center", va="bottom",
                  fontsize=8, transform=axis.get_xaxis_transform())  # fmt: skip
        offset += length
    assert mesh is not None  # datasets is not empty (the max above)
    bar = fig.colorbar(mesh, ax=axis, label="D1 SD, worse rail [mm]")
    bar.ax.axhline(threshold, color="k", lw=1.5)
    handles, labels = axis.get_legend_handles_labels()
    keep = {label: h for h, label in zip(handles, labels, strict=True)}
    if keep:
        axis.legend(keep.values(), keep.keys(), loc="upper left", bbox_to_anchor=(0.0, -0.1),
                    ncol=2, fontsize=8)  # fmt: skip
    axis.set_xlim(0.0, offset)
    axis.set_ylim(0.0, max(float(ds.mgt[-1]) for ds in datasets))
    axis.set_xlabel("distance along the line, sections end to end [m]")
    axis.set_ylabel("accumulated traffic [MGT]")
    fig.suptitle(title or "Straight-line diagram of the line")
    return fig  # laid out by hand, as the straight-line diagram


FAN_POINTS = 201
"""Tonnages the fan chart puts every member's D1 SD on [-]."""


def plot_fan(members, ax=None, *, title: str = "") -> Figure:
    """The fan chart of a section's ensemble: per segment, the D1 SD of the worse rail
    against tonnage, the members' median and 10-90 % band, the threshold, and each
    member's tampings as ticks.

    Parameters
    ----------
    members : list of xarray.Dataset
        The members' results (`trackdyn.forecast.ensemble.run_ensemble`) of one section.
    ax : array of matplotlib Axes, optional
        One per segment; default: a new figure.
    title : str
        Figure title.
    """
    segments = members[0].sizes["segment"]
    fig, axes = panels(ax, segments, 1, figsize=(9, 1.5 * segments + 1.2), sharex=True,
                       squeeze=False)  # fmt: skip
    axes = np.asarray(axes).ravel()
    total = max(float(ds.mgt[-1]) for ds in members)
    grid = np.linspace(0.0, total, FAN_POINTS)
    threshold = float(members[0].attrs["option_threshold_sd_mm"])
    worse = np.array([[np.interp(grid, ds.mgt.values, ds.d1_sd.max("rail").values[:, s],
                                 right=np.nan) for s in range(segments)]
                      for ds in members])  # fmt: skip
    for s, axis in enumerate(axes):
        low, mid, high = np.nanquantile(worse[:, s], [0.1, 0.5, 0.9], axis=0)
        axis.fill_between(grid, low, high, color="tab:blue", alpha=0.3, lw=0,
                          label="10-90 % of members")  # fmt: skip
        axis.plot(grid, mid, color="tab:blue", lw=1.5, label="median")
        axis.axhline(threshold, color="k", lw=1, ls="--", label="threshold")
        for ds in members:
            tamped = ds.intervention_mgt.values[ds.intervention_segment.values == s]
            axis.plot(tamped, np.zeros(tamped.size), "|", color="k", ms=8, alpha=0.4)
        start, end = float(members[0].segment_start[s]), float(members[0].segment_end[s])
        axis.set_ylabel(f"{start:g}-{end:g} m\nD1 SD [mm]", fontsize=8)
        axis.set_ylim(bottom=0.0)
    axes[0].legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=3, fontsize=8)
    axes[-1].set_xlabel("accumulated traffic [MGT] (ticks: members' tampings)")
    axes[-1].set_xlim(0.0, total)
    fig.suptitle(title or "Forecast")
    return finished(fig, ax)


def plot_reach_probability(table, ax=None, *, title: str = "") -> Figure:
    """The probability that each segment has had its first tamping, along the chainage
    against years (or tonnage), one panel per section (``forecast_probability.csv``).

    Parameters
    ----------
    table : pandas.DataFrame
        ``section``, ``segment_start_m``, ``segment_end_m``, ``by_year`` or ``by_mgt``,
        ``probability``.
    ax : array of matplotlib Axes, optional
        One per section; default: a new figure.
    title : str
        Figure title.
    """
    by = "by_year" if "by_year" in table else "by_mgt"
    names = list(dict.fromkeys(table.section))
    fig, axes = panels(ax, len(names), 1, figsize=(10, 2.2 * len(names) + 1.2), squeeze=False,
                       layout="constrained")  # fmt: skip
    axes = np.asarray(axes).ravel()
    mesh = None
    for name, axis in zip(names, axes, strict=True):
        part = table[table.section == name]
        at = np.unique(part[by].values)
        starts = np.unique(part.segment_start_m.values)
        edges_x = np.append(starts, part.segment_end_m.max())
        step = at[1] - at[0] if at.size > 1 else at[0]
        edges_y = np.append(at - step, at[-1])
        grid = part.pivot(index=by, columns="segment_start_m", values="probability")
        mesh = axis.pcolormesh(edges_x, edges_y, grid.loc[at, starts].values, shading="flat",
                               cmap="Reds", vmin=0.0, vmax=1.0)  # fmt: skip
        axis.set_ylabel("by year" if by == "by_year" else "by traffic [MGT]")
        axis.set_title(name, fontsize=9, loc="left")
    axes[-1].set_xlabel("distance [m]")
    fig.colorbar(mesh, ax=list(axes), label="probability of the first tamping by then [-]")
    fig.suptitle(title or "Probability of reaching the threshold")
    return fig  # a new figure is laid out by matplotlib's constrained layout


def plot_plan(table, deferred, bounds, ax=None, *, title: str = "") -> Figure:
    """A maintenance plan along the line: each year's stretches as bars from their start to
    their end (sections end to end in the order of the sections list), coloured by the
    probability of needing tamping where an ensemble gives it; what a cap deferred outlined
    in red in the year it was deferred from.

    Parameters
    ----------
    table, deferred : pandas.DataFrame
        ``plan.csv`` and ``plan_deferred.csv``
        (`trackdyn.commands.deteriorate.plan.plan_tables`).
    bounds : list of (str, float, float)
        Each section's name, start and end [m], in order.
    ax : matplotlib.axes.Axes, optional
        Where to draw; default: a new figure.
    title : str
        Figure title.
    """
    fig, axis = panels(ax, figsize=(12, 5))
    offset, offsets = 0.0, {}
    for name, start, end in bounds:
        offsets[name] = offset - start
        axis.axvline(offset, color="k", lw=0.8)
        axis.text(offset + (end - start) / 2, 1.01, name, ha="center", va="bottom", fontsize=8,
                  transform=axis.get_xaxis_transform())  # fmt: skip
        offset += end - start
    colours = plt.cm.viridis_r
    outlined = {"facecolor": "none", "edgecolor": "tab:red", "hatch": "//", "label": "deferred"}
    for frame, style in ((table, {}), (deferred, outlined)):
        for row in frame.itertuples(index=False):
            p = getattr(row, "probability", np.nan)
            shade = {} if style else {"color": colours(p if np.isfinite(p) else 1.0)}
            axis.barh(row.year, row.end_m - row.start_m, left=offsets[row.section] + row.start_m,
                      height=0.6, **style, **shade)  # fmt: skip
            style = {k: v for k, v in style.items() if k != "label"}
    if len(deferred):
        axis.legend(loc="upper right", fontsize=8)
    years = [*table["year"], *deferred["year"], 1]
    axis.set_xlim(0.0, offset)
    axis.set_ylim(max(years) + 0.5, 0.5)
    axis.yaxis.set_major_locator(MaxNLocator(integer=True))  # whole plan years
    axis.set_xlabel("distance along the line, sections end to end [m]")
    axis.set_ylabel("plan year")
    fig.suptitle(title or "Maintenance plan")
    return finished(fig, ax)
