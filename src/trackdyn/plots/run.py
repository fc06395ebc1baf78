"""Figures of `trackdyn run`: wheel loads, their exceedance, the secondary suspension and
the friction wedges."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import to_rgb

from trackdyn.plots import (
    RAIL_COLOURS,
    TAB10,
    Figure,
    envelope,
    finished,
    legend_outside,
    mark,
    panels,
)

# Line style, width and darkening of the contacts on one rail, front to back: where two
# contacts see the same track, the wide light line of the first shows around the darker
# dashes of the next.
CONTACT_STYLES = (("-", 2.4, 0.0), ("--", 1.4, 0.45), (":", 1.6, 0.7), ("-.", 0.8, 0.85))
ZOOM_M = (50.0, 100.0)  # window of the zoomed wheel-load panels [m]


def run_title(ds) -> str:
    """Model, vehicle and speed of a run (`trackdyn.simulation.simulate` result)."""
    return f"{ds.attrs['model']}, {ds.attrs['vehicle']}, {ds.attrs['speed_m_per_s'] * 3.6:.0f} km/h"


def _contact_style(ds, contacts, c) -> dict:
    """Colour of the contact's rail; line style by its order among ``contacts`` on that rail."""
    rail = str(ds.contact_rail.sel(contact=c).values)
    same_rail = [k for k in contacts if str(ds.contact_rail.sel(contact=k).values) == rail]
    ls, lw, dark = CONTACT_STYLES[same_rail.index(c) % len(CONTACT_STYLES)]
    colour = np.array(to_rgb(RAIL_COLOURS.get(rail, "k"))) * (1 - dark)
    return {"color": colour, "ls": ls, "lw": lw, "label": str(c)}


def _full_and_zoom(axes, x, y, **style) -> None:
    """Plot ``y`` against ``x`` on the full-length axes and, within `ZOOM_M`, the zoomed ones."""
    axes[0].plot(*envelope(x, y), **{**style, "lw": style["lw"] * 0.4})
    inside = (x >= ZOOM_M[0] - 1) & (x <= ZOOM_M[1] + 1)
    axes[1].plot(x[inside], y[inside], **style)


def _load_band(axes, ps: float, delta: float, label: bool) -> None:
    """The static wheel load Ps and the linearisation range Ps ± δPs [kN] on ``axes``."""
    for ax in axes:
        ax.axhspan(
            ps * (1 - delta),
            ps * (1 + delta),
            color="tab:green",
            alpha=0.1,
            lw=0,
            label=f"Ps ± δPs = {ps * (1 - delta):.0f}-{ps * (1 + delta):.0f} kN\n"
            "(range of the linearised track)"
            if label
            else None,
        )
        ax.axhline(ps, color="k", lw=0.8, ls=":", label=f"Ps = {ps:.1f} kN" if label else None)


def _outside_share(ds, delta: float) -> float:
    """Share of the wheel-load samples outside Ps ± δPs [-]."""
    ps = ds.attrs["static_wheel_load_N"]
    return float((np.abs(ds.wheel_load.values - ps) > delta * ps).mean())


def contact_position(ds, c):
    """Position of contact ``c`` along the track at each stored time [m]."""
    return (ds.distance + ds.contact_offset.sel(contact=c)).values


