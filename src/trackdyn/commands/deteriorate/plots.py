"""Figures of a deterioration prediction (matplotlib, no screen needed); one PNG each."""

from __future__ import annotations

import numpy as np

from trackdyn.commands.plots import RAIL_COLOURS, plt, save


def geometry_evolution(ds, path, title: str = "") -> None:
    """Unloaded space curve of each rail at the snapshot tonnages, and the settlement.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.
    path : path
        PNG file to write.
    title : str
        Figure title.
    """
    fig, axes = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, ds.sizes["snapshot"]))
    for ax, rail in zip(axes[:2], ds.rail.values, strict=True):
        for k, colour in enumerate(colours):
            mgt = float(ds.snapshot_mgt[k])
            ax.plot(
                ds.distance,
                ds.profile.isel(snapshot=k).sel(rail=rail) * 1e3,
                color=colour,
                lw=0.6,
                label=f"{mgt:g} MGT",
            )
        ax.set_ylabel(f"{rail} rail profile [mm]\n(down +)")
    final = ds.settlement.isel(mgt=-1)
    for rail in ds.rail.values:
        axes[2].plot(
            ds.sleeper_distance,
            final.sel(rail=rail) * 1e3,
            color=RAIL_COLOURS[str(rail)],
            lw=0.7,
            label=str(rail),
        )
    axes[2].set_ylabel(f"settlement at\n{float(ds.mgt[-1]):g} MGT [mm]")
    for ax in axes:
        ax.invert_yaxis()
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=7, ncol=2)
    axes[-1].set_xlabel("distance [m]")
    fig.suptitle(title or "Track geometry over accumulated traffic")
    save(fig, path)


def quality_evolution(ds, path, title: str = "") -> None:
    """D1 standard deviation of each 200 m segment against tonnage, with the threshold.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.
    path : path
        PNG file to write.
    title : str
        Figure title.
    """
    fig, axes = plt.subplots(1, 2, figsize=(12.5, 4.5), sharey=True)
    colours = plt.cm.tab10(np.arange(ds.sizes["segment"]) % 10)
    threshold = float(ds.attrs["option_threshold_sd_mm"])
    for ax, rail in zip(axes, ds.rail.values, strict=True):
        for j, colour in enumerate(colours):
            lo, hi = float(ds.segment_start[j]), float(ds.segment_end[j])
            ax.plot(
                ds.mgt,
                ds.d1_sd.sel(rail=rail).isel(segment=j),
                ".-",
                color=colour,
                ms=3,
                label=f"{lo:g}-{hi:g} m",
            )
        ax.axhline(threshold, color="k", ls="--", lw=1, label=f"threshold {threshold:g} mm")
        ax.set_title(f"{rail} rail")
        ax.set_xlabel("accumulated traffic [MGT]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("D1 standard deviation [mm]")
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1))  # clear of the data
    fig.suptitle(title or "Geometry quality per segment")
    save(fig, path)


def settlement_map(ds, path, title: str = "") -> None:
    """Settlement of each sleeper against tonnage, one panel per rail.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of `trackdyn.deterioration.predict`.
    path : path
        PNG file to write.
    title : str
        Figure title.
    """
    fig, axes = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    settle = ds.settlement * 1e3
    vmax = float(settle.max()) or 1.0
    for ax, rail in zip(axes, ds.rail.values, strict=True):
        mesh = ax.pcolormesh(
            ds.sleeper_distance,
            ds.mgt,
            settle.sel(rail=rail),
            shading="nearest",
            cmap="magma_r",
            vmin=0.0,
            vmax=vmax,
        )
        ax.set_ylabel(f"{rail} rail\naccumulated traffic [MGT]")
        ax.set_ylim(0.0, float(ds.mgt[-1]))
        fig.colorbar(mesh, ax=ax, label="settlement [mm]")
    axes[-1].set_xlabel("sleeper position [m]")
    fig.suptitle(title or "Sleeper settlement")
    save(fig, path)
