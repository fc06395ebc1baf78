"""Figures of `trackdyn study`: the matrix cases, the tornado of a sensitivity study, the
speed sweep and the wheel-load spectra of every study."""

from __future__ import annotations

import numpy as np

from trackdyn.plots import TAB10, Figure, finished, legend_outside, panels, plt


def plot_study_matrix(table, ax=None, *, context: str = "") -> Figure:
    """Dynamic wheel load SD and max per excitation case, grouped by vehicle and damping.

    Parameters
    ----------
    table : pandas.DataFrame
        A matrix study's table (`trackdyn.studies.runner.gather`).
    ax : array of 2 matplotlib Axes, optional
        Where to draw the SD and the max; default: a new figure.
    context : str
        What the runs share (model, speed), for the title.
    """
    ok = table[table["error"] == ""]
    groups = list(ok.groupby(["vehicle", "damping"], sort=False))
    cases = sorted(ok["case"].unique())
    fig, axes = panels(ax, 1, 2, figsize=(13, 5))
    width = 0.8 / max(len(groups), 1)
    x = np.arange(len(cases))
    for g, ((vehicle, damping), rows) in enumerate(groups):
        rows = rows.set_index("case").reindex(cases)
        for a, col in zip(axes, ("dyn_load_sd_kN", "dyn_load_max_kN"), strict=True):
            a.bar(x + g * width, rows[col], width, label=f"{vehicle}, {damping} damping")
    for a, label in zip(
        axes, ("SD of dynamic wheel load [kN]", "max dynamic wheel load [kN]"), strict=True
    ):
        a.set_xticks(x + width * (len(groups) - 1) / 2, [f"({c})" for c in cases])
        a.set_xlabel("excitation case")
        a.set_ylabel(label)
        a.grid(alpha=0.3, axis="y")
    legend_outside(axes[1])
    fig.suptitle(
        (f"Excitation cases: {context}\n" if context else "")
        + "(i) geometry, rigid track  (ii) geometry, constant stiffness  "
        "(iii) stiffness, level track  (iv) both",
        fontsize=9,
    )
    return finished(fig, ax)


def _parameter_name(name: str) -> str:
    """A vehicle parameter's description, symbol and SI unit, for an axis."""
    from trackdyn.vehicle.parameters import PARAMETERS

    if name not in PARAMETERS:
        return name
    unit, text = PARAMETERS[name]
    return f"{text}\n({name}, {unit})"