def plot_wheel_loads(ds, ax=None, *, delta: float = 0.3, marks=()) -> Figure:
    """Wheel loads of the front and back contacts, track input and stiffness under them.

    Left column: the whole track; right column: the window `ZOOM_M`. Colour: rail; line
    style: order of the contact on its rail. Contacts on one rail run over the same input
    and stiffness, so their lines there coincide, shifted at the ends by their offsets.
    The static wheel load Ps and the linearisation range Ps ± δPs are drawn on the load
    panels; the title gives the share of the run outside it.

    Parameters
    ----------
    ds : xarray.Dataset
        A run (`trackdyn.simulate`).
    ax : array of matplotlib Axes, optional
        Where to draw: rows (front contacts, back contacts where there are both, track
        input, stiffness) x 2 columns (whole track, zoom); default: a new figure.
    delta : float
        Dynamic wheel load increment δ of the linearisation [-].
    marks : sequence of trackdyn.plots.Mark
        Stretches of track to mark (`trackdyn.plots.feature_marks`).
    """
    contacts = list(ds.contact.values)
    front = ds.contact_offset.values >= 0
    groups = {"front": np.array(contacts)[front], "back": np.array(contacts)[~front]}
    groups = {name: list(g) for name, g in groups.items() if g.size}
    rows = [*groups, "input", "stiffness"]
    fig, axes = panels(
        ax,
        len(rows),
        2,
        figsize=(14, 2.6 * len(rows) + 1.4),
        sharex="col",
        gridspec_kw={"width_ratios": [2.4, 1]},
        squeeze=False,
    )
    ps = ds.attrs["static_wheel_load_N"] / 1e3
    for j, (row, (name, members)) in enumerate(zip(axes, groups.items(), strict=False)):
        _load_band(row, ps, delta, label=j == 0)
        for c in members:
            style = _contact_style(ds, members, c)
            _full_and_zoom(
                row, contact_position(ds, c), ds.wheel_load.sel(contact=c).values / 1e3, **style
            )
        where = f"{name} contacts" if len(groups) > 1 else "contacts"
        row[0].set_ylabel(f"wheel load [kN]\n{where}")
    for row, (var, scale) in zip(
        axes[len(groups) :], (("wheel_input", 1e3), ("track_stiffness", 1e-6)), strict=True
    ):
        for c in contacts:
            style = _contact_style(ds, contacts, c)
            _full_and_zoom(
                row, contact_position(ds, c), ds[var].sel(contact=c).values * scale, **style
            )
    axes[-2, 0].set_ylabel("track input [mm]\n(down +)")
    if len(contacts) > len(set(ds.contact_rail.values)):
        axes[-2, 0].set_title(
            "contacts on one rail run over the same input and stiffness: their lines coincide",
            fontsize=9,
            loc="left",
        )
    axes[-1, 0].set_ylabel("track stiffness [kN/mm]\n(sum over the contact's axles)")
    for a in axes[-2]:
        a.invert_yaxis()
    for a in axes.flat:
        a.grid(alpha=0.3)
    for a in axes[:, 1]:
        a.set_xlim(*ZOOM_M)
        legend_outside(a, handlelength=3)
    mark(axes[:, 0], marks, label_on=axes[0, 0])
    axes[-1, 0].set_xlabel("position of the contact along the track [m]")
    axes[-1, 1].set_xlabel(f"zoom {ZOOM_M[0]:g}-{ZOOM_M[1]:g} m [m]")
    peak = float(ds.wheel_load.max()) / 1e3
    fig.suptitle(
        f"Wheel loads: {run_title(ds)}\npeak {peak:.0f} kN; "
        f"{100 * _outside_share(ds, delta):.1f} % of the run outside Ps ± δPs, "
        "where the linearised track is an approximation",
        fontsize=11,
    )
    return finished(fig, ax)


