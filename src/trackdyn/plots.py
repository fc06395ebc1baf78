"""Figures (matplotlib, no screen needed). Each function writes one PNG file."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

RAIL_COLOURS = {"left": "tab:blue", "right": "tab:red"}


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
        axes[0].plot(
            ds.distance,
            ds.unloaded_profile.sel(rail=rail) * 1e3,
            color=c,
            lw=0.7,
            label=f"{rail} unloaded",
        )
        axes[1].plot(
            ds.distance,
            ds.loaded_profile.sel(rail=rail) * 1e3,
            color=c,
            lw=0.7,
            label=f"{rail} loaded",
        )
        axes[2].plot(ds.sleeper_distance, ds.k2.sel(rail=rail) / 1e6, color=c, lw=0.7, label=rail)
    sd = ds.sd_unloaded.sel(band="D1")
    width = float(sd.segment_end[0] - sd.segment_start[0])
    for j, rail in enumerate(sd.rail.values):
        axes[3].bar(
            sd.segment_start + width * (0.25 + 0.5 * j),
            sd.sel(rail=rail),
            width=width * 0.45,
            color=RAIL_COLOURS[str(rail)],
            label=str(rail),
        )
    for ax in axes[:2]:
        ax.invert_yaxis()
    labels = [
        "unloaded profile [mm]\n(down +)",
        "loaded profile [mm]\n(down +)",
        "k2 [kN/mm]",
        "D1 SD per segment [mm]",
    ]
    for ax, label in zip(axes, labels, strict=True):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("distance [m]")
    fig.suptitle(f"Track input, static wheel load {ds.attrs['static_wheel_load_N'] / 1e3:.1f} kN")
    save(fig, path)


def load_deflection(lin, path, n: int = 4) -> None:
    """Measured curves of a few sleepers with their linearisation (as the seed's Fig. 5.3)."""
    ps, dp = lin.static_load, lin.delta * lin.static_load
    k2 = lin.k2
    picks = {
        "softest": np.unravel_index(np.argmin(k2), k2.shape),
        "stiffest": np.unravel_index(np.argmax(k2), k2.shape),
        "largest ys": np.unravel_index(np.argmax(lin.ys), k2.shape),
        "median": np.unravel_index(np.argsort(k2, axis=None)[k2.size // 2], k2.shape),
    }
    fig, ax = plt.subplots(figsize=(8, 6))
    supports = lin.track.supports
    for (label, (r, i)), colour in zip(list(picks.items())[:n], plt.cm.tab10.colors, strict=False):
        rail = ("left", "right")[r]
        curve = getattr(supports, rail)[i]
        loads = np.linspace(curve.load[0], curve.load[-1], 200)
        ax.plot(curve.deflection * 1e3, curve.load / 1e3, "o", color=colour, ms=4)
        ax.plot(
            curve.deflection_at(loads) * 1e3,
            loads / 1e3,
            color=colour,
            label=f"{label}: {rail} rail, {supports.position[i]:.1f} m, "
            f"k2 = {k2[r, i] / 1e6:.0f} kN/mm",
        )
        p = np.array([ps - 1.6 * dp, ps + 1.6 * dp])
        ax.plot((lin.ys[r, i] + (p - ps) / k2[r, i]) * 1e3, p / 1e3, "--", color=colour, lw=1)
    for level in (ps - dp, ps, ps + dp):
        ax.axhline(level / 1e3, color="grey", lw=0.6, ls=":")
    ax.set_xlabel("deflection [mm]")
    ax.set_ylabel("wheel load [kN]")
    ax.set_title("Load-deflection curves (markers: measured; dashed: linearised over Ps ± ΔP)")
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


def wheel_loads(ds, path) -> None:
    """Wheel load of each contact along the track, with the track input beneath."""
    fig, axes = plt.subplots(
        3, 1, figsize=(11, 9), sharex=True, gridspec_kw={"height_ratios": [2, 1, 1]}
    )
    for c in ds.contact.values:
        x = ds.distance + ds.contact_offset.sel(contact=c)
        axes[0].plot(x, ds.wheel_load.sel(contact=c) / 1e3, lw=0.7, label=str(c))
        axes[1].plot(x, ds.wheel_input.sel(contact=c) * 1e3, lw=0.7, label=str(c))
        axes[2].plot(x, ds.track_stiffness.sel(contact=c) / 1e6, lw=0.7, label=str(c))
    axes[0].axhline(ds.attrs["static_wheel_load_N"] / 1e3, color="k", lw=0.6, ls=":")
    axes[1].invert_yaxis()
    for ax, label in zip(
        axes,
        ("wheel load [kN]", "track input [mm]\n(down +)", "track stiffness [kN/mm]"),
        strict=True,
    ):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8, ncol=4)
    axes[-1].set_xlabel("position of the contact along the track [m]")
    fig.suptitle(
        f"{ds.attrs['model']}, {ds.attrs['vehicle']}, {ds.attrs['speed_m_per_s'] * 3.6:.0f} km/h"
    )
    save(fig, path)


def secondary(ds, path) -> None:
    """Displacement across each secondary suspension along the track."""
    fig, ax = plt.subplots(figsize=(11, 4))
    for s in ds.suspension.values:
        ax.plot(
            ds.distance, ds.secondary_displacement.sel(suspension=s) * 1e3, lw=0.7, label=str(s)
        )
    ax.set_xlabel("vehicle centre position [m]")
    ax.set_ylabel("secondary displacement [mm]\n(compression +)")
    ax.grid(alpha=0.3)
    if ds.suspension.size:
        ax.legend(fontsize=8, ncol=4)
    save(fig, path)


def wedge_friction(ds, path) -> None:
    """Wedge friction force against relative velocity: the stick band and the slip limits."""
    fig, ax = plt.subplots(figsize=(7, 5))
    for s in ds.wedge.values:
        ax.plot(
            ds.wedge_velocity.sel(wedge=s) * 1e3,
            ds.wedge_force.sel(wedge=s) / 1e3,
            ".",
            ms=1,
            alpha=0.5,
            label=str(s),
        )
    ax.set_xlabel("relative velocity [mm/s] (compression +)")
    ax.set_ylabel("wedge friction force [kN]")
    ax.set_title("Friction wedges: stick (sloped band) and slip (flat limits)")
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
    axes[0].legend(fontsize=8)
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
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="x")
    save(fig, path)


def spectra(table, ds, path) -> None:
    """Wheel-load spectrum of each variant."""
    fig, ax = plt.subplots(figsize=(9, 5))
    label_cols = [
        c
        for c in table.columns
        if c in ("parameter", "factor", "vehicle", "damping", "case", "speed_kmh")
        or c.startswith("factor_")
    ]
    for run in range(ds.sizes["run"]):
        if table["error"].iloc[run]:
            continue
        label = ", ".join(f"{table[c].iloc[run]}" for c in label_cols)
        ax.semilogy(ds.frequency, ds.wheel_load_psd.isel(run=run), lw=0.8, label=label)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("PSD of the dynamic wheel load [kN²/Hz]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=6, ncol=3)
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