def plot_tornado(table, ax=None, *, column: str = "dyn_load_sd_kN", context: str = "") -> Figure:
    """Change of ``column`` from the baseline at the lowest and highest factor per parameter.

    Parameters
    ----------
    table : pandas.DataFrame
        A one-at-a-time sensitivity study's table (`trackdyn.studies.runner.gather`).
    ax : matplotlib.axes.Axes, optional
        Where to draw; default: a new figure.
    column : str
        The statistic, a column of the table with its unit suffix.
    """
    from trackdyn.labels import NOTES, header

    ok = table[table["error"] == ""]
    base = float(ok.loc[ok["parameter"] == "baseline", column].iloc[0])
    rows = []
    for name, g in ok[ok["parameter"] != "baseline"].groupby("parameter"):
        lo, hi = g.loc[g["factor"].idxmin()], g.loc[g["factor"].idxmax()]
        rows.append((name, lo[column] - base, hi[column] - base, lo["factor"], hi["factor"]))
    rows.sort(key=lambda r: max(abs(r[1]), abs(r[2])))
    fig, axis = panels(ax, figsize=(10, 1.8 + 0.9 * len(rows)))
    y = np.arange(len(rows))
    quantity, unit = (header(column).split("\n") + [""])[:2]
    if rows:  # none when every varied run failed
        axis.barh(
            y + 0.19,
            [r[1] for r in rows],
            0.36,
            color="tab:blue",
            label=f"lowest factor (x{rows[0][3]:g})",
        )
        axis.barh(
            y - 0.19,
            [r[2] for r in rows],
            0.36,
            color="tab:red",
            label=f"highest factor (x{rows[0][4]:g})",
        )
        legend_outside(axis)
    axis.set_yticks(y, [_parameter_name(r[0]) for r in rows], fontsize=9)
    axis.axvline(0, color="k", lw=0.8)
    axis.set_xlabel(f"change of {quantity} from the baseline, {base:.2f} {unit.strip('[]')} {unit}")
    notes = [note for symbol, note in NOTES.items() if symbol in quantity]
    head = f"Sensitivity of {quantity} to the vehicle parameters"
    axis.set_title("\n".join([f"{head}: {context}" if context else head, *notes]))
    axis.grid(alpha=0.3, axis="x")
    return finished(fig, ax)


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
    ds,
    ax=None,
    *,
    table,
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
    ds : xarray.Dataset
        A study's runs with their spectra (`trackdyn.studies.runner.gather`).
    ax : array of matplotlib Axes, optional
        Where to draw, one per panel, top to bottom; default: a new figure.
    table : pandas.DataFrame
        The same runs' table (`trackdyn.studies.runner.gather`).
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
    panel_values = [None] if split is None else list(dict.fromkeys(ok.loc[~baseline, split]))
    fig, axes = panels(
        ax,
        len(panel_values),
        1,
        figsize=(12, 1.8 + 2.8 * len(panel_values)),
        sharex=True,
        squeeze=False,
    )
    freq = ds.frequency.values
    positive = freq > 0
    for a, panel in zip(axes[:, 0], panel_values, strict=True):
        runs = ok[~baseline] if split is None else ok[~baseline & (ok[split] == panel)]
        for run, row in runs.iterrows():
            style = {
                "color": colours[row[colour_by]] if colour_by else "tab:blue",
                "ls": styles[row[style_by]] if style_by else "-",
                "label": ", ".join(_label(c, row[c]) for c in rest),
            }
            a.loglog(freq[positive], ds.wheel_load_psd.isel(run=run).values[positive], **style)
        for run in ok.index[baseline]:
            a.loglog(
                freq[positive],
                ds.wheel_load_psd.isel(run=run).values[positive],
                lw=1.3,
                color="k",
                label="baseline",
            )
        speeds = sorted(set(runs["speed_kmh"])) if "speed_kmh" in runs else [speed_kmh]
        lines = (
            (sleeper_spacing, "sleeper passing", "--", "v"),
            (shortest_wavelength, "synthetic geometry cut-off", ":", "o"),
        )
        for length, name, ls, marker in lines:
            if not length:
                continue
            if len(speeds) == 1:
                f = speeds[0] / 3.6 / length
                a.axvline(f, color="0.3", lw=1.0, ls=ls, label=f"{name}, {length:g} m: {f:.1f} Hz")
                continue
            # one frequency per speed: a marker on each run's curve, not a line per speed
            a.plot([], [], marker, color="0.3", mfc="none", ls="none",
                   label=f"{name}, {length:g} m: on each speed's curve")  # fmt: skip
            for run, row in runs.iterrows():
                f = row["speed_kmh"] / 3.6 / length
                psd = ds.wheel_load_psd.isel(run=run).values[positive]
                colour = colours[row[colour_by]] if colour_by else "tab:blue"
                a.plot(f, np.interp(f, freq[positive], psd), marker, color=colour, mfc="none",
                       ms=7, mew=1.5)  # fmt: skip
        a.set_ylabel("PSD [kN²/Hz]")
        shown = runs.index.union(ok.index[baseline])
        peak = float(ds.wheel_load_psd.isel(run=list(shown)).max()) if len(shown) else 0.0
        if peak > 0:  # below: the numerical floor of the spectrum, not data
            a.set_ylim(bottom=peak * PSD_RANGE)
        if split is not None:
            a.set_title(f"{split} {panel}", fontsize=10, loc="left")
        a.grid(alpha=0.3, which="both")
        legend_outside(a)
    labels = [tuple(a.get_legend_handles_labels()[1]) for a in axes[:, 0]]
    if len(set(labels)) == 1:  # the same runs in every panel: one legend, the first
        for a in axes[1:, 0]:
            a.get_legend().remove()
    axes[-1, 0].set_xlabel("frequency [Hz]")
    fig.suptitle(f"Dynamic wheel load spectra: {ds.attrs['kind']} study, {ds.attrs['model']}")
    return finished(fig, ax)


PSD_RANGE = 1e-6
"""Lowest wheel-load PSD shown, as a share of the panel's peak [-]: beyond the synthetic
geometry's cut-off the spectrum falls to its numerical floor (1e-8 kN²/Hz), which is no
part of the wheel load."""


def plot_speed_sweep(table, ax=None, *, context: str = "") -> Figure:
    """Dynamic wheel load (largest, smallest: the unloading, and standard deviation)
    against speed.

    Parameters
    ----------
    table : pandas.DataFrame
        A speed study's table (`trackdyn.studies.runner.gather`).
    ax : matplotlib.axes.Axes, optional
        Where to draw; default: a new figure.
    context : str
        What the runs share (model, vehicle), for the title.
    """
    ok = table[table["error"] == ""].sort_values("speed_kmh")
    fig, axis = panels(ax, figsize=(9, 5))
    axis.plot(ok["speed_kmh"], ok["dyn_load_max_kN"], "o-", label="largest")
    axis.plot(ok["speed_kmh"], ok["dyn_load_min_kN"], "v-", label="smallest (unloading)")
    axis.plot(ok["speed_kmh"], ok["dyn_load_sd_kN"], "s-", label="standard deviation")
    axis.axhline(0.0, color="k", lw=0.8)
    axis.set_xlabel("speed [km/h]")
    axis.set_ylabel("dynamic wheel load [kN]\n(wheel load less the static load)")
    head = "Dynamic wheel load against speed"
    axis.set_title(f"{head}\n{context}" if context else head)
    axis.grid(alpha=0.3)
    legend_outside(axis)
    return finished(fig, ax)