def plot_wheel_load_exceedance(ds, ax=None, *, delta: float = 0.3) -> Figure:
    """Share of the run in which each contact's wheel load exceeds a value (solid) and
    falls below it (dotted: the unloading tail).

    Samples are equally spaced in time, so at constant speed the share is also one of
    distance.

    Parameters
    ----------
    ds : xarray.Dataset
        A run (`trackdyn.simulate`).
    ax : matplotlib.axes.Axes, optional
        Where to draw; default: a new figure.
    delta : float
        Dynamic wheel load increment δ of the linearisation [-].
    """
    fig, axis = panels(ax, figsize=(10, 5.5))
    contacts = list(ds.contact.values)
    for c in contacts:
        load = np.sort(ds.wheel_load.sel(contact=c).values)[::-1] / 1e3
        share = np.arange(1, load.size + 1) / load.size
        style = {**_contact_style(ds, contacts, c), "lw": 1.4}
        axis.semilogy(load, share, **style)
        # the unloading tail: the share with a lower load, dotted, in the contact's colour
        axis.semilogy(load[::-1], share, **{**style, "ls": ":", "label": None})
    axis.plot([], [], color="grey", ls=":", lw=1.4, label="share with a lower load\n(unloading)")
    ps = ds.attrs["static_wheel_load_N"] / 1e3
    axis.axvspan(
        ps * (1 - delta),
        ps * (1 + delta),
        color="tab:green",
        alpha=0.1,
        lw=0,
        label="Ps ± δPs (range of the linearised track)",
    )
    axis.axvline(ps, color="k", lw=0.8, ls=":", label=f"Ps = {ps:.1f} kN")
    axis.set_xlabel("wheel load [kN]")
    axis.set_ylabel("share of the run with a higher (solid)\nor lower (dotted) load [-]")
    axis.set_ylim(bottom=min(1e-4, 0.5 / max(ds.sizes["time"], 1)))
    axis.grid(alpha=0.3, which="both")
    legend_outside(axis, handlelength=3)
    axis.set_title(f"Wheel-load exceedance\n{run_title(ds)}", fontsize=11)
    return finished(fig, ax)


def _suspension_offset(ds, s) -> float:
    """Offset of suspension ``s`` ahead of the vehicle centre [m]: that of the contact of the
    same name, else the mean of the contacts on its bogie side, else of all contacts."""
    names = [str(c) for c in ds.contact.values]
    if str(s) in names:
        return float(ds.contact_offset.sel(contact=s))
    if "contact_side" in ds.coords and str(s) in ds.contact_side.values:
        return float(ds.contact_offset.where(ds.contact_side == s, drop=True).mean())
    return float(ds.contact_offset.mean())


def plot_secondary(ds, ax=None, *, marks=()) -> Figure:
    """Displacement across each secondary suspension along the track, front and back bogie.

    The x-axis is the position along the track of the suspension's contacts, as on the
    wheel-load figure; the right column zooms into `ZOOM_M`.

    Parameters
    ----------
    ds : xarray.Dataset
        A run (`trackdyn.simulate`).
    ax : array of matplotlib Axes, optional
        Where to draw: rows (front bogie, back bogie where there are both) x 2 columns
        (whole track, zoom); default: a new figure.
    marks : sequence of trackdyn.plots.Mark
        Stretches of track to mark (`trackdyn.plots.feature_marks`).
    """
    offsets = {str(s): _suspension_offset(ds, s) for s in ds.suspension.values}
    groups = {
        "front": [s for s, o in offsets.items() if o >= 0],
        "back": [s for s, o in offsets.items() if o < 0],
    }
    groups = {k: g for k, g in groups.items() if g}
    fig, axes = panels(
        ax,
        max(len(groups), 1),
        2,
        figsize=(14, 1.6 + 2.8 * max(len(groups), 1)),
        sharex="col",
        sharey=True,
        gridspec_kw={"width_ratios": [2.4, 1]},
        squeeze=False,
    )
    for row, (name, members) in zip(axes, groups.items(), strict=False):
        for k, s in enumerate(members):
            side = s[-1:] if s[-1:] in ("L", "R") else ""
            colour = RAIL_COLOURS["left" if side == "L" else "right" if side == "R" else "left"]
            if not side and k:
                colour = TAB10[k]
            y = ds.secondary_displacement.sel(suspension=s).values * 1e3
            x = ds.distance.values + offsets[s]
            _full_and_zoom(row, x, y, color=colour, lw=1.6, ls="-", label=s)
        row[0].set_ylabel(f"secondary displacement [mm]\n{name} bogie (compression +)")
        _wedge_unloaded(row, ds, label=name == next(iter(groups)))
    for a in axes[:, 1]:
        a.set_xlim(*ZOOM_M)
        legend_outside(a)
    for a in axes.flat:
        a.grid(alpha=0.3)
    mark(axes[:, 0], marks, label_on=axes[0, 0])
    axes[-1, 0].set_xlabel("position of the suspension's contacts along the track [m]")
    axes[-1, 1].set_xlabel(f"zoom {ZOOM_M[0]:g}-{ZOOM_M[1]:g} m [m]")
    fig.suptitle(f"Secondary suspension displacement: {run_title(ds)}")
    return finished(fig, ax)


