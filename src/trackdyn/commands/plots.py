"""Figures (matplotlib, no screen needed). Each function writes one PNG file."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402

RAIL_COLOURS = {"left": "tab:blue", "right": "tab:red"}
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


def track_overview(ds, path) -> None:
    """Profiles, stiffness and D1 quality along the track (from `track_dataset`)."""
    fig, axes = plt.subplots(4, 1, figsize=(11, 10), sharex=True)
    for rail in ds.rail.values:
        c = RAIL_COLOURS[str(rail)]
        for ax, name in ((axes[0], "unloaded"), (axes[1], "loaded")):  # long tracks thinned
            profile = ds[f"{name}_profile"].sel(rail=rail).values * 1e3
            ax.plot(
                *_envelope(ds.distance.values, profile), color=c, lw=0.7, label=f"{rail} {name}"
            )
        k2 = ds.k2.sel(rail=rail).values / 1e6
        axes[2].plot(*_envelope(ds.sleeper_distance.values, k2), color=c, lw=0.7, label=rail)
    sd = ds.sd_unloaded.sel(band="D1")
    for rail in sd.rail.values:
        axes[3].hlines(
            sd.sel(rail=rail),
            sd.segment_start,
            sd.segment_end,
            color=RAIL_COLOURS[str(rail)],
            lw=3,
            label=str(rail),
        )
    axes[3].set_ylim(bottom=0)
    for ax in axes[:2]:
        ax.invert_yaxis()
    labels = [
        "unloaded profile [mm]\n(down +)",
        "loaded profile [mm]\n(down +)",
        "k2 [kN/mm]",
        "D1 SD per segment [mm]",
    ]
    legend_at = ("upper right", "upper right", "upper right", "lower right")  # D1: over 0
    for ax, label, loc in zip(axes, labels, legend_at, strict=True):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc=loc, fontsize=8)
    axes[-1].set_xlabel("distance [m]")
    fig.suptitle(f"Track input, static wheel load {ds.attrs['static_wheel_load_N'] / 1e3:.1f} kN")
    save(fig, path)


def load_deflection(picks, static_load: float, delta: float, path) -> None:
    """Measured curves of a few sleepers with their linearisation (as the seed's Fig. 5.3).

    Parameters
    ----------
    picks : list of CurvePick
        The sleepers (`trackdyn.track.analysis.curve_picks`).
    static_load : float
        Static wheel load Ps [N].
    delta : float
        Dynamic wheel load increment δ [-].
    path : path
        PNG file to write.
    """
    ps, dp = static_load, delta * static_load
    fig, ax = plt.subplots(figsize=(8, 6))
    for j, (pick, colour) in enumerate(zip(picks, plt.cm.tab10.colors, strict=False)):
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
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    save(fig, path)


def deflection_basin(rail, x0, with_gap, without_gap, load, path) -> None:
    """Deflection basin and sleeper loads over a voided sleeper (as the seed's Fig. 5.2)."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for sol, label, style in ((without_gap, "no voids", "--"), (with_gap, "measured voids", "-")):
        ax1.plot(sol.x - x0, sol.deflection * 1e3, style, label=label)
        ax2.plot(sol.support_position - x0, sol.support_force / 1e3, style + "o", ms=3, label=label)
    ax1.invert_yaxis()
    ax1.set_ylabel("rail deflection [mm] (down +)")
    ax2.set_ylabel("sleeper load [kN]")
    ax2.set_xlabel(f"distance from the wheel at {x0:.1f} m, {rail} rail [m]")
    ax1.set_title(f"Deflection basin under a {load / 1e3:.1f} kN wheel over a voided sleeper")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.legend()
    save(fig, path)


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


def wheel_loads(ds, path) -> None:
    """Wheel loads of the front and back contacts, track input and stiffness under them.

    Left column: the whole track; right column: the window `ZOOM_M`. Colour: rail; line
    style: order of the contact on its rail. Contacts on one rail run over the same input
    and stiffness, so their lines there coincide, shifted at the ends by their offsets.
    """
    contacts = list(ds.contact.values)
    front = ds.contact_offset.values >= 0
    groups = {"front": np.array(contacts)[front], "back": np.array(contacts)[~front]}
    groups = {name: list(g) for name, g in groups.items() if g.size}
    rows = [*groups, "input", "stiffness"]
    fig, axes = plt.subplots(
        len(rows),
        2,
        figsize=(14, 2.6 * len(rows) + 1),
        sharex="col",
        gridspec_kw={"width_ratios": [2.4, 1]},
        squeeze=False,
    )
    x_of = {c: (ds.distance + ds.contact_offset.sel(contact=c)).values for c in contacts}
    for row, (name, members) in zip(axes, groups.items(), strict=False):
        for c in members:
            style = _contact_style(ds, members, c)
            _full_and_zoom(row, x_of[c], ds.wheel_load.sel(contact=c).values / 1e3, **style)
        for ax in row:
            ax.axhline(ds.attrs["static_wheel_load_N"] / 1e3, color="k", lw=0.6, ls=":")
        where = f"{name} contacts" if len(groups) > 1 else "contacts"
        row[0].set_ylabel(f"wheel load [kN]\n{where}")
    for row, (var, scale) in zip(
        axes[len(groups) :], (("wheel_input", 1e3), ("track_stiffness", 1e-6)), strict=True
    ):
        for c in contacts:
            style = _contact_style(ds, contacts, c)
            _full_and_zoom(row, x_of[c], ds[var].sel(contact=c).values * scale, **style)
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
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8, handlelength=3)
    axes[-1, 0].set_xlabel("position of the contact along the track [m]")
    axes[-1, 1].set_xlabel(f"zoom {ZOOM_M[0]:g}-{ZOOM_M[1]:g} m [m]")
    fig.suptitle(f"Wheel loads: {run_title(ds)}")
    save(fig, path)


def secondary(ds, path) -> None:
    """Displacement across each secondary suspension along the track."""
    fig, ax = plt.subplots(figsize=(11, 4))
    for s in ds.suspension.values:
        y = ds.secondary_displacement.sel(suspension=s).values * 1e3
        ax.plot(*_envelope(ds.distance.values, y), lw=0.7, label=str(s))
    ax.set_xlabel("vehicle centre position [m]")
    ax.set_ylabel("secondary displacement [mm]\n(compression +)")
    ax.set_title(f"Secondary suspension displacement\n{run_title(ds)}")
    ax.grid(alpha=0.3)
    if ds.suspension.size:
        ax.legend(fontsize=8, ncol=4)
    save(fig, path)


def wedge_friction(ds, path) -> None:
    """Wedge friction force against relative velocity: the stick band and the slip limits."""
    fig, ax = plt.subplots(figsize=(7, 5))
    every = max(1, ds.time.size // 20_000)  # a point cloud: 20 000 points per wedge show it
    for s in ds.wedge.values:
        ax.plot(
            ds.wedge_velocity.sel(wedge=s).values[::every] * 1e3,
            ds.wedge_force.sel(wedge=s).values[::every] / 1e3,
            ".",
            ms=1,
            alpha=0.5,
            label=str(s),
        )
    ax.set_xlabel("relative velocity [mm/s] (compression +)")
    ax.set_ylabel("wedge friction force [kN]")
    ax.set_title(
        "Friction wedges: stick (steep band through zero) and slip\n"
        "(limit μ × normal force, which varies with the spring load)"
    )
    ax.grid(alpha=0.3)
    if ds.wedge.size:
        ax.legend(markerscale=8, fontsize=8)
    save(fig, path)


def study_matrix(table, path) -> None:
    """Dynamic wheel load SD and max per excitation case, grouped by vehicle and damping."""
    ok = table[table["error"] == ""]
    groups = list(ok.groupby(["vehicle", "damping"], sort=False))
    cases = sorted(ok["case"].unique())
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
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
    axes[1].legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8)
    fig.suptitle(
        "(i) geometry, rigid track  (ii) geometry, constant stiffness  "
        "(iii) stiffness, level track  (iv) both",
        fontsize=9,
    )
    save(fig, path)


def tornado(table, path, column: str = "dyn_load_sd_kN") -> None:
    """Change of ``column`` from the baseline at the lowest and highest factor per parameter."""
    ok = table[table["error"] == ""]
    base = float(ok.loc[ok["parameter"] == "baseline", column].iloc[0])
    rows = []
    for name, g in ok[ok["parameter"] != "baseline"].groupby("parameter"):
        lo, hi = g.loc[g["factor"].idxmin()], g.loc[g["factor"].idxmax()]
        rows.append((name, lo[column] - base, hi[column] - base, lo["factor"], hi["factor"]))
    rows.sort(key=lambda r: max(abs(r[1]), abs(r[2])))
    fig, ax = plt.subplots(figsize=(8, 1.2 + 0.6 * len(rows)))
    y = np.arange(len(rows))
    ax.barh(
        y,
        [r[1] for r in rows],
        color="tab:blue",
        label=f"lowest factor (x{rows[0][3]:g})" if rows else None,
    )
    ax.barh(
        y,
        [r[2] for r in rows],
        color="tab:red",
        label=f"highest factor (x{rows[0][4]:g})" if rows else None,
    )
    ax.set_yticks(y, [r[0] for r in rows])
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlabel(f"change of {column} from the baseline {base:.2f}")
    if rows:  # none when every varied run failed
        ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="x")
    save(fig, path)


