"""Figure of an interventions study (`trackdyn study` of ``kind = "interventions"``): the
alternatives side by side."""

from __future__ import annotations

import numpy as np
import pandas as pd

from trackdyn.plots import TAB10, Figure, finished, panels, plt
from trackdyn.units import money_name


def plot_comparison(table: pd.DataFrame, code: str, ax=None, *, title: str = "") -> Figure:
    """Bars per alternative: tampings (renewals hatched on top), the D1 SD it leaves at
    the horizon (the worst segment's, the length-weighted mean dotted) [mm], life-cycle
    cost [currency] (the intervention's own cost and the residual, the end state's work,
    hatched on top).

    Parameters
    ----------
    table : pandas.DataFrame
        The comparison, one row per alternative (`trackdyn.commands.interventions.compare`).
    code : str
        The currency of its costs (`trackdyn.units.money_name`).
    ax : array of 3 matplotlib Axes, optional
        Where to draw the three panels; default: a new figure.
    title : str
        Figure title.
    """
    lcc, own, residual = (
        money_name(k, code) for k in ("life_cycle_cost", "intervention_cost", "residual_cost")
    )
    bars = (  # the bar, its hatched top, the axis label
        (table["tampings"] + table["renewals"], table["renewals"],
         "tampings, renewals hatched [-]"),
        (table["d1_sd_horizon_max_mm"], 0.0 * table["tampings"],
         "D1 SD at the horizon, worst segment [mm]"),
        (table[lcc], table[own] + table[residual],
         f"life-cycle cost [{code}],\nintervention and residual hatched"),
    )  # fmt: skip
    fig, axes = panels(ax, 1, 3, figsize=(12, 4))
    colours = np.array([TAB10[i % len(TAB10)] for i in range(len(table))])
    names = table["alternative"]
    for k, (a, (total, hatched, label)) in enumerate(zip(axes, bars, strict=True)):
        a.bar(names, total - hatched, color=colours)
        shown = hatched > 0
        a.bar(names[shown], hatched[shown], bottom=(total - hatched)[shown], color=colours[shown],
              edgecolor="k", hatch="//")  # fmt: skip
        if k == 1:
            a.scatter(names, table["d1_sd_horizon_mean_mm"], marker="_", s=400, color="k",
                      label="length-weighted mean")  # fmt: skip
            a.legend(fontsize=8)
        a.set_ylabel(label)
        a.grid(axis="y", alpha=0.3)
        plt.setp(a.get_xticklabels(), rotation=25, ha="right")
    fig.suptitle(title)
    return finished(fig, ax)
