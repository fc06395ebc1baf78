"""The figures of runs, studies, tracks, deteriorations and calibrations (matplotlib), and
what they share: colours, the marks of a track's features, the axes a plotting function
draws on, and saving.

Each command's figures are in a module of this package (`trackdyn.plots.run`,
`trackdyn.plots.deteriorate`, ...), public: a script or a notebook draws them from the
results as the commands do (the commands draw on matplotlib's ``Agg`` backend, no screen
needed; `trackdyn.cli` sets it). Each public ``plot_*`` function takes the data first and
``ax=None``: it draws on the caller's axes when given, else on a new figure, and returns
the figure (a new figure laid out, ready for `save`).
"""

from __future__ import annotations

from dataclasses import dataclass

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

RAIL_COLOURS = {"left": "tab:blue", "right": "tab:red"}
TAB10 = tuple(f"C{i}" for i in range(10))  # matplotlib's default cycle: tab10
MARK_COLOURS = {"structure": "tab:purple", "soft spot": "tab:orange", "voids": "tab:brown"}
DPI = 120
"""Resolution of every PNG written [dots per inch]."""


def panels(ax, rows: int = 1, cols: int = 1, **subplots):
    """The figure and axes a ``plot_*`` function draws on.

    Parameters
    ----------
    ax : matplotlib.axes.Axes, array of Axes, or None
        The caller's axes, ``rows`` x ``cols`` of them in row order (their size and sharing
        are the caller's); None: a new figure, ``plt.subplots(rows, cols, **subplots)``.
    rows, cols : int
        Panels of the figure.
    **subplots
        Options of `matplotlib.pyplot.subplots` for a new figure; ``squeeze`` (default
        True) also shapes the caller's axes.

    Returns
    -------
    fig : Figure
        The figure of the axes.
    axes : Axes or array of Axes
        As `matplotlib.pyplot.subplots` returns them.
    """
    if ax is None:
        return plt.subplots(rows, cols, **subplots)
    given = np.asarray(ax, dtype=object)
    if given.size != rows * cols:
        raise ValueError(f"ax: {given.size} axes given for a figure of {rows} x {cols} panels")
    axes = given.reshape(rows, cols)
    if subplots.get("squeeze", True):
        axes = axes.item() if axes.size == 1 else axes.squeeze()
    return given.flat[0].figure, axes


def finished(fig, ax) -> Figure:
    """``fig`` laid out (`Figure.tight_layout`) if the plotting function made it (``ax`` is
    None); the caller lays out its own figure."""
    if ax is None:
        fig.tight_layout()
    return fig


def save(fig, path) -> None:
    """Write ``fig`` to ``path`` as PNG at `DPI` and close it."""
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


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


def mark(axes, marks, label_on=None) -> None:
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


def legend_outside(ax, **options) -> None:
    """A legend to the right of ``ax``, off the data."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8, **options)


def envelope(x, y, points: int = 4000):
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
