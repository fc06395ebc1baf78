"""Figures of `trackdyn calibrate`: the change since the first survey with the parity of
the D1 SD per segment, and the estimated settlement-rate field."""

from __future__ import annotations

from typing import Any

import numpy as np

from trackdyn.plots import RAIL_COLOURS, Figure, finished, panels, plt

STYLES: dict[str, dict[str, Any]] = {
    "measured": {"color": "k", "lw": 0.8},
    "predicted, fitted": {"color": "tab:orange", "lw": 0.9},
    "predicted, starting values": {"color": "0.55", "lw": 0.7, "ls": "--"},
}
"""Line of each curve, the same in every panel."""


def plot_calibration(result, ax=None, *, problem, table) -> Figure:
    """Measured and predicted D1-band change of each later survey and rail along the track,
    and measured against predicted D1 SD per segment (parity).

    Parameters
    ----------
    result : trackdyn.calibration.fit.FitResult
        The fit.
    ax : array of matplotlib Axes, optional
        Where to draw: (later surveys + 1) rows x 2 columns; a row per later survey of the
        left and right rail's change, then the parity and the legend of the change panels.
        Default: a new figure, the change panels sharing their axes.
    problem : trackdyn.calibration.problem.Calibration
        The calibration.
    table : DataFrame
        Its segment table (`trackdyn.commands.calibrate.outputs.segment_table`).
    """
    later = problem.mgt.size - 1
    fig, axes = _calibration_axes(later) if ax is None else panels(ax, later + 1, 2)
    x, fit, start = problem.x, result.comparison, result.start_comparison
    for k in range(1, problem.mgt.size):
        role = "fitted" if problem.fitted[k] else "check"
        for r, rail in enumerate(("left", "right")):
            panel = axes[k - 1, r]
            curves = (fit.measured, fit.predicted, start.predicted)
            for (label, style), values in zip(STYLES.items(), curves, strict=True):
                panel.plot(x, values[k, r] * 1e3, label=label, **style)
            panel.fill_between(x, 0, 1, where=~problem.valid, color="0.9", step="mid",
                               transform=panel.get_xaxis_transform(),
                               label="not compared")  # fmt: skip
            survey = problem.spec.survey[k].mgt
            panel.set_title(f"{rail} rail, {survey:g} MGT ({role})", fontsize=9)
            panel.grid(alpha=0.3)
            if r == 0:
                panel.set_ylabel("D1-band change [mm]\n(down +)")
            if k == later:
                panel.set_xlabel("distance [m]")
    for panel in axes[:later].flat:
        panel.yaxis.set_inverted(True)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    _parity(axes[later, 0], table)
    key = axes[later, 1]
    key.axis("off")
    key.legend(handles, labels, loc="center left", title="change panels", fontsize=9)
    fig.suptitle("Calibration: change since the first survey, D1 band (3-25 m)")
    return finished(fig, ax)


def _calibration_axes(later: int):
    """A new figure for `plot_calibration`: ``later`` rows of change panels sharing their
    axes, and a taller row for the parity and the legend."""
    fig = plt.figure(figsize=(12, 2.6 * later + 4.2))
    grid = fig.add_gridspec(later + 1, 2, height_ratios=[1] * later + [1.5])
    axes = np.empty((later + 1, 2), dtype=object)
    for k in range(later):
        for r in range(2):
            top = axes[0, 0] if k or r else None
            axes[k, r] = fig.add_subplot(grid[k, r], sharex=top, sharey=top)
    axes[later, 0] = fig.add_subplot(grid[later, 0])
    axes[later, 1] = fig.add_subplot(grid[later, 1])
    return fig, axes


def _parity(ax, table) -> None:
    """Measured against predicted D1 SD per later survey, rail and segment."""
    t = table.dropna(subset=["d1_sd_mm"])
    for role, marker in (("fit", "o"), ("check", "s")):
        for rail in ("left", "right"):
            g = t[(t.role == role) & (t.rail == rail)]
            if len(g):
                label = f"{rail} rail, {role} survey"
                ax.scatter(g.d1_sd_mm, g.d1_sd_predicted_mm, marker=marker, s=22,
                           color=RAIL_COLOURS[rail], label=label)  # fmt: skip
                ax.scatter(g.d1_sd_mm, g.d1_sd_predicted_start_mm, marker=marker, s=14,
                           facecolor="none", edgecolor="0.55")  # fmt: skip
    values = t[["d1_sd_mm", "d1_sd_predicted_mm", "d1_sd_predicted_start_mm"]].to_numpy()
    lo, hi = np.nanmin(values), np.nanmax(values)
    pad = 0.05 * (hi - lo or 1.0)
    ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], color="k", lw=0.6, label="equal")
    ax.scatter([], [], marker="o", s=14, facecolor="none", edgecolor="0.55",
               label="with the starting values")  # fmt: skip
    ax.set_xlabel("measured D1 SD per segment [mm]")
    ax.set_ylabel("predicted D1 SD [mm]")
    ax.set_title("D1 SD per segment: predicted against measured", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")


def plot_field(field, ax=None, *, extent) -> Figure:
    """The estimated settlement-rate factor per rail seat with its ±2 standard errors.

    Parameters
    ----------
    field : trackdyn.calibration.field.FieldEstimate
        The estimate.
    ax : array of 2 matplotlib Axes, optional
        Where to draw the left and right rail; default: a new figure.
    extent : tuple of float
        First and last compared distance [m].
    """
    fig, axes = panels(ax, 2, 1, figsize=(12, 6), sharex=True, sharey=True)
    x = field.position
    for r, (panel, rail) in enumerate(zip(axes, ("left", "right"), strict=True)):
        f, se = field.factor[r], field.standard_error[r]
        panel.fill_between(x, f - 2 * se, f + 2 * se, color=RAIL_COLOURS[rail], alpha=0.25,
                           lw=0, label="±2 standard errors")  # fmt: skip
        panel.plot(x, f, color=RAIL_COLOURS[rail], lw=0.9, label="estimated factor")
        panel.axhline(1.0, color="k", lw=0.6)
        for lo, hi in ((x[0], extent[0]), (extent[1], x[-1])):
            panel.axvspan(lo, hi, color="0.9", zorder=0,
                          label="not compared: the prior" if lo == x[0] else None)  # fmt: skip
        panel.set_ylabel(f"{rail} rail\nsettlement-rate factor [-]")
        panel.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1].set_xlabel("distance [m]")
    fig.suptitle(
        "How fast the ballast under each rail seat settles, relative to the fitted law\n"
        f"(spread allowed: coefficient of variation {field.cov:.2f}, chosen from the surveys; "
        f"survey noise {field.noise_mm:.3f} mm)"
    )
    return finished(fig, ax)
