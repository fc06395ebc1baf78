"""Figure of an interventions study (`trackdyn study` of ``kind = "interventions"``): the
alternatives side by side."""

from __future__ import annotations

import numpy as np
import pandas as pd

from trackdyn.commands.plots import TAB10, Figure, finished, panels, plt


def plot_comparison(table: pd.DataFrame, ax=None, *, title: str = "") -> Figure:
    """Bars per alternative: tampings (renewals hatched on top), mean interval [MGT]
    ("none" where no segment had two interventions), life-cycle cost (the intervention's
    own cost hatched on top).

    Parameters
    ----------
    table : pandas.DataFrame
        The comparison, one row per alternative (`trackdyn.commands.interventions.compare`).
    ax : array of 3 matplotlib Axes, optional
        Where to draw the three panels; default: a new figure.
    title : str
        Figure title.
    """
    bars = (
        ("tampings", "renewals", "tampings, renewals hatched [-]"),
        ("mean_interval_mgt", None, "mean interval [MGT]"),
        ("life_cycle_cost", "intervention_cost", "life-cycle cost, intervention hatched"),
    )
    fig, axes = panels(ax, 1, 3, figsize=(12, 4))
    colours = np.array([TAB10[i % len(TAB10)] for i in range(len(table))])
    names = table["alternative"]
    for a, (key, top, label) in zip(axes, bars, strict=True):
        total = table[key] + (table[top] if key == "tampings" else 0.0)
        hatched = table[top] if top else 0.0 * total
        a.bar(names, total - hatched, color=colours)
        shown = hatched > 0
        a.bar(names[shown], hatched[shown], bottom=(total - hatched)[shown], color=colours[shown],
              edgecolor="k", hatch="//")  # fmt: skip
        for i in np.flatnonzero(np.isnan(total.to_numpy())):  # e.g. no two tampings
            a.annotate("none", (i, 0.0), ha="center", va="bottom", fontsize=8)
        a.set_ylabel(label)
        a.grid(axis="y", alpha=0.3)
        plt.setp(a.get_xticklabels(), rotation=25, ha="right")
    fig.suptitle(title)
    return finished(fig, ax)
