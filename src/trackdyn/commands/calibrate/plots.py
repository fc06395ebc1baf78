"""The figures of a calibration (matplotlib, no screen needed)."""

from __future__ import annotations

from typing import Any

import numpy as np

from trackdyn.commands.plots import RAIL_COLOURS, plt, save

STYLES: dict[str, dict[str, Any]] = {
    "measured": {"color": "k", "lw": 0.8},
    "predicted, fitted": {"color": "tab:orange", "lw": 0.9},
    "predicted, starting values": {"color": "0.55", "lw": 0.7, "ls": "--"},
}
"""Line of each curve, the same in every panel."""


def calibration_figure(problem, result, table, path) -> None:
    """Measured and predicted D1-band change of each later survey and rail along the track,
    and measured against predicted D1 SD per segment (parity).

    Parameters
    ----------
    problem : trackdyn.calibration.problem.Calibration
        The calibration.
    result : trackdyn.calibration.fit.FitResult
        The fit.
    table : DataFrame
        Its segment table (`trackdyn.commands.calibrate.outputs.segment_table`).
    path : path
        PNG file to write.
    """
    later = problem.mgt.size - 1
    fig = plt.figure(figsize=(12, 2.6 * later + 4.2))
    grid = fig.add_gridspec(later + 1, 2, height_ratios=[1] * later + [1.5])
    x, fit, start = problem.x, result.comparison, result.start_comparison
    top = None
    for k in range(1, problem.mgt.size):
        role = "fitted" if problem.fitted[k] else "check"
        for r, rail in enumerate(("left", "right")):
            ax = fig.add_subplot(grid[k - 1, r], sharex=top, sharey=top)
            top = top or ax
            curves = (fit.measured, fit.predicted, start.predicted)
            for (label, style), values in zip(STYLES.items(), curves, strict=True):
                ax.plot(x, values[k, r] * 1e3, label=label, **style)
            ax.fill_between(x, 0, 1, where=~problem.valid, color="0.9", step="mid",
                            transform=ax.get_xaxis_transform(), label="not compared")  # fmt: skip
            ax.set_title(f"{rail} rail, {problem.spec.survey[k].mgt:g} MGT ({role})", fontsize=9)
            ax.grid(alpha=0.3)
            if r == 0:
                ax.set_ylabel("D1-band change [mm]\n(down +)")
            if k == later:
                ax.set_xlabel("distance [m]")
    assert top is not None  # a survey after the first (the spec's check)
    top.invert_yaxis()
    handles, labels = top.get_legend_handles_labels()
    parity = fig.add_subplot(grid[later, 0])
    _parity(parity, table)
    key = fig.add_subplot(grid[later, 1])
    key.axis("off")
    key.legend(handles, labels, loc="center left", title="change panels", fontsize=9)
    fig.suptitle("Calibration: change since the first survey, D1 band (3-25 m)")
    save(fig, path)


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


def field_figure(field, extent, path) -> None:
    """The estimated settlement-rate factor per rail seat with its ±2 standard errors.

    Parameters
    ----------
    field : trackdyn.calibration.field.FieldEstimate
        The estimate.
    extent : tuple of float
        First and last compared distance [m].
    path : path
        PNG file to write.
    """
    fig, axes = plt.subplots(2, 1, figsize=(12, 6), sharex=True, sharey=True)
    x = field.position
    for r, (ax, rail) in enumerate(zip(axes, ("left", "right"), strict=True)):
        f, se = field.factor[r], field.standard_error[r]
        ax.fill_between(x, f - 2 * se, f + 2 * se, color=RAIL_COLOURS[rail], alpha=0.25,
                        lw=0, label="±2 standard errors")  # fmt: skip
        ax.plot(x, f, color=RAIL_COLOURS[rail], lw=0.9, label="estimated factor")
        ax.axhline(1.0, color="k", lw=0.6)
        for lo, hi in ((x[0], extent[0]), (extent[1], x[-1])):
            ax.axvspan(lo, hi, color="0.9", zorder=0,
                       label="not compared: the prior" if lo == x[0] else None)  # fmt: skip
        ax.set_ylabel(f"{rail} rail\nsettlement-rate factor [-]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1].set_xlabel("distance [m]")
    fig.suptitle(
        f"Estimated settlement-rate field (cov {field.cov:.2f} of the data-chosen prior, "
        f"noise {field.noise_mm:.3f} mm)"
    )
    save(fig, path)