def spectra(table, ds, path) -> None:
    """Wheel-load spectrum of each run, one panel per value of the first varying label.

    With two or more varying labels (vehicle, parameter, ...) the runs are split into
    panels by the first one and told apart by the others; a ``baseline`` run is drawn in
    black in every panel.
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
    panels = [None] if split is None else list(dict.fromkeys(ok.loc[~baseline, split]))
    fig, axes = plt.subplots(
        len(panels), 1, figsize=(11, 1.5 + 2.6 * len(panels)), sharex=True, squeeze=False
    )
    for ax, panel in zip(axes[:, 0], panels, strict=True):
        runs = ok[~baseline] if split is None else ok[~baseline & (ok[split] == panel)]
        colours = (
            plt.cm.tab10.colors
            if len(runs) <= 10
            else plt.cm.viridis(np.linspace(0, 0.9, len(runs)))
        )
        for (run, row), colour in zip(runs.iterrows(), colours, strict=False):
            label = ", ".join(f"{c} {row[c]}" for c in rest)
            ax.semilogy(
                ds.frequency, ds.wheel_load_psd.isel(run=run), lw=0.9, color=colour, label=label
            )
        for run in ok.index[baseline]:
            ax.semilogy(
                ds.frequency, ds.wheel_load_psd.isel(run=run), lw=1.2, color="k", label="baseline"
            )
        ax.set_ylabel("PSD [kN²/Hz]")
        if split is not None:
            ax.set_title(f"{split} {panel}", fontsize=10, loc="left")
        ax.grid(alpha=0.3, which="both")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8)
    axes[-1, 0].set_xlabel("frequency [Hz]")
    fig.suptitle(f"Dynamic wheel load spectra: {ds.attrs['kind']} study, {ds.attrs['model']}")
    save(fig, path)


def speed_sweep(table, path) -> None:
    """Dynamic wheel load against speed."""
    ok = table[table["error"] == ""].sort_values("speed_kmh")
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(ok["speed_kmh"], ok["dyn_load_max_kN"], "o-", label="max")
    ax.plot(ok["speed_kmh"], ok["dyn_load_sd_kN"], "s-", label="standard deviation")
    ax.set_xlabel("speed [km/h]")
    ax.set_ylabel("dynamic wheel load [kN]")
    ax.grid(alpha=0.3)
    ax.legend()
    save(fig, path)
