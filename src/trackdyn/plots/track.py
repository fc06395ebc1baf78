"""Figures of `trackdyn track`: the track overview, the load-deflection curves and the
deflection basin over a voided sleeper."""

from __future__ import annotations

import numpy as np

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


def plot_track_overview(ds, ax=None, *, marks=(), threshold_sd_mm: float | None = None) -> Figure:
    """Profile, its D1 band, static deflection, stiffness and D1/D2 quality along the track.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.track.analysis.track_dataset`.
    ax : array of 5 matplotlib Axes, optional
        Where to draw, top to bottom; default: a new figure.
    marks : sequence of trackdyn.plots.Mark
        Stretches to mark (`feature_marks`).
    threshold_sd_mm : float, optional
        D1 SD maintenance threshold to draw [mm].
    """
    from trackdyn.track.quality import WAVEBANDS, longitudinal_level

    shortest, longest = WAVEBANDS["D1"]
    fig, axes = panels(ax, 5, 1, figsize=(12, 12), sharex=True)
    x = ds.distance.values
    for rail in ds.rail.values:
        c = RAIL_COLOURS[str(rail)]
        profile = ds.unloaded_profile.sel(rail=rail).values
        axes[0].plot(*envelope(x, profile * 1e3), color=c, lw=0.7, label=f"{rail} rail")
        if x.size > 1 and x[-1] - x[0] >= 2 * longest:  # as longitudinal_level needs
            level = longitudinal_level(x, profile, "D1") * 1e3
            axes[1].plot(*envelope(x, level), color=c, lw=0.7, label=f"{rail} rail")
        xs = ds.sleeper_distance.values
        axes[2].plot(
            *envelope(xs, ds.ys.sel(rail=rail).values * 1e3), color=c, lw=0.7, label=f"{rail} rail"
        )
        axes[3].plot(
            *envelope(xs, ds.k2.sel(rail=rail).values / 1e6), color=c, lw=0.7, label=f"{rail} rail"
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
        label = (f"D1 threshold {threshold_sd_mm:g} mm of deteriorate\n(its built-in example "
                 "starts tamped,\nbelow this measured state)")  # fmt: skip
        axes[4].axhline(threshold_sd_mm, color="k", lw=1, ls="--", label=label)
    axes[4].set_ylim(bottom=0)
    for a in axes[:3]:
        a.invert_yaxis()
    labels = [
        "unloaded profile [mm]\n(down +)",
        f"D1 band ({shortest:g}-{longest:g} m)\nof the profile [mm]\n(down +)",
        "static deflection\nys [mm] (down +)",
        "k2 [kN/mm]",
        "SD per segment\n(unloaded) [mm]",
    ]
    for a, label in zip(axes, labels, strict=True):
        a.set_ylabel(label)
        a.grid(alpha=0.3)
        legend_outside(a)
    mark(axes, marks, label_on=axes[0])
    axes[-1].set_xlabel("distance [m]")
    fig.suptitle(
        f"Track input at static wheel load Ps = {ds.attrs['static_wheel_load_N'] / 1e3:.1f} kN"
    )
    return finished(fig, ax)


def plot_load_deflection(picks, ax=None, *, static_load: float, delta: float) -> Figure:
    """Measured curves of a few sleepers with their linearisation (as Fröhling (1997), Fig. 5.3).

    Parameters
    ----------
    picks : list of CurvePick
        The sleepers (`trackdyn.track.analysis.curve_picks`).
    ax : matplotlib.axes.Axes, optional
        Where to draw; default: a new figure.
    static_load : float
        Static wheel load Ps [N].
    delta : float
        Dynamic wheel load increment δ [-].
    """
    ps, dp = static_load, delta * static_load
    fig, axis = panels(ax, figsize=(12, 6))
    for j, (pick, colour) in enumerate(zip(picks, TAB10, strict=False)):
        curve = pick.curve
        loads = np.linspace(curve.load[0], curve.load[-1], 200)
        axis.plot(curve.deflection * 1e3, curve.load / 1e3, "o", color=colour, ms=4)
        axis.plot(
            curve.deflection_at(loads) * 1e3,
            loads / 1e3,
            color=colour,
            label=f"{pick.label}: {pick.rail} rail, {pick.position:.1f} m, "
            f"k2 = {pick.k2 / 1e6:.0f} kN/mm",
        )
        p = np.array([ps - 1.6 * dp, ps + 1.6 * dp])
        axis.plot(
            (pick.ys + (p - ps) / pick.k2) * 1e3,
            p / 1e3,
            "--",
            color="k",
            lw=1.2,
            zorder=3,
            label="linearised: slope k2 through (ys, Ps)" if j == 0 else None,
        )
    for level, name in ((ps - dp, "Ps - ΔP"), (ps, "Ps"), (ps + dp, "Ps + ΔP")):
        axis.axhline(level / 1e3, color="grey", lw=0.6, ls=":")
        axis.annotate(f"{name} = {level / 1e3:.1f} kN", (0.0, level / 1e3), fontsize=8,
                      color="0.35", xycoords=("axes fraction", "data"), xytext=(3, 2),
                      textcoords="offset points")  # fmt: skip
    axis.set_xlabel("deflection [mm]")
    axis.set_ylabel("wheel load [kN]")
    axis.set_title(
        "Load-deflection curves (markers: measured; black dashed: linearised over Ps ± ΔP)"
    )
    legend_outside(axis)
    axis.grid(alpha=0.3)
    return finished(fig, ax)


def _flag_uplift(ax1, ax2, sol, x0) -> None:
    """Mark where the rail lifts (deflection below zero) and where a support pulls."""
    up = sol.deflection < 0
    if up.any():
        ax1.plot(sol.x[up] - x0, sol.deflection[up] * 1e3, ".", color="tab:purple", ms=2,
                 label=f"rail lifts, up to {-sol.deflection.min() * 1e3:.1f} mm")  # fmt: skip
    pull = sol.support_force < -1e-3 * np.abs(sol.support_force).max()  # not round-off
    if pull.any():
        text = f"support in tension, down to {sol.support_force.min() / 1e3:.1f} kN"
        ax2.plot(sol.support_position[pull] - x0, sol.support_force[pull] / 1e3, "^",
                 color="tab:purple", ms=6, label=text)  # fmt: skip


def plot_deflection_basin(basin, ax=None, *, load: float) -> Figure:
    """Deflection basin and sleeper loads over a voided sleeper (as Fröhling (1997), Fig. 5.2).

    Sleepers that carry no load with the measured voids (hanging) are marked.

    Parameters
    ----------
    basin : tuple
        ``(rail, x0, with_gap, without_gap)`` (`trackdyn.track.analysis.voided_basin`): the
        rail of the voided sleeper, its position x0 where the wheel stands [m], and the
        basins (`BeamSolution`) with the measured voids and without.
    ax : array of 2 matplotlib Axes, optional
        Where to draw the basin and the sleeper loads; default: a new figure.
    load : float
        Wheel load [N].
    """
    rail, x0, with_gap, without_gap = basin
    fig, (ax1, ax2) = panels(ax, 2, 1, figsize=(10, 7), sharex=True)
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
        for k, x in enumerate(with_gap.support_position[hanging] - x0):
            ax1.axvline(x, color="tab:red", lw=0.8, alpha=0.5,
                        label="hanging sleeper" if k == 0 else None)  # fmt: skip
    _flag_uplift(ax1, ax2, with_gap, x0)
    ax1.invert_yaxis()
    ax1.set_ylabel("rail deflection [mm] (down +)")
    ax2.set_ylabel("sleeper load [kN]")
    ax2.set_xlabel(f"distance from the wheel at {x0:.1f} m, {rail} rail [m]")
    ax1.set_title(f"Deflection basin under a {load / 1e3:.1f} kN wheel over a voided sleeper")
    for a in (ax1, ax2):
        a.grid(alpha=0.3)
        legend_outside(a)
    return finished(fig, ax)
