"""Figures of run, track and study (matplotlib, no screen needed).

Each ``plot_*`` function draws one figure from the Dataset or table a command has and
returns it; `save` writes it to a PNG file and closes it.
"""

from __future__ import annotations

from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

RAIL_COLOURS = {"left": "tab:blue", "right": "tab:red"}
TAB10 = tuple(f"C{i}" for i in range(10))  # matplotlib's default cycle: tab10
# Line style, width and darkening of the contacts on one rail, front to back: where two
# contacts see the same track, the wide light line of the first shows around the darker
# dashes of the next.
CONTACT_STYLES = (("-", 2.4, 0.0), ("--", 1.4, 0.45), (":", 1.6, 0.7), ("-.", 0.8, 0.85))
ZOOM_M = (50.0, 100.0)  # window of the zoomed wheel-load panels [m]


def run_title(ds) -> str:
    """Model, vehicle and speed of a run (`trackdyn.simulation.simulate` result)."""
    return f"{ds.attrs['model']}, {ds.attrs['vehicle']}, {ds.attrs['speed_m_per_s'] * 3.6:.0f} km/h"


def save(fig, path) -> None:
    """Write ``fig`` to ``path`` as PNG and close it."""
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


MARK_COLOURS = {"structure": "tab:purple", "soft spot": "tab:orange", "voids": "tab:brown"}


@dataclass(frozen=True)
class Mark:
    """A stretch of track to mark on the figures: ``[start, end]`` [m], its kind and label."""

    start: float
    end: float
    kind: str
    label: str


def feature_marks(features, sleeper_spacing: float = 0.6) -> list[Mark]:
    """Marks of the named features of a synthetic track (`trackdyn.track.synthetic`).

    Parameters
    ----------
    features : iterable
        ``SoftSpot``, ``VoidedSleepers`` and ``Transition`` features.
    sleeper_spacing : float
        Sleeper spacing, for the length of a row of voided sleepers [m].
    """
    from trackdyn.track.synthetic import SoftSpot, Transition, VoidedSleepers

    marks = []
    for f in features:
        if isinstance(f, SoftSpot):
            half = f.length / 2
            marks.append(Mark(f.centre - half, f.centre + half, "soft spot", "soft spot"))
        elif isinstance(f, VoidedSleepers):
            end = f.position + (f.count - 1) * sleeper_spacing
            label = f"{f.count} voided sleepers ({f.rail} rail)"
            marks.append(Mark(f.position - 0.3, end + 0.3, "voids", label))
        elif isinstance(f, Transition):
            marks.append(Mark(f.start, f.start + f.length, "structure", "stiff structure"))
    return marks


def example_marks() -> list[Mark]:
    """Marks of the built-in example section's soft spot, voids and stiff structure."""
    from trackdyn.track.synthetic import EXAMPLE_FEATURES

    return feature_marks(EXAMPLE_FEATURES)


def _mark(axes, marks, label_on=None) -> None:
    """Shade the ``marks`` on every axes (at least 0.6 % of its width); name them above
    ``label_on``."""
    for m in marks:
        colour = MARK_COLOURS[m.kind]
        for ax in axes:
            lo, hi = ax.get_xlim()
            half = max(m.end - m.start, 0.006 * (hi - lo)) / 2
            centre = (m.start + m.end) / 2
            ax.axvspan(centre - half, centre + half, color=colour, alpha=0.25, lw=0)
        if label_on is not None:
            label_on.annotate(
                m.label,
                ((m.start + m.end) / 2, 1.0),
                xycoords=("data", "axes fraction"),
                xytext=(0, 2),
                textcoords="offset points",
                ha="center",
                va="bottom",
                fontsize=8,
                color=colour,
            )