def _wedge_unloaded(axes, ds, label: bool) -> None:
    """The extension ``-x_ss`` at which the wedge springs, compressed by ``x_ss`` at rest
    (the vehicle's parameter), come unloaded and the wedges' friction vanishes, on
    ``axes``."""
    x_ss = ds.attrs.get("vehicle_x_ss")
    if x_ss is None:
        return
    text = f"wedge springs unloaded, -x_ss = -{float(x_ss) * 1e3:.0f} mm"
    for a in axes:
        a.axhline(-float(x_ss) * 1e3, color="k", lw=1.0, ls="--", label=text if label else None)


def _wedge_colour(ds, wedges, k: int, w: str):
    """A wedge's colour: that of the contact of the same name (its rail's), else the k-th."""
    contacts = [str(c) for c in ds.contact.values]
    if w in contacts:
        return _contact_style(ds, [c for c in wedges if c in contacts], w)["color"]
    return TAB10[k % 10]


def plot_wedge_friction(ds, ax=None) -> Figure:
    """Friction wedges: force against displacement (the hysteresis loop) and velocity.

    Left: the friction force of each wedge against the displacement across its secondary
    suspension while the vehicle runs over `ZOOM_M`, one loop per oscillation. Right: force
    against relative velocity over the whole run, as the density of the samples of all
    wedges (stick: the steep band through zero; slip: the limits ± μ × normal force).

    Parameters
    ----------
    ds : xarray.Dataset
        A run (`trackdyn.simulate`) of a model with friction wedges.
    ax : array of 2 matplotlib Axes, optional
        Where to draw the loops and the density; default: a new figure.
    """
    fig, (ax1, ax2) = panels(ax, 1, 2, figsize=(13, 5.5))
    window = (ds.distance >= ZOOM_M[0]) & (ds.distance <= ZOOM_M[1])
    wedges = [str(w) for w in ds.wedge.values]
    for k, w in enumerate(wedges):
        force = ds.wedge_force.sel(wedge=w).values / 1e3
        if w in ds.suspension.values:
            disp = ds.secondary_displacement.sel(suspension=w).values * 1e3
            ax1.plot(
                disp[window.values],
                force[window.values],
                lw=1.0,
                color=_wedge_colour(ds, wedges, k, w),
                label=w,
            )
    ax1.set_xlabel("displacement across the secondary suspension [mm] (compression +)")
    ax1.set_ylabel("wedge friction force [kN]")
    ax1.set_title(f"Hysteresis loops, vehicle centre at {ZOOM_M[0]:g}-{ZOOM_M[1]:g} m", fontsize=10)
    if wedges:
        velocity = ds.wedge_velocity.values.ravel() * 1e3
        force = ds.wedge_force.values.ravel() / 1e3
        art = ax2.hexbin(velocity, force, gridsize=80, bins="log", cmap="viridis", mincnt=1)
        fig.colorbar(art, ax=ax2, label="samples (all wedges)")
    ax2.set_xlabel("relative velocity [mm/s] (compression +)")
    ax2.set_ylabel("wedge friction force [kN]")
    ax2.set_title("Stick (steep band through zero) and slip (± μ × normal force)", fontsize=10)
    for a in (ax1, ax2):
        a.grid(alpha=0.3)
    legend_outside(ax1)
    fig.suptitle(f"Friction wedges: {run_title(ds)}")
    return finished(fig, ax)