def _legend_outside(ax, **options) -> None:
    """A legend to the right of ``ax``, off the data."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8, **options)


def plot_track_overview(ds, marks=(), threshold_sd_mm: float | None = None) -> Figure:
    """Profile, its D1 band, static deflection, stiffness and D1/D2 quality along the track.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.track.analysis.track_dataset`.
    marks : sequence of Mark
        Stretches to mark (`feature_marks`).
    threshold_sd_mm : float, optional
        D1 SD maintenance threshold to draw [mm].
    """
    from trackdyn.track.quality import WAVEBANDS, longitudinal_level

    shortest, longest = WAVEBANDS["D1"]
    fig, axes = plt.subplots(5, 1, figsize=(12, 12), sharex=True)
    x = ds.distance.values
    for rail in ds.rail.values:
        c = RAIL_COLOURS[str(rail)]
        profile = ds.unloaded_profile.sel(rail=rail).values
        axes[0].plot(*_envelope(x, profile * 1e3), color=c, lw=0.7, label=f"{rail} rail")
        if x.size > 1 and x[-1] - x[0] >= 2 * longest:  # as longitudinal_level needs
            level = longitudinal_level(x, profile, "D1") * 1e3
            axes[1].plot(*_envelope(x, level), color=c, lw=0.7, label=f"{rail} rail")
        xs = ds.sleeper_distance.values
        axes[2].plot(
            *_envelope(xs, ds.ys.sel(rail=rail).values * 1e3), color=c, lw=0.7, label=f"{rail} rail"
        )
        axes[3].plot(
            *_envelope(xs, ds.k2.sel(rail=rail).values / 1e6), color=c, lw=0.7, label=f"{rail} rail"
        )
    for band, style in (("D1", "-"), ("D2", ":")):
        sd = ds.sd_unloaded.sel(band=band)
        for rail in sd.rail.values:
            axes[4].hlines(
                sd.sel(rail=rail),
                sd.segment_start,
                sd.segment_end,
                color=RAIL_COLOURS[str(rail)],
                lw=3 if band == "D1" else 1.5,
                ls=style,
                label=f"{band}, {rail} rail",
            )
    if threshold_sd_mm is not None:
        label = f"D1 threshold {threshold_sd_mm:g} mm\n(deteriorate default)"
        axes[4].axhline(threshold_sd_mm, color="k", lw=1, ls="--", label=label)
    axes[4].set_ylim(bottom=0)
    for ax in axes[:3]:
        ax.invert_yaxis()
    labels = [
        "unloaded profile [mm]\n(down +)",
        f"D1 band ({shortest:g}-{longest:g} m)\nof the profile [mm]\n(down +)",
        "static deflection\nys [mm] (down +)",
        "k2 [kN/mm]",
        "SD per segment\n(unloaded) [mm]",
    ]
    for ax, label in zip(axes, labels, strict=True):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        _legend_outside(ax)
    _mark(axes, marks, label_on=axes[0])
    axes[-1].set_xlabel("distance [m]")
    fig.suptitle(
        f"Track input at static wheel load Ps = {ds.attrs['static_wheel_load_N'] / 1e3:.1f} kN"
    )
    return fig


def plot_load_deflection(picks, static_load: float, delta: float) -> Figure:
    """Measured curves of a few sleepers with their linearisation (as the seed's Fig. 5.3).

    Parameters
    ----------
    picks : list of CurvePick
        The sleepers (`trackdyn.track.analysis.curve_picks`).
    static_load : float
        Static wheel load Ps [N].
    delta : float
        Dynamic wheel load increment δ [-].
    """
    ps, dp = static_load, delta * static_load
    fig, ax = plt.subplots(figsize=(12, 6))
    for j, (pick, colour) in enumerate(zip(picks, TAB10, strict=False)):
        curve = pick.curve
        loads = np.linspace(curve.load[0], curve.load[-1], 200)
        ax.plot(curve.deflection * 1e3, curve.load / 1e3, "o", color=colour, ms=4)
        ax.plot(
            curve.deflection_at(loads) * 1e3,
            loads / 1e3,
            color=colour,
            label=f"{pick.label}: {pick.rail} rail, {pick.position:.1f} m, "
            f"k2 = {pick.k2 / 1e6:.0f} kN/mm",
        )
        p = np.array([ps - 1.6 * dp, ps + 1.6 * dp])
        ax.plot(
            (pick.ys + (p - ps) / pick.k2) * 1e3,
            p / 1e3,
            "--",
            color="k",
            lw=1.2,
            zorder=3,
            label="linearised: slope k2 through (ys, Ps)" if j == 0 else None,
        )
    for level in (ps - dp, ps, ps + dp):
        ax.axhline(level / 1e3, color="grey", lw=0.6, ls=":")
    ax.set_xlabel("deflection [mm]")
    ax.set_ylabel("wheel load [kN]")
    ax.set_title(
        "Load-deflection curves (markers: measured; black dashed: linearised over Ps ± ΔP)"
    )
    _legend_outside(ax)
    ax.grid(alpha=0.3)
    return fig


def plot_deflection_basin(rail, x0, with_gap, without_gap, load) -> Figure:
    """Deflection basin and sleeper loads over a voided sleeper (as the seed's Fig. 5.2).

    Sleepers that carry no load with the measured voids (hanging) are marked.

    Parameters
    ----------
    rail : str
        Rail of the voided sleeper.
    x0 : float
        Its position, where the wheel stands [m].
    with_gap, without_gap : BeamSolution
        Basins with the measured voids and without (`trackdyn.track.analysis.voided_basin`).
    load : float
        Wheel load [N].
    """
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    for sol, label, style in ((without_gap, "no voids", "--"), (with_gap, "measured voids", "-")):
        ax1.plot(sol.x - x0, sol.deflection * 1e3, style, label=label)
        ax2.plot(sol.support_position - x0, sol.support_force / 1e3, style + "o", ms=3, label=label)
    hanging = np.abs(with_gap.support_force) <= 1e-6 * load
    if hanging.any():
        ax2.plot(
            with_gap.support_position[hanging] - x0,
            np.zeros(hanging.sum()),
            "x",
            color="tab:red",
            ms=9,
            mew=2,
            label="hanging sleeper (no load)",
        )
        for x in with_gap.support_position[hanging] - x0:
            ax1.axvline(x, color="tab:red", lw=0.8, alpha=0.5)
    ax1.invert_yaxis()
    ax1.set_ylabel("rail deflection [mm] (down +)")
    ax2.set_ylabel("sleeper load [kN]")
    ax2.set_xlabel(f"distance from the wheel at {x0:.1f} m, {rail} rail [m]")
    ax1.set_title(f"Deflection basin under a {load / 1e3:.1f} kN wheel over a voided sleeper")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        _legend_outside(ax)
    return fig


def _contact_style(ds, contacts, c) -> dict:
    """Colour of the contact's rail; line style by its order among ``contacts`` on that rail."""
    rail = str(ds.contact_rail.sel(contact=c).values)
    same_rail = [k for k in contacts if str(ds.contact_rail.sel(contact=k).values) == rail]
    ls, lw, dark = CONTACT_STYLES[same_rail.index(c) % len(CONTACT_STYLES)]
    colour = np.array(to_rgb(RAIL_COLOURS.get(rail, "k"))) * (1 - dark)
    return {"color": colour, "ls": ls, "lw": lw, "label": str(c)}


def _envelope(x, y, points: int = 4000):
    """A long line thinned to about ``points``: each bin's minimum and maximum in turn.

    At the width of a figure the drawn line is the same (every peak is kept) and drawing
    it takes a fraction of the time of a 1 kHz series over a kilometre.
    """
    x, y = np.asarray(x), np.asarray(y)
    if x.size <= points:
        return x, y
    start = np.linspace(0, x.size, points // 2 + 1).astype(int)[:-1]
    low, high = np.minimum.reduceat(y, start), np.maximum.reduceat(y, start)
    return np.repeat(x[start], 2), np.column_stack([low, high]).ravel()


def _full_and_zoom(axes, x, y, **style) -> None:
    """Plot ``y`` against ``x`` on the full-length axes and, within `ZOOM_M`, the zoomed ones."""
    axes[0].plot(*_envelope(x, y), **{**style, "lw": style["lw"] * 0.4})
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


def plot_wheel_loads(ds, delta: float = 0.3, marks=()) -> Figure:
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
    delta : float
        Dynamic wheel load increment δ of the linearisation [-].
    marks : sequence of Mark
        Stretches of track to mark (`feature_marks`).
    """
    contacts = list(ds.contact.values)
    front = ds.contact_offset.values >= 0
    groups = {"front": np.array(contacts)[front], "back": np.array(contacts)[~front]}
    groups = {name: list(g) for name, g in groups.items() if g.size}
    rows = [*groups, "input", "stiffness"]
    fig, axes = plt.subplots(
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
    axes[-1, 0].set_ylabel("track stiffness [kN/mm]")
    for ax in axes[-2]:
        ax.invert_yaxis()
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    for ax in axes[:, 1]:
        ax.set_xlim(*ZOOM_M)
        _legend_outside(ax, handlelength=3)
    _mark(axes[:, 0], marks, label_on=axes[0, 0])
    axes[-1, 0].set_xlabel("position of the contact along the track [m]")
    axes[-1, 1].set_xlabel(f"zoom {ZOOM_M[0]:g}-{ZOOM_M[1]:g} m [m]")
    peak = float(ds.wheel_load.max()) / 1e3
    fig.suptitle(
        f"Wheel loads: {run_title(ds)}\npeak {peak:.0f} kN; "
        f"{100 * _outside_share(ds, delta):.1f} % of the run outside Ps ± δPs, "
        "where the linearised track is an approximation",
        fontsize=11,
    )
    return fig


def plot_wheel_load_exceedance(ds, delta: float = 0.3) -> Figure:
    """Share of the run in which each contact's wheel load exceeds a value.

    Samples are equally spaced in time, so at constant speed the share is also one of
    distance.

    Parameters
    ----------
    ds : xarray.Dataset
        A run (`trackdyn.simulate`).
    delta : float
        Dynamic wheel load increment δ of the linearisation [-].
    """
    fig, ax = plt.subplots(figsize=(10, 5.5))
    contacts = list(ds.contact.values)
    for c in contacts:
        load = np.sort(ds.wheel_load.sel(contact=c).values)[::-1] / 1e3
        share = np.arange(1, load.size + 1) / load.size
        ax.semilogy(load, share, **{**_contact_style(ds, contacts, c), "lw": 1.4})
    ps = ds.attrs["static_wheel_load_N"] / 1e3
    ax.axvspan(
        ps * (1 - delta),
        ps * (1 + delta),
        color="tab:green",
        alpha=0.1,
        lw=0,
        label="Ps ± δPs (range of the linearised track)",
    )
    ax.axvline(ps, color="k", lw=0.8, ls=":", label=f"Ps = {ps:.1f} kN")
    ax.set_xlabel("wheel load [kN]")
    ax.set_ylabel("share of the run with a higher load [-]")
    ax.set_ylim(bottom=min(1e-4, 0.5 / max(ds.sizes["time"], 1)))
    ax.grid(alpha=0.3, which="both")
    _legend_outside(ax, handlelength=3)
    ax.set_title(f"Wheel-load exceedance\n{run_title(ds)}", fontsize=11)
    return fig


def _suspension_offset(ds, s) -> float:
    """Offset of suspension ``s`` ahead of the vehicle centre [m]: that of the contact of the
    same name, else the mean of the contacts on its bogie side, else of all contacts."""
    names = [str(c) for c in ds.contact.values]
    if str(s) in names:
        return float(ds.contact_offset.sel(contact=s))
    if "contact_side" in ds.coords and str(s) in ds.contact_side.values:
        return float(ds.contact_offset.where(ds.contact_side == s, drop=True).mean())
    return float(ds.contact_offset.mean())


def plot_secondary(ds, marks=()) -> Figure:
    """Displacement across each secondary suspension along the track, front and back bogie.

    The x-axis is the position along the track of the suspension's contacts, as on the
    wheel-load figure; the right column zooms into `ZOOM_M`.

    Parameters
    ----------
    ds : xarray.Dataset
        A run (`trackdyn.simulate`).
    marks : sequence of Mark
        Stretches of track to mark (`feature_marks`).
    """
    offsets = {str(s): _suspension_offset(ds, s) for s in ds.suspension.values}
    groups = {
        "front": [s for s, o in offsets.items() if o >= 0],
        "back": [s for s, o in offsets.items() if o < 0],
    }
    groups = {k: g for k, g in groups.items() if g}
    fig, axes = plt.subplots(
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
    for ax in axes[:, 1]:
        ax.set_xlim(*ZOOM_M)
        _legend_outside(ax)
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    _mark(axes[:, 0], marks, label_on=axes[0, 0])
    axes[-1, 0].set_xlabel("position of the suspension's contacts along the track [m]")
    axes[-1, 1].set_xlabel(f"zoom {ZOOM_M[0]:g}-{ZOOM_M[1]:g} m [m]")
    fig.suptitle(f"Secondary suspension displacement: {run_title(ds)}")
    return fig


def plot_wedge_friction(ds) -> Figure:
    """Friction wedges: force against displacement (the hysteresis loop) and velocity.

    Left: the friction force of each wedge against the displacement across its secondary
    suspension while the vehicle runs over `ZOOM_M`, one loop per oscillation. Right: force
    against relative velocity over the whole run, as the density of the samples of all
    wedges (stick: the steep band through zero; slip: the limits ± μ × normal force).

    Parameters
    ----------
    ds : xarray.Dataset
        A run (`trackdyn.simulate`) of a model with friction wedges.
    """
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 5.5))
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
                color=TAB10[k % 10],
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
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    _legend_outside(ax1)
    fig.suptitle(f"Friction wedges: {run_title(ds)}")
    return fig


def plot_study_matrix(table) -> Figure:
    """Dynamic wheel load SD and max per excitation case, grouped by vehicle and damping.

    Parameters
    ----------
    table : pandas.DataFrame
        A matrix study's table (`trackdyn.studies.runner.gather`).
    """
    ok = table[table["error"] == ""]
    groups = list(ok.groupby(["vehicle", "damping"], sort=False))
    cases = sorted(ok["case"].unique())
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    width = 0.8 / max(len(groups), 1)
    x = np.arange(len(cases))
    for g, ((vehicle, damping), rows) in enumerate(groups):
        rows = rows.set_index("case").reindex(cases)
        for ax, col in zip(axes, ("dyn_load_sd_kN", "dyn_load_max_kN"), strict=True):
            ax.bar(x + g * width, rows[col], width, label=f"{vehicle}, {damping} damping")
    for ax, label in zip(
        axes, ("SD of dynamic wheel load [kN]", "max dynamic wheel load [kN]"), strict=True
    ):
        ax.set_xticks(x + width * (len(groups) - 1) / 2, [f"({c})" for c in cases])
        ax.set_xlabel("excitation case")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, axis="y")
    _legend_outside(axes[1])
    fig.suptitle(
        "(i) geometry, rigid track  (ii) geometry, constant stiffness  "
        "(iii) stiffness, level track  (iv) both",
        fontsize=9,
    )
    return fig


def _parameter_name(name: str) -> str:
    """A vehicle parameter's description, symbol and SI unit, for an axis."""
    from trackdyn.vehicle.parameters import PARAMETERS

    if name not in PARAMETERS:
        return name
    unit, text = PARAMETERS[name]
    return f"{text}\n({name}, {unit})"


def plot_tornado(table, column: str = "dyn_load_sd_kN") -> Figure:
    """Change of ``column`` from the baseline at the lowest and highest factor per parameter.

    Parameters
    ----------
    table : pandas.DataFrame
        A one-at-a-time sensitivity study's table (`trackdyn.studies.runner.gather`).
    column : str
        The statistic, a column of the table with its unit suffix.
    """
    from trackdyn.commands.tables import NOTES, header

    ok = table[table["error"] == ""]
    base = float(ok.loc[ok["parameter"] == "baseline", column].iloc[0])
    rows = []
    for name, g in ok[ok["parameter"] != "baseline"].groupby("parameter"):
        lo, hi = g.loc[g["factor"].idxmin()], g.loc[g["factor"].idxmax()]
        rows.append((name, lo[column] - base, hi[column] - base, lo["factor"], hi["factor"]))
    rows.sort(key=lambda r: max(abs(r[1]), abs(r[2])))
    fig, ax = plt.subplots(figsize=(10, 1.8 + 0.9 * len(rows)))
    y = np.arange(len(rows))
    quantity, unit = (header(column).split("\n") + [""])[:2]
    if rows:  # none when every varied run failed
        ax.barh(
            y + 0.19,
            [r[1] for r in rows],
            0.36,
            color="tab:blue",
            label=f"lowest factor (x{rows[0][3]:g})",
        )
        ax.barh(
            y - 0.19,
            [r[2] for r in rows],
            0.36,
            color="tab:red",
            label=f"highest factor (x{rows[0][4]:g})",
        )
        _legend_outside(ax)
    ax.set_yticks(y, [_parameter_name(r[0]) for r in rows], fontsize=9)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlabel(f"change of {quantity} from the baseline, {base:.2f} {unit.strip('[]')} {unit}")
    notes = [note for symbol, note in NOTES.items() if symbol in quantity]
    ax.set_title("\n".join([f"Sensitivity of {quantity} to the vehicle parameters", *notes]))
    ax.grid(alpha=0.3, axis="x")
    return fig


def _label(column: str, value) -> str:
    """A study label as a legend shows it: ``60 km/h``, ``damping low``."""
    return f"{value:g} km/h" if column == "speed_kmh" else f"{column} {value}"


def _colours(values) -> dict:
    """A colour per value: tab10 for up to ten, else viridis in order."""
    values = list(dict.fromkeys(values))
    if len(values) <= 10:
        return dict(zip(values, TAB10, strict=False))
    return dict(zip(values, plt.cm.viridis(np.linspace(0, 0.9, len(values))), strict=True))


def plot_spectra(
    table,
    ds,
    speed_kmh: float,
    sleeper_spacing: float | None = None,
    shortest_wavelength: float | None = None,
) -> Figure:
    """Wheel-load spectrum of each run on a log frequency axis, one panel per value of the
    first varying label.

    With two or more varying labels (vehicle, damping, case, ...) the runs are split into
    panels by the first one; colour tells the last apart and line style the one between. A
    ``baseline`` run is drawn in black in every panel. The sleeper-passing frequency and
    the highest frequency in the synthetic geometry are marked at each speed.

    Parameters
    ----------
    table : pandas.DataFrame
        A study's table (`trackdyn.studies.runner.gather`).
    ds : xarray.Dataset
        The same runs with their spectra.
    speed_kmh : float
        Speed of the runs that do not vary it [km/h].
    sleeper_spacing : float, optional
        Sleeper spacing of the track [m].
    shortest_wavelength : float, optional
        Shortest wavelength in the geometry (a synthetic profile's) [m].
    """
    label_cols = [
        c
        for c in table.columns
        if (c in ("parameter", "factor", "vehicle", "damping", "case", "speed_kmh"))
        or c.startswith("factor_")
    ]
    ok = table[table["error"] == ""]
    label_cols = [c for c in label_cols if ok[c].astype(str).nunique() > 1] or label_cols
    split, rest = (label_cols[0], label_cols[1:]) if len(label_cols) > 1 else (None, label_cols)
    baseline = ok["parameter"] == "baseline" if "parameter" in ok else np.zeros(len(ok), bool)
    if baseline.all():  # only the baseline ran: one panel
        split, rest = None, label_cols
    colour_by = rest[-1] if rest else None
    style_by = rest[0] if len(rest) > 1 else None
    colours = _colours(ok.loc[~baseline, colour_by]) if colour_by else {}
    styles = {}
    if style_by:
        values = dict.fromkeys(ok[style_by])
        styles = {v: ("-", "--", ":", "-.")[i % 4] for i, v in enumerate(values)}
    panels = [None] if split is None else list(dict.fromkeys(ok.loc[~baseline, split]))
    fig, axes = plt.subplots(
        len(panels), 1, figsize=(12, 1.8 + 2.8 * len(panels)), sharex=True, squeeze=False
    )
    freq = ds.frequency.values
    positive = freq > 0
    for ax, panel in zip(axes[:, 0], panels, strict=True):
        runs = ok[~baseline] if split is None else ok[~baseline & (ok[split] == panel)]
        for run, row in runs.iterrows():
            style = {
                "color": colours[row[colour_by]] if colour_by else "tab:blue",
                "ls": styles[row[style_by]] if style_by else "-",
                "label": ", ".join(_label(c, row[c]) for c in rest),
            }
            ax.loglog(freq[positive], ds.wheel_load_psd.isel(run=run).values[positive], **style)
        for run in ok.index[baseline]:
            ax.loglog(
                freq[positive],
                ds.wheel_load_psd.isel(run=run).values[positive],
                lw=1.3,
                color="k",
                label="baseline",
            )
        speeds = sorted(set(runs["speed_kmh"])) if "speed_kmh" in runs else [speed_kmh]
        lines = (
            (sleeper_spacing, "sleeper passing", "--"),
            (shortest_wavelength, "synthetic geometry cut-off", ":"),
        )
        for k, v in enumerate(speeds):
            colour = colours.get(v, "0.3") if colour_by == "speed_kmh" else "0.3"
            for length, name, ls in lines:
                if length:
                    f = v / 3.6 / length
                    if len(speeds) > 1:
                        text = f"{name}, {length:g} m: at each speed, in its colour"
                    else:
                        text = f"{name}, {length:g} m: {f:.1f} Hz"
                    if k == 0:  # the legend entry in grey: the lines take the speeds' colours
                        ax.plot([], [], color="0.3", lw=1.0, ls=ls, label=text)
                    ax.axvline(f, color=colour, lw=1.0, ls=ls)
        ax.set_ylabel("PSD [kN²/Hz]")
        if split is not None:
            ax.set_title(f"{split} {panel}", fontsize=10, loc="left")
        ax.grid(alpha=0.3, which="both")
        _legend_outside(ax)
    axes[-1, 0].set_xlabel("frequency [Hz]")
    fig.suptitle(f"Dynamic wheel load spectra: {ds.attrs['kind']} study, {ds.attrs['model']}")
    return fig


def plot_speed_sweep(table) -> Figure:
    """Dynamic wheel load against speed.

    Parameters
    ----------
    table : pandas.DataFrame
        A speed study's table (`trackdyn.studies.runner.gather`).
    """
    ok = table[table["error"] == ""].sort_values("speed_kmh")
    fig, ax = plt.subplots(figsize=(9, 5))
    ax.plot(ok["speed_kmh"], ok["dyn_load_max_kN"], "o-", label="max")
    ax.plot(ok["speed_kmh"], ok["dyn_load_sd_kN"], "s-", label="standard deviation")
    ax.set_xlabel("speed [km/h]")
    ax.set_ylabel("dynamic wheel load [kN]")
    ax.set_title("Dynamic wheel load against speed")
    ax.grid(alpha=0.3)
    _legend_outside(ax)
    return fig
